"""``bimbot sample light-steel-frame -o FILE.ifc [--bays NxM]``: write a generated sample IFC model.

A thin adapter over :mod:`bimbot.data.light_steel_frame` (the pure builder): it
parses the options, builds the model, writes it and logs one summary line. ``--bays NxM`` is an N×M grid
of columns (3x3, the paper's case, gives 9 footings, 9 columns and 10 beams). Bad options raise
:class:`bimbot.shared.errors.UserError`, which the ``bimbot`` dispatcher reports as one line with exit code 2.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

from bimbot.shared.errors import UserError
from bimbot.shared.output_paths import check_writable_file

KINDS = ("light-steel-frame",)
DEFAULT_BAYS = "3x3"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``bimbot sample``."""
    parser.add_argument("kind", choices=KINDS, help="which sample model to generate")
    parser.add_argument("-o", "--output", required=True, type=Path, help="IFC file to write (e.g. frame.ifc)")
    parser.add_argument(
        "--bays",
        default=DEFAULT_BAYS,
        metavar="NxM",
        help=f"grid of N×M columns (default {DEFAULT_BAYS}: 9 footings, 9 columns, 10 beams)",
    )


def run(args: argparse.Namespace) -> int:
    """Build the chosen sample model and write it to ``args.output``; 0 on success."""
    # Imported here so that a bad option fails fast, before ifcopenshell loads.
    from bimbot.data import light_steel_frame as sample

    try:
        columns_x, columns_y = sample.parse_bays(args.bays)
    except ValueError as error:
        raise UserError(str(error)) from None
    output: Path = check_writable_file(args.output, "--output")
    started_s = time.perf_counter()
    model = sample.build_light_steel_frame(columns_x, columns_y)
    try:
        model.write(str(output))
    except OSError as error:
        raise UserError(f"--output {output}: cannot write ({error.strerror or error})") from None
    except RuntimeError as error:  # ifcopenshell's own "Failed to write to path"
        raise UserError(f"--output {output}: cannot write ({error})") from None
    counts = Counter(element.is_a() for element in model.by_type("IfcElement"))
    sys.stdout.write(  # the command's result: on stdout, as convert's summary
        f"wrote {output}: {args.kind} {columns_x}x{columns_y}, {counts['IfcFooting']} footings, "
        f"{counts['IfcColumn']} columns, {counts['IfcBeam']} beams, {len(model.by_type('IfcTask'))} tasks "
        f"({time.perf_counter() - started_s:.1f} s)\n"
    )
    return 0
