"""The dashboard in a real browser: the observer's recording of a run, served by rerun's web viewer, drawn
by Chromium (not headless, WebGL through SwiftShader, under Xvfb) and screenshotted over DevTools
(:mod:`page_shots`); the 3D view must not be blank. A test decides: enough pixels of the 3D view differ
from its background. The run has work in place under way when the recording ends (a footing formed by a
pump, another laid by a block layer, two of three courses standing): the laid courses and their label
must show in the laying colour, the one nothing else on site is drawn in. Screenshots are taken until one
shows both, within a bound (the viewer draws 15 to 30 s after it loaded on a busy machine).

It needs chromium, xvfb-run and xauth (``scripts/setup.sh --tests`` installs them) and websocket-client (a
test dependency).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from page_shots import missing_programs, shoot_until
from PIL import Image
from pydantic import BaseModel
from wall_clock import bound_s

from bimbot.services.observer.app import (
    Observer,
    ObserverConfig,
    _close_recording,
    open_recording,
    web_viewer,
)
from bimbot.shared.bus import encode
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import (
    ComponentStateMsg,
    PlannedSequenceMsg,
    RobotState,
    RobotStateMsg,
    SiteInfoMsg,
)
from bimbot.shared.robot_description import DEFAULT_ROBOT, Capability, LayingSpec, RobotDescription
from bimbot.shared.site_layout import plan_site
from bimbot.supervisor import free_port

pytestmark = pytest.mark.integration

VIEW_BOX = (
    0.01,
    0.08,
    0.65,
    0.78,
)  # the 3D view in the observer's layout: left, top, right, bottom (fractions)
MIN_DRAWN = 0.02  # of the 3D view's pixels differ from its background (a real run draws ~0.1)
MIN_LAYING_PIXELS = 50  # the two courses standing and the label of the footing being laid
DRAW_BOUND_S = 60.0  # for the viewer to load the recording and draw it (software rendering; ~20 s)


MACHINE = {"urdf": "carrier.urdf", "payload_kg": 1.0, "reach_m": 40.0, "max_place_height_m": 30.0}
MACHINE |= {"length_m": 1.4, "width_m": 0.9, "max_speed_mps": 0.0, "max_turn_radps": 0.0}
PUMP = RobotDescription(name="pump", capabilities={Capability.STAND_FIXED, Capability.POUR}, **MACHINE)
LAYER = RobotDescription(
    name="block_layer",
    capabilities={Capability.STAND_FIXED, Capability.LAY},
    laying=LayingSpec(
        block_length_m=0.4, block_height_m=0.1, block_width_m=0.2, block_mass_kg=10.0, blocks_per_h=60.0
    ),
    **MACHINE,
)
CAST, LAID = 6, 8  # Footing C1 and C3 of the frame: the synthetic run's robots never touch them


def site_info(manifest: Manifest) -> SiteInfoMsg:
    """What physics answers on physics/info for the frame's site with the synthetic run's two robots, a
    pump (r3) and a block layer (r4)."""
    layout = plan_site(manifest.components, robots=4)
    types = {"r1": DEFAULT_ROBOT.name, "r2": DEFAULT_ROBOT.name, "r3": PUMP.name, "r4": LAYER.name}
    return SiteInfoMsg(
        robot_ids=list(types),
        robot_starts_xy_yaw=list(layout.robot_starts),
        robot_type_of=types,
        robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT, PUMP.name: PUMP, LAYER.name: LAYER},
        step_s=1 / 240,
        control_period_s=0.1,
        lock_step=True,
        layout=layout,
    )


def with_work_in_place(manifest: Manifest) -> Manifest:
    """The frame with Footing C1 cast in place and Footing C3 laid."""
    items = list(manifest.components)
    items[CAST] = items[CAST].model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE})
    items[LAID] = items[LAID].model_copy(update={"method": ConstructionMethod.LAID})
    return manifest.model_copy(update={"components": items})


def work_in_place(manifest: Manifest, after_s: float) -> list[BaseModel]:
    """The pump forming Footing C1 and the block layer laying Footing C3's third course of three."""
    cast, laid = manifest.components[CAST].guid, manifest.components[LAID].guid
    t = after_s + 1.0
    common = {"sim_time_s": t, "wall_time_s": t}
    state = {"event": "e", **common}
    robot = {"state": RobotState.WORK_IN_PLACE, "pose_xy_yaw": (0.0, 0.0, 0.0), **common}
    return [
        ComponentStateMsg(guid=cast, previous=S.PLANNED, state=S.RELEASED, **state),
        ComponentStateMsg(guid=laid, previous=S.PLANNED, state=S.RELEASED, **state),
        ComponentStateMsg(guid=cast, previous=S.RELEASED, state=S.FORMING, robot_id="r3", **state),
        ComponentStateMsg(guid=laid, previous=S.RELEASED, state=S.LAYING, robot_id="r4", **state),
        RobotStateMsg(robot_id="r3", task_id="T-C1", guid=cast, activity="formwork", **robot),
        RobotStateMsg(robot_id="r4", task_id="T-C3", guid=laid, activity="course 3/3", **robot),
    ]


