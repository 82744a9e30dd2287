"""Components built where they stand: poured whole by a pump, laid course by course by a block layer, and
the clock's jump over a quiet site. Real pybullet on the bundled frame, its footings made cast in place
and laid (the mechanism does not care that a footing is rarely laid)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from physics_builders import drive

from bimbot.services.physics.client import p
from bimbot.services.physics.handling_state import Phase
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import Fleet
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import AttachRequest, BuildRequest, SkipRequest
from bimbot.shared.robot_description import Capability, LayingSpec, RobotDescription

PUMP = RobotDescription(
    name="pump",
    urdf="carrier.urdf",
    payload_kg=1.0,
    reach_m=60.0,
    max_place_height_m=30.0,
    length_m=1.4,
    width_m=0.9,
    max_speed_mps=0.0,
    max_turn_radps=0.0,
    capabilities=frozenset({Capability.STAND_FIXED, Capability.POUR}),
)
LAYER = PUMP.model_copy(
    update={
        "name": "layer",
        "capabilities": frozenset({Capability.STAND_FIXED, Capability.LAY}),
        "laying": LayingSpec(
            block_length_m=0.6, block_height_m=0.3, block_width_m=0.4, block_mass_kg=45.0, blocks_per_h=300.0
        ),
    }
)
SHORT_BOOM = PUMP.model_copy(update={"name": "short_pump", "reach_m": 2.0})
CARRIER_FLEET = Fleet.model_validate(
    {
        "types": {
            "pump": PUMP.model_dump(),
            "layer": LAYER.model_dump(),
            "short_pump": SHORT_BOOM.model_dump(),
            "carrier": RobotDescription(
                name="carrier",
                urdf="carrier.urdf",
                payload_kg=3000,
                reach_m=1.8,
                max_place_height_m=3.5,
                length_m=1.4,
                width_m=0.9,
                max_speed_mps=0.8,
                max_turn_radps=1.0,
            ).model_dump(),
        },
        "robots": [
            {"type": "pump", "count": 1},
            {"type": "layer", "count": 1},
            {"type": "short_pump", "count": 1},
            {"type": "carrier", "count": 1},
        ],
    }
)


@pytest.fixture
def site(bundled_build: Path, frame_manifest: Manifest) -> tuple[Simulation, str, str]:
    """A simulation whose first footing is cast in place and second laid; r1 pump, r2 layer, r3 a pump
    with a 2 m boom, r4 a carrier."""
    footings = [c for c in frame_manifest.components if c.ifc_class == "IfcFooting"]
    cast, laid = footings[0].guid, footings[1].guid
    methods = {cast: ConstructionMethod.CAST_IN_PLACE, laid: ConstructionMethod.LAID}
    manifest = frame_manifest.model_copy(
        update={
            "components": [
                c.model_copy(update={"method": methods[c.guid]}) if c.guid in methods else c
                for c in frame_manifest.components
            ]
        }
    )
    config = SimConfig(fleet=CARRIER_FLEET, odom_noise=0.0)
    with Simulation(manifest, bundled_build, config) as sim:
        yield sim, cast, laid


def _top_z(body_ids: list[int]) -> float:
    return max(p.getAABB(body)[1][2] for body in body_ids)


def test_a_cast_component_is_out_of_sight_until_poured_then_stands_fixed_at_its_target(
    site: tuple[Simulation, str, str],
) -> None:
    sim, cast, _ = site
    item = sim.handling.items[cast]
    assert item.phase is Phase.UNBUILT
    assert cast not in sim.poses().components  # nobody sees an unbuilt component
    refused = sim.attach(AttachRequest(robot_id="r4", guid=cast))
    assert not refused.ok and "built where it stands" in refused.reason

    reply = sim.build(BuildRequest(robot_id="r1", guid=cast))
    assert reply.ok
    assert item.phase is Phase.PLACED
    target = item.component.target_pose_world
    pose = sim.poses().components[cast]
    assert pose.fixed and not pose.joined
    assert math.dist(pose.pose.position_m, target.position_m) < 1e-6
    for _ in range(10):  # concrete in its formwork does not settle
        sim.advance()
    assert math.dist(sim.poses().components[cast].pose.position_m, target.position_m) < 1e-6
    sim.handling.note_constructed(cast, True)
    assert item.phase is Phase.JOINED


def test_a_laid_component_grows_course_by_course_and_stands_whole_after_the_last(
    site: tuple[Simulation, str, str],
) -> None:
    sim, _, laid = site
    component = sim.handling.items[laid].component
    bottom, top = component.bbox_world.min_m[2], component.bbox_world.max_m[2]
    assert sim.build(BuildRequest(robot_id="r2", guid=laid, height_fraction=0.5)).ok
    courses = sim.in_place_work.courses[laid]
    assert courses, "half a wall stands as course bodies"
    assert _top_z(courses) == pytest.approx(bottom + 0.5 * (top - bottom), abs=0.01)
    assert sim.handling.items[laid].phase is Phase.UNBUILT  # not standing whole yet
    assert sim.build(BuildRequest(robot_id="r2", guid=laid, height_fraction=0.75)).ok
    assert _top_z(sim.in_place_work.courses[laid]) == pytest.approx(bottom + 0.75 * (top - bottom), abs=0.01)
    assert sim.build(BuildRequest(robot_id="r2", guid=laid, height_fraction=1.0)).ok
    assert laid not in sim.in_place_work.courses  # the course bodies are gone
    for body in courses:
        with pytest.raises(p.error):
            p.getBasePositionAndOrientation(body, physicsClientId=sim.client_id)
    assert sim.handling.items[laid].phase is Phase.PLACED
    sim.advance()  # the laser's caster rebuilds over the removed bodies without an error


def test_work_in_place_is_refused_with_the_reason_a_user_can_act_on(
    site: tuple[Simulation, str, str],
) -> None:
    sim, cast, laid = site
    wrong_kind = sim.build(BuildRequest(robot_id="r1", guid=laid))
    assert not wrong_kind.ok and "cannot lay" in wrong_kind.reason
    short = sim.build(BuildRequest(robot_id="r3", guid=cast))
    assert not short.ok and "whose boom reaches 2 m" in short.reason
    lifted = next(c.guid for c in sim.manifest.components if c.ifc_class == "IfcColumn")
    not_in_place = sim.build(BuildRequest(robot_id="r1", guid=lifted))
    assert not not_in_place.ok and "carried and placed" in not_in_place.reason


def test_the_clock_skips_over_a_quiet_site_and_refuses_while_a_robot_drives(
    site: tuple[Simulation, str, str],
) -> None:
    sim, _, _ = site
    sim.advance()
    before_step, before_s = sim.step, sim.sim_time_s
    jumped = sim.skip(SkipRequest(to_sim_s=before_s + 3 * 24 * 3600.0, why="curing"))
    assert jumped.ok and sim.sim_time_s == pytest.approx(before_s + 3 * 24 * 3600.0)
    assert sim.step == before_step  # the steps go on one by one: consumers see no leap of steps
    sim.advance()
    assert sim.sim_time_s == pytest.approx(before_s + 3 * 24 * 3600.0 + sim.config.control_period_s)
    drive(sim, "r4", 0.5, 0.0, 0.4)
    refused = sim.skip(SkipRequest(to_sim_s=sim.sim_time_s + 600.0))
    assert not refused.ok and "r4 is driving" in refused.reason


def test_the_stability_replay_builds_cast_components_where_they_stand(
    bundled_build: Path, frame_manifest: Manifest
) -> None:
    """``--check-stability``: a cast footing stands in its formwork (not released, not settling); the
    frame's columns and beams then stand on it as before."""
    from bimbot.services.physics.stability import check_stability
    from bimbot.shared.sequence import read_sequence

    cast = {c.guid for c in frame_manifest.components if c.ifc_class == "IfcFooting"}
    manifest = frame_manifest.model_copy(
        update={
            "components": [
                c.model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE}) if c.guid in cast else c
                for c in frame_manifest.components
            ]
        }
    )
    order = read_sequence(bundled_build / "sequence.xml").guids()
    report = check_stability(manifest, bundled_build, order)
    assert report.stands, [step for step in report.steps if not step.stands]
    built_in_place = [step for step in report.steps if step.guid in cast]
    assert len(built_in_place) == len(cast) == 9
    assert all(step.settle_s == 0.0 and step.drift_m == 0.0 for step in built_in_place)
