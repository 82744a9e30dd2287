"""The observer's adapter: Zenoh in, rerun out (a web viewer on loopback and an ``.rrd``), reports at the end.

Wiring, in order:

1. one rerun recording with two sinks at once (``RecordingStream.set_sinks``): a ``FileSink`` (the
   ``.rrd``, always) and, unless ``web`` is off, a ``GrpcServerSink`` bound to ``bind`` (127.0.0.1 by
   default) that viewers connect to; the layout of :mod:`.blueprint` is the default blueprint of both;
2. the web viewer: the ``rerun`` CLI of the wheel (``rerun --serve-web --bind <bind>
   --web-viewer-port <port> <grpc url>``) serves only the viewer's HTML/JS/Wasm, bound like the gRPC
   server (the SDK's own ``serve_web_viewer`` always binds every interface). Its page connects to our
   gRPC server;
3. the static scene (site, every component's mesh once) and the initial yard poses at sim time 0; once
   physics answers with its site info, the site plan (staging areas too) and every robot as its type's
   URDF model (:mod:`.fleet_log`);
4. one subscriber on ``bimbot/<site>/**``, the liveliness of ``bimbot/<site>/alive/**`` (joins and
   leaves go to the text log) and its own token ``alive/observer/main``; then one query of every
   component's twin (``components/*/twin``), so an observer started mid-run knows what happened before
   (a transition seen both live and in a twin's history is applied once). Callbacks only enqueue
   (:class:`bimbot.shared.bus.RawSample`, validated twin answers, liveliness changes); the loop routes a
   key to its message model through the registry (:func:`route_key`), validates it (invalid payloads
   are logged and counted), logs it on the ``sim_time`` timeline through :class:`.twin_log.TwinLog` and
   feeds :class:`.report.ReportCollector`.

When the planner's progress says ``done``, the loop keeps collecting for ``done_grace_s`` (the robots'
return to idle comes after the last verdict), then writes ``report.json`` and ``report.png``; with
``exit_when_done`` it then stops, else it keeps serving the viewer until ``stop`` is set (SIGTERM/SIGINT).
On stop the report is written again if anything arrived since, held-back poses are logged, the web
viewer process is ended, and the recording is flushed, closed (the ``.rrd`` footer is written) and
compacted (``rerun rrd optimize``: rows of an entity merged into fewer chunks) unless ``compact`` is off.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import subprocess
import threading
import time
import urllib.parse
import uuid
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from datetime import timedelta
from pathlib import Path

import rerun as rr
import zenoh
from pydantic import BaseModel

from bimbot.shared.asked import Asked
from bimbot.shared.bus import (
    Answer,
    BusOptions,
    Inbox,
    InvalidPayloads,
    LivelinessChange,
    RawSample,
    decode,
    open_session,
)
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    COMPONENT_EVENT,
    COMPONENT_TWIN,
    PHYSICS_INFO,
    PLANNER_PLAN,
    ROBOT_CMD_VEL,
    ComponentState,
    ComponentStateMsg,
    PlannedSequenceMsg,
    ProgressMsg,
    SiteInfoMsg,
    TwinMsg,
    key,
    site_root,
    topic_of,
)
from bimbot.shared.report.collector import ReportCollector, twin_messages
from bimbot.shared.report.png import write_report_files
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.service_runner import BuildInput
from bimbot.shared.site_plan import SiteLayout

from . import VIEWER_GRPC_PORT, VIEWER_WEB_PORT
from .blueprint import cranes_of, observer_blueprint, series_items, site_items
from .twin_items import TIMELINE, LogItem
from .twin_log import TwinLog, TwinLogOptions

_log = logging.getLogger(__name__)

LOOP_WAIT_S = 0.05
# Rows logged within one tick share a chunk per entity (each chunk carries ~2 KB of schema): longer ticks
# give a smaller .rrd and a later viewer. Measured on the bundled build: 8 ms (rerun's default) 663 KiB,
# 0.5 s 600 KiB, 2 s 463 KiB; compacting at the end (``rerun rrd optimize``) 792 → 461 KiB in 54 ms.
FLUSH_TICK_S = 0.25
TWIN_QUERY_TIMEOUT_S = 5.0
# robots' commands and the events sent to agents: nothing the twin or the report shows
NOT_READ = frozenset({ROBOT_CMD_VEL.template, COMPONENT_EVENT.template})


@dataclass(frozen=True)
class ObserverConfig:
    rrd_path: Path
    report_dir: Path | None  # None: no report (bimbot run writes its own)
    web: bool = True
    web_port: int = VIEWER_WEB_PORT
    grpc_port: int = VIEWER_GRPC_PORT
    bind: str = "127.0.0.1"
    exit_when_done: bool = False
    compact: bool = True  # rewrite the .rrd with rerun's chunk compaction when the run ends
    done_grace_s: float = 1.0  # wall seconds of collecting after the planner says done
    twin: TwinLogOptions = field(default_factory=TwinLogOptions)
    run: RunFolder | None = None  # the run folder it writes to: marked ended when it reports the end


def route_key(site: str, key_expr: str) -> type[BaseModel] | None:
    """The message model the registry names for ``key_expr``, or None for keys the observer does not
    read."""
    topic = topic_of(site, key_expr)
    return topic.model if topic is not None and topic.template not in NOT_READ else None


def load_mesh(build_dir: Path, component: Component) -> tuple[bytes, str] | None:
    """The component's visual mesh file as (contents, media type): the GLB, else the OBJ; None if neither."""
    for name, media_type in (
        (component.files.visual_glb, "model/gltf-binary"),
        (component.files.visual_obj, "model/obj"),
    ):
        path = build_dir / name
        if name and path.is_file():
            return path.read_bytes(), media_type
    _log.warning("component %s has no visual mesh file; it is not drawn", component.guid)
    return None


