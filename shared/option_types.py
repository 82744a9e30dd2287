"""Argparse ``type=`` checks for numeric options: a bad number is argparse's own one-line error (exit 2).

``float("nan")``, ``float("inf")`` and ``-1`` all parse as floats, so ``--physics-hz nan`` or ``--rtf -1``
used to get past argparse and fail later (a ``ValueError`` deep in a config, or a run that never ends).
Each helper here parses one option value and raises :class:`argparse.ArgumentTypeError` with a sentence
naming the value and what is allowed; argparse prefixes the option's name::

    bimbot physics: error: argument --physics-hz: nan is not a finite number

Config dataclasses still check their own invariants (a library caller passes no command line); these only
stop impossible values at the door, before anything starts.

:class:`OptionSpec` is an option declared once, for the parser that takes it and for the command line that
passes it on (``bimbot run`` builds its services' command lines from the same declarations).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal


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


def non_negative_float_up_to(limit: float, unit: str) -> Callable[[str], float]:
    """A check for a finite float in ``[0, limit]``, given and bounded in ``unit`` (the unit the user typed:
    ``--total-station-mm 2000`` is answered in mm, not in the metres a config holds)."""

    def check(text: str) -> float:
        value = non_negative_float(text)
        if value > limit:
            raise argparse.ArgumentTypeError(f"{text} {unit} is more than {limit:g} {unit}, the most allowed")
        return value

    check.__name__ = f"number of {unit} up to {limit:g}"
    return check


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


@dataclass(frozen=True)
class OptionSpec:
    """One command-line option, declared once: what argparse needs to take it and what a command line needs
    to pass it on (:meth:`flags`). ``kind``: ``value`` (takes a value; with ``const``, the value may be left
    out), ``switch`` (``store_true``) or ``boolean`` (``--x``/``--no-x``)."""

    flag: str
    help: str
    type: Callable[[str], Any] | None = None
    default: Any = None
    kind: Literal["value", "switch", "boolean"] = "value"
    metavar: str | None = None
    choices: tuple[Any, ...] | None = None
    const: Any = None  # ``--from-ifc`` alone: the value is this
    dest: str = ""  # default: the flag's name with ``_`` for ``-``
    short: str | None = None  # ``-q``

    def __post_init__(self) -> None:
        if not self.dest:
            object.__setattr__(self, "dest", self.flag.lstrip("-").replace("-", "_"))
        if self.kind == "switch" and self.default is None:
            object.__setattr__(self, "default", False)

    def declare(self, parser: argparse.ArgumentParser | argparse._ActionsContainer) -> None:
        """Add the option to ``parser`` (or an argument group of it)."""
        names = [self.short, self.flag] if self.short else [self.flag]
        common: dict[str, Any] = {"default": self.default, "help": self.help, "dest": self.dest}
        if self.kind == "switch":
            parser.add_argument(*names, action="store_true", **common)
        elif self.kind == "boolean":
            parser.add_argument(*names, action=argparse.BooleanOptionalAction, **common)
        else:
            more: dict[str, Any] = {"type": self.type, "metavar": self.metavar, "choices": self.choices}
            if self.const is not None:
                more.update(nargs="?", const=self.const)
            parser.add_argument(*names, **common, **more)

    def flags(self, value: Any) -> list[str]:
        """The command-line words that pass ``value`` on (none for an unset value or a switch that is off)."""
        if value is None or (self.kind == "switch" and not value):
            return []
        if self.kind == "switch":
            return [self.flag]
        if self.kind == "boolean":
            return [self.flag if value else "--no-" + self.flag.removeprefix("--")]
        if self.const is not None and value == self.const:
            return [self.flag]
        return [self.flag, repr(value) if isinstance(value, float) else str(value)]
