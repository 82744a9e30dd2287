"""Argparse ``type=`` checks for numeric options: a bad number is argparse's own one-line error (exit 2).

``float("nan")``, ``float("inf")`` and ``-1`` all parse as floats, so ``--physics-hz nan`` or ``--rtf -1``
used to get past argparse and fail later (a ``ValueError`` deep in a config, or a run that never ends).
Each helper here parses one option value and raises :class:`argparse.ArgumentTypeError` with a sentence
naming the value and what is allowed; argparse prefixes the option's name::

    bimbot physics: error: argument --physics-hz: nan is not a finite number

Config dataclasses still check their own invariants (a library caller passes no command line); these only
stop impossible values at the door, before anything starts.
"""

from __future__ import annotations

import argparse
import math


def finite_float(text: str) -> float:
    """Any finite float (no ``nan``, ``inf``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number")
    return value


def positive_float(text: str) -> float:
    """A finite float > 0 (rates, periods, limits, distances)."""
    value = finite_float(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"{text} must be a positive number")
    return value


def non_negative_float(text: str) -> float:
    """A finite float ≥ 0 (where 0 has a meaning: "as fast as possible", "never", "exact")."""
    value = finite_float(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"{text} must be zero or a positive number")
    return value


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None


def positive_int(text: str) -> int:
    """A whole number ≥ 1 (counts of robots, beams, steps)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} must be at least 1")
    return value


def non_negative_int(text: str) -> int:
    """A whole number ≥ 0."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} must be zero or more")
    return value
