"""The ``.rrd`` the observer writes: it verifies with ``rerun rrd verify`` and reads back with the twin in it.

The synthetic run (see conftest) is fed through :class:`bimbot.services.observer.app.Observer` as encoded
payloads, exactly as the Zenoh loop would, into a recording with only the file sink (no viewer).
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pytest
from pydantic import BaseModel
from rerun.chunk import RrdReader
from wall_clock import bound_s

from bimbot.services.observer.app import (
    Observer,
    ObserverConfig,
    _close_recording,
    open_recording,
    rerun_cli_binary,
)
from bimbot.services.observer.twin_log import component_path
from bimbot.shared.bus import encode
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, PlannedSequenceMsg, PoseMsg, SiteInfoMsg, TwinMsg
from bimbot.shared.report.png import REPORT_JSON, REPORT_PNG
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_layout import plan_site


@dataclass
class Recorded:
    rrd: Path
    report_dir: Path
    invalid: int
    chunks: list  # (entity path, static, rows, column names, record batch)


@pytest.fixture(scope="module")
def recorded(
    bundled_build: Path,
    frame_manifest: Manifest,
    run_messages: list[tuple[str, BaseModel]],
    tmp_path_factory: pytest.TempPathFactory,
) -> Recorded:
    out = tmp_path_factory.mktemp("recording")
    config = ObserverConfig(rrd_path=out / "twin.rrd", report_dir=out / "report", web=False)
    recording, url = open_recording(frame_manifest.site, config)
    assert url is None
    observer = Observer(frame_manifest, bundled_build, config, recording)
    observer.site_known(site_info(frame_manifest))  # what physics answers on physics/info
    planned = list(reversed([c.guid for c in frame_manifest.components]))  # not the build's sequence.xml
    observer.plan_known(PlannedSequenceMsg(source="test", order=planned, predecessors={}))
    for key_expr, message in run_messages:
        observer.handle(key_expr, encode(message))
    observer.handle(f"bimbot/{frame_manifest.site}/progress", b'{"schema_version": 1, "total": "many"}')
    observer.handle(f"bimbot/{frame_manifest.site}/robots/r1/cmd_vel", b"not read at all")
    observer.finish()
    observer.write_reports_if_new()
    _close_recording(recording, config.rrd_path, compact=True)
    chunks = []
    for chunk in RrdReader(config.rrd_path).store().stream():
        batch = chunk.to_record_batch()
        chunks.append((str(chunk.entity_path), chunk.is_static, chunk.num_rows, batch.schema.names, batch))
    return Recorded(config.rrd_path, config.report_dir, observer.invalid.total, chunks)


def test_the_recording_passes_rerun_rrd_verify(recorded: Recorded) -> None:
    result = subprocess.run(
        [str(rerun_cli_binary()), "rrd", "verify", str(recorded.rrd)],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(60),
    )
    assert result.returncode == 0, result.stderr[-2000:]


def test_every_component_mesh_is_in_the_recording_once_and_static(
    recorded: Recorded, frame_manifest: Manifest
) -> None:
    for component in frame_manifest.components:
        path = "/" + component_path(component.guid)
        meshes = [c for c in recorded.chunks if c[0] == path and "Asset3D:blob" in c[3]]
        assert len(meshes) == 1, component.guid
        _, static, rows, _, _ = meshes[0]
        assert static and rows == 1


def test_placed_components_are_at_their_target_in_the_end(
    recorded: Recorded, frame_sequence: list[str]
) -> None:
    first = frame_sequence[0]
    path = "/" + component_path(first)
    (transforms,) = [c[4] for c in recorded.chunks if c[0] == path and "Transform3D:translation" in c[3]]
    times_ns = transforms.column("sim_time").cast(pa.int64()).to_pylist()
    translations = transforms.column("Transform3D:translation").to_pylist()
    _, last = max(zip(times_ns, translations, strict=True))
    assert last == [pytest.approx([0.0, 0.0, -0.3])]  # Footing A1's BIM pose
    # yard at 0; carried at 3.00, 3.05, 3.10 s with 0.1 s throttling: 3.05 dropped; placed at 10
    assert sorted(times_ns) == [0, 3_000_000_000, 3_100_000_000, 10_000_000_000]


def test_the_run_is_on_the_sim_time_timeline_with_its_log_and_plots(recorded: Recorded) -> None:
    paths = {c[0] for c in recorded.chunks}
    expected = {
        "/log/components",
        "/log/tasks",
        "/log/robots",
        "/progress/percent_constructed",
        "/world/robots/r1",
    }
    assert expected <= paths
    assert {"/world/robots/r1/scan", "/world/plans/r1", "/world/site/fence", "/world/targets"} <= paths
    assert any(path.startswith("/world/trails/r1/") for path in paths)
    (log,) = [c[4] for c in recorded.chunks if c[0] == "/log/components" and not c[1]]
    assert "sim_time" in log.schema.names
    texts = [text for row in log.column("TextLog:text").to_pylist() for text in row]
    assert any("verifying → misplaced" in text for text in texts)


def test_the_robot_is_drawn_once_from_its_type_urdf_instead_of_a_box(recorded: Recorded) -> None:
    link = "/world/robots/r1/model/base_link"  # the site info's type: pybullet_data's Husky
    meshes = [c for c in recorded.chunks if c[0] == link and "Mesh3D:vertex_positions" in c[3]]
    assert len(meshes) == 1 and meshes[0][1] and meshes[0][2] == 1  # once, static
    assert any(c[0] == link and not c[1] and "Transform3D:translation" in c[3] for c in recorded.chunks)
    paths = {c[0] for c in recorded.chunks}
    assert "/world/robots/r1/marker" in paths and "/world/robots/r1/body" not in paths


def test_the_recording_carries_the_observer_blueprint(recorded: Recorded) -> None:
    assert RrdReader(recorded.rrd).blueprints()


def test_invalid_payloads_are_counted_and_unread_keys_ignored(recorded: Recorded) -> None:
    assert recorded.invalid == 1


def test_the_reports_are_written_beside(recorded: Recorded, frame_manifest: Manifest) -> None:
    report = json.loads((recorded.report_dir / REPORT_JSON).read_text())
    assert report["totals"]["constructed"] == 3
    # the report's planned order is the planner's (asked on planner/plan), not a file's
    by_index = sorted(report["components"], key=lambda c: c["sequence_index"])
    assert [c["guid"] for c in by_index] == list(reversed([c.guid for c in frame_manifest.components]))
    assert (recorded.report_dir / REPORT_PNG).stat().st_size > 0


def test_a_late_observer_learns_the_past_from_twins_and_counts_each_transition_once(
    bundled_build: Path, frame_manifest: Manifest, tmp_path: Path
) -> None:
    config = ObserverConfig(rrd_path=tmp_path / "late.rrd", report_dir=tmp_path, web=False)
    recording, _ = open_recording(frame_manifest.site, config)
    observer = Observer(frame_manifest, bundled_build, config, recording)
    component = frame_manifest.components[0]
    steps = [
        (S.PLANNED, S.RELEASED, 1.0),
        (S.RELEASED, S.PICKING, 2.0),
        (S.PICKING, S.TRANSPORTING, 3.0),
        (S.TRANSPORTING, S.ASSEMBLING, 4.0),
        (S.ASSEMBLING, S.VERIFYING, 5.0),
        (S.VERIFYING, S.MISPLACED, 6.0),
        (S.MISPLACED, S.RELEASED, 7.0),
    ]
    pose = PoseMsg(position_m=(1.0, 2.0, 3.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    twin = TwinMsg(
        guid=component.guid,
        key=component.key,
        ifc_class=component.ifc_class,
        name=component.name,
        storey=None,
        material=None,
        mass_kg=component.mass_kg,
        target_pose=pose,
        current_pose=pose,
        current_pose_sim_time_s=6.5,
        state=S.RELEASED,
        attempt=1,
        robot_id=None,
        history=[
            ComponentStateMsg(
                guid=component.guid,
                previous=a,
                state=b,
                event="e",
                sim_time_s=t,
                wall_time_s=t,
                attempt=1,
                robot_id="r2" if b is not S.RELEASED else None,
                position_error_m=0.03 if b is S.MISPLACED else None,
            )
            for a, b, t in steps
        ],
    )
    site = frame_manifest.site
    observer.twin_reply(f"bimbot/{site}/components/{component.key}/twin", encode(twin))
    live = ComponentStateMsg(
        guid=component.guid,
        state=S.MISPLACED,
        previous=S.VERIFYING,
        event="e",
        sim_time_s=6.0,
        wall_time_s=9.0,
    )
    observer.handle(f"bimbot/{site}/components/{component.key}/state", encode(live))  # seen twice: once
    _close_recording(recording, config.rrd_path, compact=False)
    (entry,) = [c for c in observer.collector.report()["components"] if c["guid"] == component.guid]
    assert (entry["released_s"], entry["picked_s"], entry["placed_s"]) == (1.0, 2.0, 5.0)
    assert entry["retries"] == 1 and entry["state"] == "released"
    assert entry["robot_ids"] == ["r2"] and entry["position_error_mm"] == 30.0  # from the twin alone


def site_info(manifest: Manifest) -> SiteInfoMsg:
    layout = plan_site(manifest.components, robots=1)
    return SiteInfoMsg(
        robot_ids=["r1"],
        robot_starts_xy_yaw=list(layout.robot_starts),
        robot_type_of={"r1": DEFAULT_ROBOT.name},
        robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT},
        step_s=1 / 240,
        control_period_s=0.1,
        lock_step=True,
        layout=layout,
    )


def test_the_planner_leaving_ends_the_wait_even_when_its_done_progress_was_missed(
    bundled_build: Path, frame_manifest: Manifest, tmp_path: Path
) -> None:
    config = ObserverConfig(rrd_path=tmp_path / "late.rrd", report_dir=tmp_path, web=False)
    recording, _ = open_recording(frame_manifest.site, config)
    observer = Observer(frame_manifest, bundled_build, config, recording)
    alive = f"bimbot/{frame_manifest.site}/alive"
    observer.alive(f"{alive}/robot/r1", False)
    assert observer.done_at is None  # a robot leaving is not the end
    observer.alive(f"{alive}/planner/main", True)
    assert observer.done_at is None
    observer.alive(f"{alive}/planner/main", False)
    assert observer.done_at is not None  # with --exit-when-done the observer now ends
    _close_recording(recording, config.rrd_path, compact=False)


def test_the_3d_view_opens_looking_at_the_building_from_the_south_west(frame_manifest: Manifest) -> None:
    from bimbot.services.observer.blueprint import site_eye

    eye = site_eye(frame_manifest.components)
    assert eye is not None
    position, target = (
        eye.position.as_arrow_array().to_pylist()[0],  # type: ignore[union-attr]
        eye.look_target.as_arrow_array().to_pylist()[0],  # type: ignore[union-attr]
    )
    assert position[0] < target[0] and position[1] < target[1] and position[2] > 10.0
    assert 0.0 <= target[0] <= 6.0  # the bundled frame spans 0–6 m
