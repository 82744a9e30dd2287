"""The agents as a lock-step participant ride out restarts: a shard steps once physics' site info came,
answers each clock as it comes (physics' clock vouches for the inputs it takes: nobody else's answer is
waited for, so a restarted shard answers the first step it hears), a step heard again is answered again
(physics says the open step again while it waits; the first answer may have been lost with a router), and
once the bus was cut every agent says its state again (a state message sent meanwhile may be lost)."""

from __future__ import annotations

from agent_builders import SITE, manifest

from bimbot.services.component_agents.host import AgentHost
from bimbot.services.component_agents.reconnect import PhysicsReach
from bimbot.services.component_agents.stepped import SteppedAgents
from bimbot.shared.bus import LivelinessChange, Received
from bimbot.shared.messages import ALIVE_KEY, CLOCK, CLOCK_KEY, ClockMsg, StepDoneMsg, key


def _clock(step: int) -> Received[ClockMsg]:
    message = ClockMsg(sim_time_s=0.2 * step, step=step, real_time_factor=0.0, lock_step=True)
    return Received(CLOCK, key(CLOCK_KEY, site=SITE), message)


def _shard(answers: list[StepDoneMsg]) -> SteppedAgents:
    shard = SteppedAgents(AgentHost(manifest()), lambda _out: None, answers.append)
    shard.start()
    return shard


def test_a_shard_steps_once_physics_site_info_came_and_then_answers_each_clock_as_it_comes() -> None:
    answers: list[StepDoneMsg] = []
    shard = SteppedAgents(AgentHost(manifest()), lambda _out: None, answers.append)
    shard.hear(_clock(40))  # the run is at step 40 (a restarted shard)
    shard.step_ready()
    assert answers == []  # the tolerances in force are not known yet
    shard.start()
    shard.step_ready()
    shard.hear(_clock(41))
    shard.step_ready()
    assert [answer.step for answer in answers] == [40, 41]


def test_a_step_heard_again_is_answered_again() -> None:
    answers: list[StepDoneMsg] = []
    shard = _shard(answers)
    shard.hear(_clock(0))
    shard.hear(_clock(0))  # not answered yet: nothing to say again
    shard.step_ready()
    assert [answer.step for answer in answers] == [0]
    shard.hear(_clock(0))
    assert [answer.step for answer in answers] == [0, 0] and answers[1] == answers[0]


def test_physics_back_after_it_went_is_a_cut_bus_and_its_first_token_is_not() -> None:
    reach = PhysicsReach()
    alive = key(ALIVE_KEY, site=SITE, kind="physics", id="main")
    robot = key(ALIVE_KEY, site=SITE, kind="robot", id="r1")
    assert not reach.back(LivelinessChange(alive, True))  # reported at start: nothing was missed
    assert not reach.back(LivelinessChange(robot, False)) and not reach.back(LivelinessChange(robot, True))
    assert not reach.back(LivelinessChange(alive, False))
    assert reach.back(LivelinessChange(alive, True))  # back: say every state again
    assert not reach.back(LivelinessChange(alive, True))


def test_a_shard_says_every_state_again_at_its_next_step_stamped_with_it() -> None:
    said: list[object] = []
    shard = SteppedAgents(AgentHost(manifest()), said.extend, lambda _answer: None)
    shard.start()
    shard.hear(_clock(7))
    shard.restate()
    shard.step_ready()
    restated = [item.message for item in said if item.message.event == "restate"]
    assert len(restated) == len(manifest().components)
    assert {m.sim_time_s for m in restated} == {_clock(7).message.sim_time_s}
    shard.hear(_clock(8))
    shard.step_ready()  # once
    assert len([item for item in said if item.message.event == "restate"]) == len(restated)
