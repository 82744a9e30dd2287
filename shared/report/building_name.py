"""How a report names the building it built: its site and its model file.

Why: Revit names every ``IfcSite`` "Default", so a trial user read ``default`` (in ``bimbot compare``'s
building row and in report.png's title) as the building's name. A site of no name of its own is left out
and the model file names the building.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

UNNAMED_SITES = frozenset({"default", "site"})  # Revit's site name, and the converter's slug for none


def building_name(site: str | None, model: str | None) -> str:
    """``greenhouse-site (light_steel_frame.ifc)``; the model alone where the site has no name of its own;
    ``unknown`` when neither is known."""
    if site is None or (model and site in UNNAMED_SITES):
        return model or "unknown"
    return f"{site} ({model})" if model else site


def model_file(report: Mapping[str, Any]) -> str | None:
    """The file name of the model a report's run built (its settings), or None."""
    path = ((report.get("settings") or {}).get("model") or {}).get("path")
    return PurePath(path).name if isinstance(path, str) else None


def report_building(report: Mapping[str, Any]) -> str:
    """:func:`building_name` of a report."""
    return building_name(report.get("site"), model_file(report))
