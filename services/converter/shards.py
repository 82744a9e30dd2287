"""Convert elements in shards, one per core: tessellation and per-element work run in parallel processes.

ifcopenshell's iterator can tessellate with several threads, but the rest of a conversion (convex
decomposition, split IFCs, mesh and SDF files) is Python and would keep one core busy while the other
idles; and on the public samples two iterator threads are no faster than one (on the hub's steel, 0.39 s
against 0.25 s). So the elements are split into shards, each converted start to finish, tessellation and
files, by a forked worker process (which inherits the opened model) with a one-thread iterator. There are
a few more shards than workers, of similar estimated cost and handed out costliest first, so a worker that
finishes early takes the next one instead of idling while the other finishes a slow shard (the cost is
estimated from the size of each representation: one element of acad2010_objects tessellates for 0.2 s, a
Revit steel member in 2 ms). Elements that share geometry through the same mapped representation go to
the same shard (unless their own work is more than a worker's share), so repeated geometry is
tessellated, decomposed and written once per shard; within a worker, sections
(:mod:`.prism_split`) and spatial chains are shared across its shards.
With fewer than ``2 × MIN_ELEMENTS_PER_WORKER`` elements no process is forked: a fork costs more than it
saves.
"""

from __future__ import annotations

import gc
import logging
import multiprocessing
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_EXCEPTION, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from multiprocessing.sharedctypes import Synchronized

import ifcopenshell
import numpy as np

from bimbot.shared.construction_methods import PanelisedElement
from bimbot.shared.manifest import Component, SkippedElement

from .component_work import GeometryWork, ShardContext
from .component_writer import geometry_work, place_element, skipped_entry
from .panel_writer import write_element
from .room_contents import cut_at_room_floor
from .sdf_writer import ModelSpec
from .tessellation import tessellate

_log = logging.getLogger(__name__)

# Below this many elements per worker a process costs more than it saves. The bundled frame's 28 elements:
# 132 ms in one process and 118 ms in two on an idle machine, but 171 against 252 ms while other processes
# keep the cores busy; so small models stay in one process.
MIN_ELEMENTS_PER_WORKER = 16
SHARDS_PER_WORKER = 3  # shards handed out one at a time balance the workers' load
COST_LEVELS = 8  # levels of a representation counted by representation_size
# Estimated cost per representation instance (representation_size), fitted to the Revit hub's steel (about
# 100 instances: 4.5 ms of tessellation and decomposition, 4 ms of files and split IFC a member) and the
# Revit house's windows (about 2,000: 290 ms and 24 ms)
GEOMETRY_MS_PER_INSTANCE = 0.15
ELEMENT_MS = 3.0
COPY_MS_PER_INSTANCE = 0.01
MIN_ELEMENTS_PER_SHARD = 8  # a shard's own tessellation iterator and caches cost a few milliseconds
ProgressCallback = Callable[[str, int, int], None]

# Set in the parent just before forking; workers inherit them (an ifcopenshell file cannot be pickled,
# and the context's caches hold its entities).
_MODEL: ifcopenshell.file | None = None
_CONTEXT: ShardContext | None = None
_DONE: Synchronized[int] | None = None


@dataclass
class ShardResult:
    step_ids: list[int] = field(default_factory=list)  # of the converted components' elements, in order
    components: list[Component] = field(default_factory=list)  # an element's panels follow each other
    specs: list[ModelSpec] = field(default_factory=list)
    skipped: list[SkippedElement] = field(default_factory=list)
    bboxes_ifc_world_m: list[np.ndarray] = field(default_factory=list)
    panelised: list[PanelisedElement] = field(default_factory=list)
    seconds_by_stage: dict[str, float] = field(default_factory=dict)


def geometry_group(element: ifcopenshell.entity_instance) -> str:
    """Elements with the same key may share a tessellation: the sources their mapped items map."""
    sources: list[int] = []
    for representation in getattr(element.Representation, "Representations", None) or ():
        for item in representation.Items or ():
            if item.is_a("IfcMappedItem"):
                sources.append(item.MappingSource.id())
            else:
                return f"#{element.id()}"
    return "map:" + ",".join(map(str, sorted(sources))) if sources else f"#{element.id()}"


