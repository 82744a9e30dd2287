"""Does every partial structure of a sequence stand? A physics-only replay, without robots.

Why: a builder wants to know whether a schedule leaves the structure unstable before rehearsing it with
robots (``bimbot run OUT/ --check-stability``: seconds instead of a build). The replay puts every component
of the sequence, in order, exactly at its BIM pose, releases it into dynamics as a robot's placement does
(:mod:`.releasing`: onto what is under it, into the open pit of a foundation not placed yet), lets it come to
rest (:mod:`.release`), and checks every component placed so far and not yet joined: one that moved more
than ``drift_tolerance_m`` since its release means the partial structure does not stand. Each component
that stood is joined to the structure, as its agent's verification would. The first step that does not
stand ends the replay, naming the component, how far it moved and what it rested on. A component cast in
place or laid is built where it stands (static, as concrete in its formwork or masonry in mortar), not
released; a panel is released like any lifted component.

Exact placements, no robots, no localisation: what is tested is the order, not the robots' hands.
"""

from __future__ import annotations

import logging
import shlex
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from bimbot.shared.connection_hold import longest_hold_s
from bimbot.shared.identifiers import named_guid
from bimbot.shared.manifest import Manifest
from bimbot.shared.reasons import BESIDE_IT, CLASH_ADVICE, clash_clause
from bimbot.shared.support_graph import support_predecessors

from .connections import ConnectionConfig
from .handling_state import target_frame
from .in_place_work import BUILT_IN_PLACE
from .model_clashes import Clash, model_clashes
from .profiles import REHEARSAL
from .release import SettleConfig
from .simulation import SimConfig, Simulation

_log = logging.getLogger(__name__)

TAG = "stability"


@dataclass(frozen=True)
class Moved:
    """A component that moved beyond the tolerance in a step: by how much, and what it rested on."""

    guid: str
    name: str
    drift_m: float
    placed_on: tuple[str, ...]  # what it was set down on
    rests_on: tuple[str, ...]  # what it came to rest on
    open_pits: tuple[str, ...] = ()  # foundations not placed yet whose open pit it was set down over
    missing: tuple[str, ...] = ()  # what it rests on in the support graph and was not placed yet
    clashes: tuple[tuple[str, float], ...] = ()  # what the model puts where it is (GUID, overlap in m)


@dataclass(frozen=True)
class StabilityStep:
    index: int  # 1-based, in the sequence
    guid: str
    name: str
    settle_s: float  # sim seconds until it came to rest (or the settling bound)
    drift_m: float  # how far it moved since its release
    rests_on: tuple[str, ...]  # what it rested on
    moved: tuple[Moved, ...] = ()  # everything that moved beyond the tolerance in this step
    supports: tuple[str, int] | None = None  # the temporary supports it needed (kind, count), if any
    removed: tuple[str, ...] = ()  # members whose temporary supports came off in this step

    @property
    def stands(self) -> bool:
        return not self.moved


@dataclass(frozen=True)
class StabilityReport:
    total: int
    steps: list[StabilityStep] = field(default_factory=list)
    sim_s: float = 0.0
    wall_s: float = 0.0
    clashes: list[Clash] = field(default_factory=list)  # every pair the model puts into each other
    supported_at_end: tuple[str, ...] = ()  # members whose temporary supports still stand at the end

    @property
    def first_failure(self) -> StabilityStep | None:
        return next((step for step in self.steps if not step.stands), None)

    @property
    def stands(self) -> bool:
        return self.first_failure is None and len(self.steps) == self.total


