"""Whole builds in one process, no bus: physics stand-in + real agents + real planner core + the executors.

The 2×1 generated frame (2 footings, 2 columns, 1 beam) with one robot, with two robots on the derived
(parallel) sequence, and with a misplaced first attempt that the component catches and the planner retries.
Deterministic: lock-step, seeded noise, fake wall clock.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from frames import convert_small_frame
from robot_sim import SiteSim

from bimbot.services.planner.sources import SourceKind
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentEvent, ComponentState, RobotState
from bimbot.shared.verification import Tolerances


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return convert_small_frame(tmp_path_factory.mktemp("frame"))


@pytest.fixture(scope="module")
def frame(build: Path) -> Manifest:
    return read_manifest(build)


def placement_errors_m(sim: SiteSim, frame: Manifest) -> list[float]:
    errors = []
    for component in frame.components:
        placed = sim.physics.poses[component.guid].pose.position_m
        errors.append(math.dist(placed, component.target_pose_world.position_m))
    return errors


def test_one_robot_builds_the_frame_every_component_within_tolerance(build: Path, frame: Manifest) -> None:
    sim = SiteSim(frame, build, ("r1",))
    steps = sim.run(6000, until=SiteSim.all_constructed)
    assert sim.all_constructed(), f"not done after {steps} steps"
    assert max(placement_errors_m(sim, frame)) < Tolerances().position_m
    verdicts = [m.state for m in sim.record.states]
    assert ComponentState.MISPLACED not in verdicts, "judged on a pose from the assembly motion"
    states = [message.state for message in sim.record.robot_states["r1"]]
    cycle = [state for state, _ in itertools.groupby(states)]
    assert cycle[:6] == [
        RobotState.IDLE,
        RobotState.DETECT_COMPONENT_POSITION,
        RobotState.PICK_UP,
        RobotState.IDENTIFY_TARGET_LOCATION,
        RobotState.ASSEMBLE,
        RobotState.IDLE,
    ]
    assert sim.record.cmd_steps["r1"] == list(range(1, steps + 1)), "every clock step answered"
    truth = sim.physics.truth  # nothing ever drove through a component, the fence or the built columns
    path = np.array(sim.record.true_paths["r1"])
    rc = truth.geometry.world_to_cell(path)
    assert not truth.static_grid().occupied[rc[:, 0], rc[:, 1]].any()
    assert steps * 0.1 < 400, "simulated minutes, not hours"


def test_two_robots_build_it_together_and_keep_apart(build: Path, frame: Manifest) -> None:
    sim = SiteSim(frame, build, ("r1", "r2"), source=SourceKind.DERIVE)
    sim.run(6000, until=SiteSim.all_constructed)
    assert sim.all_constructed()
    assert all(len(sim.executors[rid].done) >= 1 for rid in ("r1", "r2")), "both robots worked"
    paths = [np.array(sim.record.true_paths[rid]) for rid in ("r1", "r2")]
    separation = np.hypot(*(paths[0] - paths[1]).T).min()
    assert separation > 1.0, f"robots came within {separation:.2f} m of each other"


def test_a_misplaced_first_attempt_is_caught_and_rebuilt(build: Path, frame: Manifest) -> None:
    footing = next(c for c in frame.components if c.ifc_class == "IfcFooting")
    sim = SiteSim(frame, build, ("r1",), placement_error_m=0.05, inject_guids=frozenset({footing.guid}))
    sim.run(6000, until=SiteSim.all_constructed)
    assert sim.all_constructed()
    verdicts = [m.state for m in sim.record.states if m.guid == footing.guid]
    assert ComponentState.MISPLACED in verdicts and verdicts[-1] is ComponentState.CONSTRUCTED
    picks = [e for e in sim.record.events if e.guid == footing.guid and e.event is ComponentEvent.PICK]
    assert len({e.event_id for e in picks}) == 2, "picked up again from where it was misplaced"
    assert max(placement_errors_m(sim, frame)) < Tolerances().position_m
