"""The report of a mixed fleet: lanes grouped by robot type, utilisation per type, hand-off tasks as their own
records and bars, and the staging areas in the 3D scene.

A small synthetic log on the bundled build's first three components. Fleet (physics' site info): r1 husky,
r2 and r4 carriers (r4 never leaves idle), r3 a tower crane. Component A is carried by r2 to the crane's
staging area (hand-off task ``T-A-h1``, announced by the planner with its put-down spot) and built by the
crane (``T-A``); component B is built by r2 (``T-B``); r1 starts a hand-off of C (``T-C-h2``) that the
planner's message never reached the report for. First release at 0 s, last constructed at 100 s:

    r1 husky        20 → 45   T-C-h2 (hand-off)                  25 s / (1 × 100 s) = 25 %
    r2 carrier      10 → 30   T-A-h1 (hand-off), 40 → 60 T-B      40 s / (2 × 100 s) = 20 %
    r4 carrier      never busy
    r3 tower_crane  30 → 100  T-A                                 70 s / (1 × 100 s) = 70 %
"""

from __future__ import annotations

from pathlib import Path

import pytest
import rerun as rr
from matplotlib.figure import Figure

from bimbot.services.observer.blueprint import cranes_of, site_items
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentStateMsg,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    SiteInfoMsg,
    TaskKind,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.report.collector import ReportCollector
from bimbot.shared.report.fleet import lane_label, robot_order, task_kind, utilisation_line
from bimbot.shared.report.png import HAND_OFF_HATCH, _robot_lanes, class_colors, render_report_png
from bimbot.shared.site_plan import Rect, SiteLayout

TYPES = {"r1": "husky", "r2": "carrier", "r3": "tower_crane", "r4": "carrier"}
STAGING = Rect((20.0, 0.0), (24.0, 4.0))


def _site_info() -> SiteInfoMsg:
    fleet = default_fleet()
    layout = SiteLayout(
        building=Rect((0.0, 0.0), (10.0, 10.0)),
        yard=Rect((12.0, 0.0), (18.0, 10.0)),
        depot=Rect((12.0, 12.0), (18.0, 14.0)),
        fence=Rect((-5.0, -5.0), (30.0, 20.0)),
        slots={},
        robot_starts=tuple((12.5 + i, 13.0, 0.0) for i in range(4)),
        staging=(STAGING,),
    )
    return SiteInfoMsg(
        robot_ids=list(TYPES),
        robot_starts_xy_yaw=list(layout.robot_starts),
        robot_type_of=TYPES,
        robot_types={name: fleet.types[name] for name in set(TYPES.values())},
        step_s=0.01,
        control_period_s=0.1,
        lock_step=True,
        layout=layout,
    )


def _state(guid: str, previous: S | None, state: S, t: float, robot: str | None = None, *, event: str = "e"):
    return ComponentStateMsg(
        guid=guid, previous=previous, state=state, event=event, sim_time_s=t, wall_time_s=t, robot_id=robot
    )


def _robot(robot: str, state: RobotState, t: float, task: str | None = None, guid: str | None = None):
    return RobotStateMsg(
        robot_id=robot,
        state=state,
        task_id=task,
        guid=guid,
        pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=t,
        wall_time_s=t,
    )


def _task(task_id: str, guid: str, robot: str, kind: TaskKind, put_down: tuple[float, float] | None = None):
    pose = PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    return TaskMsg(
        task_id=task_id,
        guid=guid,
        component_key=guid,
        status=TaskStatus.ASSIGNED,
        robot_id=robot,
        target_pose=pose,
        sim_time_s=0.0,
        wall_time_s=0.0,
        kind=kind,
        put_down_xy_m=put_down,
    )


@pytest.fixture(scope="module")
def guids(frame_manifest: Manifest) -> tuple[str, str, str]:
    a, b, c = (component.guid for component in frame_manifest.components[:3])
    return a, b, c


