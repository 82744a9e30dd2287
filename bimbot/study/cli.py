"""``bimbot study BUILD --fleet A.toml --fleet B.toml --seeds N [--sequence …] -o DIR/``: compare scenarios.

Runs the grid (every fleet × sequence × seed; :mod:`.grid`) on Dask (:mod:`.cluster`: an embedded
``LocalCluster``, or ``--scheduler tcp://HOST:8786``), each run a ``bimbot run`` of its own in
``DIR/runs/<name>/``, with a progress bar; then writes ``DIR/study.csv`` (one row per run, :mod:`.rows`),
``DIR/study.md`` (the table per scenario) and ``DIR/study.png`` (makespan spread and utilisation;
:mod:`.summary`), and prints the table. A run that failed is a row with its reason. Exit 0 when at least
one run wrote a report, 1 when none did, 2 for unusable input.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path
from typing import Any

from bimbot.shared.errors import UserError
from bimbot.shared.option_types import non_negative_int, positive_float, positive_int
from bimbot.shared.seeds import DEFAULT_SEED

from .grid import DEFAULT_FIDELITY, DERIVE, FIDELITIES, run_accepts_seed, study_grid
from .rows import FAILED

_log = logging.getLogger(__name__)

DEFAULT_SEEDS = 3
DEFAULT_RUN_TIMEOUT_S = 900.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder (bimbot convert … -o BUILD)")
    parser.add_argument(
        "--fleet",
        type=Path,
        action="append",
        required=True,
        metavar="FLEET.toml",
        help="a fleet to compare (repeatable); hourly rates (cost_per_h) in it give the cost columns",
    )
    parser.add_argument(
        "--seeds",
        type=positive_int,
        default=DEFAULT_SEEDS,
        metavar="N",
        help=f"runs per scenario ({DEFAULT_SEEDS})",
    )
    parser.add_argument(
        "--first-seed",
        type=non_negative_int,
        default=DEFAULT_SEED,
        metavar="N",
        help=f"the seeds are N … N + seeds - 1 ({DEFAULT_SEED}: the first is the run `bimbot run` makes)",
    )
    parser.add_argument(
        "--sequence",
        action="append",
        default=None,
        metavar="FILE|derive",
        help="a sequence or schedule to compare (repeatable; `derive`: from the supports; "
        "default: the build's)",
    )
    parser.add_argument(
        "--fidelity", choices=sorted(FIDELITIES), default=DEFAULT_FIDELITY, help="what each run simulates"
    )
    parser.add_argument("-o", "--out", type=Path, required=True, metavar="DIR", help="the study's folder")
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:8786",
        help="run on this Dask cluster (its workers need bimbot, the build and DIR at the same paths); "
        "default: an embedded LocalCluster",
    )
    parser.add_argument(
        "--workers",
        type=positive_int,
        default=max(1, (os.cpu_count() or 2) // 2),
        metavar="N",
        help="runs at once on the embedded cluster (default: half the cores)",
    )
    parser.add_argument(
        "--timeout-s",
        type=positive_float,
        default=DEFAULT_RUN_TIMEOUT_S,
        help=f"each run's time limit, wall seconds ({DEFAULT_RUN_TIMEOUT_S:g})",
    )


def _check(args: argparse.Namespace) -> None:
    """One clear line for unusable input, before any run starts."""
    from bimbot.shared.fleet import load_fleet

    if not (args.build / "manifest.json").is_file():
        raise UserError(f"{args.build}: not a converted build (no manifest.json; bimbot convert … -o BUILD)")
    for fleet in args.fleet:
        load_fleet(fleet)
    for sequence in args.sequence or ():
        if sequence != DERIVE and not Path(sequence).is_file():
            raise UserError(f"--sequence {sequence}: no such file")


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from .cluster import run_on_dask
    from .execute import RunJob
    from .summary import markdown_table, write_csv, write_plot

    _check(args)
    import distributed  # noqa: F401 - its import sets its loggers to INFO: quieted after it, not before

    logging.getLogger("distributed").setLevel(max(logging.WARNING, logging.getLogger().level))
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    sequences = [s if s == DERIVE else str(Path(s).resolve()) for s in args.sequence or ()]
    fleets = [f.resolve() for f in args.fleet]
    grid = study_grid(fleets, args.seeds, sequences, args.fidelity, first_seed=args.first_seed)
    pass_seed = run_accepts_seed()
    if not pass_seed:
        _log.warning("bimbot run has no --seed here: the seeds of a scenario are repeats (seed_reached_run)")
    jobs = [RunJob(args.build.resolve(), out, run, args.timeout_s, pass_seed) for run in grid]
    where = args.scheduler or f"an embedded Dask LocalCluster ({args.workers} at once)"
    sys.stdout.write(f"study: {len(jobs)} runs on {where}; runs in {out / 'runs'}/\n")
    sys.stdout.flush()
    with tqdm(total=len(jobs), unit="run", desc="study", disable=bool(getattr(args, "quiet", False))) as bar:

        def done(row: dict[str, Any]) -> None:
            bar.set_postfix_str(f"{row['fleet']}-{row['seed']}: {row['status']}")
            bar.update(1)

        rows = run_on_dask(jobs, args.scheduler, args.workers, done)
    write_csv(rows, out / "study.csv")
    table = markdown_table(rows)
    (out / "study.md").write_text(f"# Study of {args.build}\n\n{table}", encoding="utf-8")
    write_plot(rows, out / "study.png")
    sys.stdout.write(table + f"\nwritten: {out / 'study.csv'}, {out / 'study.md'}, {out / 'study.png'}\n")
    return 0 if any(row["status"] != FAILED for row in rows) else 1