@pytest.fixture(scope="module")
def recording(
    bundled_build: Path,
    frame_manifest: Manifest,
    run_messages: list[tuple[str, BaseModel]],
    tmp_path_factory: pytest.TempPathFactory,
) -> Path:
    """The observer's recording of the synthetic run, then work in place (its own blueprint: the 3D view
    of the site)."""
    out = tmp_path_factory.mktemp("dashboard")
    config = ObserverConfig(rrd_path=out / "site.rrd", report_dir=out / "report", web=False)
    manifest = with_work_in_place(frame_manifest)
    stream, _ = open_recording(manifest.site, config, manifest.components)
    observer = Observer(manifest, bundled_build, config, stream)
    observer.site_known(site_info(manifest))
    order = [component.guid for component in manifest.components]
    observer.plan_known(PlannedSequenceMsg(source="test", order=order, predecessors={}))
    for key_expr, message in run_messages:
        observer.handle(key_expr, encode(message))
    for message in work_in_place(manifest, observer.sim_time_s):
        observer.apply(message)
    observer.finish()
    _close_recording(stream, config.rrd_path, compact=True)
    return config.rrd_path


@pytest.fixture(scope="module")
def served(recording: Path) -> Iterator[str]:
    """The recording served as ``bimbot observe`` serves its own: a gRPC server sink of the rerun SDK (here
    in the test's process, fed the recording's file) and the page from the observer's :func:`web_viewer`;
    the viewer's URL. Not ``rerun --serve-web FILE``: serving a file, the CLI keeps a core busy for as
    long as it runs, which the browser's software rendering then waits for."""
    stream = rr.RecordingStream("bimbot")
    server = rr.GrpcServerSink(bind_ip="127.0.0.1", port=free_port())
    stream.set_sinks(server)
    try:
        stream.log_file_from_path(recording)
        with web_viewer("127.0.0.1", free_port(), server.uri) as page:
            yield page
    finally:
        stream.disconnect()


def drawn_fraction(png: Path, box: tuple[float, float, float, float] = VIEW_BOX) -> float:
    """The share of the box's pixels that differ from its most common colour (its background) by more
    than 40 in the sum of their RGB channels. The colours are counted as one integer each (0xRRGGBB, in
    the same order as the RGB rows): a tenth of the time of counting rows, on a 1600×1000 screenshot."""
    pixels = np.asarray(Image.open(png).convert("RGB"), dtype=np.int32)
    height, width, _ = pixels.shape
    left, top, right, bottom = box
    region = pixels[int(top * height) : int(bottom * height), int(left * width) : int(right * width)].reshape(
        -1, 3
    )
    packed = (region[:, 0] << 16) | (region[:, 1] << 8) | region[:, 2]
    colours, counts = np.unique(packed, return_counts=True)
    top_colour = int(colours[counts.argmax()])
    background = np.array([top_colour >> 16, (top_colour >> 8) & 0xFF, top_colour & 0xFF], dtype=np.int32)
    return float((np.abs(region - background).sum(axis=1) > 40).mean())


def laying_pixels(png: Path, box: tuple[float, float, float, float] = VIEW_BOX) -> int:
    """The box's pixels in the laying colour (magenta, lit or not: red and blue high, green well below)."""
    pixels = np.asarray(Image.open(png).convert("RGB"), dtype=np.int32)
    height, width, _ = pixels.shape
    left, top, right, bottom = box
    region = pixels[int(top * height) : int(bottom * height), int(left * width) : int(right * width)]
    red, green, blue = region[..., 0], region[..., 1], region[..., 2]
    return int(((red > 140) & (blue > 140) & (green < 0.6 * np.minimum(red, blue))).sum())


def test_a_blank_page_counts_as_blank(tmp_path: Path) -> None:
    blank = tmp_path / "blank.png"
    Image.new("RGB", (1600, 1000), (255, 255, 255)).save(blank)
    assert drawn_fraction(blank) == 0.0


def test_the_recording_draws_the_site_in_the_3d_view_of_a_real_browser(served: str, tmp_path: Path) -> None:
    assert missing_programs() == [], "not installed (scripts/setup.sh --tests installs them)"

    def drawn(png: Path) -> bool:  # the cheap check first: until the viewer draws, it alone decides
        return laying_pixels(png) >= MIN_LAYING_PIXELS and drawn_fraction(png) >= MIN_DRAWN

    shot = shoot_until(
        served, tmp_path / "dashboard.png", drawn, port=free_port(), timeout_s=bound_s(DRAW_BOUND_S)
    )
    assert drawn_fraction(shot) >= MIN_DRAWN, f"the 3D view is blank (see {shot})"
    assert laying_pixels(shot) >= MIN_LAYING_PIXELS, f"no laid courses in the 3D view (see {shot})"
