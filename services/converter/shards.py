"""Convert elements in shards, one per core: tessellation and per-element work run in parallel processes.

ifcopenshell's iterator can tessellate with several threads, but the rest of a conversion (convex
decomposition, split IFCs, mesh and SDF files) is Python and would keep one core busy while the other
idles; and on the public samples two iterator threads are no faster than one (on the hub's steel, 0.39 s
against 0.25 s). So the elements are split into shards, each converted start to finish, tessellation and
files, by a forked worker process (which inherits the opened model) with a one-thread iterator. There are
a few more shards than workers, largest first, so a worker that finishes early takes the next one instead
of idling while the other finishes a slow shard. Elements that share geometry through the same mapped
representation go to the same shard (unless there are more of them than a shard's share), so repeated
geometry is tessellated, decomposed and written once per shard; within a worker, sections
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

from bimbot.shared.manifest import Component, SkippedElement

from .component_writer import (
    GeometryWork,
    ShardContext,
    geometry_work,
    place_element,
    skipped_entry,
    write_component,
)
from .sdf_writer import ModelSpec
from .tessellation import tessellate

_log = logging.getLogger(__name__)

# Below this many elements per worker a process costs more than it saves. The bundled frame's 28 elements:
# 132 ms in one process and 118 ms in two on an idle machine, but 171 against 252 ms while other processes
# keep the cores busy; so small models stay in one process.
MIN_ELEMENTS_PER_WORKER = 16
SHARDS_PER_WORKER = 3  # shards handed out one at a time balance the workers' load
MIN_ELEMENTS_PER_SHARD = 8  # a shard's own tessellation iterator and caches cost a few milliseconds
ProgressCallback = Callable[[str, int, int], None]

# Set in the parent just before forking; workers inherit them (an ifcopenshell file cannot be pickled,
# and the context's caches hold its entities).
_MODEL: ifcopenshell.file | None = None
_CONTEXT: ShardContext | None = None
_DONE: Synchronized[int] | None = None


@dataclass
class ShardResult:
    step_ids: list[int] = field(default_factory=list)  # of the converted components, in their order
    components: list[Component] = field(default_factory=list)
    specs: list[ModelSpec] = field(default_factory=list)
    skipped: list[SkippedElement] = field(default_factory=list)
    bboxes_ifc_world_m: list[np.ndarray] = field(default_factory=list)
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


def plan_shards(elements: Sequence[ifcopenshell.entity_instance], count: int) -> list[list[int]]:
    """Step ids in ``count`` shards of similar size, each in step-id order. A geometry group stays in one
    shard unless it is larger than a shard's share: then it is cut into pieces of about that size, each
    costing its shard one more tessellation and decomposition of the geometry (milliseconds) where a whole
    group would leave the other workers idle (a large frame is three groups of thousands of members)."""
    groups: dict[str, list[int]] = defaultdict(list)
    for element in elements:
        groups[geometry_group(element)].append(element.id())
    count = max(1, count)
    share = -(-len(elements) // count)  # ceil
    pieces: list[list[int]] = []
    for members in groups.values():
        cuts = -(-len(members) // share)
        size = -(-len(members) // cuts)
        pieces.extend(members[start : start + size] for start in range(0, len(members), size))
    shards: list[list[int]] = [[] for _ in range(count)]
    for piece in sorted(pieces, key=len, reverse=True):
        min(shards, key=len).extend(piece)
    return [sorted(shard) for shard in shards if shard]


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
            item = place_element(element, shape)
            work = works.get(item.geometry_key)
            if work is None:
                work = works[item.geometry_key] = geometry_work(item, context)
            component, spec = write_component(model, item, work, context)
        except Exception as error:  # one bad element never stops the conversion; the reason is kept
            _log.warning("%s %s: %s", element.is_a(), element.GlobalId, error, exc_info=_log.isEnabledFor(10))
            result.skipped.append(
                skipped_entry(element, f"conversion failed: {type(error).__name__}: {error}")
            )
            continue
        finally:
            if on_element is not None:
                on_element()
        result.step_ids.append(step_id)
        result.components.append(component)
        result.specs.append(spec)
        result.bboxes_ifc_world_m.append(item.bbox_ifc_world_m)
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
    shards = sorted(plan_shards(elements, count), key=len, reverse=True)  # largest first
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
