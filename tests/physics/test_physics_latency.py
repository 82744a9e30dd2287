"""The lock-step's command latency: a command or request answering step k acts from step k + latency,
however early it arrives, so the outcome does not depend on whether physics or the robot is faster."""

from __future__ import annotations

from bimbot.services.physics.latency import Pipeline
from bimbot.shared.messages import CmdVelMsg


def _cmd(robot_id: str, step: int, v: float) -> CmdVelMsg:
    return CmdVelMsg(robot_id=robot_id, v_mps=v, w_radps=0.0, sim_time_s=0.2 * step, step=step)


def test_without_latency_every_command_and_request_acts_at_once() -> None:
    pipeline: Pipeline[str] = Pipeline(0)
    assert pipeline.command_now(_cmd("r1", 5, 0.3))
    assert pipeline.request_now(5, 5, "attach")
    assert pipeline.target(5) == 5 and pipeline.due_commands(5) == [] and pipeline.due_requests(5) == []


def test_with_one_period_a_command_answering_k_acts_when_physics_advances_from_k_plus_1() -> None:
    pipeline: Pipeline[str] = Pipeline(1)
    assert pipeline.target(7) == 6  # before advancing from 7, every robot must have answered 6
    early = [_cmd("r1", 6, 0.1), _cmd("r1", 7, 0.7), _cmd("r2", 6, 0.2)]  # r1 answered 7 already
    assert not any(pipeline.command_now(command) for command in early)
    assert pipeline.due_commands(6) == []  # from 6: the answers to 5 act (none held)
    due = {command.robot_id: command.v_mps for command in pipeline.due_commands(7)}
    assert due == {"r1": 0.1, "r2": 0.2}  # r1's answer to 7 waits for its turn
    assert [c.v_mps for c in pipeline.due_commands(8)] == [0.7]
    assert not pipeline.command_now(CmdVelMsg(robot_id="r1", v_mps=0.0, w_radps=0.0, sim_time_s=2.0, step=9))
    assert pipeline.command_now(CmdVelMsg(robot_id="r1", v_mps=0.0, w_radps=0.0, sim_time_s=2.0))  # no step


def test_a_request_stamped_k_is_handled_with_that_steps_command_in_the_order_requests_came() -> None:
    pipeline: Pipeline[str] = Pipeline(1)
    assert not pipeline.request_now(7, 7, "attach r1")  # physics is at 7: it acts from 8
    assert not pipeline.request_now(7, 7, "place r2")
    assert pipeline.request_now(5, 7, "late drop")  # answered 5: its turn (advancing from 6) is past
    assert pipeline.request_now(None, 7, "unstamped")
    assert pipeline.due_requests(7) == []
    assert pipeline.due_requests(8) == ["attach r1", "place r2"] and pipeline.due_requests(9) == []


def test_a_request_whose_turn_is_the_coming_advance_waits_for_it_however_late_it_came() -> None:
    """Stamped 6 and come while physics is at 7 (before advancing from 7), or while it was still at 6:
    either way it is handled when physics advances from 7, after that step's inputs, not before them."""
    pipeline: Pipeline[str] = Pipeline(1)
    assert not pipeline.request_now(6, 6, "attach r1")  # came early
    assert not pipeline.request_now(6, 7, "attach r2")  # came once physics was at 7
    assert pipeline.due_requests(7) == ["attach r1", "attach r2"]


def test_a_lost_robots_held_commands_go() -> None:
    pipeline: Pipeline[str] = Pipeline(1)
    pipeline.command_now(_cmd("r1", 3, 0.5))
    pipeline.forget(["r1"])
    assert pipeline.due_commands(10) == []
