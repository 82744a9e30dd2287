"""Connections (services/physics/connections.py), with real pybullet on the bundled frame.

Beam A1-A2 lies on Column A1 and Column A2 and meets Beam A2-A3 end to end over Column A2. With only
Column A1 under it, it tips off its free end (test_physics_handling.py). With Beam A2-A3 built beside it,
its crew connects it to that beam while the robot holds it: it stays where it was set down. Resting on
top of something is not a connection, a placement off its target is never connected (but stands on the
props its manifest gives it until a robot takes it up again), and with connections off every component
must stand by itself.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path

import pytest
from physics_builders import angle_between, idle, pose

from bimbot.services.physics.client import p
from bimbot.services.physics.connections import ConnectionConfig, side_neighbours
from bimbot.services.physics.handling_state import Phase
from bimbot.services.physics.scene import component_pose, footprint
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.connection_hold import longest_hold_s
from bimbot.shared.connection_kinds import (
    ConnectionKind,
    ConnectionLink,
    SupportKind,
    SupportWhen,
    TemporarySupportNeed,
)
from bimbot.shared.manifest import Component, Manifest, Pose
from bimbot.shared.messages import AttachRequest, PhysicsReply, PlaceRequest, SkipRequest

HOLD_S = 3.0  # short, so that the tests stay fast; the default is 20 s


def _named(manifest: Manifest, name: str) -> Component:
    return next(c for c in manifest.components if c.name == name)


def _built(sim: Simulation, component: Component) -> None:
    """``component`` at its target, joined to the structure (as a restarted physics puts one back)."""
    target = component.target_pose_world
    sim.handling.restore(component.guid, (target.position_m, target.quat_xyzw), fixed=True, carrier=None)
    sim.handling.note_constructed(component.guid, True)


def _pick_up(sim: Simulation, component: Component) -> None:
    """r1 takes ``component`` from its yard slot."""
    slot = sim.layout.slots[component.guid]
    spot = slot.footprint
    x = spot.min_xy[0] - 0.8 if slot.aisle_side < 0 else spot.max_xy[0] + 0.8
    sim.teleport_robot("r1", (x, (spot.min_xy[1] + spot.max_xy[1]) / 2.0, math.pi / 2))
    assert sim.attach(AttachRequest(robot_id="r1", guid=component.guid)).ok
    idle(sim, 1.2)


def _beside_target(sim: Simulation, component: Component) -> Pose:
    """r1 stands west of ``component``'s target; the target."""
    target = component.target_pose_world
    rect = footprint(component, (target.position_m, target.quat_xyzw))
    sim.teleport_robot("r1", (rect.min_xy[0] - 0.8, (rect.min_xy[1] + rect.max_xy[1]) / 2.0, 0.0))
    return target


def _place(
    sim: Simulation, component: Component, *, offset_y_m: float = 0.0, within_s: float | None = None
) -> tuple[PhysicsReply, float]:
    """Pick ``component`` from the yard, stand west of its target and place it (``offset_y_m`` off its
    target); the reply and the sim seconds from the end of the motion to the reply."""
    _pick_up(sim, component)
    target = _beside_target(sim, component)
    x0, y0, z0 = target.position_m
    request = PlaceRequest(
        robot_id="r1",
        guid=component.guid,
        pose=pose((x0, y0 + offset_y_m, z0), target.quat_xyzw),
        duration_s=1.0,
    )
    assert sim.place(request, tag="ticket") is None
    released_s = sim.sim_time_s + 1.0
    if within_s is None:  # settling, and the hold while its connections (from the manifest) are made
        within_s = 15.0 + longest_hold_s(component, HOLD_S)
    for _ in range(round(within_s / sim.config.control_period_s)):
        result = sim.advance()
        for tag, reply in result.replies:
            assert tag == "ticket"
            return reply, sim.sim_time_s - released_s
    raise AssertionError(f"no reply to the placement of {component.name} within {within_s} s")


