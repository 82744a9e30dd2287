"""The placement tolerances as command-line options, declared once for ``bimbot physics`` (which serves
them to every service in its site info) and ``bimbot run``/``demo`` (which pass them to physics)."""

from __future__ import annotations

import argparse
import math

from .option_types import non_negative_float
from .verification import Tolerances


def add_tolerance_arguments(parser: argparse.ArgumentParser, *, defaults_shown: bool = True) -> None:
    """``--position-tolerance-m``, ``--angle-tolerance-deg``, ``--drift-tolerance-m``; their defaults are
    :class:`~bimbot.shared.verification.Tolerances`' (None with ``defaults_shown=False``: a run passes on
    only what the user set)."""
    tolerances = Tolerances()
    angle_deg = math.degrees(tolerances.angle_rad)
    parser.add_argument(
        "--position-tolerance-m",
        type=non_negative_float,
        default=tolerances.position_m if defaults_shown else None,
        metavar="M",
        help=f"accepted placement position error, m (default {tolerances.position_m:g})",
    )
    parser.add_argument(
        "--angle-tolerance-deg",
        type=non_negative_float,
        default=angle_deg if defaults_shown else None,
        metavar="DEG",
        help=f"accepted placement angle error, degrees (default {angle_deg:g})",
    )
    parser.add_argument(
        "--drift-tolerance-m",
        type=non_negative_float,
        default=tolerances.drift_m if defaults_shown else None,
        metavar="M",
        help="how far a placed component may move after its release and still count as standing, m "
        f"(default {tolerances.drift_m:g})",
    )


def tolerances_from(args: argparse.Namespace) -> Tolerances:
    """The tolerances the options give (a value left unset keeps its default)."""
    defaults = Tolerances()
    angle_deg = getattr(args, "angle_tolerance_deg", None)
    return Tolerances(
        position_m=_or(getattr(args, "position_tolerance_m", None), defaults.position_m),
        angle_rad=defaults.angle_rad if angle_deg is None else math.radians(angle_deg),
        drift_m=_or(getattr(args, "drift_tolerance_m", None), defaults.drift_m),
    )


def tolerance_flags(tolerances: Tolerances) -> list[str]:
    """The options that give ``tolerances`` (only those that differ from the defaults)."""
    defaults, flags = Tolerances(), []
    if tolerances.position_m != defaults.position_m:
        flags += ["--position-tolerance-m", repr(tolerances.position_m)]
    if tolerances.angle_rad != defaults.angle_rad:
        flags += ["--angle-tolerance-deg", repr(math.degrees(tolerances.angle_rad))]
    if tolerances.drift_m != defaults.drift_m:
        flags += ["--drift-tolerance-m", repr(tolerances.drift_m)]
    return flags


def _or(value: float | None, default: float) -> float:
    return default if value is None else value
