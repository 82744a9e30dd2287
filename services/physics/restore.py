"""A restarted physics puts the site back as it was: its own record for where things are, the agents' twins
for what is constructed.

Truth, by owner (``docs/architecture.md``, "Restart is normal"):

* **constructed** — the agents' twins. A component whose twin says constructed is fixed to the structure
  and can no longer be attached: at the pose physics last published for it, or, when its record has none
  (physics died between the placement and the record), at the pose its agent last saw (the target pose
  if it saw none).
* **where things are** — physics' record (:mod:`.snapshot`): robots (by id) where their bodies were (their
  odometry continues from its last value, so a robot's localisation sees no jump), their loads still on
  them, components where their last pose message put them. A tower crane stays where the site plan
  stands it (its base is fixed) and takes back its joint values and its load on the hook.
* **the clock** — continues after the last published step, never backwards, in a new epoch so every
  consumer knows a restart from a leap (:mod:`bimbot.shared.clock_guard`).

A component that was being placed when physics died is put back on its carrier: the robot's place request
got no answer, and the robot asks again.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass

from bimbot.shared.messages import ComponentState, PoseMsg, TwinMsg

from .handling_state import Phase
from .scene import Frame
from .simulation import Simulation
from .snapshot import PhysicsSnapshot

_log = logging.getLogger(__name__)

MOVED_M = 1e-3  # a component further than this from its yard slot was moved (carried, placed, dropped)


@dataclass(frozen=True)
class Restored:
    epoch: int
    step: int
    robots: int
    moved: int  # components not where the fresh scene put them (carried, placed, dropped)
    constructed: int  # fixed and locked because their twins say constructed
    fixed_from_twins: int  # of those: constructed with no fixed pose in the record


def _frame(pose: PoseMsg) -> Frame:
    return tuple(pose.position_m), tuple(pose.quat_xyzw)  # type: ignore[return-value]


def restore_site(sim: Simulation, snapshot: PhysicsSnapshot, twins: Iterable[TwinMsg]) -> Restored:
    """Put ``sim`` (a freshly built scene) into the state of ``snapshot`` and the twins; a new epoch."""
    handling = sim.handling
    robots = 0
    for robot_id, robot in snapshot.robots.items():
        if robot_id not in sim.robots:
            _log.warning("the record has robot %s, this physics has %s: left out", robot_id, sim.robot_ids)
            continue
        sim.teleport_robot(robot_id, robot.pose.pose_xy_yaw)  # a crane stays where it stands
        if robot.pose.joint_positions:
            sim.set_crane_joints(robot_id, robot.pose.joint_positions)
        if robot.odom_xy_yaw is not None:
            sim.set_odometry_pose(robot_id, robot.odom_xy_yaw)
        robots += 1
    twins = list(twins)
    built = {t.guid for t in twins if t.state == ComponentState.CONSTRUCTED and t.guid in handling.items}
    # the constructed first, joined as they are put back: a placed component that was connected to one of
    # them (connections.py) is connected again only to a structure already there, else it would fall
    handling.constructed.update(built)
    moved = 0
    for guid, pose in sorted(snapshot.components.items(), key=lambda entry: entry[0] not in built):
        if guid not in handling.items:
            continue
        carrier = sim.robots.get(pose.attached_to or "")
        frame = _frame(pose.pose)
        before = handling.items[guid].pose
        if carrier is not None or pose.fixed or math.dist(before[0], frame[0]) > MOVED_M:
            moved += 1
        if handling.items[guid].phase is Phase.UNBUILT:  # built where it stands: poured or laid
            if pose.fixed:
                sim.in_place_work.stand_built(guid, frame)
            continue
        handling.restore(
            guid,
            frame,
            fixed=pose.fixed and carrier is None,
            carrier=carrier,
            fitted_target=_frame(pose.fitted_target) if pose.fitted_target is not None else None,
        )
    constructed = from_twins = 0
    for twin in twins:
        if twin.state != ComponentState.CONSTRUCTED or twin.guid not in handling.items:
            continue
        constructed += 1
        handling.note_constructed(twin.guid, True)
        record = snapshot.components.get(twin.guid)
        if record is None or not record.fixed:
            placed = twin.current_pose or twin.target_pose
            if handling.items[twin.guid].phase is Phase.UNBUILT:
                sim.in_place_work.stand_built(twin.guid, _frame(placed))
                handling.note_constructed(twin.guid, True)
            else:
                handling.restore(twin.guid, _frame(placed), fixed=True, carrier=None)
            from_twins += 1
    sim.step = snapshot.step + 1  # after the last step anyone can have seen
    # the clock's jumps over quiet sites (Simulation.skip) carry over: sim time is not step × period
    sim.skipped_s = max(0.0, snapshot.sim_time_s - snapshot.step * sim.config.control_period_s)
    sim.epoch = snapshot.epoch + 1
    restored = Restored(sim.epoch, sim.step, robots, moved, constructed, from_twins)
    _log.warning(
        "physics restarted: epoch %d from step %d (sim %.1f s); %d robot(s) where they were, %d component(s) "
        "moved, %d constructed by their twins (%d fixed from the twin's pose)",
        restored.epoch,
        restored.step,
        sim.sim_time_s,
        restored.robots,
        restored.moved,
        restored.constructed,
        restored.fixed_from_twins,
    )
    return restored