@pytest.fixture(scope="module")
def report(frame_manifest: Manifest, guids: tuple[str, str, str]) -> dict:
    a, b, c = guids
    idle = RobotState.IDLE
    busy = RobotState.DETECT_COMPONENT_POSITION
    messages = [
        _site_info(),
        _task("T-A-h1", a, "r2", TaskKind.HAND_OFF, (22.0, 2.0)),
        _task("T-B", b, "r2", TaskKind.BUILD),
        _task("T-A", a, "r3", TaskKind.BUILD),
        *(_state(guid, S.PLANNED, S.RELEASED, 0.0) for guid in (a, b)),
        *(_robot(robot, idle, 0.0) for robot in ("r1", "r2", "r3")),  # r4 says nothing
        _robot("r2", busy, 10.0, "T-A-h1", a),
        _state(a, S.RELEASED, S.PICKING, 10.0, "r2"),
        _state(a, S.PICKING, S.TRANSPORTING, 12.0, "r2"),
        _robot("r1", busy, 20.0, "T-C-h2", c),
        _state(a, S.TRANSPORTING, S.RELEASED, 30.0, "r2", event=ComponentEvent.HAND_OFF.value),
        _robot("r2", idle, 30.0),
        _robot("r3", busy, 30.0, "T-A", a),
        _state(a, S.RELEASED, S.PICKING, 31.0, "r3"),
        _robot("r2", busy, 40.0, "T-B", b),
        _robot("r1", idle, 45.0),
        _state(b, S.VERIFYING, S.CONSTRUCTED, 60.0, "r2"),
        _robot("r2", idle, 60.0),
        _state(a, S.VERIFYING, S.CONSTRUCTED, 100.0, "r3"),
        _robot("r3", idle, 100.0),
    ]
    collector = ReportCollector(frame_manifest)
    for message in messages:
        collector.add(message)
    return collector.report()


def test_each_robot_carries_its_type_and_robots_on_site_that_never_reported_are_listed(report: dict) -> None:
    assert {robot_id: robot["type"] for robot_id, robot in report["robots"].items()} == TYPES
    assert report["robots"]["r4"]["busy_s"] == 0.0 and report["robots"]["r4"]["tasks"] == []


def test_utilisation_per_type_is_busy_share_of_its_robots_over_the_makespan(report: dict) -> None:
    totals = report["totals"]
    assert totals["makespan_s"] == 100.0
    by_type = totals["by_type"]
    assert list(by_type) == ["husky", "carrier", "tower_crane"]  # in lane order
    assert by_type["carrier"]["robots"] == ["r2", "r4"]
    assert by_type["husky"]["utilisation"] == pytest.approx(0.25)
    assert by_type["carrier"]["utilisation"] == pytest.approx(40.0 / (2 * 100.0))
    assert by_type["tower_crane"]["utilisation"] == pytest.approx(0.70)
    assert utilisation_line(report) == (
        "utilisation by type (busy within the makespan / robots × makespan): "
        "husky 25 % (1 robot), carrier 20 % (2 robots), tower_crane 70 % (1 robot)"
    )


def test_hand_off_tasks_are_their_own_records(report: dict, guids: tuple[str, str, str]) -> None:
    a, _, _ = guids
    r2 = report["robots"]["r2"]["tasks"]
    assert [(t["task_id"], t["kind"]) for t in r2] == [("T-A-h1", "hand_off"), ("T-B", "build")]
    assert r2[0]["put_down_xy_m"] == (22.0, 2.0) and "put_down_xy_m" not in r2[1]
    (r1,) = report["robots"]["r1"]["tasks"]
    assert r1["kind"] == "hand_off"  # no TaskMsg heard: by the planner's id (<build task id>-h<n>)
    assert report["robots"]["r3"]["tasks"][0]["kind"] == "build"
    assert report["totals"]["hand_off_tasks"] == 2
    assert report["totals"]["by_type"]["carrier"]["hand_off_tasks"] == 1
    assert report["totals"]["by_type"]["carrier"]["build_tasks"] == 1
    component = next(c for c in report["components"] if c["guid"] == a)
    assert component["handed_off_s"] == [30.0] and component["robot_ids"] == ["r2", "r3"]


def test_the_gantt_lanes_are_grouped_by_type_and_hand_offs_hatched(report: dict, tmp_path: Path) -> None:
    robots = report["robots"]
    assert robot_order(robots) == ["r1", "r2", "r4", "r3"]
    assert lane_label("r2", robots["r2"]) == "r2 (carrier)"
    ax = Figure().subplots()
    _robot_lanes(ax, report, class_colors([c["ifc_class"] for c in report["components"]]))
    labels = [label.get_text() for label in ax.get_yticklabels()]
    assert labels == ["r1 (husky)", "r2 (carrier)", "r4 (carrier)", "r3 (tower_crane)"]
    hatched = [bars for bars in ax.collections if bars.get_hatch() == HAND_OFF_HATCH]
    assert len(hatched) == 2  # T-A-h1 and T-C-h2; the builds are plain
    assert "utilisation by type" in ax.get_title()
    assert render_report_png(report, tmp_path / "fleet.png").stat().st_size > 10_000


