"""A ready component waits while placing it would cut off work still to be built (the access hold), and a
hold never stops a run: with nothing else in flight, the first held component goes."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path

from planner_builders import one_robot_site_info, portal_manifest, state_msg
from site_models import ROOM_WALLS

from bimbot.services.planner.access_hold import AccessGuard
from bimbot.services.planner.scheduler import Phase, PlannerCore
from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan, plan_from_sequence
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.support_graph import derive_sequence, support_predecessors

S = ComponentState


def _construct_released(core: PlannerCore, order: tuple[str, ...], keep: set[str]) -> None:
    """Every released task's component constructed, but those in ``keep``."""
    for guid in order:
        if core.phase(guid) is Phase.RELEASED and guid not in keep:
            core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))


def test_the_wall_that_would_close_the_room_waits_for_the_column_inside_it(walls_first_build: Path) -> None:
    """The plan (support only, the walls first) releases the four room walls and the column together; the
    wall that closes the room waits until the column is constructed. Without the hold it is released at
    once, and a robot that builds it first leaves the column unreachable."""
    manifest = read_manifest(walls_first_build)
    guid = {c.name: c.guid for c in manifest.components}
    given = load_plan(manifest, walls_first_build, PlanSource(SourceKind.BUILD))
    support = support_predecessors(manifest.components)
    plan = replace(given, predecessors={g: frozenset(support[g]) for g in given.order}, derived=True)
    closing = max(ROOM_WALLS, key=lambda wall: plan.order.index(guid[wall]))
    column = guid["Column R1"]
    counter = itertools.count(1)

    def core_with(access: AccessGuard | None) -> PlannerCore:
        return PlannerCore(manifest, plan, new_id=lambda: f"ev{next(counter)}", access=access)

    unguarded = core_with(None)
    unguarded.step(0.0)
    assert unguarded.phase(guid[closing]) is Phase.RELEASED

    core = core_with(AccessGuard.for_site(manifest, one_robot_site_info(manifest), plan.predecessors))
    for _ in range(len(plan.order)):  # whatever is released is built, the column last
        core.step(0.0)
        _construct_released(core, plan.order, keep={column})
    assert core.phase(column) is Phase.RELEASED
    assert core.phase(guid[closing]) is Phase.WAITING
    assert all(core.phase(guid[wall]) is Phase.DONE for wall in ROOM_WALLS if wall != closing)
    core.observe_component_state(state_msg(column, S.CONSTRUCTED, event="verified"))
    core.step(0.0)
    assert core.phase(guid[closing]) is Phase.RELEASED


class _EachCutsOffTheOther:
    """A guard by which placing either footing would cut the other off (a site where nothing goes on)."""

    def __init__(self) -> None:
        self.asked: list[str] = []

    def observe(self, standing, gone) -> None:
        self.standing = set(standing)

    def stand(self, guid: str) -> None:
        self.standing.add(guid)

    def cut_off(self, guid: str, to_build) -> list[str]:
        self.asked.append(guid)
        other = {"foot_a": "foot_b", "foot_b": "foot_a"}.get(guid)
        return [other] if other in to_build and other not in self.standing else []


def test_with_nothing_else_in_flight_the_first_held_component_goes() -> None:
    manifest = portal_manifest()
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    guard = _EachCutsOffTheOther()
    core = PlannerCore(manifest, plan, new_id=lambda: f"ev{next(counter)}", access=guard)  # type: ignore[arg-type]
    core.step(0.0)
    assert {"foot_a", "foot_b"} <= set(guard.asked)
    first, second = sorted(("foot_a", "foot_b"), key=plan.order.index)
    # foot_c is ready and goes, then post_c on it: while they are in flight both footings wait
    assert core.phase("foot_c") is Phase.RELEASED
    for independent in ("foot_c", "post_c"):
        assert core.phase(first) is Phase.WAITING and core.phase(second) is Phase.WAITING
        core.observe_component_state(state_msg(independent, S.CONSTRUCTED, event="verified"))
        core.step(0.0)
    # nothing in flight: the first held footing goes, the second stays held while the first is in flight
    assert core.phase(first) is Phase.RELEASED
    assert core.phase(second) is Phase.WAITING
