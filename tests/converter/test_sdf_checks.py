"""The batch SDF check says what ``ign sdf -k`` says: a valid file is ``Valid.``, a broken one gets the
reference parser's message (the converter's SDF tests rest on it)."""

from __future__ import annotations

from pathlib import Path

from sdf_checks import ign_sdf_check, sdf_check_all

VALID = "<sdf version='1.9'><model name='m'><link name='a'/></model></sdf>"
TWO_LINKS_ONE_NAME = "<sdf version='1.9'><model name='m'><link name='a'/><link name='a'/></model></sdf>"


def test_the_batch_check_agrees_with_the_reference_command_on_valid_and_broken_files(tmp_path: Path) -> None:
    models = tmp_path / "models"
    models.mkdir()
    files = {name: tmp_path / f"{name}.sdf" for name in ("valid", "broken", "valid_again")}
    files["valid"].write_text(VALID)
    files["broken"].write_text(TWO_LINKS_ONE_NAME)
    files["valid_again"].write_text(VALID.replace("'m'", "'n'"))
    checked = sdf_check_all(list(files.values()), models)
    assert checked[files["valid"]] == "Valid." == checked[files["valid_again"]]
    assert "link with name[a] already exists" in checked[files["broken"]]
    assert checked == {path: ign_sdf_check(path, models) for path in files.values()}
