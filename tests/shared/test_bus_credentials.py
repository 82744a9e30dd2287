"""The secured bus's files: private, new passwords each time, one usable Zenoh config per service role; the
``--bus-config`` file under bimbot's options; a run's command lines on a secured bus and on the open one."""

from __future__ import annotations

import argparse
import json
import stat
from pathlib import Path

import pytest
import zenoh

import bimbot.cli
from bimbot.run.commands import monitor_bus_options, router_arguments, run_fleet, service_commands
from bimbot.run.options import RunOptions
from bimbot.shared.bus import BusOptions, zenoh_config
from bimbot.shared.bus_access import bus_users
from bimbot.shared.bus_credentials import bus_files, parse_robot_ids, write_bus_credentials
from bimbot.shared.errors import UserError
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.service_runner import service_bus


def _bus_args(**given: object) -> argparse.Namespace:
    return argparse.Namespace(**{"mode": None, "connect": None, "listen": None, "bus_config": None, **given})


def _dictionary(path: Path) -> dict[str, str]:
    return dict(line.split(":", 1) for line in path.read_text().splitlines())


def test_every_file_is_private_and_every_user_has_a_password_and_a_client_config(tmp_path: Path) -> None:
    files = write_bus_credentials(tmp_path, ("r1", "r2"), site="site_a")
    assert stat.S_IMODE(files.dir.stat().st_mode) == 0o700
    written = sorted(files.dir.iterdir())
    assert written and all(stat.S_IMODE(path.stat().st_mode) == 0o600 for path in written)
    passwords = _dictionary(files.dictionary)
    users = [user.name for user in bus_users(("r1", "r2"))]
    assert set(passwords) == {"bus", *users}
    assert len(set(passwords.values())) == len(passwords), "every user has its own password"
    for user in users:
        config = zenoh.Config.from_file(str(files.service(user)))
        assert json.loads(config.get_json("mode")) == "client"
        assert json.loads(config.get_json("transport/auth/usrpwd/user")) == user
        assert json.loads(config.get_json("transport/auth/usrpwd/password")) == passwords[user]
    router = zenoh.Config.from_file(str(files.router))
    assert json.loads(router.get_json("transport/auth/usrpwd/dictionary_file")) == str(files.dictionary)
    assert json.loads(router.get_json("access_control/enabled")) is True


def test_new_passwords_every_time_and_a_removed_robots_file_goes(tmp_path: Path) -> None:
    first = _dictionary(write_bus_credentials(tmp_path, ("r1", "r2")).dictionary)
    files = write_bus_credentials(tmp_path, ("r1",))
    second = _dictionary(files.dictionary)
    assert first["physics"] != second["physics"]
    assert files.robot("r1").is_file() and not files.robot("r2").exists()
    assert "robot-r2" not in second


def test_robots_are_ids_or_a_count() -> None:
    assert parse_robot_ids("r1, r2") == ("r1", "r2")
    assert parse_robot_ids("3") == ("r1", "r2", "r3")
    for bad in ("", "r1,r1", "r:1"):
        with pytest.raises(ValueError):
            parse_robot_ids(bad)


