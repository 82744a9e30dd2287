"""Where the construction sequence comes from, and the precedence DAG the planner releases tasks over.

Four sources (:class:`SourceKind`):

* ``build`` — the build's own ``sequence.xml`` (the converter wrote it from the IFC schedule, or derived it);
* ``sequence`` — a user's XML file in the same format (``docs/sequence-format.md``), or a planner's
  schedule: MS Project XML, Primavera P6 XML or XER (:mod:`bimbot.shared.planner_schedules`: tasks
  matched to components by GlobalId or name, the unmatched ones named in one warning);
* ``ifc`` — the 4D schedule of an IFC file (IfcTask, IfcRelAssignsToProduct, IfcRelSequence), by default the
  model the build was converted from (``manifest.source.path``);
* ``derive`` — derived from the support graph (connections plus contact under gravity).

Precedence: a sequence that names predecessors anywhere is taken as given; a plain ordered list (no
predecessors at all) gets the support graph as its DAG and keeps its order as release priority. Components
of the build that the sequence does not mention are appended in derived order with their supports as
predecessors (one warning). A sequence naming GUIDs the build does not have, a cycle, or an unreadable file
is a :class:`PlanError` (a :class:`~bimbot.shared.errors.UserError`: one line, exit code 2).

Every plan is checked against the support graph: a component sequenced before something it rests on, or
that does not wait for it in the DAG, gives one warning naming both GUIDs (logged and kept in
:attr:`Plan.violations` / :attr:`Plan.warnings`). Nothing here touches the bus.
"""

from __future__ import annotations

import graphlib
import hashlib
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path

from bimbot.shared.errors import UserError
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.sequence import (
    ConstructionSequence,
    SequenceError,
    read_sequence,
)
from bimbot.shared.support_graph import derive_sequence, support_predecessors, support_violations

_log = logging.getLogger(__name__)

MAX_NAMED_GUIDS = 5  # unknown GUIDs named in one error line


class PlanError(UserError):
    """A sequence the planner cannot use (unreadable, unknown GUIDs, cycle): one clear line."""


class SourceKind(StrEnum):
    BUILD = "build"  # <build>/sequence.xml
    SEQUENCE = "sequence"  # a user's sequence XML
    IFC = "ifc"  # an IFC file's 4D schedule
    DERIVE = "derive"  # the support graph


@dataclass(frozen=True)
class PlanSource:
    """Which sequence: ``path`` is the XML (``sequence``) or the IFC (``ifc``; None → the build's model)."""

    kind: SourceKind = SourceKind.BUILD
    path: Path | None = None


@dataclass(frozen=True)
class Plan:
    """Every component of a build once, in release-priority order, with its predecessors."""

    source: str  # human-readable label, e.g. "sequence.xml (ifc_schedule)"
    order: tuple[str, ...]  # GUIDs, release priority (earlier first)
    predecessors: Mapping[str, frozenset[str]]  # GUID → GUIDs that must be constructed first
    task_ids: Mapping[str, str]  # GUID → task id (a Zenoh key chunk: tasks/<task_id>)
    names: Mapping[str, str]  # GUID → task name (may be empty)
    explicit: bool  # predecessors as given by the sequence (False: the support graph)
    warnings: tuple[str, ...] = ()
    violations: tuple[tuple[str, str], ...] = ()  # (component, support) pairs the plan gets wrong
    derived: bool = False  # derived from the support graph (the planner may add precedences for access)
    # GUID → what it physically rests on (the support graph); None: unknown, every precedence is physical
    supports: Mapping[str, frozenset[str]] | None = None
    # GUIDs no ground robot can get to at their turn that a crane on site sets from above: asked of a crane
    # first (the access check, :mod:`.access_plan`)
    from_above: frozenset[str] = frozenset()
    # GUID → the component whose placement the access check found cuts it off from the depot (its warning):
    # a failure to get to it names that cause and what a user can do (:mod:`.failures`)
    cut_off_by: Mapping[str, str] = field(default_factory=dict)

    def successors(self) -> dict[str, set[str]]:
        """GUID → GUIDs that wait for it directly."""
        return _invert(self.order, self.predecessors)

    def dependents(self) -> dict[str, set[str]]:
        """GUID → GUIDs that rest on it directly (the support graph; the precedences when unknown): what
        cannot be built when it is not."""
        return _invert(self.order, self.supports if self.supports is not None else self.predecessors)


def _invert(order: Sequence[str], preds: Mapping[str, frozenset[str]]) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {guid: set() for guid in order}
    for guid, values in preds.items():
        for pred in values:
            if pred in out:
                out[pred].add(guid)
    return out


