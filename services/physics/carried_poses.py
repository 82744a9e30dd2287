"""Which carried loads' poses go out in the plan fidelity: each once when it is taken up, then at most every
:data:`CARRIED_POSE_EVERY_S` of sim time (pure bookkeeping).

Why: physics published a carried load's pose every period, and every subscriber decoded it: each robot,
asleep or not, the planner, the agents, the run. On the generated 988-component frame that was about 6 of
the 7 component poses a period (counted on the bus, the first minute of the build). Nobody needs where a
load is on its way: a robot's map clears a carried load (it is on its robot), the planner places a load
where it is set down, an agent judges a pose once its load is placed. The first carried pose still goes
out (it says who carries it), and so does the pose a load is set down at, at once (not carried any more).
The dashboard draws a load on its way a little less often.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from bimbot.shared.messages import ComponentPoseMsg

CARRIED_POSE_EVERY_S = 1.0  # sim seconds between two poses of a load on its way


@dataclass
class CarriedPoses:
    """When each load's pose last went out while carried, and by whom (load → (robot, sim s))."""

    sent: dict[str, tuple[str, float]] = field(default_factory=dict)

    def due(self, message: object) -> bool:
        """Whether ``message`` goes out: anything but a carried load's pose always; that once when taken
        up (by this robot), then at most every :data:`CARRIED_POSE_EVERY_S`."""
        if not isinstance(message, ComponentPoseMsg):
            return True
        if message.attached_to is None:
            self.sent.pop(message.guid, None)
            return True
        robot, sent_s = self.sent.get(message.guid, (None, -math.inf))
        if robot == message.attached_to and message.sim_time_s - sent_s < CARRIED_POSE_EVERY_S:
            return False
        self.sent[message.guid] = (message.attached_to, message.sim_time_s)
        return True
