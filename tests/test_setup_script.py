"""scripts/setup.sh, run on a copy of the project with a stand-in for the venv's Python (no install).

The stand-in fails the import check (so setup installs) and answers ``pip`` as pip does on a machine whose
pip configuration names local ``file://`` indexes that lack a package: one warning per package and index.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
IGNORED = (
    "WARNING: Location 'file:///opt/pypi-more/simple/pip/' is ignored: it is neither a file nor a directory."
)
OTHER = "WARNING: something else pip has to say"


def _project(tmp_path: Path, pip_exit: int) -> Path:
    project = tmp_path / "project"
    (project / "scripts").mkdir(parents=True)
    shutil.copy(ROOT / "scripts" / "setup.sh", project / "scripts" / "setup.sh")
    (project / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    python = project / ".venv" / "bin" / "python"
    python.parent.mkdir(parents=True)
    python.write_text(
        "#!/usr/bin/env bash\n"
        'if [ "$1" = "-c" ]; then exit 1; fi\n'  # the import check: not installed yet
        f'echo "{IGNORED}" >&2\n'
        f'echo "{OTHER}" >&2\n'
        'echo "pip stdout"\n'
        f"exit {pip_exit}\n"
    )
    python.chmod(python.stat().st_mode | stat.S_IXUSR)
    return project


def _setup(project: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", "scripts/setup.sh"],
        check=False,
        cwd=project,
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "PYTHON": "false"},
    )


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_setup_drops_pips_lines_about_missing_local_index_folders_and_keeps_the_rest(tmp_path: Path) -> None:
    done = _setup(_project(tmp_path, pip_exit=0))
    assert done.returncode == 0, done.stderr
    assert "is ignored: it is neither a file nor a directory" not in done.stderr
    assert done.stderr.count(OTHER) == 2  # pip's other warnings, from both pip commands
    assert done.stdout.count("pip stdout") == 2
    assert (tmp_path / "project" / ".venv" / ".bimbot-installed").is_file()


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_setup_still_fails_when_pip_fails(tmp_path: Path) -> None:
    done = _setup(_project(tmp_path, pip_exit=3))
    assert done.returncode == 3
    assert OTHER in done.stderr
    assert not (tmp_path / "project" / ".venv" / ".bimbot-installed").exists()
