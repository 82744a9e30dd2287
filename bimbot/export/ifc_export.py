"""The 4D IFC of a run: the source model with the simulated construction written into it.

The source model (``manifest.source.path``) is opened, brought to IFC4 when it is IFC2X3 (IfcTaskTime and
the 4D relationships 4D tools read are IFC4's; :mod:`.ifc_upgrade`), and gets the
simulated schedule (:mod:`.ifc_tasks`), the as-built property sets and the precast panels
(:mod:`.ifc_as_built`). :func:`validate_ifc` checks a written file with ``ifcopenshell.validate``.
"""

from __future__ import annotations

import datetime as dt
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.validate

from bimbot.export.ifc_as_built import add_as_built_pset, add_panels
from bimbot.export.ifc_tasks import add_simulated_schedule
from bimbot.export.ifc_upgrade import upgrade_to_ifc4
from bimbot.export.sim_schedule import SimSchedule
from bimbot.export.work_time import WorkWeek, site_time
from bimbot.shared.errors import UserError
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest

_log = logging.getLogger(__name__)

EXPORT_SCHEMA = "IFC4"


@dataclass(frozen=True)
class IfcExport:
    path: Path
    tasks: int  # every IfcTask written (component tasks, their steps, panelised elements)
    timed_tasks: int
    component_tasks: int
    resources: int
    size_bytes: int
    seconds: float
    migrated_from: str | None  # the source schema when it was brought to IFC4


def source_ifc(manifest: Manifest, build_dir: Path) -> Path:
    """The IFC the build was converted from: as recorded, else relative to the build or its parent."""
    recorded = Path(manifest.source.path)
    for candidate in (recorded, build_dir / recorded, build_dir.parent / recorded):
        if candidate.is_file():
            return candidate
    raise UserError(f"the build's source IFC {recorded} is not found (name it: --source FILE.ifc)")


def open_as_ifc4(path: Path) -> tuple[ifcopenshell.file, str | None]:
    """The model at ``path`` in IFC4 (migrated when it is IFC2X3); (model, the schema it came from)."""
    model = open_model(path)
    if model.schema == EXPORT_SCHEMA:
        return model, None
    if model.schema != "IFC2X3":
        raise UserError(f"{path}: schema {model.schema}: the export writes IFC4 from IFC4 or IFC2X3 models")
    migrated, dropped = upgrade_to_ifc4(model)
    _log.info("%s: IFC2X3 → IFC4, %d attribute value(s) with no IFC4 equivalent dropped", path, dropped)
    return migrated, model.schema


def export_ifc(
    manifest: Manifest,
    build_dir: Path,
    schedule: SimSchedule,
    out: Path,
    start: dt.datetime,
    *,
    week: WorkWeek | None = None,
    source: Path | None = None,
) -> IfcExport:
    """Write the 4D IFC of ``schedule`` to ``out`` (see the module docstring)."""
    began = time.perf_counter()
    model, migrated_from = open_as_ifc4(source or source_ifc(manifest, build_dir))
    panels = add_panels(model, manifest, build_dir)
    products = {}
    for guid in [*(work.guid for work in schedule.components), *(item.guid for item in manifest.panelised)]:
        product = panels.get(guid) or _product(model, guid)
        if product is not None:
            products[guid] = product
    missing = [work.guid for work in schedule.components if work.guid not in products]
    if missing:
        _log.warning("%d component(s) are not in the source model: tasks without products", len(missing))
    written = add_simulated_schedule(
        model,
        schedule,
        lambda sim_s: site_time(start, sim_s, week),
        week=week,
        products=products,
        element_names={item.guid: item.name or item.ifc_class for item in manifest.panelised},
    )
    for work in schedule.components:
        if work.guid in products:
            add_as_built_pset(model, products[work.guid], work)
    out.parent.mkdir(parents=True, exist_ok=True)
    model.write(str(out))
    return IfcExport(
        path=out,
        tasks=len(written.all_tasks),
        timed_tasks=written.timed_tasks,
        component_tasks=len(written.tasks),
        resources=len(written.resources),
        size_bytes=out.stat().st_size,
        seconds=time.perf_counter() - began,
        migrated_from=migrated_from,
    )


def _product(model: ifcopenshell.file, guid: str) -> ifcopenshell.entity_instance | None:
    try:
        return model.by_guid(guid)
    except RuntimeError:
        return None


def validate_ifc(path: Path) -> list[str]:
    """``ifcopenshell.validate`` of the file at ``path``: its error messages (empty: valid)."""
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(ifcopenshell.open(str(path)), logger)
    return [str(statement.get("message", statement)) for statement in logger.statements]
