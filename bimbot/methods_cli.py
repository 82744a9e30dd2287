"""``bimbot methods show [--preset NAME] > methods.toml``: the construction-method rules in force, as TOML.

Why: a builder changes how a model is built by editing a file, not code. The printed preset is a complete
methods file (:mod:`bimbot.shared.methods_file`): keep what you want, change the rest, and convert with
``bimbot convert MODEL.ifc -o OUT/ --methods methods.toml``. Without ``--preset`` it prints the default,
``prefab``. ``--check FILE`` reads a methods file and says whether it is valid (exit 2 with one line when
not).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bimbot.shared.methods_file import DEFAULT_PRESET, PRESETS, load_methods, preset_text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("show", "check"), help="show: print a preset; check: read a file")
    parser.add_argument("file", type=Path, nargs="?", help="check: the methods file")
    parser.add_argument(
        "--preset",
        choices=PRESETS,
        default=DEFAULT_PRESET,
        help=f"show: which preset (default {DEFAULT_PRESET})",
    )


def run(args: argparse.Namespace) -> int:
    if args.action == "show":
        sys.stdout.write(preset_text(args.preset))
        return 0
    if args.file is None:
        from bimbot.shared.errors import UserError

        raise UserError("bimbot methods check: give the methods file (methods.toml)")
    methods = load_methods(args.file)
    sys.stdout.write(
        f"{args.file}: valid (preset {methods.preset}, {len(methods.rules)} rule(s), "
        f"{len(methods.by_guid) + len(methods.by_class) + len(methods.by_material)} override(s))\n"
    )
    return 0
