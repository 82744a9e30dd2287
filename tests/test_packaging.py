"""The distribution installs the project's packages under its own name, and children cannot be shadowed."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from wall_clock import bound_s

from bimbot.supervisor import ServiceProcess

ROOT = Path(__file__).resolve().parents[1]
TOP_LEVEL = {"bimbot": "bimbot", "services": "bimbot.services", "shared": "bimbot.shared"}


def _packages_on_disk() -> set[str]:
    found = set()
    for folder, dotted in TOP_LEVEL.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            parts = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join((dotted, *parts)) if parts else dotted)
    return found


def test_every_package_folder_is_installed_under_the_bimbot_name() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert set(config["packages"]) == _packages_on_disk()
    assert config["package-dir"] == {dotted: folder for folder, dotted in TOP_LEVEL.items()}


def test_imports_never_name_the_bare_top_level_folders() -> None:
    offenders = [
        f"{path.relative_to(ROOT)}:{number}"
        for folder in ("bimbot", "services", "shared", "tests", "bench")
        for path in (ROOT / folder).rglob("*.py")
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if line.lstrip().startswith(("from services", "from shared", "import services", "import shared"))
    ]
    assert offenders == []


def test_a_child_started_in_a_folder_with_its_own_bimbot_package_runs_ours(tmp_path: Path) -> None:
    decoy = tmp_path / "bimbot"
    decoy.mkdir()
    (decoy / "__init__.py").write_text("raise ImportError('the decoy bimbot package was imported')\n")
    for name in ("shared", "services"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "__init__.py").write_text("raise ImportError('decoy')\n")
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        child = ServiceProcess("version", ["--version"], tmp_path / "logs")
        code = child.wait(bound_s(60))
        log = child.log()
        child.stop()
    finally:
        os.chdir(here)
    assert code == 0, log
    assert log.startswith("bimbot "), log


def test_every_data_file_the_packages_read_is_installed_with_them() -> None:
    """A wheel (the container image) gets only what package-data names: the default fleet and the robot
    models must be in it, else physics in a container cannot start."""
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    data_folders = {
        "bimbot/data": ("bimbot.data", ROOT / "bimbot/data"),
        "shared/robots": ("bimbot.shared.robots", ROOT / "shared/robots"),
    }
    checked = 0
    for folder, (package, base) in data_folders.items():
        for path in (ROOT / folder).iterdir():
            if path.is_file() and path.suffix != ".py":
                relative = path.relative_to(base)
                assert any(relative.match(glob) for glob in globs.get(package, [])), (
                    f"{path} is not installed"
                )
                checked += 1
    assert checked >= 4  # the bundled model, the default fleet, the carrier and the tower crane
