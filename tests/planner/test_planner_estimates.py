"""A task's estimate counts the time its robot holds the component at its target until it is connected
(and its temporary supports set), as physics holds it; a bid that waits for a busy robot sees it (pure)."""

from __future__ import annotations

import pytest
from planner_builders import component, idle_core, portal_manifest, state_msg

from bimbot.services.planner.capability import SiteRobot, Where, task_estimate_s
from bimbot.services.planner.feasibility import slot_where
from bimbot.services.planner.scheduler import Phase
from bimbot.shared.connection_hold import UNLINKED_CONNECTION_S, expected_hold_s
from bimbot.shared.connection_kinds import (
    ConnectionKind,
    ConnectionLink,
    SupportKind,
    SupportWhen,
    TemporarySupportNeed,
)
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentState, TaskStatus

TYPES = default_fleet().types
CARRIER, CRANE = TYPES["carrier"], TYPES["tower_crane"]
BOLTED_BASE_S = 120.0  # the methods file's bolted base (a link carries its time)
PINNED_END_S = 60.0
PROPS = TemporarySupportNeed(kind=SupportKind.PROPS, count=2, place_s=90.0, when=SupportWhen.ALWAYS)


def _link(other: str, kind: ConnectionKind, time_s: float, source: str = "side") -> ConnectionLink:
    return ConnectionLink(other_guid=other, kind=kind, time_s=time_s, source=source)


def _column(
    guid: str, x: float, *links: ConnectionLink, need: TemporarySupportNeed | None = None
) -> Component:
    item = component(guid, "IfcColumn", (x - 0.05, -0.05, 0.0), (x + 0.05, 0.05, 3.0))
    return item.model_copy(
        update={"mass_kg": 40.0, "connection_links": list(links), "temporary_support": need}
    )


def _bolted_column(guid: str = "col", x: float = 0.0) -> Component:
    return _column(guid, x, _link("footing", ConnectionKind.BOLTED_BASE, BOLTED_BASE_S, "joint"))


def test_a_column_set_on_its_bolted_base_is_estimated_with_the_120_s_its_robot_holds_it() -> None:
    robot = SiteRobot("r1", CARRIER, (0.0, -3.0, 0.0))
    lies = Where((0.0, -6.0), 0.5)
    bolted = task_estimate_s(robot, (0.0, -3.0), _bolted_column(), lies)
    unlinked = task_estimate_s(robot, (0.0, -3.0), _column("col", 0.0), lies)
    assert bolted >= BOLTED_BASE_S
    # the same drive and handling; the hold is the link's, and one connection in physics' fallback time
    # for a column its manifest links to nothing
    assert bolted - unlinked == pytest.approx(BOLTED_BASE_S - UNLINKED_CONNECTION_S)
    # put down at a staging spot (a hand-off) it is not held: no connection is made there
    handed = task_estimate_s(robot, (0.0, -3.0), _bolted_column(), lies, (0.0, -9.0))
    assert bolted - handed > BOLTED_BASE_S


def test_a_crane_s_estimate_holds_the_member_too() -> None:
    crane = SiteRobot("c1", CRANE, (0.0, 10.0, 0.0))
    lies = Where((5.0, 10.0), 0.5)
    bolted = task_estimate_s(crane, (0.0, 10.0), _bolted_column(), lies)
    unlinked = task_estimate_s(crane, (0.0, 10.0), _column("col", 0.0), lies)
    assert bolted - unlinked == pytest.approx(BOLTED_BASE_S - UNLINKED_CONNECTION_S)


def test_the_expected_hold_is_the_slowest_connection_and_the_supports_physics_would_set() -> None:
    pinned_joint = _link("frame", ConnectionKind.PINNED_END, PINNED_END_S, "joint")
    pinned_side = _link("frame", ConnectionKind.PINNED_END, PINNED_END_S, "side")
    unconnected = PROPS.model_copy(update={"when": SupportWhen.UNCONNECTED})
    bearing = _link("beam", ConnectionKind.BEARING, 20.0, "bearing face")
    # the slowest of its links
    assert expected_hold_s(_column("a", 0.0, bearing, pinned_side, pinned_joint)) == PINNED_END_S
    # propped always (a precast panel): its props are set while its robot holds it
    assert expected_hold_s(_column("b", 0.0, pinned_joint, need=PROPS)) == PINNED_END_S + 180.0
    # propped only when nothing fixes it: a window framed into its joint partner is held by it ...
    assert expected_hold_s(_column("c", 0.0, pinned_joint, need=unconnected)) == PINNED_END_S
    # ... one bolted to a single neighbour at its side turns about it (a hinge), so it is propped
    assert expected_hold_s(_column("d", 0.0, pinned_side, need=unconnected)) == PINNED_END_S + 180.0


def test_a_busy_robot_whose_column_is_still_held_is_not_waited_for_by_the_next_column() -> None:
    """r1 is beside both columns, r2 two minutes' drive away: without the holds, r1 would set both
    sooner and the second column would wait for it; with each column held 120 s on its bolts, r2 (which
    holds its own column as long) sets the second one first."""
    manifest = portal_manifest()
    columns = [_bolted_column("col_a", 0.0), _bolted_column("col_b", 4.0)]
    manifest = manifest.model_copy(update={"components": columns})
    robots = [SiteRobot("r1", CARRIER, (2.0, -3.0, 0.0)), SiteRobot("r2", CARRIER, (60.0, -3.0, 0.0))]
    core = idle_core(manifest, robots)
    core.step(0.0)
    for guid in ("col_a", "col_b"):
        core.observe_component_state(state_msg(guid, ComponentState.RELEASED, event="release"))
    out = core.step(0.1)
    assigned = {m.guid: m.robot_id for m in out if getattr(m, "status", None) is TaskStatus.ASSIGNED}
    assert assigned == {"col_a": "r1", "col_b": "r2"}
    assert core.phase("col_b") is Phase.ASSIGNED
    # the bids: r1 is free after its first column (its estimate with the hold), then sets the second
    lies = slot_where(columns[1], None)  # no yard slots: it lies at its target
    near = task_estimate_s(robots[0], (2.0, -3.0), columns[1], lies)
    far = task_estimate_s(robots[1], (60.0, -3.0), columns[1], lies)
    assert 2 * (near - BOLTED_BASE_S) < far - BOLTED_BASE_S  # without the holds r1 would win ...
    assert far < 2 * near  # ... with them r2 does


def test_a_components_hold_is_remembered_while_the_component_lives_and_no_longer() -> None:
    """Every assignment pass asks the hold of each released task for every robot: it is worked out once
    per component object, and forgotten with the object (a long planner or test session keeps no dead
    manifest alive, and a new object that takes the same id is not given another's hold)."""
    import gc

    from bimbot.services.planner import capability

    robot = SiteRobot("r1", CARRIER, (0.0, -3.0, 0.0))
    item = _bolted_column("remembered")
    first = task_estimate_s(robot, (0.0, -3.0), item, Where((0.0, -6.0), 0.5))
    key = id(item)
    assert capability._HOLDS[key] == expected_hold_s(item) == BOLTED_BASE_S
    assert task_estimate_s(robot, (0.0, -3.0), item, Where((0.0, -6.0), 0.5)) == first
    del item
    gc.collect()
    assert key not in capability._HOLDS
