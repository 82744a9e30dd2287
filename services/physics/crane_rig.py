"""A spawned tower crane's joints in pybullet: found by name, set where :mod:`.crane` says, held there.

Why a rig of its own: a crane never drives (no wheels, a fixed base), physics moves its loads itself, and
its joints only show what it does. They are set with ``resetJointState`` (no dynamics: a crane reaches its
pose at once) and held by velocity motors with a large force, so gravity does not let the hook sink
between two settings. The crane's jib height is measured on the URDF (the hook's tip at hoist 0), so the
hook is drawn where the load is even if a fleet file names another height (logged).
"""

from __future__ import annotations

import logging

from bimbot.shared.errors import InputError
from bimbot.shared.robot_description import CraneSpec

from .client import p
from .crane import JOINT_NAMES, CraneJoints, parked

_log = logging.getLogger(__name__)

HOLD_FORCE = 1e7  # N or N·m: the joint motors that hold the crane's pose, far above any load on them
JIB_HEIGHT_TOLERANCE_M = 0.5  # the URDF's and the fleet file's jib heights may differ this much unlogged


class CraneRig:
    """The slew, trolley and hoist joints of one crane body (see :mod:`.crane` for their meaning)."""

    def __init__(self, client_id: int, body_id: int, spec: CraneSpec, *, name: str) -> None:
        self.body_id = body_id
        self.spec = spec
        found = {
            p.getJointInfo(body_id, index, physicsClientId=client_id)[1].decode(): index
            for index in range(p.getNumJoints(body_id, physicsClientId=client_id))
        }
        missing = [joint for joint in JOINT_NAMES if joint not in found]
        if missing:
            raise InputError(
                f"crane type {name!r}: its URDF has no joint(s) {', '.join(missing)} "
                f"(a crane needs {', '.join(JOINT_NAMES)}; it has {', '.join(found) or 'none'})"
            )
        self.indices = tuple(found[joint] for joint in JOINT_NAMES)
        for index in self.indices:
            p.setJointMotorControl2(
                body_id,
                index,
                p.VELOCITY_CONTROL,
                targetVelocity=0.0,
                force=HOLD_FORCE,
                physicsClientId=client_id,
            )
        self.joints = parked(spec)
        self.set(client_id, self.joints)
        hook = p.getLinkState(
            body_id, self.indices[2], computeForwardKinematics=True, physicsClientId=client_id
        )
        self.jib_height_m = float(hook[4][2]) - self._base_z(client_id)
        if abs(self.jib_height_m - spec.jib_height_m) > JIB_HEIGHT_TOLERANCE_M:
            _log.warning(
                "crane type %s: its URDF's jib is %.2f m high, the fleet file says %.2f m; the hook is drawn "
                "at the URDF's",
                name,
                self.jib_height_m,
                spec.jib_height_m,
            )

    def _base_z(self, client_id: int) -> float:
        position, _ = p.getBasePositionAndOrientation(self.body_id, physicsClientId=client_id)
        com_z = p.getDynamicsInfo(self.body_id, -1, physicsClientId=client_id)[3][2]
        return float(position[2]) - float(com_z)

    def set(self, client_id: int, joints: CraneJoints) -> None:
        """Put the joints at ``joints`` now (at rest)."""
        values = (joints.slew_rad, joints.trolley_m, joints.hoist_m)
        for index, value in zip(self.indices, values, strict=True):
            p.resetJointState(self.body_id, index, value, 0.0, physicsClientId=client_id)
        self.joints = joints
