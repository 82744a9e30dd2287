"""compose.yaml runs one robot service per robot of the fleet physics simulates, each with its own bus login.

Physics holds the site's clock for every robot of its fleet. A robot with no service leaves the stack
waiting for it, and the smoke test then finds out only after its whole wait (the default fleet gained a
line pump, r5, once without a service). This reads compose.yaml as data, so it needs no docker daemon.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from bimbot.shared.fleet import default_fleet

ROOT = Path(__file__).resolve().parents[2]


def _services() -> dict[str, dict[str, Any]]:
    services: dict[str, dict[str, Any]] = yaml.safe_load((ROOT / "compose.yaml").read_text())["services"]
    return services


def _option(command: list[str], name: str) -> str | None:
    return command[command.index(name) + 1] if name in command else None


def _physics_robot_ids() -> set[str]:
    command = [str(word) for word in _services()["physics"]["command"]]
    assert _option(command, "--fleet") is None, "a fleet file in the volume: read it here instead"
    count = _option(command, "--robots")
    fleet = default_fleet() if count is None else default_fleet().with_robots(int(count))
    return set(fleet.type_of())


def _robot_services() -> dict[str, dict[str, Any]]:
    return {
        name: service
        for name, service in _services().items()
        if service.get("command") and service["command"][0] == "robot"
    }


def test_every_robot_physics_simulates_has_its_own_robot_service() -> None:
    by_id = {_option(service["command"], "--id"): name for name, service in _robot_services().items()}
    assert set(by_id) == _physics_robot_ids()
    assert all(name == f"robot-{robot_id}" for robot_id, name in by_id.items())


def test_every_robot_service_logs_in_with_credentials_written_for_its_id() -> None:
    command = _services()["bus-credentials"]["command"]
    written = set(str(_option(command, "--robots")).split(","))
    assert written == _physics_robot_ids()
    for service in _robot_services().values():
        robot_id = _option(service["command"], "--id")
        assert service["environment"]["BIMBOT_ZENOH_CONFIG"] == f"/data/bus/robot-{robot_id}.json5"
