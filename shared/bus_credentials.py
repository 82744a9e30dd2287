"""A secured bus's files: one password per service role, the router's config, one config per service.

``bimbot bus-credentials RUN_DIR`` (and ``bimbot run --secure``) writes them into ``RUN_DIR/bus/``::

    bus/passwords.txt         the router's password dictionary (``user:password`` lines)
    bus/router.json5          the router's Zenoh config: its own user, the dictionary, the access
                              control (:func:`bimbot.shared.bus_access.access_control`); for
                              ``bimbot bus --bus-config``
    bus/<user>.json5          one per service role: ``mode: "client"`` and its user and password; for the
                              service's ``--bus-config`` (or BIMBOT_ZENOH_CONFIG)
                              users: physics, planner, agents, observer, monitor (``bimbot run``'s own
                              session, ``bimbot watch``), robot-<id> per robot

Passwords are random (:mod:`secrets`), new on every call, and every file is readable by its owner only
(0600, in a 0700 folder). A service holding one file can speak only as that role. Everything in the files
is Zenoh's own configuration, so a user can read, check and change them with Zenoh's documentation.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .bus_access import ANY_SITE, ROUTER_USER, access_control, bus_users, check_robot_id, robot_user

BUS_DIR_NAME = "bus"
DICTIONARY_NAME = "passwords.txt"
ROUTER_CONFIG_NAME = "router.json5"
CONFIG_SUFFIX = ".json5"
PASSWORD_BYTES = 24  # secrets.token_urlsafe: 32 characters of [A-Za-z0-9_-] (no ':' for the dictionary)


@dataclass(frozen=True)
class BusFiles:
    """Where a secured bus's files are (``RUN_DIR/bus/``); pure paths, nothing is read or written."""

    dir: Path

    @property
    def dictionary(self) -> Path:
        return self.dir / DICTIONARY_NAME

    @property
    def router(self) -> Path:
        return self.dir / ROUTER_CONFIG_NAME

    def service(self, user: str) -> Path:
        """The config file of the bus user ``user`` (``physics``, ``robot-r1``, …)."""
        return self.dir / f"{user}{CONFIG_SUFFIX}"

    def robot(self, robot_id: str) -> Path:
        return self.service(robot_user(robot_id))

    @property
    def physics(self) -> Path:
        return self.service("physics")

    @property
    def planner(self) -> Path:
        return self.service("planner")

    @property
    def agents(self) -> Path:
        return self.service("agents")

    @property
    def observer(self) -> Path:
        return self.service("observer")

    @property
    def monitor(self) -> Path:
        return self.service("monitor")


def bus_files(run_dir: Path) -> BusFiles:
    """The secured-bus files of the run folder ``run_dir`` (``RUN_DIR/bus/``)."""
    return BusFiles(Path(run_dir) / BUS_DIR_NAME)


def robot_ids(count: int) -> tuple[str, ...]:
    """The ids of ``count`` robots as ``bimbot run`` names them: r1, r2, …"""
    return tuple(f"r{number}" for number in range(1, count + 1))


def parse_robot_ids(text: str) -> tuple[str, ...]:
    """``--robots``: a comma-separated list of ids (``r1,r2``) or a count (``2`` → r1, r2); a ValueError
    for an empty list, a bad id or a repeated one."""
    text = text.strip()
    if text.isdigit():
        return robot_ids(int(text))
    ids = tuple(part.strip() for part in text.split(",") if part.strip())
    if not ids:
        raise ValueError("--robots: give robot ids (r1,r2) or a number of robots")
    for robot_id in ids:
        check_robot_id(robot_id)
    if len(set(ids)) != len(ids):
        raise ValueError(f"--robots: an id is repeated in {text}")
    return ids


def service_config(user: str, password: str) -> dict[str, Any]:
    """A service's Zenoh config: client mode (the router's rules apply on its links only) and its user."""
    return {"mode": "client", "transport": {"auth": {"usrpwd": {"user": user, "password": password}}}}


def router_config(
    files: BusFiles, passwords: dict[str, str], robots: Sequence[str], site: str = ANY_SITE
) -> dict[str, Any]:
    """The router's Zenoh config: router mode, its own user, the dictionary file, the access control."""
    return {
        "mode": "router",
        "transport": {
            "auth": {
                "usrpwd": {
                    "user": ROUTER_USER,
                    "password": passwords[ROUTER_USER],
                    "dictionary_file": str(files.dictionary.resolve()),
                }
            }
        },
        "access_control": access_control(robots, site),
    }


def write_bus_credentials(
    run_dir: Path,
    robots: Sequence[str],
    site: str = ANY_SITE,
    new_password: Callable[[], str] = lambda: secrets.token_urlsafe(PASSWORD_BYTES),
) -> BusFiles:
    """Write a secured bus's files for ``robots`` on ``site`` (``*``: any) into ``run_dir/bus/``, new
    passwords every time (files of users no longer there are removed); the paths. A ValueError for a bad
    robot id or site; OSError when the folder cannot be written."""
    files = bus_files(run_dir)
    users = [user.name for user in bus_users(robots)]
    passwords = {name: new_password() for name in (ROUTER_USER, *users)}
    router = router_config(files, passwords, robots, site)  # checks ids and site before writing
    files.dir.mkdir(parents=True, exist_ok=True)
    os.chmod(files.dir, 0o700)
    _write_private(files.dictionary, "".join(f"{name}:{password}\n" for name, password in passwords.items()))
    _write_private(files.router, json.dumps(router, indent=2) + "\n")
    for name in users:
        _write_private(
            files.service(name), json.dumps(service_config(name, passwords[name]), indent=2) + "\n"
        )
    wanted = {files.router, *(files.service(name) for name in users)}
    for stale in files.dir.glob(f"*{CONFIG_SUFFIX}"):
        if stale not in wanted:
            stale.unlink()
    return files


def _write_private(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` readable by its owner only (0600), replacing the file in one step."""
    partial = path.with_name(f".{path.name}.partial")
    descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "w", encoding="utf-8") as stream:
        os.fchmod(stream.fileno(), 0o600)
        stream.write(text)
    os.replace(partial, path)
