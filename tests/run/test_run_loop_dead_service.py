"""A service that dies during ``bimbot run`` ends the run with the tail of its log (the traceback) in the
summary; a planner that crashed (exit 1 with a traceback) is not mistaken for its "something failed"
verdict."""

from __future__ import annotations

from run_builders import watch_of

from bimbot.cli import BUG_MARK
from bimbot.run.loop import LOG_TAIL_LINES, RunWatch

TRACEBACK = [
    f"ERROR bimbot: bimbot planner {BUG_MARK} (a bug; traceback follows)",
    "Traceback (most recent call last):",
    *[f'  File "x.py", line {n}, in f' for n in range(20)],
    "pydantic_core._pydantic_core.ValidationError: 1 validation error for TaskMsg",
]


class _Dead:
    def __init__(self, name: str, code: int, log: list[str]) -> None:
        self.name, self.code, self.text = name, code, "\n".join(log) + "\n"

    def alive(self) -> bool:
        return False

    def wait(self, _timeout_s: float | None) -> int:
        return self.code

    def log(self) -> str:
        return self.text


class _Alive(_Dead):
    def alive(self) -> bool:
        return True


class _Monitor:
    constructed, total, sim_time_s = 0, 28, 12.0


def _watch(planner: _Dead, everyone: list[_Dead]) -> RunWatch:
    return watch_of(planner, everyone, _Monitor())


def test_a_crashed_planner_ends_the_run_with_its_traceback_tail() -> None:
    planner = _Dead("planner", 1, ["INFO planner: 28 task(s)", *TRACEBACK])
    result = _watch(planner, [planner])._ended(3.0)
    assert result is not None and result.ending.how == "service_stopped"
    assert "planner stopped unexpectedly (exit 1)" in result.ending.message
    assert len(result.ending.details) == LOG_TAIL_LINES
    assert result.ending.details[-1].endswith("ValidationError: 1 validation error for TaskMsg")


def test_a_planner_verdict_of_1_without_a_traceback_is_the_end_of_the_build() -> None:
    planner = _Dead("planner", 1, ["WARNING planner: 3 component(s) failed, 2 blocked"])
    result = _watch(planner, [planner])._ended(3.0)
    assert result is not None and result.ending.how == "done"


def test_a_dead_robot_ends_the_run_with_its_log_tail() -> None:
    planner = _Alive("planner", 0, [])
    robot = _Dead("robot-r1", 1, ["INFO robot: start", *TRACEBACK])
    result = _watch(planner, [planner, robot])._ended(3.0)
    assert result is not None and result.ending.how == "service_stopped"
    assert "robot-r1 stopped unexpectedly (exit 1)" in result.ending.message
    assert result.ending.details[-1].startswith("robot-r1.log: ")
    assert "ValidationError" in result.ending.details[-1]
