"""The agents as a lock-step participant rejoin a running site at once: a restarted shard answers the
first step it hears without the answers given before it listened, and a step heard again is answered
again (physics says the open step again while it waits; the first answer may have been lost with a
router)."""

from __future__ import annotations

from agent_builders import SITE, manifest

from bimbot.services.component_agents.host import AgentHost
from bimbot.services.component_agents.stepped import SteppedAgents
from bimbot.shared.bus import Received
from bimbot.shared.messages import CLOCK, CLOCK_KEY, ClockMsg, StepDoneMsg, key


def _clock(step: int) -> Received[ClockMsg]:
    message = ClockMsg(sim_time_s=0.2 * step, step=step, real_time_factor=0.0, lock_step=True)
    return Received(CLOCK, key(CLOCK_KEY, site=SITE), message)


def _shard(answers: list[StepDoneMsg]) -> SteppedAgents:
    shard = SteppedAgents(AgentHost(manifest()), lambda _out: None, answers.append)
    shard.expect(["r1"], ["planner", "agents-1of1"])
    return shard


def test_a_restarted_shard_answers_the_first_step_it_hears_and_then_waits_for_every_answer() -> None:
    answers: list[StepDoneMsg] = []
    shard = _shard(answers)
    shard.hear(_clock(40))  # the run is at step 40: r1 and the planner answered 38 before this shard listened
    shard.step_ready()
    assert [answer.step for answer in answers] == [40]
    shard.hear(_clock(41))
    shard.step_ready()  # 41 takes what was said at 39: their answers to it first
    assert [answer.step for answer in answers] == [40]


def test_a_step_heard_again_is_answered_again() -> None:
    answers: list[StepDoneMsg] = []
    shard = _shard(answers)
    shard.hear(_clock(0))
    shard.hear(_clock(0))  # not answered yet: nothing to say again
    shard.step_ready()
    assert [answer.step for answer in answers] == [0]
    shard.hear(_clock(0))
    assert [answer.step for answer in answers] == [0, 0] and answers[1] == answers[0]