def test_the_command_writes_the_files_and_names_them(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = bimbot.cli.main(["bus-credentials", str(tmp_path), "--site", "site_a", "--robots", "r1,r2"])
    assert code == 0
    printed = capsys.readouterr().out.split()
    files = bus_files(tmp_path)
    assert str(files.router) in printed and str(files.robot("r2")) in printed
    assert all(Path(path).is_file() for path in printed)
    assert bimbot.cli.main(["bus-credentials", str(tmp_path), "--robots", "r/2"]) == 2


def test_the_config_files_mode_counts_unless_an_option_or_the_environment_says_otherwise(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    files = write_bus_credentials(tmp_path, ("r1",))
    monkeypatch.delenv("BIMBOT_ZENOH_MODE", raising=False)
    options = service_bus(_bus_args(bus_config=files.physics))
    assert (options.mode, options.listen, options.config_file) == ("client", (), files.physics)
    assert service_bus(_bus_args(bus_config=files.physics, mode="peer")).mode == "peer"
    monkeypatch.setenv("BIMBOT_ZENOH_CONFIG", str(files.planner))
    assert service_bus(_bus_args()).config_file == files.planner
    config = zenoh_config(service_bus(_bus_args()))
    assert json.loads(config.get_json("transport/auth/usrpwd/user")) == "planner"
    assert json.loads(config.get_json("connect/timeout_ms")) > 0, "a secured session gives up in time"


def test_a_missing_or_broken_config_file_or_a_bad_endpoint_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="no such file"):
        service_bus(_bus_args(bus_config=tmp_path / "missing.json5"))
    broken = tmp_path / "broken.json5"
    broken.write_text("{ mood: 'client' }")
    with pytest.raises(UserError, match=r"not a usable Zenoh config.*mood") as error:
        service_bus(_bus_args(bus_config=broken))
    assert ".rs:" not in str(error.value)
    with pytest.raises(UserError, match="--connect 'garbage': not a Zenoh endpoint"):
        service_bus(_bus_args(connect=["tcp/127.0.0.1:7447", "garbage"]))


def test_a_secured_run_gives_every_service_its_own_file_in_client_mode(tmp_path: Path) -> None:
    run = RunFolder(tmp_path / "run")
    options = RunOptions(robots=2, secure=True)  # two carriers; the crane, pumps, block layer, rig r3–r7
    files = write_bus_credentials(run.root, tuple(run_fleet(options).type_of()))
    commands = dict(service_commands(tmp_path / "build", "tcp/127.0.0.1:7000", options, run, files))
    assert set(commands) == {"physics", "agents", "planner", *(f"robot-r{n}" for n in range(1, 8))}
    for name, arguments in commands.items():
        config = Path(arguments[arguments.index("--bus-config") + 1])
        assert config.is_file() and config.name == f"{name}.json5"
        assert arguments[arguments.index("--mode") + 1] == "client"
    assert router_arguments("tcp/127.0.0.1:7000", files)[-2:] == ["--bus-config", str(files.router)]
    assert monitor_bus_options("tcp/127.0.0.1:7000", files).config_file == files.monitor


def test_an_open_run_is_as_before(tmp_path: Path) -> None:
    run = RunFolder(tmp_path / "run")
    commands = service_commands(tmp_path / "build", "tcp/127.0.0.1:7000", RunOptions(robots=1), run)
    assert all("--bus-config" not in arguments for _, arguments in commands)
    # lock-step (the default profile): every service a client of the run's router, one link each, so the
    # messages of one service reach another in the order they were sent (reproducible runs)
    assert all(arguments[-2:] == ["--mode", "client"] for name, arguments in commands if name != "observer")
    free = service_commands(
        tmp_path / "build", "tcp/127.0.0.1:7000", RunOptions(robots=1, lock_step=False), run
    )
    assert all("--mode" not in arguments for _, arguments in free)
    assert router_arguments("tcp/127.0.0.1:7000") == ["bus", "--listen", "tcp/127.0.0.1:7000"]
    assert monitor_bus_options("tcp/127.0.0.1:7000") == BusOptions(connect=("tcp/127.0.0.1:7000",))


def test_the_agents_extra_token_sessions_join_with_the_same_credentials(tmp_path: Path) -> None:
    from bimbot.services.component_agents.app import token_session_options

    files = write_bus_credentials(tmp_path, ("r1",))
    options = BusOptions(mode="client", connect=("tcp/127.0.0.1:7000",), listen=(), config_file=files.agents)
    extra = token_session_options(options, 2500)
    assert extra and all(each.config_file == files.agents and each.mode == "client" for each in extra)


def test_a_client_retries_a_router_that_is_still_starting_fast_first(tmp_path: Path) -> None:
    """bimbot run opens its monitor's session right after starting the router: Zenoh's own first retry
    comes after 1 s, the router listens after about 0.25 s. A config file's own retry settings are kept."""
    client = zenoh_config(BusOptions(mode="client", connect=("tcp/127.0.0.1:7447",), listen=()))
    retry = json.loads(client.get_json("connect/retry"))
    assert retry["period_init_ms"] <= 100 and retry["period_max_ms"] >= 1000
    router = zenoh_config(BusOptions(mode="router", connect=(), listen=("tcp/127.0.0.1:7447",)))
    assert json.loads(router.get_json("connect/retry")) is None
    own = tmp_path / "own.json5"
    own.write_text("{ connect: { retry: { period_init_ms: 700 } } }")
    mine = zenoh_config(
        BusOptions(mode="client", connect=("tcp/127.0.0.1:7447",), listen=(), config_file=own)
    )
    assert json.loads(mine.get_json("connect/retry"))["period_init_ms"] == 700


def test_a_session_waits_for_no_scouting_unless_its_config_file_says_so(tmp_path: Path) -> None:
    """Zenoh's default ``scouting/delay`` held every session's opening for 0.5 s, multicast off or on."""
    for mode in ("peer", "client", "router"):
        config = zenoh_config(BusOptions(mode=mode, connect=("tcp/127.0.0.1:7447",), listen=()))
        assert json.loads(config.get_json("scouting/delay")) == 0, mode
    own = tmp_path / "own.json5"
    own.write_text("{ scouting: { delay: 300 } }")
    mine = zenoh_config(BusOptions(mode="peer", connect=("tcp/127.0.0.1:7447",), listen=(), config_file=own))
    assert json.loads(mine.get_json("scouting/delay")) == 300
