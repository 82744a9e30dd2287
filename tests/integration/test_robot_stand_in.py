"""The robot stand-in's waits (no bus): a robot finds the state it waits for among the states published
since it acted, even when later states came in the same burst and the latest has moved past it."""

from __future__ import annotations

from types import SimpleNamespace
from typing import cast

from robot_stand_in import EXPECTED_AFTER, VERDICTS, RobotStandIn

from bimbot.shared.bus import BusOptions
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentEvent, ComponentState, ComponentStateMsg

GUID = "0beam000000000000000000"


def _stand_in() -> RobotStandIn:
    # a stand-in that is never entered reads nothing of its manifest but the site
    return RobotStandIn(cast(Manifest, SimpleNamespace(site="test-site")), BusOptions())


def _state(state: ComponentState, previous: ComponentState, attempt: int) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=GUID,
        state=state,
        previous=previous,
        event="test",
        attempt=attempt,
        sim_time_s=1.0,
        wall_time_s=1.0,
    )


def test_a_misplaced_verdict_followed_at_once_by_the_retry_release_is_still_found() -> None:
    stand_in = _stand_in()
    stand_in.record_state(_state(ComponentState.ASSEMBLING, ComponentState.TRANSPORTING, 0))
    placing = stand_in.mark()
    # what the agent and the planner publish within milliseconds of the placement, before the robot runs
    stand_in.record_state(_state(ComponentState.VERIFYING, ComponentState.ASSEMBLING, 1))
    stand_in.record_state(_state(ComponentState.MISPLACED, ComponentState.VERIFYING, 1))
    stand_in.record_state(_state(ComponentState.RELEASED, ComponentState.MISPLACED, 1))

    placed = stand_in.wait_for(GUID, EXPECTED_AFTER[ComponentEvent.PLACE], since=placing, timeout_s=0.0)
    verdict = stand_in.wait_for(GUID, VERDICTS, since=placing, timeout_s=0.0)

    assert placed is not None and placed.state is ComponentState.VERIFYING
    assert verdict is not None and verdict.state is ComponentState.MISPLACED
    # the second placement's wait does not take the first one's verdict
    assert stand_in.wait_for(GUID, VERDICTS, since=stand_in.mark(), timeout_s=0.0) is None
