"""What a run was asked to simulate, for its report: the physics profile with every value it resolved to.

Why: two reports of the same building differ by their settings as much as by the code (a total station on
site, another physics rate, fewer laser beams, a fleet file), and a report that does not say which
settings made it cannot be compared with another. ``report.json`` therefore carries a ``settings`` object:
the options as ``bimbot run`` resolved them, each value the profile's unless the user set it, and the
total station's precision (``null``: none on site). Pure: from :class:`~bimbot.run.options.RunOptions` only.
"""

from __future__ import annotations

import math
from typing import Any

from bimbot.run.options import RunOptions
from bimbot.services.component_agents.agent import AgentConfig
from bimbot.services.physics.profiles import PROFILES
from bimbot.shared.manifest import SourceModel

DEFAULT_FLEET = "the default fleet"  # the fleet embedded in bimbot (shared/models/default_fleet.toml)


def run_settings(options: RunOptions) -> dict[str, Any]:
    """The run's settings as JSON-ready values (see the module doc)."""
    profile = PROFILES[options.profile]

    def chosen(value: Any, default: Any) -> Any:
        return default if value is None else value

    rtf = float(chosen(options.rtf, profile.rtf))
    return {
        "profile": profile.name,
        "fidelity": options.fidelity,
        "robots": options.robots,  # null: the fleet's own robots
        "fleet": DEFAULT_FLEET if options.fleet is None else str(options.fleet),
        "off_site": list(options.off_site),  # the fleet's machines with no work in this build
        "cranes": dict(options.cranes),  # crane counts raised for the building's footprint
        "physics_hz": float(chosen(options.physics_hz, profile.physics_hz)),
        "control_period_s": float(chosen(options.control_period_s, profile.control_period_s)),
        "laser_beams": int(chosen(options.laser_beams, profile.laser_beams)),
        "lock_step": bool(chosen(options.lock_step, profile.lock_step)),
        "command_latency_steps": int(chosen(options.command_latency_steps, profile.command_latency_steps)),
        "real_time_factor": rtf,
        "pace": "as fast as it can" if rtf == 0.0 else f"{rtf:g}× real time",
        "total_station_mm": float(chosen(options.total_station_mm, profile.total_station_mm)),  # 0: none
        "connections": options.connections,
        "sequence": sequence_source(options.planner_source),
        "max_attempts": int(chosen(options.max_attempts, AgentConfig.max_attempts)),
        "timeout_s": options.timeout_s,
        "inject_placement_error_m": options.inject_placement_error_m,
        "seed": options.seed,
        "routers": options.routers,
        "tolerances": {
            "position_mm": 1000.0 * options.tolerances.position_m,
            "angle_deg": math.degrees(options.tolerances.angle_rad),
            "drift_mm": 1000.0 * options.tolerances.drift_m,
        },
    }


def sequence_source(planner_source: tuple[str, ...]) -> str:
    """Where the planner's sequence came from, in words: ``derived``, a file, or the build's own."""
    if "--derive" in planner_source:
        return "derived from the structure (--derive)"
    if "--sequence" in planner_source:
        return planner_source[planner_source.index("--sequence") + 1]
    if "--from-ifc" in planner_source:
        named = [*planner_source[planner_source.index("--from-ifc") + 1 :], "--"][0]
        return f"the IFC schedule of {'the build model' if named.startswith('--') else named}"
    return "the build's sequence.xml"


def model_settings(source: SourceModel) -> dict[str, str]:
    """The model the run built, for its report: the IFC file and its content's hash, so two reports tell
    whether they built the same building (``bimbot compare``)."""
    return {"path": source.path, "sha256": source.sha256}