def check_port_free(bind: str, port: int, what: str) -> None:
    """A UserError naming the option when ``bind:port`` is taken (before anything is started)."""
    with socket.socket(socket.AF_INET6 if ":" in bind else socket.AF_INET) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((bind, port))
        except OSError as error:
            raise UserError(f"{what}: cannot listen on {bind}:{port} ({error.strerror})") from error


def rerun_cli_binary() -> Path:
    """The ``rerun`` executable shipped in the rerun-sdk wheel (started directly, not through its Python
    launcher, so that terminating it ends the server and not just a wrapper)."""
    import rerun_cli

    override = os.environ.get("RERUN_CLI_PATH")
    return Path(override) if override else Path(rerun_cli.__file__).parent / "rerun"


@contextlib.contextmanager
def web_viewer(bind: str, web_port: int, grpc_url: str) -> Iterator[str]:
    """Serve the web viewer (the wheel's ``rerun`` CLI) on ``bind:web_port``; yields the page's URL."""
    command = [str(rerun_cli_binary()), "--serve-web", "--bind", bind]
    command += ["--web-viewer-port", str(web_port), grpc_url]
    env = {**os.environ, "RUST_LOG": os.environ.get("RUST_LOG", "warn")}  # its INFO lines are noise here
    process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, env=env)
    try:
        if not _wait_for_port(bind, web_port, process, timeout_s=20.0):
            raise UserError(f"the rerun web viewer did not start on {bind}:{web_port}")
        yield f"http://{bind}:{web_port}/?url={urllib.parse.quote(grpc_url, safe='')}"
    finally:
        process.terminate()
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=5)


