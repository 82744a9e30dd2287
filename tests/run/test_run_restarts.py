"""A service that dies is restarted after a doubling backoff, at most ``max_restarts`` times; every death is
recorded for the report; the run loop goes on meanwhile and ends only when the limit is spent."""

from __future__ import annotations

from run_builders import watch_of

from bimbot.run.loop import RunWatch
from bimbot.run.restarts import Restart, Restarter, RestartPolicy


class _Service:
    def __init__(self, name: str, code: int = -9) -> None:
        self.name, self.code, self.up, self.starts = name, code, False, 0

    def alive(self) -> bool:
        return self.up

    def wait(self, _timeout_s: float | None) -> int:
        return self.code

    def log(self) -> str:
        return "INFO started\n"

    def restart(self) -> None:
        self.starts += 1
        self.up = True


def test_a_dead_service_is_restarted_after_a_doubling_backoff_then_given_up() -> None:
    restarter = Restarter(RestartPolicy(max_restarts=2, first_backoff_s=1.0))
    physics = _Service("physics")
    assert restarter.keep_going(physics, -9, 10.0, 100.0)  # died: restart due at 11 s
    assert physics.starts == 0
    assert restarter.keep_going(physics, -9, 10.5, 100.0) and physics.starts == 0
    assert restarter.keep_going(physics, -9, 11.0, 100.0) and physics.starts == 1
    physics.up = False  # died again: backoff 2 s
    assert restarter.keep_going(physics, 1, 20.0, 150.0)
    assert restarter.keep_going(physics, 1, 21.9, 150.0) and physics.starts == 1
    assert restarter.keep_going(physics, 1, 22.0, 150.0) and physics.starts == 2
    physics.up = False
    assert not restarter.keep_going(physics, 1, 30.0, 200.0)  # the third death ends the run
    assert [(r.service, r.exit_code, r.restarted_wall_s) for r in restarter.records] == [
        ("physics", -9, 11.0),
        ("physics", 1, 22.0),
        ("physics", 1, None),
    ]
    assert restarter.report()[0]["died_sim_time_s"] == 100.0
    line = Restart(**restarter.report()[0]).line()
    assert line == "physics died (exit -9, killed by a signal) at sim 100.0 s, restarted 1.0 s later"


class _Monitor:
    constructed, total, sim_time_s = 3, 28, 12.0


def _watch(planner: _Service, everyone: list[_Service], restarter: Restarter) -> RunWatch:
    return watch_of(planner, everyone, _Monitor(), restarter)


def test_the_run_goes_on_while_a_dead_robot_is_restarted_and_ends_when_the_limit_is_spent() -> None:
    planner, robot = _Service("planner"), _Service("robot-r1")
    planner.up = True
    watch = _watch(planner, [planner, robot], Restarter(RestartPolicy(max_restarts=1, first_backoff_s=0.0)))
    assert watch._ended(1.0) is None  # death recorded, restart due now
    assert watch._ended(1.1) is None and robot.starts == 1 and robot.alive()
    robot.up = False
    result = watch._ended(5.0)
    assert result is not None and result.ending.how == "service_stopped"
    assert "robot-r1 stopped unexpectedly (exit -9) after 1 restart(s)" in result.ending.message


def test_a_killed_planner_is_restarted_but_its_verdict_ends_the_run() -> None:
    planner = _Service("planner", code=-9)
    watch = _watch(planner, [planner], Restarter(RestartPolicy(max_restarts=3, first_backoff_s=0.0)))
    assert watch._ended(1.0) is None
    assert watch._ended(1.1) is None and planner.starts == 1
    planner.up, planner.code = False, 0  # the restarted planner finished the build
    result = watch._ended(9.0)
    assert result is not None and result.ending.how == "done"