def test_a_beam_set_down_at_its_target_beside_a_built_beam_is_connected_and_stays(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="bimbot.services.physics.releasing")
    sim = make_sim(robots=1, connections=ConnectionConfig(hold_s=HOLD_S))
    beam, neighbour = _named(frame_manifest, "Beam A1-A2"), _named(frame_manifest, "Beam A2-A3")
    for name in ("Footing A1", "Column A1"):  # Column A2 is not there: alone, the beam would tip off
        _built(sim, _named(frame_manifest, name))
    _built(sim, neighbour)
    reply, waited_s = _place(sim, beam)
    assert reply.ok, reply.reason
    assert waited_s >= HOLD_S - 1e-6, "the robot holds it until the connection is made"
    message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
    column = _named(frame_manifest, "Column A1")
    # beside the built beam, and on the column's cap (the model links it: a bolted end on its cap plate)
    assert sorted(message.connected_to) == sorted([neighbour.guid, column.guid])
    assert message.connection_kinds[neighbour.guid] == "pinned_end"
    assert neighbour.guid in message.supports
    assert message.drift_m is not None and message.drift_m < 0.001
    target = beam.target_pose_world
    rest = component_pose(sim.client_id, sim.handling.items[beam.guid].body)
    assert math.dist(rest[0], target.position_m) < 0.003 and angle_between(rest[1], target.quat_xyzw) < 1e-3
    assert f"pinned_end to {neighbour.guid}" in caplog.text
    idle(sim, 3.0)  # connected: it does not move while it waits for its agent's verdict
    assert sim.handling.pose_message(beam.guid, sim.sim_time_s).drift_m == pytest.approx(message.drift_m)
    sim.handling.note_constructed(beam.guid, True)
    assert sim.handling.items[beam.guid].phase is Phase.JOINED
    assert neighbour.guid in sim.handling.pose_message(beam.guid, sim.sim_time_s).connected_to


def _placed_unconnected_and_tipped(
    sim: Simulation, manifest: Manifest, built: tuple[str, ...], offset_y_m: float = 0.0
) -> float:
    """Beam A1-A2 placed with ``built`` in place: it was not connected and its free end fell. The sim seconds
    from the end of its motion to the reply."""
    beam = _named(manifest, "Beam A1-A2")
    for name in built:
        _built(sim, _named(manifest, name))
    reply, waited_s = _place(sim, beam, offset_y_m=offset_y_m)
    assert reply.ok
    message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
    assert message.connected_to == []
    assert message.drift_m is not None and message.drift_m > 0.5  # its free end fell
    return waited_s


def test_without_connections_the_same_beam_tips_off(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1, connections=ConnectionConfig(enabled=False))
    _placed_unconnected_and_tipped(sim, frame_manifest, ("Footing A1", "Column A1", "Beam A2-A3"))


def _with_beam_support(manifest: Manifest, need: TemporarySupportNeed | None) -> Manifest:
    """``manifest`` with Beam A1-A2's ``temporary_support`` replaced by ``need``."""
    return manifest.model_copy(
        update={
            "components": [
                c.model_copy(update={"temporary_support": need}) if c.name == "Beam A1-A2" else c
                for c in manifest.components
            ]
        }
    )


def test_a_beam_set_down_off_its_target_is_not_connected_and_without_props_tips_off(
    frame_manifest: Manifest, bundled_build: Path
) -> None:
    unpropped = _with_beam_support(frame_manifest, None)
    config = SimConfig(robots=1, odom_noise=0.0, connections=ConnectionConfig(hold_s=HOLD_S))
    with Simulation(unpropped, bundled_build, config) as sim:
        # 30 mm: beyond the agents' 10 mm, the holes miss
        _placed_unconnected_and_tipped(sim, unpropped, ("Footing A1", "Column A1", "Beam A2-A3"), 0.03)