def check_stability(
    manifest: Manifest,
    build_dir: Path,
    order: list[str] | tuple[str, ...],
    *,
    drift_tolerance_m: float = 0.005,  # the agents' (bimbot run passes theirs)
    settle: SettleConfig | None = None,
    connections: ConnectionConfig | None = None,
    physics_hz: float = REHEARSAL.physics_hz,
    control_period_s: float = REHEARSAL.control_period_s,
) -> StabilityReport:
    """Replay ``order`` (GUIDs of ``manifest``) in physics; stop at the first step that does not stand."""
    names = {component.guid: component.name or component.ifc_class for component in manifest.components}
    rests_on = support_predecessors(manifest.components, joints=manifest.joints, cycles_level=logging.INFO)
    placed: set[str] = set()
    config = SimConfig(
        robots=0,
        step_s=1.0 / physics_hz,
        control_period_s=control_period_s,
        settle=settle or SettleConfig(),
        connections=connections or ConnectionConfig(),
    )
    started = time.monotonic()
    steps: list[StabilityStep] = []
    with Simulation(manifest, build_dir, config) as sim:
        handling = sim.handling
        in_order = {guid: handling.items[guid] for guid in order if guid in handling.items}
        clashes = model_clashes(
            sim.client_id,
            {guid: item.body for guid, item in in_order.items()},
            {guid: target_frame(item.component) for guid, item in in_order.items()},
            handling.joints,
        )
        for index, guid in enumerate(order, start=1):
            since_s = sim.sim_time_s
            item = handling.items.get(guid)
            standing_before = set(handling.supports.standing)
            if item is not None and item.component.method in BUILT_IN_PLACE:
                # cast in its formwork or laid in mortar: it stands where it is built, static
                sim.in_place_work.stand_built(guid)
                handling.note_constructed(guid, True)
                placed.add(guid)
                steps.append(StabilityStep(index, guid, names.get(guid, guid), 0.0, 0.0, ()))
                _log.info(
                    "step %d/%d: %s built in place (%s)",
                    index,
                    len(order),
                    names.get(guid, guid),
                    item.component.method.value,
                )
                continue
            handling.set_down(guid, since_s, tag=TAG)
            placed.add(guid)
            # the watch answers by then at the latest (held while its connections and supports are made)
            assert item is not None
            hold_s = longest_hold_s(item.component, handling.connections.hold_s)
            bound_s = handling.settle.max_settle_s + hold_s + control_period_s
            while not any(tag == TAG for tag, _ in sim.advance().replies):
                if sim.sim_time_s - since_s > bound_s:
                    break
                watch = handling.watch[guid]
                if watch.settled and all(w.settled for w in handling.watch.values()):
                    # at rest, held while its connections and supports are made: nothing moves until then
                    sim.skipped_s += max(0.0, watch.hold_until_s - sim.sim_time_s)
            moved = tuple(
                Moved(
                    other,
                    names.get(other, other),
                    watch.drift_m,
                    watch.placed_on or (),
                    watch.supports,
                    watch.open_pits,
                    tuple(sorted(rests_on.get(other, set()) - placed - {other})),
                    watch.clashes,
                )
                for other, watch in handling.watch.items()
                if watch.drift_m > drift_tolerance_m
            )
            watch = handling.watch[guid]
            standing = handling.supports.standing.get(guid)
            step = StabilityStep(
                index,
                guid,
                names.get(guid, guid),
                sim.sim_time_s - since_s,
                watch.drift_m,
                watch.supports,
                moved,
                (standing.kind.value, standing.count) if standing is not None else None,
                tuple(sorted(standing_before - set(handling.supports.standing))),
            )
            steps.append(step)
            _log.info(
                "step %d/%d: %s %s (%.1f mm after %.1f s, on %s)",
                index,
                len(order),
                step.name,
                "stands" if step.stands else "does not stand",
                1000.0 * step.drift_m,
                step.settle_s,
                ", ".join(step.rests_on) or "the ground",
            )
            if not step.stands:
                break
            handling.note_constructed(guid, True)  # verified: joined to the structure
            placed.add(guid)
        sim_s = sim.sim_time_s
        at_end = tuple(sorted(handling.supports.standing))
    return StabilityReport(len(order), steps, sim_s, time.monotonic() - started, clashes, at_end)


MAX_CLASHES_SHOWN = 30  # named in the output; the rest are counted


def _clash_lines(clashes: list[Clash], named: Callable[[tuple[str, ...]], str]) -> list[str]:
    """Every clash in the model, deepest first (at most ``MAX_CLASHES_SHOWN`` named), before the replay's
    verdict: the replay stops at the first that makes a step fail, a user repairs them all at once."""
    if not clashes:
        return []
    lines = [
        f"the model puts {len(clashes)} pair(s) of components into each other, deeper than a contact "
        "(clashes in the IFC: physics pushes each pair apart, so a step with one does not stand):"
    ]
    lines += [
        f"  {named((clash.first,))} and {named((clash.second,))}: {1000.0 * clash.depth_m:.0f} mm deep"
        for clash in clashes[:MAX_CLASHES_SHOWN]
    ]
    if len(clashes) > MAX_CLASHES_SHOWN:
        lines.append(f"  and {len(clashes) - MAX_CLASHES_SHOWN} more pair(s), less deep")
    return lines


MAX_SUPPORT_STEPS_SHOWN = 40  # steps needing temporary supports named in the output; the rest are counted


def _support_lines(report: StabilityReport, named: Callable[[tuple[str, ...]], str]) -> list[str]:
    """The steps that need temporary supports (which, how many), when each came off, what still stands."""
    needing = [step for step in report.steps if step.supports is not None]
    if not needing:
        return []
    removed_at = {guid: step.index for step in report.steps for guid in step.removed}
    total = sum(step.supports[1] for step in needing if step.supports is not None)
    lines = [f"{len(needing)} step(s) need temporary supports ({total} in all), set as each is placed:"]
    for step in needing[:MAX_SUPPORT_STEPS_SHOWN]:
        assert step.supports is not None
        kind, count = step.supports
        off = (
            f", removed at step {removed_at[step.guid]} (its connections then hold it)"
            if step.guid in removed_at
            else ""
        )
        lines.append(f"  step {step.index}: {step.name} ({step.guid}) needs {count} {kind}{off}")
    if len(needing) > MAX_SUPPORT_STEPS_SHOWN:
        lines.append(f"  and {len(needing) - MAX_SUPPORT_STEPS_SHOWN} more step(s)")
    if report.supported_at_end:
        lines.append(
            f"{len(report.supported_at_end)} member(s) still stand on temporary supports at the end (no "
            "connection path to something that stands by itself, or grout not set yet): "
            + named(report.supported_at_end[:MAX_SUPPORT_STEPS_SHOWN])
            + (" …" if len(report.supported_at_end) > MAX_SUPPORT_STEPS_SHOWN else "")
        )
    return lines