def _wait_for_port(host: str, port: int, process: subprocess.Popen[bytes], timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    target = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    while time.monotonic() < deadline and process.poll() is None:
        with contextlib.suppress(OSError), socket.create_connection((target, port), timeout=0.2):
            return True
        time.sleep(0.05)
    return False


def write_reports(collector: ReportCollector, report_dir: Path) -> dict:
    """``report.json`` and ``report.png`` in ``report_dir``; the report."""
    report = collector.report()
    write_report_files(report, report_dir)
    totals = report["totals"]
    _log.info(
        "report written to %s: %d/%d constructed, %d retries, makespan %s s",
        report_dir,
        totals["constructed"],
        totals["components"],
        totals["retries"],
        f"{totals['makespan_s']:.1f}" if totals["makespan_s"] is not None else "-",
    )
    return report


class Observer:
    """The loop's state: the twin logger, the report collector and the recording they write to."""

    def __init__(
        self, manifest: Manifest, build_dir: Path, config: ObserverConfig, recording: rr.RecordingStream
    ):
        self.manifest = manifest
        self.site = manifest.site
        self.config = config
        self.recording = recording
        self.twin = TwinLog(manifest, config.twin)
        self.collector = ReportCollector(manifest)  # its planned order: the planner's, once it answered
        self.layout: SiteLayout | None = None  # the site physics planned, once it answered
        self.invalid = InvalidPayloads()
        self.sim_time_s = 0.0
        self.done_at: float | None = None  # monotonic wall time the planner first said done
        self.reported_at_messages = -1
        self._transitions: set[tuple[str, ComponentState | None, ComponentState, float]] = set()
        self._state_time_s: dict[str, float] = {}  # latest sim time a component's state was logged at
        meshes, initial = self.twin.scene(lambda component: load_mesh(build_dir, component))
        self._log_items(series_items() + meshes)
        self._log_items(initial, at_s=0.0)

    def site_known(self, info: SiteInfoMsg) -> None:
        """Physics answered with its site info: draw its site (staging areas included), every component at
        its yard slot and every robot as its type's model."""
        if self.layout is None:
            self.layout = info.layout
            self._log_items(site_items(info.layout, self.manifest.components, cranes_of(info)))
            self._log_items(self.twin.yard_poses(info.layout), at_s=0.0)
            static, initial, now = self.twin.robots(info, self.sim_time_s)
            self._log_items(static)
            self._log_items(initial, at_s=0.0)
            self._log_items(now, at_s=self.sim_time_s)
            self.collector.add(info)  # the report's lanes and utilisation go by robot type

    def plan_known(self, plan: PlannedSequenceMsg) -> None:
        """The planner answered with its plan: the report's planned order is the one it builds by."""
        if not self.collector.sequence_guids:
            self.collector.sequence_guids = list(plan.order)

    def handle(self, key_expr: str, payload: bytes) -> None:
        model = route_key(self.site, key_expr)
        message = decode(model, key_expr, payload, self.invalid) if model is not None else None
        if message is not None:
            self.apply(message)

    def twin_reply(self, key_expr: str, payload: bytes) -> None:
        """A component's twin as it came over the bus (see :meth:`apply_twin`)."""
        twin = decode(TwinMsg, key_expr, payload, self.invalid)
        if twin is not None:
            self.apply_twin(twin)

    def apply_twin(self, twin: TwinMsg) -> None:
        """A component's twin (asked once at start): its history for an observer that joined late."""
        for message in twin_messages(twin):
            self.apply(message)

    def apply(self, message: BaseModel) -> None:
        if isinstance(message, ComponentStateMsg):  # seen live and in a twin's history: once
            transition = (message.guid, message.previous, message.state, message.sim_time_s)
            if transition in self._transitions:
                return
            self._transitions.add(transition)
        sim_time_s = getattr(message, "sim_time_s", None)
        if isinstance(sim_time_s, float):
            self.sim_time_s = max(self.sim_time_s, sim_time_s)
        if isinstance(message, ComponentStateMsg):
            # Agents stamp a verdict from their own view of the clock, which may lag the robot's stamp of
            # the state before it; a component's colour must still end on its latest state.
            sim_time_s = max(message.sim_time_s, self._state_time_s.get(message.guid, 0.0))
            self._state_time_s[message.guid] = sim_time_s
        self.collector.add(message)
        self._log_items(self.twin.items(message), at_s=sim_time_s)
        if isinstance(message, ProgressMsg) and message.done and self.done_at is None:
            self.done_at = time.monotonic()
            _log.info(
                "the planner says the construction is done (%.0f %% constructed)", message.percent_constructed
            )

    def alive(self, key_expr: str, alive: bool) -> None:
        what = key_expr.removeprefix(f"{site_root(self.site)}/alive/")
        self._log_items(self.twin.site_event(f"{what} {'joined' if alive else 'left'}"), at_s=self.sim_time_s)
        if what == "planner/main" and not alive and self.done_at is None:
            # the planner ends when the build is settled; its last progress may have gone out before
            # this observer listened (a build that was done at once): its leaving ends the wait too
            self.done_at = time.monotonic()
            _log.info("the planner left the bus: the build is over")

    def finish(self) -> None:
        for at_s, item in self.twin.flush():
            self._log_items([item], at_s=at_s)

    def write_reports_if_new(self) -> None:
        if self.config.report_dir is not None and self.collector.messages != self.reported_at_messages:
            write_reports(self.collector, self.config.report_dir)
            self.reported_at_messages = self.collector.messages

    def _log_items(self, items: list[LogItem], at_s: float | None = None) -> None:
        if at_s is not None and any(not item.static for item in items):
            self.recording.set_time(TIMELINE, duration=at_s)
        for item in items:
            self.recording.log(item.entity_path, item.archetype, static=item.static)


def open_recording(
    site: str, config: ObserverConfig, components: Sequence[Component] = ()
) -> tuple[rr.RecordingStream, str | None]:
    """The recording with its sinks: the ``.rrd`` file and (web on) a gRPC server; the server's URL."""
    batching = rr.ChunkBatcherConfig(flush_tick=timedelta(seconds=FLUSH_TICK_S))
    recording = rr.RecordingStream(
        "bimbot", recording_id=f"{site}-{uuid.uuid4().hex[:12]}", batcher_config=batching
    )
    recording.set_log_tick_enabled(False)  # sim_time (and wall log_time) are enough; smaller .rrd
    config.rrd_path.parent.mkdir(parents=True, exist_ok=True)
    sinks: list[rr.FileSink | rr.GrpcServerSink] = [rr.FileSink(config.rrd_path)]
    url = None
    if config.web:
        server = rr.GrpcServerSink(bind_ip=config.bind, port=config.grpc_port)
        sinks.append(server)
        url = server.uri
    recording.set_sinks(*sinks, default_blueprint=observer_blueprint(site, components))
    recording.send_recording_name(f"bimbot {site}")
    return recording, url


def main(options: BusOptions, build: BuildInput, config: ObserverConfig, stop: threading.Event) -> int:
    """Observe the site until ``stop`` (or done, with ``exit_when_done``); 0 on a clean stop."""
    if config.web:
        check_port_free(config.bind, config.web_port, "--web-port")
        check_port_free(config.bind, config.grpc_port, "--grpc-port")
    recording, grpc_url = open_recording(build.manifest.site, config, build.manifest.components)
    with contextlib.ExitStack() as stack:
        stack.callback(_close_recording, recording, config.rrd_path, config.compact)
        if grpc_url is not None:
            page = stack.enter_context(web_viewer(config.bind, config.web_port, grpc_url))
            _log.info("web viewer: %s (gRPC %s)", page, grpc_url)
        observer = Observer(build.manifest, build.dir, config, recording)
        if config.report_dir is None:
            _log.info(
                "recording to %s; no report of its own (the run writes the run's report)", config.rrd_path
            )
        else:
            _log.info("recording to %s; reports to %s", config.rrd_path, config.report_dir)
        with open_session(options) as session:
            try:
                serve(session, observer, stop)
            finally:
                observer.finish()
                observer.write_reports_if_new()
    return 0


def serve(session: zenoh.Session, observer: Observer, stop: threading.Event) -> None:
    """Subscribe and run the loop until ``stop`` is set, or done with ``exit_when_done``."""
    root = site_root(observer.site)
    inbox = Inbox(observer.invalid)
    declarations = [
        inbox.subscribe_raw(session, f"{root}/**"),
        inbox.subscribe_liveliness(session, f"{root}/alive/**"),
        session.liveliness().declare_token(key(ALIVE_KEY, site=observer.site, kind="observer", id="main")),
    ]
    inbox.ask(session, COMPONENT_TWIN, timeout_s=TWIN_QUERY_TIMEOUT_S, site=observer.site, key="*")
    # facts other services own, asked until they answer (they may start after the observer)
    site_info = Asked(session, PHYSICS_INFO, observer.invalid, site=observer.site)
    plan = Asked(session, PLANNER_PLAN, observer.invalid, site=observer.site)
    _log.info("observing %s/** on the bus", root)
    config = observer.config
    reported = False
    while not stop.is_set():
        if observer.layout is None and (info := site_info.poll()) is not None:
            observer.site_known(info)
        if not observer.collector.sequence_guids and (planned := plan.poll()) is not None:
            observer.plan_known(planned)
        for item in inbox.drain(first_timeout_s=LOOP_WAIT_S):
            try:
                match item:
                    case RawSample():
                        observer.handle(item.key, item.payload)
                    case Answer(message=TwinMsg() as twin):
                        observer.apply_twin(twin)
                    case LivelinessChange():
                        observer.alive(item.key, item.alive)
            except Exception:
                _log.exception("handling %s failed; going on", type(item).__name__)
        if (
            observer.done_at is not None
            and not reported
            and time.monotonic() - observer.done_at >= config.done_grace_s
        ):
            observer.write_reports_if_new()
            reported = True
            if config.report_dir is not None and config.run is not None:
                config.run.mark_ended("done: the planner ended (seen by bimbot observe)")
            if config.exit_when_done:
                break
    if observer.invalid.total:
        _log.info("%d invalid payloads were received and ignored", observer.invalid.total)
    del declarations


def _close_recording(recording: rr.RecordingStream, rrd_path: Path, compact: bool) -> None:
    recording.flush()
    recording.disconnect()  # drops the sinks: the .rrd footer is written, the gRPC server stops
    if compact:
        compact_rrd(rrd_path)
    size = rrd_path.stat().st_size if rrd_path.exists() else 0
    _log.info("recording saved: %s (%.1f KiB)", rrd_path, size / 1024)


def compact_rrd(rrd_path: Path, timeout_s: float = 300.0) -> bool:
    """Merge the recording's small chunks (``rerun rrd optimize``), in place; False (and the file left
    as it was) when that fails."""
    compacted = rrd_path.with_name(f".{rrd_path.name}.compacted")
    command = [str(rerun_cli_binary()), "rrd", "optimize", str(rrd_path), "-o", str(compacted)]
    env = {**os.environ, "RUST_LOG": "warn"}
    try:
        result = subprocess.run(
            command, capture_output=True, text=True, timeout=timeout_s, env=env, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as error:
        _log.warning("could not compact %s (%s); kept as recorded", rrd_path, error)
        compacted.unlink(missing_ok=True)
        return False
    if result.returncode != 0 or not compacted.is_file():
        _log.warning("could not compact %s: %s", rrd_path, result.stderr.strip()[-500:])
        compacted.unlink(missing_ok=True)
        return False
    compacted.replace(rrd_path)
    return True
