"""A robot that says it is walled in (no way to its depot) gets no new task while another robot can take
it, and tasks again once it says it can move; when no other robot can take a task, it gets it once it has
been walled in for a while (its give-backs are bounded, so the run still ends)."""

from __future__ import annotations

from planner_builders import idle_core, portal_manifest, robot_msg, state_msg

from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.dispatch import WALLED_IN_WAIT_S
from bimbot.services.planner.records import PlannerLimits
from bimbot.services.planner.scheduler import PlannerCore
from bimbot.shared.fleet import default_fleet
from bimbot.shared.messages import ComponentState, RobotState, RobotStateMsg

S = ComponentState
CARRIER = default_fleet().types["carrier"]
FOOTINGS = ("foot_a", "foot_b", "foot_c")
HOLD_S = PlannerLimits().hold_s


def _core(*robot_ids: str) -> PlannerCore:
    """Carriers ``robot_ids``, the first beside the footings, the others far away (its bid would win)."""
    robots = [
        SiteRobot(robot_id, CARRIER, (-40.0 * index, -5.0, 0.0)) for index, robot_id in enumerate(robot_ids)
    ]
    return idle_core(portal_manifest(), robots)


def _walled_in(robot_id: str, since_s: float | None, sim_time_s: float) -> RobotStateMsg:
    message = robot_msg(robot_id, (0.0, -5.0), sim_time_s=sim_time_s)
    return message.model_copy(update={"walled_in_since_s": since_s})


def _tasks_of(core: PlannerCore, robot_id: str) -> list[str]:
    return [guid for guid in FOOTINGS if core.robot_of(guid) == robot_id]


def _release(core: PlannerCore, *guids: str) -> None:
    core.step(0.0)
    for guid in guids:
        core.observe_component_state(state_msg(guid, S.RELEASED, event="release"))


def test_a_walled_in_robot_gets_no_task_another_can_take_and_gets_one_once_it_can_move() -> None:
    core = _core("r1", "r2")
    core.observe_robot_state(_walled_in("r1", since_s=5.0, sim_time_s=5.0))
    _release(core, *FOOTINGS)
    core.step(0.1)
    assert _tasks_of(core, "r1") == [], "r1 is nearest, but walled in"
    assert len(_tasks_of(core, "r2")) == 1  # the others wait for r2, busy now
    core.observe_robot_state(robot_msg("r2", (0.0, -4.0), state=RobotState.PICK_UP, task_id="T"))
    core.step(0.2)
    assert _tasks_of(core, "r1") == [], "r2 can take them once free: r1 still gets none"
    core.observe_robot_state(_walled_in("r1", since_s=None, sim_time_s=60.0))  # it drove out
    core.step(0.3)
    assert len(_tasks_of(core, "r1")) == 1


def test_a_robot_walled_in_for_a_while_waits_before_it_gets_a_task_no_other_robot_can_take() -> None:
    """A way shut for a while (a crane's load passing) opens again: the only robot gets no task until it has
    been walled in for WALLED_IN_WAIT_S of sim time; then it does (its give-backs fail the component with
    its reason, bounded)."""
    core = _core("r1")
    core.observe_robot_state(_walled_in("r1", since_s=5.0, sim_time_s=5.0))
    _release(core, *FOOTINGS)
    core.step(0.1)
    assert _tasks_of(core, "r1") == [], "walled in for a moment: no task burns a give-back yet"
    core.observe_robot_state(_walled_in("r1", since_s=5.0, sim_time_s=5.0 + WALLED_IN_WAIT_S - 10.0))
    core.step(0.2)
    assert _tasks_of(core, "r1") == []
    core.observe_robot_state(_walled_in("r1", since_s=5.0, sim_time_s=5.0 + WALLED_IN_WAIT_S))
    core.step(0.3)
    assert len(_tasks_of(core, "r1")) == 1, "the only robot, walled in for long: it gets one, bounded"


def test_a_robot_out_again_before_the_wait_is_over_gets_its_task_at_once() -> None:
    core = _core("r1")
    core.observe_robot_state(_walled_in("r1", since_s=5.0, sim_time_s=5.0))
    _release(core, *FOOTINGS)
    core.step(0.1)
    assert _tasks_of(core, "r1") == []
    core.observe_robot_state(_walled_in("r1", since_s=None, sim_time_s=600.0))  # its way opened again
    core.step(0.2)
    assert len(_tasks_of(core, "r1")) == 1


def test_a_task_a_robot_gave_back_is_not_given_to_it_again_for_the_hold_but_is_after() -> None:
    """FZK-Haus: a carrier found the crane's staging spot cut off and gave its hand-off back; given it
    again 2.4 s later, it found the same and the panel's last hand-off was spent. The world it found must
    have time to change: the same robot gets the task again only after the limits' hold_s."""
    core = _core("r1")
    _release(core, "foot_a")
    core.step(0.1)
    assert core.robot_of("foot_a") == "r1"
    core.observe_component_state(state_msg("foot_a", S.PICKING, event="pick", robot_id="r1", sim_time_s=10.0))
    core.observe_component_state(
        state_msg("foot_a", S.RELEASED, event="abandon", robot_id="r1", sim_time_s=12.0)
    )
    core.observe_robot_state(robot_msg("r1", (0.0, -5.0), sim_time_s=14.0))
    core.step(0.2)
    assert core.robot_of("foot_a") is None, "given back 2 s ago: not again at once"
    core.observe_robot_state(robot_msg("r1", (0.0, -5.0), sim_time_s=12.0 + HOLD_S))
    core.step(0.3)
    assert core.robot_of("foot_a") == "r1"
