"""The placement tolerances as command-line options, declared once for ``bimbot physics`` (which serves
them to every service in its site info) and ``bimbot run``/``demo`` (which pass them to physics)."""

from __future__ import annotations

import argparse
import math

from .option_types import OptionSpec, non_negative_float
from .verification import Tolerances

_DEFAULTS = Tolerances()

#: ``--position-tolerance-m``, ``--angle-tolerance-deg``, ``--drift-tolerance-m``, defaulting to
#: :class:`~bimbot.shared.verification.Tolerances`'.
TOLERANCE_OPTIONS: tuple[OptionSpec, ...] = (
    OptionSpec(
        "--position-tolerance-m",
        type=non_negative_float,
        default=_DEFAULTS.position_m,
        metavar="M",
        help=f"accepted placement position error, m (default {_DEFAULTS.position_m:g})",
    ),
    OptionSpec(
        "--angle-tolerance-deg",
        type=non_negative_float,
        default=math.degrees(_DEFAULTS.angle_rad),
        metavar="DEG",
        help=f"accepted placement angle error, degrees (default {math.degrees(_DEFAULTS.angle_rad):g})",
    ),
    OptionSpec(
        "--drift-tolerance-m",
        type=non_negative_float,
        default=_DEFAULTS.drift_m,
        metavar="M",
        help="how far a placed component may move after its release and still count as standing, m "
        f"(default {_DEFAULTS.drift_m:g})",
    ),
)


def add_tolerance_arguments(parser: argparse.ArgumentParser) -> None:
    """The tolerance options (:data:`TOLERANCE_OPTIONS`)."""
    for option in TOLERANCE_OPTIONS:
        option.declare(parser)


def tolerances_from(args: argparse.Namespace) -> Tolerances:
    """The tolerances the options give (a value left unset keeps its default)."""
    defaults = Tolerances()
    angle_deg = getattr(args, "angle_tolerance_deg", None)
    return Tolerances(
        position_m=_or(getattr(args, "position_tolerance_m", None), defaults.position_m),
        angle_rad=defaults.angle_rad if angle_deg is None else math.radians(angle_deg),
        drift_m=_or(getattr(args, "drift_tolerance_m", None), defaults.drift_m),
    )


def _or(value: float | None, default: float) -> float:
    return default if value is None else value