def load_plan(manifest: Manifest, build_dir: Path, source: PlanSource) -> Plan:
    """The plan for ``manifest``'s components from ``source``; warnings are logged and kept in the plan."""
    components = list(manifest.components)
    if not components:
        raise PlanError(f"{build_dir}: the build has no components to construct")
    build_dir = Path(build_dir)
    extra_warnings: list[str] = []
    support = support_predecessors(components, joints=manifest.joints, cycles_level=logging.INFO)
    if source.kind is SourceKind.DERIVE:
        sequence, label = derive_sequence(components, support=support), "derived from the support graph"
    elif source.kind is SourceKind.BUILD:
        path = build_dir / manifest.sequence_file
        sequence = _read_xml(path)
        label = f"{manifest.sequence_file} of the build ({sequence.source})"
    elif source.kind is SourceKind.SEQUENCE:
        if source.path is None:
            raise PlanError("a sequence source needs the XML file's path")
        sequence, notes = _read_sequence_file(source.path, components)
        extra_warnings += notes
        label = f"{source.path} ({sequence.source})"
    else:
        path = source.path or _build_source_ifc(manifest, build_dir, extra_warnings)
        sequence, label = _ifc_sequence(path, components), f"IFC schedule of {path}"
    plan = plan_from_sequence(sequence, components, label, origin=label, support=support)
    if source.kind is SourceKind.DERIVE or (source.kind is SourceKind.BUILD and sequence.source == "derived"):
        plan = replace(plan, derived=True)
    if extra_warnings:
        plan = replace(plan, warnings=(*extra_warnings, *plan.warnings))
    for warning in plan.warnings:
        _log.warning("%s", warning)
    _log.info(
        "plan from %s: %d task(s), %s predecessors, %d warning(s)",
        plan.source,
        len(plan.order),
        "explicit" if plan.explicit else "support-graph",
        len(plan.warnings),
    )
    return plan


def plan_from_sequence(
    sequence: ConstructionSequence,
    components: Sequence[Component],
    label: str,
    *,
    origin: str = "sequence",
    support: Mapping[str, set[str]] | None = None,
) -> Plan:
    """Check ``sequence`` against ``components`` and build the plan (pure; see the module docstring).

    ``support`` is the components' support graph (:func:`bimbot.shared.support_graph.support_predecessors`),
    computed here when not given.
    """
    by_guid = {item.guid: item for item in components}
    listed = sequence.guids()
    unknown = [guid for guid in listed if guid not in by_guid]
    if unknown:
        shown = ", ".join(unknown[:MAX_NAMED_GUIDS]) + (" …" if len(unknown) > MAX_NAMED_GUIDS else "")
        raise PlanError(
            f"{origin}: {len(unknown)} task(s) name component(s) that are not in the build: {shown}"
        )
    support = support if support is not None else support_predecessors(components, cycles_level=logging.INFO)
    explicit = sequence.has_explicit_predecessors
    preds: dict[str, frozenset[str]] = {}
    if explicit:
        preds.update({guid: frozenset(values) for guid, values in sequence.predecessor_guids().items()})
    else:
        preds.update({guid: frozenset(support[guid]) for guid in listed})
    listed_set = set(listed)
    missing = [
        guid for guid in derive_sequence(components, support=support).guids() if guid not in listed_set
    ]
    warnings: list[str] = []
    if missing:
        warnings.append(
            f"{len(missing)} component(s) of the build are not in the sequence; appended in derived order "
            "with their supports as predecessors"
        )
    for guid in missing:
        preds[guid] = frozenset(support[guid])
    order = (*listed, *missing)
    task_ids = _task_ids(sequence, missing)
    names = {task.guid: task.name or "" for task in sequence.tasks}
    names.update({guid: f"Erect {by_guid[guid].name or by_guid[guid].ifc_class}" for guid in missing})
    violations = _support_check(order, preds, support)
    warnings += [_violation_text(guid, other, by_guid, kind) for guid, other, kind in violations]
    return Plan(
        source=label,
        order=order,
        predecessors=preds,
        task_ids=task_ids,
        names=names,
        explicit=explicit,
        warnings=tuple(warnings),
        violations=tuple((guid, other) for guid, other, _ in violations),
        supports={guid: frozenset(support.get(guid, ())) for guid in order},
    )


