"""Converter inputs: schemas, length units, awkward names, class filters, unmeshable and broken files."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import numpy as np
import pytest
from cli_runs import Ended, bimbot_in_process, bimbot_process
from ifc_builders import SmallModel, add_beam, add_wall, new_model, translation

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.shared.manifest import Manifest

BROKEN = Path(__file__).parent / "broken"


def _convert_small(small: SmallModel, tmp_path: Path, options: ConvertOptions | None = None) -> Manifest:
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    return convert_model(ifcopenshell.open(str(source)), source, tmp_path / "out", options)


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4", "IFC4X3"])
def test_every_supported_schema_converts(schema: str, tmp_path: Path) -> None:
    small = new_model(schema)
    add_beam(small, "B1", matrix_m=translation(1.0, 2.0, 0.5))
    manifest = _convert_small(small, tmp_path)
    (component,) = manifest.components
    assert manifest.source.schema_name.startswith(schema)
    assert component.target_pose_world.position_m == pytest.approx((1.0, 2.0, 0.5))
    split = ifcopenshell.open(str(tmp_path / "out" / component.files.split_ifc))
    assert split.schema_identifier == small.file.schema_identifier


@pytest.mark.parametrize(
    ("unit", "prefix_or_name", "metres_per_unit"),
    [("si", None, 1.0), ("si", "MILLI", 0.001), ("imperial", "foot", 0.3048)],
)
def test_length_units_are_converted_to_metres_once(
    unit: str, prefix_or_name: str | None, metres_per_unit: float, tmp_path: Path
) -> None:
    small = new_model()
    if unit == "si":
        length = ifcopenshell.api.unit.add_si_unit(small.file, unit_type="LENGTHUNIT", prefix=prefix_or_name)
    else:
        length = ifcopenshell.api.unit.add_conversion_based_unit(small.file, name=prefix_or_name)
    ifcopenshell.api.unit.assign_unit(small.file, units=[length])
    beam = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcBeam", name="B")
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=10.0, height=2.0, thickness=1.0
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=beam, representation=body)
    matrix = translation(100.0, 0.0, 0.0)  # in file units: the api writes matrices as given
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=beam, matrix=matrix, is_si=False)
    ifcopenshell.api.spatial.assign_container(small.file, products=[beam], relating_structure=small.storey)
    manifest = _convert_small(small, tmp_path)
    (component,) = manifest.components
    assert manifest.source.length_unit_m == pytest.approx(metres_per_unit)
    assert component.target_pose_world.position_m[0] == pytest.approx(100.0 * metres_per_unit)
    size = np.array(component.bbox_local.max_m) - np.array(component.bbox_local.min_m)
    assert sorted(size) == pytest.approx(sorted([10.0, 2.0, 1.0]), rel=1e-6)  # the api sizes are in metres


def test_unicode_slashes_and_quotes_in_names_never_reach_paths(tmp_path: Path) -> None:
    small = new_model()
    small.site.Name = 'Baustelle "Süd"/../x'
    add_wall(small, 'Wand "Süd"/1 \\ ✓')
    manifest = _convert_small(small, tmp_path)
    (component,) = manifest.components
    assert component.name == 'Wand "Süd"/1 \\ ✓'
    for path in (tmp_path / "out").rglob("*"):
        relative = path.relative_to(tmp_path / "out").as_posix()
        assert relative.isascii() and '"' not in relative and "\\" not in relative and ".." not in relative
    assert manifest.world_file == "worlds/baustelle-sud-x.world"


def test_only_and_exclude_filter_by_class_with_subclasses(tmp_path: Path) -> None:
    small = new_model()
    add_wall(small, "W")
    add_beam(small, "B")
    add_beam(small, "M", schema_class="IfcMember")
    only_walls = _convert_small(small, tmp_path / "a", ConvertOptions(only=("IfcWall",)))
    assert [c.name for c in only_walls.components] == ["W"]
    no_beams = _convert_small(small, tmp_path / "b", ConvertOptions(exclude=("IfcBeam",)))
    assert sorted(c.name for c in no_beams.components) == ["M", "W"]


def test_curve_only_element_is_skipped_with_its_reason_and_the_rest_converts(tmp_path: Path) -> None:
    small = new_model()
    add_beam(small, "Beam")
    weld = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcFastener", name="Weld seam")
    points = [small.file.createIfcCartesianPoint(p) for p in ((0.0, 0.0, 0.0), (1000.0, 0.0, 0.0))]
    curve = small.file.createIfcPolyline(points)
    representation = small.file.createIfcShapeRepresentation(small.body, "Body", "Curve3D", [curve])
    weld.Representation = small.file.createIfcProductDefinitionShape(None, None, [representation])
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=weld, matrix=translation())
    ifcopenshell.api.spatial.assign_container(small.file, products=[weld], relating_structure=small.storey)
    manifest = _convert_small(small, tmp_path)
    assert [c.name for c in manifest.components] == ["Beam"]
    (skipped,) = manifest.skipped
    assert skipped.name == "Weld seam" and skipped.ifc_class == "IfcFastener"
    assert "cannot be meshed" in skipped.reason or "could not build" in skipped.reason


def test_cli_converts_and_prints_a_summary(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    small = new_model()
    add_wall(small, "W")
    source = tmp_path / "m.ifc"
    small.file.write(str(source))

    def bimbot(*args: str) -> Ended:
        return bimbot_in_process(*args, capfd=capfd, caplog=caplog)

    result = bimbot("convert", str(source), "-o", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    assert "converted 1 component(s), skipped 0" in result.stdout
    assert "sequence sequence.xml derived from the structure" in result.stdout  # no schedule in the file
    assert (tmp_path / "out" / "manifest.json").is_file()
    assert "earlier conversion" not in result.stderr
    # converting again into a folder that holds runs keeps them, and says they are of the earlier conversion
    (tmp_path / "out" / "runs" / "20261127-120000").mkdir(parents=True)
    again = bimbot("convert", str(source), "-o", str(tmp_path / "out"))
    assert again.returncode == 0, again.stderr
    assert "out/runs/ holds 1 run(s) of an earlier conversion into this folder" in again.stderr
    assert (tmp_path / "out" / "runs" / "20261127-120000").is_dir()


UNREADABLE = [
    ("missing.ifc", "no such file"),
    ("empty.ifc", "empty file"),
    ("not_ifc.ifc", "not an IFC file"),
    ("truncated.ifc", "truncated IFC file"),
    # cut inside an entity, its end markers added back: the parser's log says where
    (
        "cut_mid_entity.ifc",
        "cut_mid_entity.ifc line 22: not a readable IFC file: '0.ENDSEC' is no valid STEP",
    ),
    ("unsupported_schema.ifc", "unsupported IFC schema"),
    # one instance's brackets left open: the parser swallows the rest and names only the end markers
    ("unclosed_bracket.ifc", "unclosed_bracket.ifc line 22: not a readable IFC file: the brackets of this"),
]


def _one_clear_line(result: Ended, name: str, message: str) -> None:
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and name in lines[0], result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(("name", "message"), UNREADABLE)
def test_unreadable_input_gives_one_clear_line_and_exit_2(
    name: str,
    message: str,
    tmp_path: Path,
    capfd: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    result = bimbot_in_process(
        "convert", str(BROKEN / name), "-o", str(tmp_path / "out"), capfd=capfd, caplog=caplog
    )
    _one_clear_line(result, name, message)


def test_a_zipped_model_is_told_to_be_unzipped(tmp_path: Path) -> None:
    """The Janesville restaurant ships as a .zip: "not an IFC file" gave no hint what to do."""
    import zipfile

    archive = tmp_path / "model.zip"
    with zipfile.ZipFile(archive, "w") as packed:
        packed.write(BROKEN / "duplicate_guids.ifc", "model.ifc")
    result = bimbot_process("convert", str(archive), "-o", str(tmp_path / "out"))
    _one_clear_line(result, "model.zip", "a zip archive, not an IFC file: unzip it")


def test_the_real_command_says_a_truncated_file_in_one_line_and_exits_2(tmp_path: Path) -> None:
    """A process of its own, for a file ifcopenshell's parser reads part of: nothing else on stderr."""
    result = bimbot_process("convert", str(BROKEN / "truncated.ifc"), "-o", str(tmp_path / "out"))
    _one_clear_line(result, "truncated.ifc", "truncated IFC file")


