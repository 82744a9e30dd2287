"""What a run simulates (``--fidelity``), one name for every service of the run.

* ``physics`` (the default): the full simulation, every robot driven by its wheels, laser, particle filter
  and DWA, Bullet stepped every period.
* ``plan``: the same planner, agents, protocol, reasons and report, with kinematic robots along their A*
  paths, physics only where an answer needs it (stability at release, supports, reach) and a clock that
  jumps by events (``services/physics/plan_fidelity.py``, ``services/robot/plan_executor.py``); for
  scenario studies, many runs.
"""

from __future__ import annotations

import argparse

from .option_types import OptionSpec

FIDELITIES = ("physics", "plan")
DEFAULT_FIDELITY = "physics"


FIDELITY_OPTION = OptionSpec(
    "--fidelity",
    choices=FIDELITIES,
    default=DEFAULT_FIDELITY,
    help="what is simulated: physics (default; robots by their wheels, laser, localisation, Bullet every "
    "period) or plan (kinematic robots along their A* paths, physics only at release, the clock jumping by "
    "events: a scenario study's runs)",
)


def add_fidelity_argument(parser: argparse.ArgumentParser) -> None:
    FIDELITY_OPTION.declare(parser)
