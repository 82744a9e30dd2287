"""Live progress: the real-time factor over a window, the progress and robot lines, one plain line every
10 s when stdout is not a terminal, and nothing with -q."""

from __future__ import annotations

import io

from bimbot.run.progress import (
    NoProgress,
    PlainProgress,
    RateWindow,
    make_progress,
    progress_line,
    robot_line,
)
from bimbot.shared.messages import RobotState, RobotStateMsg

GUID = "2O2Fr$t4X7Zf8NOew3FLOH"
ROBOT = RobotStateMsg(
    robot_id="r1",
    state=RobotState.PICK_UP,
    task_id="T0004",
    guid=GUID,
    pose_xy_yaw=(0.0, 0.0, 0.0),
    sim_time_s=10.0,
    wall_time_s=0.0,
    activity="driving to the yard " + "x" * 100,
)


def test_the_real_time_factor_is_measured_over_the_last_window() -> None:
    rate = RateWindow(window_s=10.0)
    assert rate.factor() is None
    for wall in range(31):  # 2× real time for 20 s, then 8×
        rate.add(float(wall), 2.0 * wall if wall <= 20 else 40.0 + 8.0 * (wall - 20))
    assert rate.factor() == 8.0


def test_progress_and_robot_lines() -> None:
    assert (
        progress_line(3, 9, 412.04, 8.12, 51.2)
        == "constructed 3/9 · sim 412.0 s · 8.1× real time · wall 51 s"
    )
    assert "starting the services" in progress_line(0, 9, 0.0, None, 12.0)  # the clock has not moved yet
    assert progress_line(13, 85, 300.0, 9.0, 30.0, not_built=69) == (  # failed before the build: said at once
        "constructed 13/85 · 69 will not be built (the table at the end says why) · sim 300.0 s · "
        "9.0× real time · wall 30 s"
    )
    line = robot_line(ROBOT, {GUID: "Column A1"})
    assert line.startswith("r1 pick_up T0004 Column A1: driving to the yard")
    assert line.endswith("…") and len(line) < 100


def test_plain_progress_says_one_line_as_the_clock_starts_then_one_every_ten_seconds() -> None:
    said: list[str] = []
    said_at: list[float] = []
    wall = [0.0]

    def say(line: str) -> None:
        said.append(line)
        said_at.append(wall[0])

    plain = PlainProgress({GUID: "Column A1"}, say, every_s=10.0)
    for tenth in range(0, 305):  # 30.5 s of updates, ten a second; the clock held at 0 for the first 1 s
        wall[0] = tenth / 10.0
        plain.update(1, 5, max(0.0, tenth - 10) * 0.5, {"r1": ROBOT}, wall[0])
    assert said_at == [1.1, 11.1, 21.1]  # as the clock started, then every ten seconds
    assert (
        said[0].startswith("progress: constructed 1/5 · sim ") and "; r1 pick_up T0004 Column A1" in said[0]
    )


def test_quiet_or_not_a_terminal_chooses_the_display() -> None:
    assert isinstance(make_progress({}, quiet=True, say=print), NoProgress)
    assert isinstance(make_progress({}, quiet=False, say=print, stream=io.StringIO()), PlainProgress)
