"""`bimbot agents` refuses bad input with one clear line and exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from bimbot.cli import main


def run_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    capsys.readouterr()
    code = main(["agents", *args])
    err = capsys.readouterr().err.rstrip("\n")
    assert err.startswith("bimbot agents: error: "), err
    return code, err.removeprefix("bimbot agents: error: ")


def test_missing_manifest_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, message = run_cli(["--build", str(tmp_path)], capsys)
    assert code == 2
    assert "no manifest" in message
    assert "\n" not in message


def test_an_ifc_model_given_as_the_build_says_to_convert_it_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "house.ifc"
    model.write_text("ISO-10303-21;\n")
    code, message = run_cli(["--build", str(model)], capsys)
    assert code == 2
    assert "an IFC model, not a converted build" in message and f"bimbot convert {model}" in message


def test_invalid_manifest_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "manifest.json").write_text('{"schema_version": 1, "components": 3}')
    code, message = run_cli(["--build", str(tmp_path)], capsys)
    assert (code, "invalid manifest" in message) == (2, True)
    (tmp_path / "manifest.json").write_text("{not json")
    code, message = run_cli(["--build", str(tmp_path)], capsys)
    assert (code, "not a JSON manifest" in message) == (2, True)


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--shard", "3/2"], "--shard"),
        (["--shard", "x"], "--shard"),
        (["--max-attempts", "0"], "max_attempts"),
        (["--verify-timeout-s", "0"], "verify_timeout_s"),
    ],
)
def test_bad_options_are_one_line_and_exit_2(
    agents_build: Path, args: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, message = run_cli(["--build", str(agents_build), *args], capsys)
    assert code == 2
    assert expected in message


def test_the_agents_process_does_not_load_ifcopenshell() -> None:
    # ifcopenshell (imported by bimbot.shared.identifiers) adds ~50 MB to every agent process.
    code = (
        "import sys, bimbot.services.component_agents.cli, bimbot.services.component_agents.app;"
        "print(sorted({'ifcopenshell', 'pybullet', 'numpy'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
