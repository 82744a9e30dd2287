"""Output checks say where and why a command cannot write, before it starts, and leave nothing behind."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimbot.shared.errors import UserError
from bimbot.shared.output_paths import PROBE_PREFIX, check_writable_dir, check_writable_file
from bimbot.shared.run_folder import new_run_folder, open_run_folder


def test_a_folder_that_can_be_made_passes_and_nothing_is_made(tmp_path: Path) -> None:
    assert check_writable_dir(tmp_path / "a" / "b", "--output") == tmp_path / "a" / "b"
    assert list(tmp_path.iterdir()) == []  # the probe folder is gone, nothing was made


def test_a_folder_under_a_regular_file_names_the_file(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    with pytest.raises(UserError, match=r"--output .*f/out: .*f is a file, not a folder; try this"):
        check_writable_dir(tmp_path / "f" / "out", "--output", "try this")


def test_a_file_needs_an_existing_folder_and_is_not_a_folder(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="is a folder"):
        check_writable_file(tmp_path, "--output")
    with pytest.raises(UserError, match="does not exist"):
        check_writable_file(tmp_path / "missing" / "x.ifc", "--output")
    existing = tmp_path / "x.ifc"
    existing.write_text("kept")
    assert check_writable_file(existing, "--output") == existing
    assert existing.read_text() == "kept"
    assert not any(path.name.startswith(PROBE_PREFIX) for path in tmp_path.iterdir())


def test_a_build_that_cannot_hold_a_run_folder_says_to_use_run_dir(tmp_path: Path) -> None:
    (tmp_path / "runs").write_text("not a folder")
    for make in (new_run_folder, open_run_folder):
        with pytest.raises(UserError, match=r"cannot make a run folder .*--run-dir"):
            make(tmp_path)
