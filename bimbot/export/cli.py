"""``bimbot export BUILD|RUN --ifc OUT.ifc --msp OUT.xml --p6 OUT.xml --usd OUT.usda``: a run's simulated
construction for the tools builders work in (a 4D IFC, MS Project and P6 schedules, a USD stage), and one
component as URDF or SDF (``--component GUID --urdf OUT.urdf | --sdf OUT_DIR``).

Dates: the project starts at ``--start`` (default: when the run started) and each task at that date plus
its sim time, counted in the working time of ``--calendar`` when one is given.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from bimbot.shared.errors import UserError

_log = logging.getLogger(__name__)

USD_SUFFIXES = (".usda", ".usdc", ".usd")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "run", type=Path, metavar="BUILD|RUN", help="a build (its latest run) or a run folder"
    )
    parser.add_argument(
        "--build", type=Path, default=None, help="the run's build, when the run is kept elsewhere"
    )
    parser.add_argument(
        "--ifc", type=Path, metavar="OUT.ifc", help="the source model with the simulated 4D schedule"
    )
    parser.add_argument(
        "--msp", type=Path, metavar="OUT.xml", help="the simulated schedule as MS Project XML"
    )
    parser.add_argument(
        "--p6", type=Path, metavar="OUT.xml", help="the simulated schedule as Primavera P6 XML"
    )
    parser.add_argument(
        "--usd", type=Path, metavar="OUT.usda", help="the run as a USD stage (.usda or .usdc)"
    )
    parser.add_argument("--component", metavar="GUID", help="the component --urdf and --sdf export")
    parser.add_argument(
        "--urdf", type=Path, metavar="OUT.urdf", help="one component as a URDF (meshes beside it)"
    )
    parser.add_argument(
        "--sdf", type=Path, metavar="OUT_DIR", help="one component's SDF model folder, copied"
    )
    parser.add_argument(
        "--start", metavar="DATETIME", help="project start, e.g. 2027-03-01T07:00 (default: the run's)"
    )
    parser.add_argument(
        "--calendar",
        metavar="WEEK",
        help="the site's working week, e.g. 'Mon-Fri 07:00-12:00 13:00-17:00': sim time counts working time "
        "(default: elapsed time)",
    )
    parser.add_argument(
        "--source", type=Path, metavar="FILE.ifc", help="the source IFC (default: the build's)"
    )
    parser.add_argument(
        "--validate", action="store_true", help="validate the written IFC (ifcopenshell.validate)"
    )


def run(args: argparse.Namespace) -> int:
    from bimbot.export.run_data import load_run
    from bimbot.export.work_time import parse_start, parse_work_week

    outputs = [args.ifc, args.msp, args.p6, args.usd, args.urdf, args.sdf]
    if not any(outputs):
        raise UserError("name at least one output: --ifc, --msp, --p6, --usd, --urdf or --sdf")
    if args.usd is not None and args.usd.suffix not in USD_SUFFIXES:
        raise UserError(f"--usd {args.usd}: the file name must end in .usda, .usdc or .usd")
    week = parse_work_week(args.calendar) if args.calendar else None
    start = parse_start(args.start) if args.start else None
    data = load_run(args.run, args.build)
    start = start or data.started
    schedule = data.schedule()
    say = _say
    say(
        f"export: run {data.run.root} of {data.build_dir}: {len(schedule.components)} component task(s), "
        f"{sum(work.timed for work in schedule.components)} timed, from {start:%Y-%m-%d %H:%M}"
        + (f" in working time ({week.text})" if week else "")
    )
    if args.ifc is not None:
        from bimbot.export.ifc_export import export_ifc, validate_ifc

        result = export_ifc(
            data.manifest, data.build_dir, schedule, args.ifc, start, week=week, source=args.source
        )
        say(
            f"ifc: {result.path} ({result.size_bytes / 1e6:.2f} MB, {result.tasks} tasks, "
            f"{result.timed_tasks} timed, {result.resources} resources"
            f"{', from IFC2X3' if result.migrated_from else ''}) in {result.seconds:.2f} s"
        )
        if args.validate:
            began = time.perf_counter()
            errors = validate_ifc(result.path)
            say(f"ifc: ifcopenshell.validate: {len(errors)} error(s) in {time.perf_counter() - began:.1f} s")
            for error in errors[:10]:
                say(f"  {error}")
            if errors:
                return 1
    if args.msp is not None or args.p6 is not None:
        from bimbot.export.planner_files import write_msp, write_p6

        for path, writer, label in ((args.msp, write_msp, "msp"), (args.p6, write_p6, "p6")):
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                say(f"{label}: {path} ({writer(schedule, path, start, week)} tasks)")
    if args.usd is not None:
        from bimbot.export.poses import run_poses
        from bimbot.export.usd_stage import write_usd

        poses = run_poses(data.manifest, schedule, data.recording)
        write_usd(data.manifest, data.build_dir, schedule, poses, args.usd)
        moving = sum(1 for samples in poses.components.values() if len(samples) > 1)
        say(f"usd: {args.usd} (poses from the {poses.source}: {moving} component(s) animated)")
    if args.urdf is not None or args.sdf is not None:
        from bimbot.export.component_model import copy_sdf_model, find_component, write_urdf

        component = find_component(data.manifest, args.component)
        if args.urdf is not None:
            say(f"urdf: {write_urdf(component, data.build_dir, args.urdf)}")
        if args.sdf is not None:
            say(f"sdf: {copy_sdf_model(component, data.build_dir, args.sdf)}")
    return 0


def _say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()
