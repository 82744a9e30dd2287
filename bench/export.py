"""Benchmark of ``bimbot export --ifc``: exporting a model's 4D IFC against converting it, in the same run.

Run: ``.venv/bin/python bench/export.py`` (``--model FILE.ifc``, ``--repeat N``; default the Revit sample
house beside the checkout, ``../shared/samples/ifc/revit2021_sample_project.ifc``).

1. conversion: ``bimbot convert``'s work (open the IFC, :func:`convert_model` into a build folder);
2. a finished run on that build, written as a run writes it (the agents' journal records and the
   observer's report): every component picked, carried, placed and constructed in the build's order;
3. export: ``bimbot export --ifc``'s work (read the run, open the source, IFC2X3 → IFC4 when needed, the
   simulated schedule, resources and as-built property sets, write the file).

Each is timed ``--repeat`` times, alternated, and the medians compared: the export should take at most
half the conversion (target ratio ≤ 0.5). The written file's size, task counts and ``ifcopenshell.validate``
result (not timed) are printed too.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import logging
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from bimbot.export.ifc_export import IfcExport, export_ifc, validate_ifc
from bimbot.export.run_data import load_run
from bimbot.services.component_agents.journal import JournalRecord
from bimbot.services.converter.convert import convert_model
from bimbot.shared.ifc_input import read_model
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg
from bimbot.shared.report.collector import ReportCollector, RunEnding
from bimbot.shared.sequence import read_sequence

HOUSE = Path(__file__).resolve().parents[2] / "shared" / "samples" / "ifc" / "revit2021_sample_project.ifc"
TARGET_RATIO = 0.5
STATES = (ComponentState.PICKING, ComponentState.TRANSPORTING, ComponentState.ASSEMBLING)
STATES += (ComponentState.VERIFYING, ComponentState.CONSTRUCTED)


def convert(model_path: Path, out: Path) -> tuple[float, Manifest]:
    began = time.perf_counter()
    read = read_model(model_path)
    manifest = convert_model(read.model, model_path, out, damage=read.damage)
    return time.perf_counter() - began, manifest


def write_run(build: Path, manifest: Manifest) -> None:
    """``build/runs/20270301-070000/``: each component built in turn, 30 sim seconds each, by r1 or r2."""
    order = read_sequence(build / manifest.sequence_file).guids()
    run = build / "runs" / "20270301-070000"
    (run / "state").mkdir(parents=True)
    (run / "report").mkdir()
    collector = ReportCollector(manifest, order)
    with (run / "state" / "agents-1of1.jsonl").open("w", encoding="utf-8") as journal:
        for index, guid in enumerate(order):
            previous, robot = ComponentState.RELEASED, ("r1", "r2")[index % 2]
            for step, state in enumerate(STATES):
                change = ComponentStateMsg(
                    guid=guid,
                    state=state,
                    previous=previous,
                    event="bench",
                    attempt=1,
                    robot_id=robot,
                    sim_time_s=30.0 * index + 6.0 * step,
                    wall_time_s=0.0,
                )
                journal.write(JournalRecord.from_message(change, None, None).model_dump_json() + "\n")
                collector.add(change)
                previous = state
    report = collector.report(RunEnding("done", None, "bench"))
    (run / "report" / "report.json").write_text(json.dumps(report), encoding="utf-8")


def export(build: Path, out: Path) -> tuple[float, IfcExport]:
    began = time.perf_counter()
    data = load_run(build / "runs" / "20270301-070000")
    result = export_ifc(data.manifest, build, data.schedule(), out, dt.datetime(2027, 3, 1, 7, 0))
    return time.perf_counter() - began, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=HOUSE)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    logging.basicConfig(level=logging.ERROR)
    if not args.model.is_file():
        raise SystemExit(
            f"{args.model}: no such model (the samples sit beside the checkout, or give --model)"
        )
    print(f"bench/export.py: {args.model.name}, {args.repeat} rounds, {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory(prefix="bimbot-bench-export-") as tmp:
        converts, exports = [], []
        result: IfcExport | None = None
        for index in range(args.repeat):
            build = Path(tmp) / f"build{index}"
            seconds, manifest = convert(args.model, build)
            converts.append(seconds)
            if index == 0:
                write_run(build, manifest)
                exported = Path(tmp) / "export"
                exported.mkdir()
            else:
                shutil.rmtree(build)
            seconds, result = export(Path(tmp) / "build0", exported / f"model-4d-{index}.ifc")
            exports.append(seconds)
        assert result is not None
        convert_s, export_s = statistics.median(converts), statistics.median(exports)
        print(f"conversion: median {convert_s:.2f} s ({', '.join(f'{s:.2f}' for s in converts)})")
        print(f"export --ifc: median {export_s:.2f} s ({', '.join(f'{s:.2f}' for s in exports)})")
        ratio = export_s / convert_s
        verdict = "ok" if ratio <= TARGET_RATIO else "over the target"
        print(f"ratio export / conversion: {ratio:.2f} (target ≤ {TARGET_RATIO}: {verdict})")
        print(
            f"file: {result.size_bytes / 1e6:.2f} MB, {result.tasks} tasks ({result.timed_tasks} timed, "
            f"{result.component_tasks} components), {result.resources} resources"
        )
        began = time.perf_counter()
        errors = validate_ifc(result.path)
        print(
            f"ifcopenshell.validate: {len(errors)} error(s) ({time.perf_counter() - began:.1f} s, not timed)"
        )


if __name__ == "__main__":
    main()