def test_a_robot_going_from_task_to_task_without_idle_gets_an_interval_per_task(
    frame_manifest: Manifest,
) -> None:
    collector = ReportCollector(frame_manifest)
    busy = RobotState.DETECT_COMPONENT_POSITION
    for message in (
        _robot("r1", busy, 1.0, "T-X-h1", "X"),
        _robot("r1", RobotState.PICK_UP, 2.0, "T-X-h1", "X"),
        _robot("r1", busy, 5.0, "T-Y", "Y"),
        _robot("r1", RobotState.IDLE, 9.0),
    ):
        collector.add(message)
    tasks = collector.report()["robots"]["r1"]["tasks"]
    assert [(t["task_id"], t["start_s"], t["end_s"]) for t in tasks] == [
        ("T-X-h1", 1.0, 5.0),
        ("T-Y", 5.0, 9.0),
    ]


def test_task_kind_without_a_task_message() -> None:
    assert task_kind("T-7-h3", {}) == "hand_off"
    assert task_kind("T-7-h3", {"T-7-h3": TaskKind.BUILD}) == "build"  # the planner's word first
    assert task_kind("T-h", {}) == "build" and task_kind(None, {}) is None


def test_the_staging_areas_are_drawn_beside_the_yard_and_depot_labelled_with_their_crane() -> None:
    info = _site_info()
    assert cranes_of(info) == ["r3"]
    items = {item.entity_path: item for item in site_items(info.layout, [], cranes_of(info))}
    assert {"world/site/yard", "world/site/depot", "world/site/staging"} <= set(items)
    staging = items["world/site/staging"]
    assert staging.static and isinstance(staging.archetype, rr.LineStrips3D)
    assert [str(label) for label in staging.archetype.labels.pa_array.to_pylist()] == ["staging r3"]


def test_the_run_summary_lists_robots_by_type_with_hand_offs_and_utilisation_per_type(report: dict) -> None:
    from bimbot.run.summary import RunOutcome, summary_text

    text = summary_text(RunOutcome(exit_code=0, constructed=2, total=28, report=report))
    lines = text.splitlines()
    robot_lines = [line for line in lines if " task(s)" in line]
    assert [line.split(":")[0] for line in robot_lines] == [
        "r1 (husky)",
        "r2 (carrier)",
        "r4 (carrier)",
        "r3 (tower_crane)",
    ]
    assert "1 hand-off(s) to a crane" in robot_lines[1] and "hand-off" not in robot_lines[3]
    assert utilisation_line(report) in lines


def test_the_summary_s_sim_time_is_never_before_the_last_construction_the_report_counts() -> None:
    """In plan fidelity the run's monitor may stop before it hears the last clock; the report, built after
    the last message, knows it: the summary says the later of the two (never less than the makespan)."""
    from bimbot.run.summary import RunOutcome, summary_text

    report = {"sim_time_s": 1_795_233.6, "totals": {"makespan_s": 1_794_991.0}}
    first = summary_text(
        RunOutcome(exit_code=0, constructed=2, total=2, sim_time_s=1_738_309.7, report=report)
    )
    assert first.splitlines()[0].startswith(
        "constructed 2/2 components in 20.8 days round the clock (1,795,234 s) of sim time"
    )
    later = summary_text(
        RunOutcome(exit_code=0, constructed=2, total=2, sim_time_s=1_800_000.0, report=report)
    )
    assert "in 20.8 days round the clock (1,800,000 s) of sim time" in later


def test_the_observer_s_report_says_the_fidelity_physics_simulates_at(frame_manifest: Manifest) -> None:
    collector = ReportCollector(frame_manifest)
    assert collector.report()["settings"] == {}  # physics has not said: no guess
    collector.add(_site_info().model_copy(update={"fidelity": "plan"}))
    assert collector.report()["settings"] == {"fidelity": "plan"}  # a compose site's report says it too


def test_the_summary_says_round_the_clock_once_at_its_first_time_in_days() -> None:
    """A trial user read "round the clock" eight times in the house's summary: it is said at the first time
    in days, and every later time in days is read the same way."""
    from bimbot.run.summary import RunOutcome, summary_text

    report = {"sim_time_s": 574_792.0, "totals": {"makespan_s": 574_791.0}}
    text = summary_text(RunOutcome(exit_code=0, constructed=2, total=2, sim_time_s=574_792.0, report=report))
    assert text.count("round the clock") == 1
    first = text.splitlines()[0]
    assert first.startswith("constructed 2/2 components in 6.7 days round the clock (574,792 s)")
    assert "makespan 6.7 days (574,791 s)" in first
