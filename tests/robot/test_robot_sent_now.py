"""What a lock-step robot sends at a step is stamped with that step: a state made between two steps (a
physics reply handled as it came) carried the step before's stamp, went out after that step's answer and
was taken by the others at whichever step it arrived."""

from __future__ import annotations

from bimbot.services.robot.stepped import sent_now
from bimbot.shared.messages import CmdVelMsg, PlanMsg, RobotState, RobotStateMsg


def test_states_and_plans_made_before_the_step_go_out_stamped_with_it() -> None:
    step_s = 120.4
    state = RobotStateMsg(
        robot_id="r1", state=RobotState.IDLE, pose_xy_yaw=(1.0, 2.0, 0.0), sim_time_s=120.2, wall_time_s=5.0
    )
    plan = PlanMsg(robot_id="r1", path_xy_m=[(0.0, 0.0), (1.0, 1.0)], goal_xy_m=(1.0, 1.0), sim_time_s=120.0)
    command = CmdVelMsg(robot_id="r1", v_mps=0.0, w_radps=0.0, sim_time_s=step_s, step=602)
    out = sent_now([state, plan, command], step_s)
    assert [message.sim_time_s for message in out] == [step_s, step_s, step_s]  # type: ignore[union-attr]
    assert out[0].model_copy(update={"sim_time_s": 120.2}) == state  # nothing else changed
    assert out[2] is command
