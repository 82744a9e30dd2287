"""A study's grid (every fleet × sequence × seed) and the ``bimbot run`` command line of each of its runs.

Pure: paths and numbers in, :class:`StudyRun` values and argument lists out. Every run gets a folder of its
own under ``DIR/runs/<fleet>[-<sequence>]-<seed>`` and its own bus (``bimbot run`` picks free ports), so runs
can go side by side on one machine or on many.

The seed reaches a run only when ``bimbot run`` has a ``--seed`` option (:func:`run_accepts_seed`); without
one the runs of a fleet are plain repeats, and each row says so (:mod:`.rows` reads the seed the run's
report names).
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from bimbot.shared.seeds import DEFAULT_SEED

#: What each fidelity adds to ``bimbot run``: "physics" is the full simulation (every service, PyBullet).
FIDELITIES: dict[str, tuple[str, ...]] = {"physics": (), "plan": ("--fidelity", "plan")}
DEFAULT_FIDELITY = "physics"
DERIVE = "derive"  # ``--sequence derive``: the planner derives the sequence from the supports
BUILD_SEQUENCE = "build"  # the label of the build's own sequence (no --sequence given)
_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


@dataclass(frozen=True)
class StudyRun:
    """One run of the grid: which fleet, sequence, seed and fidelity, and the folder name it runs in."""

    fleet: Path
    fleet_label: str
    seed: int
    fidelity: str = DEFAULT_FIDELITY
    sequence: str | None = None  # a schedule file, DERIVE, or None for the build's own sequence
    sequence_label: str = BUILD_SEQUENCE

    @property
    def name(self) -> str:
        """``carriers-3`` (``carriers-derive-3`` when the study compares sequences)."""
        parts = [self.fleet_label]
        if self.sequence is not None:
            parts.append(self.sequence_label)
        if self.fidelity != DEFAULT_FIDELITY:
            parts.append(self.fidelity)
        return "-".join([*parts, str(self.seed)])


def unique_labels(paths: Sequence[str | Path]) -> list[str]:
    """A short label per path, its file name without suffix, made unique with ``-2``, ``-3`` … and safe
    for a folder name."""
    labels: list[str] = []
    for path in paths:
        base = _UNSAFE.sub("_", Path(str(path)).stem) or "x"
        label, number = base, 2
        while label in labels:
            label, number = f"{base}-{number}", number + 1
        labels.append(label)
    return labels


def study_grid(
    fleets: Sequence[Path],
    seeds: int,
    sequences: Sequence[str] = (),
    fidelity: str = DEFAULT_FIDELITY,
    first_seed: int = DEFAULT_SEED,
) -> list[StudyRun]:
    """Every fleet × sequence × seed, fleets outermost (seeds ``first_seed`` … ``first_seed + seeds - 1``;
    from ``bimbot run``'s own default, so a study's first seed is the run a user has seen); no sequences
    given: the build's own."""
    if seeds < 1:
        raise ValueError("a study needs at least one seed")
    if fidelity not in FIDELITIES:
        raise ValueError(f"fidelity {fidelity!r}: expected one of {', '.join(FIDELITIES)}")
    chosen: list[str | None] = list(sequences) or [None]
    sequence_labels = unique_labels([s for s in chosen if s is not None])
    label_of = dict(zip([s for s in chosen if s is not None], sequence_labels, strict=True))
    return [
        StudyRun(
            fleet=fleet,
            fleet_label=fleet_label,
            seed=seed,
            fidelity=fidelity,
            sequence=sequence,
            sequence_label=label_of.get(sequence, BUILD_SEQUENCE) if sequence is not None else BUILD_SEQUENCE,
        )
        for fleet, fleet_label in zip(fleets, unique_labels(fleets), strict=True)
        for sequence in chosen
        for seed in range(first_seed, first_seed + seeds)
    ]


def run_arguments(
    build: Path, run: StudyRun, run_dir: Path, timeout_s: float, *, pass_seed: bool, extra: Sequence[str] = ()
) -> list[str]:
    """The ``bimbot`` arguments of one run: quiet, in its own run folder, with its fleet, sequence,
    fidelity and time limit; ``--seed`` only when ``pass_seed`` (``bimbot run`` has it)."""
    arguments = ["run", str(build), "--fleet", str(run.fleet), "--run-dir", str(run_dir), "-q"]
    arguments += ["--timeout-s", repr(float(timeout_s))]
    if run.sequence == DERIVE:
        arguments.append("--derive")
    elif run.sequence is not None:
        arguments += ["--sequence", run.sequence]
    if pass_seed:
        arguments += ["--seed", str(run.seed)]
    return [*arguments, *FIDELITIES[run.fidelity], *extra]


def run_accepts_seed() -> bool:
    """Whether this bimbot's ``bimbot run`` takes ``--seed`` (its parser, built here as the CLI builds it)."""
    from bimbot.run.main import add_arguments

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return "--seed" in parser._option_string_actions