def representation_size(element: ifcopenshell.entity_instance) -> int:
    """The instances the element's representation reaches within ``COST_LEVELS`` levels: items, their
    faces, loops and points, or profiles and placements. 1–10 ms for a whole public sample, where a full
    traverse costs up to 34 ms; it ranks the elements by the kernel's time as a full traverse does."""
    if element.Representation is None:
        return 0
    return len(element.file.traverse(element.Representation, max_levels=COST_LEVELS))


def plan_shards(
    elements: Sequence[ifcopenshell.entity_instance], count: int, workers: int | None = None
) -> list[list[int]]:
    """Step ids in at most ``count`` shards of similar estimated cost, each in step-id order, the
    costliest first (handed out in that order, so an element that tessellates for 0.2 s, acad2010's
    curtain wall, is not the last work of one worker while the other idles).

    The elements of a geometry group share one tessellation and decomposition of their geometry, so a
    group stays in one shard unless its members' own work (files, split IFC) is more than a worker's share
    (``workers``, default ``count``) of the whole: then it is cut into pieces of about a shard's share,
    each costing its shard the geometry once more (a large frame is three groups of thousands of members;
    the Revit house's eleven windows, 0.29 s of decomposition, stay together). Costs are estimated from
    :func:`representation_size`, calibrated on the public samples (see the constants)."""
    count = max(1, count)
    workers = max(1, workers or count)
    groups: dict[str, list[ifcopenshell.entity_instance]] = defaultdict(list)
    for element in elements:
        groups[geometry_group(element)].append(element)
    size = {key: representation_size(members[0]) for key, members in groups.items()}
    geometry_ms = {key: GEOMETRY_MS_PER_INSTANCE * size[key] for key in groups}
    member_ms = {key: ELEMENT_MS + COPY_MS_PER_INSTANCE * size[key] for key in groups}
    total_ms = sum(geometry_ms[key] + len(members) * member_ms[key] for key, members in groups.items())
    pieces: list[tuple[float, list[ifcopenshell.entity_instance]]] = []
    for key, members in groups.items():
        cuts = 1
        if geometry_ms[key] + len(members) * member_ms[key] > total_ms / workers:
            cuts = min(len(members), max(1, round(len(members) * member_ms[key] / (total_ms / count))))
        length = -(-len(members) // cuts)
        for start in range(0, len(members), length):
            piece = members[start : start + length]
            pieces.append((geometry_ms[key] + len(piece) * member_ms[key], piece))
    shards: list[tuple[float, list[int]]] = [(0.0, []) for _ in range(count)]
    for cost_ms, piece in sorted(pieces, key=lambda item: item[0], reverse=True):
        cheapest = min(range(count), key=lambda index: shards[index][0])
        planned_ms, ids = shards[cheapest]
        shards[cheapest] = (planned_ms + cost_ms, ids + [element.id() for element in piece])
    return [sorted(ids) for _, ids in sorted(shards, key=lambda item: item[0], reverse=True) if ids]


def without_elements(result: ShardResult, step_ids: set[int], guids: set[str]) -> ShardResult:
    """``result`` without what the elements ``step_ids`` (GlobalIds ``guids``) became: their components,
    panelised entries and skipped entries."""
    kept = [index for index, step_id in enumerate(result.step_ids) if step_id not in step_ids]
    return ShardResult(
        step_ids=[result.step_ids[index] for index in kept],
        components=[result.components[index] for index in kept],
        specs=[result.specs[index] for index in kept],
        skipped=[entry for entry in result.skipped if entry.guid not in guids],
        bboxes_ifc_world_m=[result.bboxes_ifc_world_m[index] for index in kept],
        panelised=[entry for entry in result.panelised if entry.guid not in guids],
        seconds_by_stage=result.seconds_by_stage,
    )


def convert_shard(
    model: ifcopenshell.file,
    step_ids: Sequence[int],
    context: ShardContext,
    *,
    threads: int | None = None,
    on_element: Callable[[], None] | None = None,
) -> ShardResult:
    """Tessellate and write the components of ``step_ids``; failures become ``skipped`` entries."""
    result = ShardResult()
    started = time.perf_counter()
    elements = [model.by_id(step_id) for step_id in step_ids]
    by_id = {element.id(): element for element in elements}
    tessellation = tessellate(model, elements, threads=threads)
    result.skipped.extend(skipped_entry(by_id[i], reason) for i, reason in tessellation.failures.items())
    tessellated = time.perf_counter()
    works: dict[str, GeometryWork] = {}
    for step_id, shape in sorted(tessellation.shapes.items()):
        element = by_id[step_id]
        try:
            built, cut = cut_at_room_floor(shape, context.room_floors.get(step_id))
            item = place_element(element, built)
            if cut is not None:
                item.notes = (cut,)
                _log.info("%s %s: %s", element.is_a(), element.GlobalId, cut)
            work = works.get(item.geometry_key)
            if work is None:
                work = works[item.geometry_key] = geometry_work(item, context)
            written = write_element(model, item, work, context)
        except Exception as error:  # one bad element never stops the conversion; the reason is kept
            _log.warning("%s %s: %s", element.is_a(), element.GlobalId, error, exc_info=_log.isEnabledFor(10))
            result.skipped.append(
                skipped_entry(element, f"conversion failed: {type(error).__name__}: {error}")
            )
            continue
        finally:
            if on_element is not None:
                on_element()
        result.step_ids.extend([step_id] * len(written.components))
        result.components.extend(written.components)
        result.specs.extend(written.specs)
        result.bboxes_ifc_world_m.extend(written.bboxes_ifc_world_m)
        if written.panelised is not None:
            result.panelised.append(written.panelised)
    result.seconds_by_stage = {
        "tessellate": tessellated - started,
        "components": time.perf_counter() - tessellated,
    }
    return result


def run_shards(
    model: ifcopenshell.file,
    elements: Sequence[ifcopenshell.entity_instance],
    context: ShardContext,
    *,
    workers: int,
    progress: ProgressCallback | None = None,
) -> list[ShardResult]:
    """Convert ``elements`` with ``workers`` processes (in this process when few elements or one worker)."""
    total = len(elements)
    if workers <= 1 or total < 2 * MIN_ELEMENTS_PER_WORKER:
        done = 0

        def on_element() -> None:
            nonlocal done
            done += 1
            if progress is not None:
                progress("convert", done, total)

        ids = [element.id() for element in elements]
        return [convert_shard(model, ids, context, threads=workers, on_element=on_element)]
    global _MODEL, _CONTEXT, _DONE
    mp_context = multiprocessing.get_context("fork")
    _MODEL, _CONTEXT, _DONE = model, context, mp_context.Value("i", 0)
    workers = min(workers, total // MIN_ELEMENTS_PER_WORKER)
    count = max(workers, min(workers * SHARDS_PER_WORKER, total // MIN_ELEMENTS_PER_SHARD))
    shards = plan_shards(elements, count, workers)  # costliest first
    # the workers inherit every object of this process; frozen, their garbage collector leaves them alone
    # instead of touching (and so copying) each page of them: 20 % less wall time on the hub's steel
    gc.freeze()
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=mp_context) as pool:
            futures = [pool.submit(_convert_in_worker, shard) for shard in shards]
            pending = set(futures)
            while pending:
                finished, pending = wait(pending, timeout=0.1, return_when=FIRST_EXCEPTION)
                if progress is not None:
                    progress("convert", _DONE.value, total)
                for future in finished:
                    future.result()  # re-raise a worker's crash here rather than later
            return [future.result() for future in futures]
    finally:
        gc.unfreeze()
        _MODEL, _CONTEXT, _DONE = None, None, None


def _convert_in_worker(step_ids: list[int]) -> ShardResult:
    assert _MODEL is not None and _CONTEXT is not None and _DONE is not None, "worker started without a fork"
    counter = _DONE

    def on_element() -> None:
        with counter.get_lock():
            counter.value += 1

    return convert_shard(_MODEL, step_ids, _CONTEXT, threads=1, on_element=on_element)
