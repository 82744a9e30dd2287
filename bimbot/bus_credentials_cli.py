"""``bimbot bus-credentials RUN_DIR``: the files of a secured bus, where only the right service can speak.

Writes ``RUN_DIR/bus/`` (:mod:`bimbot.shared.bus_credentials`): new random passwords, the router's
dictionary and config (authentication and the access control derived from the message registry,
:mod:`bimbot.shared.bus_access`), and one Zenoh config per service role, all readable by their owner only.
Then start the router with ``bimbot bus --bus-config RUN_DIR/bus/router.json5`` and each service with its
own file (``--bus-config RUN_DIR/bus/physics.json5`` or ``BIMBOT_ZENOH_CONFIG``), in Zenoh client mode,
which the files set. Prints the files it wrote, one per line.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from bimbot.shared.bus_access import ANY_SITE, bus_users
from bimbot.shared.bus_credentials import parse_robot_ids, write_bus_credentials
from bimbot.shared.errors import UserError
from bimbot.shared.service_runner import writable_dir

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_dir", type=Path, metavar="RUN_DIR", help="the files go to RUN_DIR/bus/")
    parser.add_argument(
        "--site",
        default=ANY_SITE,
        help="the site slug the rules are for (the build's manifest names it; default '*': any site)",
    )
    parser.add_argument(
        "--robots",
        default="r1",
        metavar="IDS",
        help="robot ids, comma-separated (r1,r2), or a number of robots (2: r1,r2); default r1",
    )


def run(args: argparse.Namespace) -> int:
    """Write the files; print their paths; exit 0 (2 for a bad site, robot id or folder)."""
    try:
        robots = parse_robot_ids(args.robots)
    except ValueError as error:
        raise UserError(str(error)) from None
    writable_dir(Path(args.run_dir), "RUN_DIR")
    try:
        files = write_bus_credentials(args.run_dir, robots, site=args.site)
    except ValueError as error:
        raise UserError(str(error)) from None
    except OSError as error:
        raise UserError(f"cannot write {Path(args.run_dir) / 'bus'}: {error.strerror or error}") from None
    _log.info("secured bus for site %s, robots %s: %s", args.site, ", ".join(robots) or "none", files.dir)
    paths = [files.router, files.dictionary, *(files.service(user.name) for user in bus_users(robots))]
    sys.stdout.write("".join(f"{path}\n" for path in paths))
    return 0