def _task_ids(sequence: ConstructionSequence, missing: Sequence[str]) -> dict[str, str]:
    """The sequence's task ids as key chunks; appended components get the next free ``T####``."""
    ids = {task.guid: guid_to_key(task.task_id) for task in sequence.tasks}
    taken = set(ids.values())
    number = len(sequence.tasks)
    for guid in missing:
        number += 1
        while f"T{number:04d}" in taken:
            number += 1
        ids[guid] = f"T{number:04d}"
        taken.add(ids[guid])
    return ids


def _support_check(
    order: Sequence[str], preds: Mapping[str, frozenset[str]], support: Mapping[str, set[str]]
) -> list[tuple[str, str, str]]:
    """(component, support, kind): kind ``order`` (sequenced before its support) or ``dag`` (no wait)."""
    found = {(guid, other): "order" for guid, other in support_violations(order, support)}
    index = {guid: number for number, guid in enumerate(order)}
    ancestors: dict[str, int] = {}  # GUID → bit set (an int) of the indices of its transitive predecessors
    for guid in graphlib.TopologicalSorter({guid: preds.get(guid, ()) for guid in order}).static_order():
        mask = 0
        for pred in preds.get(guid, ()):
            mask |= ancestors[pred] | (1 << index[pred])
        ancestors[guid] = mask
    for guid in order:
        for other in sorted(support.get(guid, ())):
            if other in index and not (ancestors[guid] >> index[other]) & 1:
                found.setdefault((guid, other), "dag")
    pairs = sorted(found, key=lambda pair: (index[pair[0]], index.get(pair[1], len(order))))
    return [(guid, other, found[(guid, other)]) for guid, other in pairs]


def _violation_text(guid: str, other: str, by_guid: Mapping[str, Component], kind: str) -> str:
    def describe(item: str) -> str:
        component = by_guid.get(item)
        return f"{item} ({component.name or component.ifc_class})" if component else item

    if kind == "order":
        return f"support check: {describe(guid)} is sequenced before {describe(other)}, which supports it"
    return f"support check: {describe(guid)} does not wait for {describe(other)}, which supports it"


def _read_xml(path: Path) -> ConstructionSequence:
    try:
        return read_sequence(Path(path))
    except SequenceError as error:
        raise PlanError(str(error)) from None
    except OSError as error:
        raise PlanError(f"{path}: cannot read ({error.strerror})") from None


def _read_sequence_file(
    path: Path, components: Sequence[Component]
) -> tuple[ConstructionSequence, list[str]]:
    """A sequence XML, or a planner's schedule (MS Project, P6 XML or XER) matched to ``components``."""
    if not Path(path).is_file():
        return _read_xml(path), []
    from bimbot.shared.planner_schedules import (
        ScheduleFormat,
        read_planner_schedule,
        schedule_format,
        summary,
    )

    kind = schedule_format(Path(path))
    if kind is ScheduleFormat.BIMBOT:
        return _read_xml(path), []
    names = {item.guid: item.name or item.ifc_class for item in components}
    try:
        matched = read_planner_schedule(Path(path), kind, names)
    except SequenceError as error:
        raise PlanError(str(error)) from None
    if not matched.sequence.tasks:
        raise PlanError(
            f"{path}: no task of the {kind.value} file matched a component of the build by GlobalId or name"
        )
    _log.info("%s (%s): %s", path, kind.value, summary(matched, list(names)))
    return matched.sequence, matched.notes(str(path))


def _ifc_sequence(path: Path, components: Sequence[Component]) -> ConstructionSequence:
    from bimbot.shared.ifc_input import open_model  # ifcopenshell: only for an IFC schedule
    from bimbot.shared.ifc_schedule import schedule_from_ifc

    model = open_model(Path(path))  # UserError naming the problem when unreadable
    try:
        schedule = schedule_from_ifc(model, [item.guid for item in components])
    except SequenceError as error:
        raise PlanError(f"{path}: IFC schedule: {error}") from None
    if schedule is None:
        raise PlanError(
            f"{path}: no IfcTask of the IFC schedule is assigned to a component of the build "
            "(use --derive or --sequence FILE)"
        )
    return schedule.sequence


def _build_source_ifc(manifest: Manifest, build_dir: Path, warnings: list[str]) -> Path:
    """The IFC the build was converted from: as recorded, else relative to the build or its parent."""
    recorded = Path(manifest.source.path)
    candidates = [recorded]
    if not recorded.is_absolute():
        candidates += [build_dir / recorded, build_dir.parent / recorded]
    for candidate in candidates:
        if candidate.is_file():
            if _sha256(candidate) != manifest.source.sha256:
                warnings.append(f"{candidate} changed since the build was converted (sha256 differs)")
            return candidate
    raise PlanError(f"the build's source IFC {recorded} is not found (name it: --from-ifc FILE.ifc)")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