def _came_to_rest(moved: Moved, named: Callable[[tuple[str, ...]], str]) -> str:
    """Where a moved component ended, without naming twice what it was set down on (a member that slid or
    tipped but still touches its supports: ``came to rest on …, still touching what it was set down on``)."""
    placed_on = set(moved.placed_on)
    if placed_on and placed_on <= set(moved.rests_on):
        others = tuple(guid for guid in moved.rests_on if guid not in placed_on)
        still = "still touching what it was set down on"
        return f"came to rest on {named(others)}, {still}" if others else f"came to rest {still}"
    return "came to rest on " + (
        named(moved.rests_on) or ("the pit's floor" if moved.open_pits else "the ground")
    )


def describe(
    report: StabilityReport, names: dict[str, str], *, derived: bool = False, connections: bool = True
) -> list[str]:
    """The lines a user reads: every partial structure stands, or the first step that does not, what was
    left unchecked and what to try (``derived``: the order already is the support graph's; ``connections``:
    whether the replay connected components to what was built beside them). Components as ``Name (GUID)``,
    as the run's table names them."""
    failure = report.first_failure
    timing = f"{report.sim_s:.0f} s of sim time, {report.wall_s:.1f} s wall"

    def named(guids: tuple[str, ...]) -> str:
        return ", ".join(named_guid(guid, names.get(guid)) for guid in guids)

    clash_lines = _clash_lines(report.clashes, named) + _support_lines(report, named)
    if failure is None:
        return [
            *clash_lines,
            f"every partial structure stands: {len(report.steps)} step(s) placed and settled ({timing})",
        ]
    lines = [*clash_lines, f"step {failure.index} of {report.total} does not stand ({timing}):"]

    missing: list[str] = []
    clashing: list[str] = []
    for moved in failure.moved:
        where = (
            f"over the open pit of {named(moved.open_pits)}, not placed yet"
            if moved.open_pits
            else (f"on {named(moved.placed_on)}" if moved.placed_on else "on nothing but the ground")
        )
        unplaced = f"; it rests on {named(moved.missing)}, not placed before it" if moved.missing else ""
        clash = clash_clause([(named((other,)), depth_m) for other, depth_m in moved.clashes])
        missing += [*moved.open_pits, *moved.missing]
        clashing += [other for other, _ in moved.clashes]
        lines.append(
            f"  {moved.name} ({moved.guid}) moved {moved.drift_m:.3f} m after it was placed: it was set down "
            f"{where} and {_came_to_rest(moved, named)}{unplaced}{clash}"
        )
    if failure.index < report.total:
        lines.append(
            f"steps {failure.index + 1}–{report.total} were not checked: the replay stops at the first step "
            "that does not stand"
        )
    if clashing:
        lines.append(
            f"to try: {CLASH_ADVICE}: {named(tuple(dict.fromkeys(clashing)))} or "
            f"{failure.name} ({failure.guid}), e.g. bimbot convert MODEL.ifc -o OUT/ --exclude "
            f"{shlex.quote(failure.guid)} (a GlobalId may hold a $: keep the quotes)"
        )
    elif missing:
        first = named(tuple(dict.fromkeys(missing)))
        why = (
            ": the support graph's order (derived) places what rests on something after it, but does not "
            "see open pits (the excavation under a foundation, open until it is placed)"
            if derived
            else ", or --derive for the support graph's order"
        )
        lines.append(f"to try: place {first} earlier (--sequence F.xml){why}")
    elif not connections:
        lines.append(
            "to try: the replay made no connections (--no-connections): without it, a member set down at "
            f"its target beside one already built ({BESIDE_IT}) is connected to it and stays"
        )
    elif derived:
        lines.append(
            "to try: everything it rests on was placed before it, and no component built beside it "
            f"({BESIDE_IT}) could be connected to it, and it has no temporary supports (the converter "
            "gives props and braces to precast panels, members with nothing under them and slender columns)"
        )
    else:
        lines.append(
            "to try: what holds it must be placed before it (--sequence F.xml, or --derive): it is connected "
            f"only to components built beside it before it ({BESIDE_IT})"
        )
    return lines
