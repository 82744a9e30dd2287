"""Live progress: the real-time factor over a window, the progress and robot lines, one plain line every
10 s when stdout is not a terminal, and nothing with -q."""

from __future__ import annotations

import io

from bimbot.run.progress import (
    NoProgress,
    PlainProgress,
    RateWindow,
    grouped_robot_lines,
    make_progress,
    progress_line,
    robot_line,
    robot_lines,
)
from bimbot.shared.messages import PreparingMsg, RobotState, RobotStateMsg

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
        progress_line(3, 9, 412.04, 8.12, 51.2) == "constructed 3/9 · sim 412 s · real time ×8.1 · wall 51 s"
    )
    assert "starting the services" in progress_line(0, 9, 0.0, None, 12.0)  # the clock has not moved yet
    said = PreparingMsg(stage="access check, mended 2 time(s)", done=120, total=468)
    assert progress_line(0, 9, 0.0, None, 95.0, preparing=said) == (  # the planner works on its plan
        "constructed 0/9 · the planner prepares its plan: access check, mended 2 time(s), 120/468 · wall 95 s"
    )
    assert progress_line(13, 85, 300.0, 9.0, 30.0, not_built=69) == (  # failed before the build: said at once
        "constructed 13/85 · 69 will not be built (the table at the end says why) · sim 300 s · "
        "real time ×9.0 · wall 30 s"
    )
    line = robot_line(ROBOT, {GUID: "Column A1"}, {"r1": "husky"})
    assert line.startswith("r1 (husky) pick_up T0004 Column A1: driving to the yard")
    assert line.endswith("…") and len(line) < 110


def test_a_plan_runs_progress_says_its_sim_time_in_days_and_its_speed_up_as_a_whole_number() -> None:
    line = progress_line(40, 85, 4.5 * 86400.0, 47001.1, 9.0)
    assert line == "constructed 40/85 · sim 4.5 days · real time ×47,001 · wall 9 s"
    assert "sim 13.1 h ·" in progress_line(1, 2, 13.1 * 3600.0, 950.0, 50.0)
    assert "sim 43.8 min ·" in progress_line(1, 2, 2627.0, 92.6, 28.0)
    assert "real time ×93 ·" in progress_line(1, 2, 2627.0, 92.6, 28.0)


def test_robots_are_named_with_their_type_and_the_idle_ones_share_a_line() -> None:
    def idle(robot_id: str, activity: str = "") -> RobotStateMsg:
        return RobotStateMsg(
            robot_id=robot_id,
            state=RobotState.IDLE,
            pose_xy_yaw=(0.0, 0.0, 0.0),
            sim_time_s=10.0,
            wall_time_s=0.0,
            activity=activity,
        )

    types = {"r1": "husky", "r2": "carrier", "r3": "tower_crane", "r10": "carrier", "r4": "block_layer"}
    robots = {"r1": ROBOT, "r2": idle("r2"), "r3": idle("r3"), "r10": idle("r10"), "r4": idle("r4", "stays")}
    lines = robot_lines(robots, {GUID: "Column A1"}, types)
    assert lines[0].startswith("r1 (husky) pick_up T0004 Column A1")
    assert lines[1] == "r4 (block_layer) idle: stays"  # an idle robot with something to say: its own line
    assert lines[2] == "idle: r2, r10 (carrier), r3 (tower_crane)"
    assert robot_lines({"r2": idle("r2")}, {}, {}) == ["idle: r2"]  # type not known


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


def test_a_plain_line_groups_many_robots_at_work_by_state() -> None:
    """Eleven robots named each with task and component made a 900-character line: past
    ``PLAIN_ROBOTS_NAMED`` at work, a plain line says who is in which state, one group per state."""

    def at(robot_id: str, state: RobotState, activity: str = "") -> RobotStateMsg:
        return RobotStateMsg(
            robot_id=robot_id,
            state=state,
            task_id=None if state is RobotState.IDLE else f"T{robot_id}",
            guid=None if state is RobotState.IDLE else GUID,
            pose_xy_yaw=(0.0, 0.0, 0.0),
            sim_time_s=10.0,
            wall_time_s=0.0,
            activity=activity,
        )

    types = {f"r{i}": "carrier" for i in range(1, 11)} | {"r11": "tower_crane"}
    states = [RobotState.PICK_UP] * 3 + [RobotState.IDENTIFY_TARGET_LOCATION] * 4 + [RobotState.IDLE] * 3
    robots = {f"r{i}": at(f"r{i}", state) for i, state in enumerate(states, start=1)}
    robots["r11"] = at("r11", RobotState.ASSEMBLE, "waiting for r4 to step aside")
    assert grouped_robot_lines(robots, types) == [
        "pick_up: r1, r2, r3 (carrier)",
        "identify_target_location: r4, r5, r6, r7 (carrier)",
        "r11 (tower_crane) assemble Tr11 " + GUID + ": waiting for r4 to step aside",
        "idle: r8, r9, r10 (carrier)",
    ]
    said: list[str] = []
    plain = PlainProgress({GUID: "Column A1"}, said.append, every_s=10.0, types=types)
    plain.update(1, 988, 5.0, robots, 1.0)
    assert said == [
        "progress: "
        + progress_line(1, 988, 5.0, None, 1.0)
        + "; "
        + "; ".join(grouped_robot_lines(robots, types))
    ]
    assert len(said[0]) < 300
    few = {robot_id: robots[robot_id] for robot_id in ("r1", "r8")}  # few at work: each named in full
    plain.update(1, 988, 6.0, few, 12.0)
    assert "r1 (carrier) pick_up Tr1 Column A1" in said[1]
