"""Access-aware plans: a sequence checked (and, when derived, mended) so no placement cuts off later work.

Why: the support graph says what rests on what, not what a robot can still drive to. Four walls built
before the column inside them leave the column unreachable; the robots would find out only after driving
there. The check (:func:`bimbot.shared.site_access.check_order`) walks the plan's order on the site grid
of the robot type on site and finds, for every step, the components it cuts off. Then:

* a plan the planner may reorder (``--derive``, or the build's derived ``sequence.xml``) gets one extra
  precedence per cut-off — the component cut off must be constructed before the one that cuts it off —
  unless that would close a cycle; the order is recomputed (release priority kept) and checked again, at
  most ``MAX_ROUNDS`` times, so the release of the ready set keeps access whatever the robots' pace;
* a given sequence (an XML or the IFC's 4D schedule) is not changed: every cut-off is a warning naming
  both GUIDs (``strict``: a :class:`~.sources.PlanError`, exit 2);
* a component whose target (or yard slot) is cut off by the components that must stand before it (its
  ancestors in the plan) can never be built by a ground robot: when a crane on site can set it at its
  target (load chart, jib height) it goes in ``Plan.from_above`` and a crane is asked first, as a site
  lifts in what it cannot drive to (the Revit duplex's upper-floor door in a room its exterior walls
  close); else it is returned with reason ``unreachable`` naming them, and the planner fails it before
  the build starts. Checked on the robots' own 0.1 m grid, so a coarse grid
  never fails a buildable component.

A component built where it stands (cast in place, laid: :mod:`.work_in_place`) is reached by its machine's
boom, not driven to: it is still an obstacle once built, but its own access is not checked and nothing is
reordered or failed for it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

from bimbot.shared.identifiers import named_guid
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import SiteInfoMsg
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.sequence import priority_topological_order
from bimbot.shared.site_access import AccessConfig, SiteAccess, check_order

from .capability import can_place, site_robots
from .preparing import Report, no_report
from .sources import Plan, PlanError
from .work_in_place import works_in_place

_log = logging.getLogger(__name__)

MAX_ROUNDS = 8
FINE = AccessConfig(resolution_m=0.1)
MAX_NAMED = 4


@dataclass(frozen=True)
class AccessOutcome:
    plan: Plan
    unreachable: dict[str, Reason]  # never accessible at its turn: fail before the build
    warnings: tuple[str, ...]
    added: int = 0  # precedences added to keep access


def site_robot(info: SiteInfoMsg) -> RobotDescription:
    """The robot type the access check plans for: the widest ground type on site (what fits it fits the
    others; a machine that stands fixed never drives), with the lowest step of them (a floor every one
    drives on)."""
    ground = [robot for robot in info.robot_types.values() if robot.can(Capability.DRIVE)]
    widest = max(ground or info.robot_types.values(), key=lambda robot: (robot.radius_m, robot.name))
    step_m = min((robot.max_step_m for robot in ground), default=0.0)
    return widest.model_copy(update={"max_step_m": step_m})


def access_plan(
    plan: Plan,
    manifest: Manifest,
    info: SiteInfoMsg,
    *,
    adjust: bool,
    strict: bool = False,
    report: Report = no_report,
) -> AccessOutcome:
    """Check ``plan`` for access (see the module docstring); mend it when ``adjust``. ``report`` hears how
    far the check is, step by step (:mod:`.preparing`)."""
    components = list(manifest.components)
    robot = site_robot(info)
    layout = info.layout  # physics' site plan: the one the robots drive in
    by_guid = {component.guid: component for component in components}
    in_place = {component.guid for component in components if works_in_place(component)}
    added = 0
    grid = _stage(report, "access check: the site grid")
    access = SiteAccess(components, layout, robot, in_place=manifest.in_place, on_step=grid)
    check = check_order(access, plan.order, _stage(report, "access check"))
    for rounds in range(1, (MAX_ROUNDS if adjust else 0) + 1):
        preds = {guid: set(plan.predecessors.get(guid, ())) for guid in plan.order}
        new = 0
        for placed, cut in _driven_to(check.cut_offs, in_place):
            if cut not in preds[placed] and not _depends_on(preds, cut, placed):
                preds[placed].add(cut)
                new += 1
        _log.info(
            "access check round %d: %d cut-off(s), %d precedence(s) added", rounds, len(check.cut_offs), new
        )
        if not new:
            break
        added += new
        frozen = {guid: frozenset(values) for guid, values in preds.items()}
        earlier = (plan.order, check)
        plan = replace(plan, predecessors=frozen, order=_priority_order(plan.order, frozen))
        access.reset()
        stage = _stage(report, f"access check, mended {rounds} time(s)")
        check = check_order(access, plan.order, stage, earlier=earlier)
    cut_offs = _driven_to(check.cut_offs, in_place)
    warnings = [
        f"access check: placing {_describe(placed, by_guid)} cuts off {_describe(cut, by_guid)}"
        for placed, cut in cut_offs
    ]
    if cut_offs:
        plan = replace(plan, cut_off_by={cut: placed for placed, cut in reversed(cut_offs)})
    unreachable: dict[str, Reason] = {}
    from_above: set[str] = set()
    cranes = [robot for robot in site_robots(info) if robot.lifts_by_hook]
    fine: SiteAccess | None = None  # one fine grid for every doubt, changed only where ancestors differ
    for done, guid in enumerate(check.inaccessible):
        report("access check: what no robot can reach", done, len(check.inaccessible))
        if guid in in_place:
            continue
        ancestors = _ancestors(plan.predecessors, guid)
        fine = fine or SiteAccess(components, layout, robot, FINE, in_place=manifest.in_place)
        _stand_only(fine, ancestors, plan.order)
        if fine.slot_accessible(guid) and fine.target_accessible(guid):
            continue
        where = "target" if not fine.target_accessible(guid) else "yard slot"
        if where == "target" and any(can_place(crane, by_guid[guid]) for crane in cranes):
            from_above.add(guid)  # a crane sets it from above while nothing covers it (a site lifts it in)
            continue
        if manifest.in_place and not check.inaccessible[guid] and _cut_off_alone(fine, guid, plan.order):
            cutters = []  # nothing built by the plan is needed to cut it off: the existing work does
        else:
            cutters = [other for other in check.inaccessible[guid] if other in ancestors] or sorted(ancestors)
        named = ", ".join(_describe(other, by_guid) for other in cutters[:MAX_NAMED])
        more = f" and {len(cutters) - MAX_NAMED} more" if len(cutters) > MAX_NAMED else ""
        verb = "stand" if len(cutters) > 1 else "stands"
        empty = "with the work in place before the robots come" if manifest.in_place else "on the empty site"
        cause = f"once {named}{more} {verb} (built before it by the plan)" if cutters else empty
        unreachable[guid] = Reason(
            code=ReasonCode.UNREACHABLE,
            message=(
                f"no cell within the {robot.name} robot's reach ({robot.reach_m:.2f} m) of its {where} "
                f"can be driven to from the depot {cause}"
            ),
            guid=cutters[0] if cutters else None,
        )
    for warning in warnings:
        _log.warning("%s", warning)
    if added:
        _log.info("access check: %d precedence(s) added so that no placement cuts off later work", added)
    if from_above:
        _log.info(
            "access check: %d component(s) no ground robot can get to at their turn go to a crane first",
            len(from_above),
        )
        plan = replace(plan, from_above=frozenset(from_above))
    if strict and warnings:
        raise PlanError(f"{len(warnings)} step(s) of the sequence cut off later work; first: {warnings[0]}")
    return AccessOutcome(plan, unreachable, tuple(warnings), added)


def _stage(report: Report, stage: str) -> Callable[[int, int], None]:
    return lambda done, total: report(stage, done, total)


def _cut_off_alone(access: SiteAccess, guid: str, order: Sequence[str]) -> bool:
    """Whether ``guid`` is cut off with nothing the plan builds standing (by the site and what is in place
    before the robots come alone); ``access`` is left so."""
    _stand_only(access, set(), order)
    return not (access.slot_accessible(guid) and access.target_accessible(guid))


def _stand_only(access: SiteAccess, guids: set[str], order: Sequence[str]) -> None:
    """Change ``access`` so exactly ``guids`` stand at their targets (the rest back in their slots): only
    the difference from what stands now is moved (the restaurant's 245 doubts each built a 0.1 m grid of
    a 220 m site afresh and placed every ancestor on it: the planner never finished starting)."""
    for other in [guid for guid in access.placed if guid not in guids]:
        access.remove(other)
    for other in order:
        if other in guids and other not in access.placed:
            access.place(other)


def _driven_to(cut_offs: tuple[tuple[str, str], ...], in_place: set[str]) -> list[tuple[str, str]]:
    """The cut-offs of components a robot drives to (not those a boom reaches where they stand)."""
    return [(placed, cut) for placed, cut in cut_offs if cut not in in_place]


def _depends_on(preds: Mapping[str, set[str]], guid: str, other: str) -> bool:
    """``guid`` (transitively) waits for ``other``."""
    stack, seen = [guid], set()
    while stack:
        item = stack.pop()
        if item == other:
            return True
        if item not in seen:
            seen.add(item)
            stack.extend(preds.get(item, ()))
    return False


def _ancestors(preds: Mapping[str, frozenset[str]], guid: str) -> set[str]:
    seen: set[str] = set()
    stack = list(preds.get(guid, ()))
    while stack:
        item = stack.pop()
        if item not in seen:
            seen.add(item)
            stack.extend(preds.get(item, ()))
    return seen


def _priority_order(order: tuple[str, ...], preds: Mapping[str, frozenset[str]]) -> tuple[str, ...]:
    """A topological order of ``preds`` that keeps ``order``'s priority wherever the precedences allow."""
    rank = {guid: index for index, guid in enumerate(order)}
    return tuple(
        priority_topological_order({guid: set(preds.get(guid, ())) for guid in order}, rank.__getitem__)
    )


def _describe(guid: str, by_guid: Mapping[str, Component]) -> str:
    component = by_guid.get(guid)
    return named_guid(guid, component.name or component.ifc_class) if component else guid
