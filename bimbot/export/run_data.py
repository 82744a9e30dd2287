"""Read one finished run for the exporters: its build's manifest, report, journal and plan.

``bimbot export`` takes a build folder (its latest run) or a run folder (``BUILD/runs/<time>/``; a run kept
elsewhere names its build with ``--build``). The plan is the planner's, rebuilt from the source the run's
settings name (the build's ``sequence.xml``, ``--derive`` or a ``--sequence`` file), so the exported
precedences are the ones the planner released tasks over.
"""

from __future__ import annotations

import datetime as dt
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bimbot.export.sim_schedule import PlanView, SimSchedule, sim_schedule
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import MANIFEST_FILE_NAME, Manifest, load_manifest
from bimbot.shared.run_folder import RunFolder, latest_run_folder

_log = logging.getLogger(__name__)

RUN_NAME_FORMAT = "%Y%m%d-%H%M%S"  # bimbot.shared.run_folder names runs by their start time


@dataclass(frozen=True)
class RunData:
    run: RunFolder
    build_dir: Path
    manifest: Manifest
    report: dict[str, Any]
    journal: dict[str, list[tuple[str, float]]]  # GUID → (state entered, sim s), in order
    plan: PlanView
    started: dt.datetime  # the run's start (local time)

    def schedule(self) -> SimSchedule:
        return sim_schedule(self.manifest, self.report, self.journal, self.plan)

    @property
    def recording(self) -> Path | None:
        path = self.run.recording_path(self.manifest.site)
        return path if path.is_file() else None


def resolve_run(path: Path, build: Path | None = None) -> tuple[RunFolder, Path]:
    """(run folder, build folder) for ``path``: a build (its latest run) or a run folder."""
    path = Path(path)
    if not path.exists():
        raise UserError(f"{path}: no such build or run folder")
    if (path / MANIFEST_FILE_NAME).is_file():
        latest = latest_run_folder(path)
        if latest is None:
            raise UserError(f"{path}: the build has no run yet (bimbot run {path})")
        return latest, path
    run = RunFolder(path)
    if not (run.report_dir / "report.json").is_file():
        raise UserError(f"{path}: neither a build (no {MANIFEST_FILE_NAME}) nor a run folder (no report)")
    build = build if build is not None else path.resolve().parent.parent
    if not (build / MANIFEST_FILE_NAME).is_file():
        raise UserError(f"{path}: the run's build is not {build} (name it: --build BUILD)")
    return run, build


def load_run(path: Path, build: Path | None = None) -> RunData:
    """Everything the exporters read of one run (:class:`UserError` naming what is missing)."""
    run, build_dir = resolve_run(path, build)
    manifest = load_manifest(build_dir)
    report_path = run.report_dir / "report.json"
    if not report_path.is_file():
        raise UserError(f"{run.root}: the run has no report yet (still running, or it ended without one)")
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as error:
        raise UserError(f"{report_path}: unreadable report ({error})") from None
    return RunData(
        run=run,
        build_dir=build_dir,
        manifest=manifest,
        report=report,
        journal=read_journal(run.state_dir),
        plan=run_plan(manifest, build_dir, report),
        started=run_start(run),
    )


def read_journal(state_dir: Path) -> dict[str, list[tuple[str, float]]]:
    """Every agent shard's journal merged: GUID → state entries in sim-time order."""
    from bimbot.services.component_agents.journal import replay

    entries: dict[str, list[tuple[str, float]]] = {}
    for path in sorted(Path(state_dir).glob("agents-*.jsonl")):
        for guid, records in replay(path).records.items():
            entries.setdefault(guid, []).extend(
                (str(record.change.state), record.change.sim_time_s) for record in records
            )
    return {guid: _sorted(states) for guid, states in entries.items()}


def _sorted(states: list[tuple[str, float]]) -> list[tuple[str, float]]:
    return sorted(states, key=lambda item: item[1])  # stable: equal times keep the journal's order


def run_plan(manifest: Manifest, build_dir: Path, report: dict[str, Any]) -> PlanView:
    """The plan the run's planner used, from the sequence its settings name."""
    from bimbot.services.planner.sources import PlanError, PlanSource, SourceKind, load_plan

    said = str((report.get("settings") or {}).get("sequence") or "")
    source = PlanSource()
    if "--derive" in said:
        source = PlanSource(SourceKind.DERIVE)
    elif said.startswith("the IFC schedule of "):
        named = said.removeprefix("the IFC schedule of ")
        source = PlanSource(SourceKind.IFC, None if named == "the build model" else Path(named))
    elif said and said != "the build's sequence.xml":
        source = PlanSource(SourceKind.SEQUENCE, Path(said))
    try:
        plan = load_plan(manifest, build_dir, source)
    except PlanError as error:
        _log.warning("the run's sequence (%s) cannot be read again (%s): the build's is used", said, error)
        plan = load_plan(manifest, build_dir, PlanSource())
    return PlanView(plan.order, plan.predecessors, plan.task_ids, plan.names)


def run_start(run: RunFolder) -> dt.datetime:
    """When the run started: its folder's name, else the time its folder was made."""
    try:
        return dt.datetime.strptime(run.root.resolve().name, RUN_NAME_FORMAT)
    except ValueError:
        return dt.datetime.fromtimestamp(run.root.stat().st_mtime).replace(microsecond=0)