def test_a_member_set_down_off_its_target_stands_on_its_props_until_it_is_taken_up_again(
    frame_manifest: Manifest, bundled_build: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # the bundled Beam A1-A2's own props (when unconnected), set in 1 s each so that the test stays fast
    props = TemporarySupportNeed(
        kind=SupportKind.PROPS, count=2, place_s=1.0, when=SupportWhen.UNCONNECTED, why="test"
    )
    propped = _with_beam_support(frame_manifest, props)
    caplog.set_level(logging.INFO, logger="bimbot.services.physics")
    config = SimConfig(robots=1, odom_noise=0.0, connections=ConnectionConfig(hold_s=HOLD_S))
    with Simulation(propped, bundled_build, config) as sim:
        for name in ("Footing A1", "Column A1", "Beam A2-A3"):
            _built(sim, _named(propped, name))
        beam = _named(propped, "Beam A1-A2")
        reply, waited_s = _place(sim, beam, offset_y_m=0.03)  # beyond the agents' 10 mm: the holes miss
        assert reply.ok, reply.reason
        assert waited_s >= 2 * props.place_s - 1e-6, "its robot holds it while its props are set"
        message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
        assert message.connected_to == [] and message.connection_kinds == {}
        assert message.temporary_supports == 2
        assert message.drift_m is not None and message.drift_m < 0.001  # propped where it was set
        assert f"{beam.guid} set down off its target: no connection" in caplog.text
        idle(sim, 3.0)
        assert sim.handling.pose_message(beam.guid, sim.sim_time_s).drift_m == pytest.approx(message.drift_m)
        # misplaced: a robot takes it up again for its retry, and its props come away
        assert sim.attach(AttachRequest(robot_id="r1", guid=beam.guid)).ok
        assert sim.handling.pose_message(beam.guid, sim.sim_time_s).temporary_supports == 0
        (support,) = [s for s in sim.handling.supports.history if s.guid == beam.guid]
        assert support.removed_s is not None and beam.guid not in sim.handling.supports.standing


def test_without_a_link_resting_on_top_of_a_built_column_is_not_a_connection(
    frame_manifest: Manifest, bundled_build: Path
) -> None:
    # an older build, without the converter's connection links: only what is beside it is connected
    unlinked = frame_manifest.model_copy(
        update={
            "components": [
                c.model_copy(update={"connection_links": [], "temporary_support": None})
                for c in frame_manifest.components
            ]
        }
    )
    config = SimConfig(robots=1, odom_noise=0.0, connections=ConnectionConfig(hold_s=HOLD_S))
    with Simulation(unlinked, bundled_build, config) as sim:
        waited_s = _placed_unconnected_and_tipped(sim, unlinked, ("Footing A1", "Column A1"))
    assert waited_s < HOLD_S + 3.0


def test_a_member_bearing_on_one_support_and_bolted_at_its_other_end_is_simply_supported_and_stays(
    frame_manifest: Manifest, bundled_build: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A pin and a bearing hold a member as a pin and a roller do: Beam A1-A2, seated on Column A1's cap
    (a bearing here) and bolted at its other end to the built Beam A2-A3, with Column A2 not there and no
    props. Its one pinned end alone would be a hinge; the bearing keeps it from turning about it. Left
    free, a curtain wall's bottom transom on its slab, bolted only to the wall it abuts, was shot 0.3 m
    off its target by the release of its neighbour set against it (the Revit house, seed 1)."""
    column, neighbour = _named(frame_manifest, "Column A1"), _named(frame_manifest, "Beam A2-A3")
    bearing = ConnectionLink(
        other_guid=column.guid, kind=ConnectionKind.BEARING, time_s=HOLD_S, source="bearing face"
    )

    def seated(c: Component) -> Component:
        if c.name != "Beam A1-A2":
            return c
        links = [bearing if link.other_guid == column.guid else link for link in c.connection_links]
        return c.model_copy(update={"connection_links": links, "temporary_support": None})

    manifest = frame_manifest.model_copy(
        update={"components": [seated(c) for c in frame_manifest.components]}
    )
    caplog.set_level(logging.INFO, logger="bimbot.services.physics.releasing")
    config = SimConfig(robots=1, odom_noise=0.0, connections=ConnectionConfig(hold_s=HOLD_S))
    with Simulation(manifest, bundled_build, config) as sim:
        for name in ("Footing A1", "Column A1", "Beam A2-A3"):
            _built(sim, _named(manifest, name))
        beam = _named(manifest, "Beam A1-A2")
        reply, _ = _place(sim, beam)
        assert reply.ok, reply.reason
        message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
        assert message.connection_kinds == {neighbour.guid: "pinned_end", column.guid: "bearing"}
        assert message.connected_to == [neighbour.guid], "fixed by its pin; the bearing carries it"
        assert message.drift_m is not None and message.drift_m < 0.001, "without the fix its free end fell"
        assert f"pinned_end to {neighbour.guid}" in caplog.text and f"bearing to {column.guid}" in caplog.text
        idle(sim, 3.0)
        assert sim.handling.pose_message(beam.guid, sim.sim_time_s).drift_m == pytest.approx(message.drift_m)


def test_side_neighbours_are_beside_within_the_gap_not_below(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=0)
    handling = sim.handling
    for name in ("Column A1", "Beam A1-A2", "Beam A2-A3"):
        _built(sim, _named(frame_manifest, name))
    names = ("Column A1", "Beam A1-A2", "Beam A2-A3")
    body = {name: handling.items[_named(frame_manifest, name).guid].body.body_id for name in names}
    guid = {name: _named(frame_manifest, name).guid for name in names}
    structure = {body["Column A1"]: guid["Column A1"], body["Beam A2-A3"]: guid["Beam A2-A3"]}
    # Beam A1-A2 lies on Column A1 (below it) and meets Beam A2-A3 end to end
    assert side_neighbours(sim.client_id, body["Beam A1-A2"], structure, 0.1) == (guid["Beam A2-A3"],)
    # Beam A2-A3 moved 0.3 m east: beyond the gap
    position, quat = p.getBasePositionAndOrientation(body["Beam A2-A3"], physicsClientId=sim.client_id)
    moved = (position[0] + 0.3, position[1], position[2])
    p.resetBasePositionAndOrientation(body["Beam A2-A3"], moved, quat, physicsClientId=sim.client_id)
    assert side_neighbours(sim.client_id, body["Beam A1-A2"], structure, 0.1) == ()
    assert side_neighbours(sim.client_id, body["Beam A1-A2"], structure, 0.4) == (guid["Beam A2-A3"],)


def test_connection_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="gap_m"):
        ConnectionConfig(gap_m=-0.1)
    with pytest.raises(ValueError, match="hold_s"):
        ConnectionConfig(hold_s=math.nan)


def test_the_clock_skips_to_the_end_of_a_hold_only_while_the_robot_named_holds_its_load(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A robot that holds a member at rest while its crew bolts it moves nothing: a quiet site's skip goes
    on to the end of the hold (where the robot is answered), no further, and only while it holds."""
    sim = make_sim(robots=1, connections=ConnectionConfig(hold_s=HOLD_S))
    beam, neighbour = _named(frame_manifest, "Beam A1-A2"), _named(frame_manifest, "Beam A2-A3")
    for name in ("Footing A1", "Column A1"):
        _built(sim, _named(frame_manifest, name))
    _built(sim, neighbour)
    far_s = sim.sim_time_s + 3600.0
    _pick_up(sim, beam)
    carried = sim.skip(SkipRequest(to_sim_s=far_s, holding=["r1"]))
    assert not carried.ok and "r1 carries" in (carried.reason or "")
    target = _beside_target(sim, beam)
    request = PlaceRequest(
        robot_id="r1", guid=beam.guid, pose=pose(target.position_m, target.quat_xyzw), duration_s=1.0
    )
    assert sim.place(request, tag="t") is None
    watch = None
    for _ in range(round(15.0 / sim.config.control_period_s)):
        assert not sim.advance().replies, "answered before its hold ended"
        watch = sim.handling.watch.get(beam.guid)
        if watch is not None and watch.settled:
            break
    assert watch is not None and watch.settled and watch.tag == "t"
    hold_end_s = watch.hold_until_s
    assert hold_end_s - sim.sim_time_s > 30.0, "the beam's pinned ends take longer than its settling"
    skipped = sim.skip(SkipRequest(to_sim_s=far_s, why="curing", holding=["r1"]))
    assert skipped.ok and skipped.sim_time_s == pytest.approx(hold_end_s), "to the hold's end, not beyond"
    replies = sim.advance().replies
    assert [tag for tag, reply in replies if reply.ok] == ["t"], "answered at the first step after the skip"
    after = sim.skip(SkipRequest(to_sim_s=far_s, holding=["r1"]))
    assert not after.ok and "r1 holds no load" in (after.reason or ""), "answered: it acts next, no skip"