def test_model_without_geometry_reports_every_element_and_exits_2(tmp_path: Path) -> None:
    """Nothing in it can be built: unusable input (exit 2), as the README's exit codes say."""
    result = bimbot_process("convert", str(BROKEN / "no_geometry.ifc"), "-o", str(tmp_path / "out"))
    assert result.returncode == 2
    assert "no element could be converted" in result.stderr and "Traceback" not in result.stderr


def test_duplicate_guid_converts_the_first_and_skips_the_second_with_the_reason(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    out = str(tmp_path / "out")
    result = bimbot_in_process(
        "convert", str(BROKEN / "duplicate_guids.ifc"), "-o", out, capfd=capfd, caplog=caplog
    )
    assert result.returncode == 0, result.stderr
    assert "converted 1 component(s), skipped 1" in result.stdout
    manifest = Manifest.model_validate_json((tmp_path / "out" / "manifest.json").read_text())
    assert manifest.skipped[0].reason.startswith("duplicate GlobalId")
    assert manifest.skipped[0].name == "Wall 2" and manifest.components[0].name == "Wall 1"


def test_unknown_class_in_include_is_a_user_error(tmp_path: Path) -> None:
    result = bimbot_process(
        "convert", str(BROKEN / "duplicate_guids.ifc"), "-o", str(tmp_path / "o"), "--include", "IfcWal"
    )
    assert result.returncode == 2 and "unknown IFC class" in result.stderr and "IfcWal" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr


def test_the_command_imports_neither_trimesh_nor_scipy_until_a_step_needs_them() -> None:
    """They cost a command about a second of imports (half of a user error's answer): the converter imports
    them where a step uses them (a bar's oriented box, an overlap's plan area, a flat mesh)."""
    code = (
        "import sys, bimbot.services.converter.cli, bimbot.services.converter.convert;"
        "print(sorted({name.split('.')[0] for name in sys.modules} & {'trimesh', 'scipy'}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
