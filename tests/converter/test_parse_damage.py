"""A damaged IFC file: what ifcopenshell could not read is named by its line, the element it leaves
incomplete is left out with that reason, and the rest converts (before, a Revit beam whose profile curve was
cut in half converted silently with 570 kg instead of 308 kg)."""

from __future__ import annotations

import json
from pathlib import Path

import ifcopenshell
import pytest
from cli_runs import bimbot_in_process, bimbot_process

from bimbot.data.light_steel_frame import build_light_steel_frame
from bimbot.services.converter.convert import convert_model
from bimbot.services.converter.selection import select_elements
from bimbot.shared.ifc_input import read_model
from bimbot.shared.ifc_parse_damage import damaged_elements


@pytest.fixture
def frame(tmp_path: Path) -> Path:
    path = tmp_path / "frame.ifc"
    build_light_steel_frame(3, 2).write(str(path))
    return path


def _line_of(path: Path, instance_id: int) -> int:
    lines = path.read_text().splitlines()
    return next(n for n, line in enumerate(lines, start=1) if line.startswith(f"#{instance_id}="))


def _cut_in_half(path: Path, line_number: int) -> None:
    lines = path.read_text().splitlines(keepends=True)
    line = lines[line_number - 1]
    lines[line_number - 1] = line[: len(line) // 2] + "\n"
    path.write_text("".join(lines))


def test_a_line_cut_in_half_leaves_out_the_element_it_belongs_to_and_says_where(
    frame: Path, tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    model = ifcopenshell.open(str(frame))
    column = next(c for c in model.by_type("IfcColumn") if c.Name == "Column A2")
    solid = column.Representation.Representations[0].Items[0]
    guid, line = column.GlobalId, _line_of(frame, solid.id())
    total = len(select_elements(model, (), (), ()).elements)
    _cut_in_half(frame, line)

    command = ["convert", str(frame), "-o", str(tmp_path / "out"), "--no-progress"]
    done = bimbot_in_process(*command, capfd=capfd, caplog=caplog)
    assert done.returncode == 0, done.stderr
    # left out before the count of elements to convert (as a new user saw: "49 IFC elements to convert",
    # then "from 58 IFC element(s) (… 9 not converted)"), said skipped with its reason
    assert f"converted {total - 1} component(s), skipped 1 (1 damaged in the file)" in done.stdout
    assert f"frame.ifc line {line}: could not be read" in done.stderr and "Traceback" not in done.stderr
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert guid not in {c["guid"] for c in manifest["components"]}
    (skipped,) = [s for s in manifest["skipped"] if s["guid"] == guid]
    assert skipped["reason"].startswith("damaged in the file:") and f"(line {line})" in skipped["reason"]


def test_a_sound_file_has_no_damage_and_loses_nothing(frame: Path, tmp_path: Path) -> None:
    read = read_model(frame)
    assert not read.damage
    manifest = convert_model(read.model, frame, tmp_path / "out", damage=read.damage)
    assert not manifest.skipped and not manifest.warnings


def test_a_damaged_line_that_costs_the_project_is_named_in_one_line(frame: Path) -> None:
    lines = frame.read_text().splitlines(keepends=True)
    project = next(n for n, line in enumerate(lines) if "IFCPROJECT(" in line)
    lines.insert(project, "#99999=IFCWALL(garbage(((;\n")  # the parser loses its way from here on
    frame.write_text("".join(lines))

    done = bimbot_process("convert", str(frame), "-o", str(frame.parent / "out"))
    assert done.returncode == 2 and "Traceback" not in done.stderr
    (said,) = done.stderr.strip().splitlines()
    assert f"frame.ifc line {project + 1}: not a readable IFC file: the brackets of this instance" in said


def test_a_real_export_s_dangling_references_leave_its_elements_whole(samples_dir: Path) -> None:
    """The Revit hub's window style refers to four instances the file lacks: no element built reaches them."""
    read = read_model(samples_dir / "revit2021_structural_hub.ifc")
    assert len(read.damage.lost) == 4 and not read.damage.unreadable
    elements = select_elements(read.model, (), (), ()).elements
    assert damaged_elements(read.model, read.damage, elements) == {}
