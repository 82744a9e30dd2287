"""``bimbot observe --build OUT/``: log the live twin to rerun (web viewer + ``.rrd``) and write the report.

Defaults: the recording goes to the run folder's ``observer/<site>.rrd`` and the report to its ``report/``
(``--run-dir``, default ``OUT/runs/latest``; see :mod:`bimbot.shared.run_folder`); the web viewer is served
on ``http://127.0.0.1:9090`` and its data on gRPC ``127.0.0.1:9876``. The report's planned order is the
planner's (asked on ``planner/plan``), not a file. Another address is
used only when given with ``--bind``. Runs until SIGTERM/SIGINT (reports written, recording closed, exit 0);
with ``--exit-when-done`` it returns once the planner reports the construction done.
"""

from __future__ import annotations

import argparse
import logging
import os
from dataclasses import replace
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.run_folder import open_run_folder
from bimbot.shared.service_runner import resolve_build, run_service, service_bus, writable_dir

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The observer options; every default (and the default named in a help text) is its config's field."""
    from .app import ObserverConfig  # rerun is imported only by the command that needs it
    from .twin_log import TwinLogOptions

    defaults, config = TwinLogOptions(), ObserverConfig  # the class: rrd_path and report_dir have no default
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT/", help="converted build (folder or manifest.json)"
    )
    parser.add_argument("--site", default=None, help="site slug (default: the manifest's; env BIMBOT_SITE)")
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="the run's folder (default OUT/runs/latest, made when missing): the recording goes to "
        "DIR/observer/<site>.rrd, the report to DIR/report/",
    )
    parser.add_argument("--rrd", type=Path, default=None, metavar="PATH", help="the recording elsewhere")
    parser.add_argument("--report-dir", type=Path, default=None, metavar="DIR", help="the report elsewhere")
    parser.add_argument(
        "--no-report",
        action="store_true",
        help="record only; the report is written by someone else (bimbot run writes its own)",
    )
    parser.add_argument(
        "--web-port",
        type=int,
        default=config.web_port,
        help=f"web viewer HTTP port (default {config.web_port})",
    )
    parser.add_argument(
        "--grpc-port",
        type=int,
        default=config.grpc_port,
        help=f"rerun gRPC port viewers connect to (default {config.grpc_port})",
    )
    parser.add_argument(
        "--bind",
        default=config.bind,
        help=f"address of the web viewer and gRPC server (default {config.bind}: this machine only)",
    )
    parser.add_argument(
        "--no-web", action="store_true", help="no viewer, no gRPC server: only the .rrd and the report"
    )
    parser.add_argument(
        "--exit-when-done", action="store_true", help="exit once the planner reports the build done"
    )
    parser.add_argument(
        "--no-compact", action="store_true", help="keep the .rrd as recorded (default: compacted at the end)"
    )
    parser.add_argument(
        "--scan-every",
        type=int,
        default=defaults.scan_every,
        help=f"draw every N-th laser scan (default {defaults.scan_every})",
    )
    parser.add_argument(
        "--pose-interval-s",
        type=float,
        default=defaults.pose_min_interval_s,
        help=f"sim seconds between logged poses of a moving body (default {defaults.pose_min_interval_s:g})",
    )
    add_bus_arguments(parser)


def check_options(args: argparse.Namespace) -> None:
    """A UserError for an option value the observer cannot use (ports, intervals)."""
    for name in ("web_port", "grpc_port"):
        port = getattr(args, name)
        if not 0 < port < 65536:
            raise UserError(f"--{name.replace('_', '-')} {port}: not a TCP port")
    if args.scan_every < 1 or args.pose_interval_s < 0:
        raise UserError("--scan-every must be ≥ 1 and --pose-interval-s ≥ 0")


def run(args: argparse.Namespace) -> int:
    """Check the options, the build and the output folders, then observe until stopped (or done)."""
    from . import app
    from .twin_log import TwinLogOptions

    options = service_bus(args)
    check_options(args)
    build = resolve_build(args.build)
    manifest = build.manifest
    site = args.site or os.environ.get("BIMBOT_SITE") or manifest.site
    if site != manifest.site:
        manifest = manifest.model_copy(update={"site": site})
    run = open_run_folder(build.dir, args.run_dir)
    config = app.ObserverConfig(
        rrd_path=args.rrd or run.recording_path(site),
        report_dir=None if args.no_report else args.report_dir or run.report_dir,
        web=not args.no_web,
        web_port=args.web_port,
        grpc_port=args.grpc_port,
        bind=args.bind,
        exit_when_done=args.exit_when_done,
        compact=not args.no_compact,
        run=run,
        twin=TwinLogOptions(scan_every=args.scan_every, pose_min_interval_s=args.pose_interval_s),
    )
    writable_dir(config.rrd_path.parent, "--rrd")
    if config.report_dir is not None:
        writable_dir(config.report_dir, "--report-dir")
    if args.bind not in ("127.0.0.1", "::1", "localhost") and config.web:
        _log.warning("serving the viewer on %s: reachable from other machines", args.bind)
    return run_service(app.main, options, replace(build, manifest=manifest), config)
