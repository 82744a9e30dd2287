"""The SDF checks the converter's tests rest on: the batch check says what ``ign sdf -k`` says (a valid file
is ``Valid.``, a broken one gets the reference parser's message); the check of a whole build fails for a
broken value in any of its files, and gives the reference parser every file of a new structure."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from sdf_checks import ign_sdf_check, one_file_per_structure, sdf_check_all, sdf_check_files
from sdf_values import sdf_value_problems

from bimbot.shared.manifest import read_manifest

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


# --- the check of a whole build: values in every file, the reference parser once per structure -----------

#: (what breaks, pattern, replacement, what the value check says); the first match in a column's model.sdf
BROKEN_VALUES = [
    ("negative mass", r"<mass>[^<]*</mass>", "<mass>-1.0</mass>", "is not positive"),
    ("zero mass", r"<mass>[^<]*</mass>", "<mass>0</mass>", "is not positive"),  # the parser: valid
    ("infinite mass", r"<mass>[^<]*</mass>", "<mass>inf</mass>", "not finite"),  # the parser: valid
    ("empty mass", r"<mass>[^<]*</mass>", "<mass></mass>", "1 number(s) expected"),  # the parser: valid
    ("mass not a number", r"<mass>[^<]*</mass>", "<mass>heavy</mass>", "not a number"),
    ("inertia", r"<ixx>[^<]*</ixx>", "<ixx>1e9</ixx>", "principal moments"),
    ("negative inertia", r"<iyy>[^<]*</iyy>", "<iyy>-1.0</iyy>", "principal moments"),
    ("inertia not finite", r"<izz>[^<]*</izz>", "<izz>nan</izz>", "not finite"),
    ("short pose", r"<pose>[^<]*</pose>", "<pose>0 0 0 0 0</pose>", "6 number(s) expected"),
    ("pose not finite", r"<pose>[^<]*</pose>", "<pose>nan 0 0 0 0 0</pose>", "not finite"),
    ("static", r"<static>[^<]*</static>", "<static>maybe</static>", "not a boolean"),
    ("colour", r"<ambient>[^<]*</ambient>", "<ambient>0.1 0.2 0.3</ambient>", "4 number(s) expected"),
    ("colour range", r"<diffuse>[^<]*</diffuse>", "<diffuse>0.1 0.2 3 1</diffuse>", "outside [0, 1]"),
    ("mesh", r"collision_0\.obj</uri>", "collision_9.obj</uri>", "names no file"),
    ("empty uri", r"<uri>[^<]*</uri>", "<uri></uri>", "empty <uri>"),
    ("empty ifc_name", r'ifc_name="[^"]*"', 'ifc_name=""', "empty attribute ifc_name"),  # the parser: valid
    ("reserved name", r'<link name="[^"]*"', '<link name="world"', "reserved or invalid name"),
    ("scoped name", r'<model name="[^"]*"', '<model name="a::b"', "reserved or invalid name"),
    ("same name twice", r'name="collision_1"', 'name="collision_0"', "two children named 'collision_0'"),
    ("not XML", r"</sdf>", "", "not XML"),
]


def _column_sdf(build: Path) -> Path:
    column = next(c for c in read_manifest(build).components if c.ifc_class == "IfcColumn")
    return build / column.files.sdf_file


def _break(path: Path, pattern: str, replacement: str, into: Path) -> Path:
    text, count = re.subn(pattern, replacement, path.read_text(), count=1)
    assert count == 1, pattern
    into.unlink(missing_ok=True)  # a new file: the build may link identical files to one another
    into.write_text(text)
    return into


@pytest.mark.parametrize(("pattern", "replacement", "says"), [case[1:] for case in BROKEN_VALUES],
                         ids=[case[0] for case in BROKEN_VALUES])  # fmt: skip
def test_the_value_check_refuses_each_broken_value_the_writer_varies(
    bundled_build: Path, tmp_path: Path, pattern: str, replacement: str, says: str
) -> None:
    original = _column_sdf(bundled_build)
    assert sdf_value_problems(original, bundled_build / "models") == []
    broken = _break(original, pattern, replacement, tmp_path / "model.sdf")
    problems = sdf_value_problems(broken, bundled_build / "models")
    assert any(says in problem for problem in problems), problems


def test_a_leaf_the_value_check_has_no_rule_for_is_a_problem(bundled_build: Path, tmp_path: Path) -> None:
    broken = _break(
        _column_sdf(bundled_build), r"</link>", "<gravity_scale>2</gravity_scale></link>", tmp_path / "m.sdf"
    )
    (problem,) = sdf_value_problems(broken, bundled_build / "models")
    assert "no value rule for <gravity_scale>" in problem


def test_a_broken_value_in_any_file_fails_the_build_check_and_a_new_structure_meets_the_reference_parser(
    bundled_build: Path, tmp_path: Path
) -> None:
    """Two of the frame's nine columns, neither the one the reference parser reads for their structure: a
    negative mass in one fails the value check; a joint to no link in the other makes its structure new, so
    the reference parser reads it too and refuses it."""
    build = tmp_path / "build"
    shutil.copytree(bundled_build, build, symlinks=True)
    manifest = read_manifest(build)
    files = [build / c.files.sdf_file for c in manifest.components] + [build / manifest.world_file]
    columns = [build / c.files.sdf_file for c in manifest.components if c.ifc_class == "IfcColumn"]
    sampled = one_file_per_structure(files)
    assert build / manifest.world_file in sampled and len(sampled) < len(files) / 3
    light, jointed = [path for path in columns if path not in sampled][:2]
    _break(light, r"<mass>[^<]*</mass>", "<mass>-1.0</mass>", light)
    joint = '</link><joint name="j" type="fixed"><parent>nowhere</parent><child>x</child></joint>'
    _break(jointed, r"</link>", joint, jointed)
    assert jointed in one_file_per_structure(files) and light not in one_file_per_structure(files)
    checked = sdf_check_files(files, build / "models")
    assert {path for path, answer in checked.items() if answer != "Valid."} == {light, jointed}
    assert "value check:" in checked[light] and "is not positive" in checked[light]
    assert "reference parser:" not in checked[light]
    assert "reference parser:" in checked[jointed] and "not found in model" in checked[jointed]
