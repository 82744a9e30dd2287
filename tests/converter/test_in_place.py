"""``convert --in-place``: components in place before the robots come are converted but listed apart.

The Revit hub's foundations (a 49 t ground slab, 3–11 t footings) are heavier than any robot: without
them in place a run built 3 of 115, everything else ``blocked_by`` them. Here on the generated 2×1 frame
(two footings in the ground, two columns, a beam), with the command's ``main`` in this process, and a token
it does not know with the real command (tests/converter/cli_runs.py).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from cli_runs import Ended, bimbot_in_process, bimbot_process

from bimbot.data.light_steel_frame import build_light_steel_frame
from bimbot.services.converter.in_place import above_ground, in_the_ground, named_existing, split_in_place
from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.sequence import read_sequence


@pytest.fixture(scope="module")
def frame_ifc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    source = tmp_path_factory.mktemp("frame") / "frame.ifc"
    build_light_steel_frame(2, 1).write(str(source))
    return source


Convert = Callable[..., Ended]


@pytest.fixture
def convert(capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture) -> Convert:
    """``convert(source, out, *options)``: ``bimbot convert`` in this process."""

    def run(source: Path, out: Path, *extra: str) -> Ended:
        command = ["convert", str(source), "-o", str(out), "--no-progress", *extra]
        return bimbot_in_process(*command, capfd=capfd, caplog=caplog)

    return run


@pytest.fixture(scope="module")
def plain(frame_ifc: Path, tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    """The frame converted without --in-place, once for the tests that read it: read-only."""
    from bimbot.services.converter.convert import convert_model
    from bimbot.shared.ifc_input import open_model

    return convert_model(open_model(frame_ifc), frame_ifc, tmp_path_factory.mktemp("plain"))


def test_foundations_in_place_are_converted_apart_and_left_out_of_the_sequence(
    frame_ifc: Path, tmp_path: Path, convert: Convert
) -> None:
    result = convert(frame_ifc, tmp_path / "out", "--in-place", "foundations")
    assert result.returncode == 0, result.stderr
    assert (
        "converted 3 component(s) from 5 IFC element(s) (3 as one component each, 2 in place before the "
        "robots come)" in result.stdout
    )
    manifest = read_manifest(tmp_path / "out")
    assert sorted(c.name for c in manifest.in_place) == ["Footing A1", "Footing A2"]
    assert {(c.method, c.method_source, c.method_note) for c in manifest.in_place} == {
        (ConstructionMethod.IN_PLACE, MethodSource.USER, "convert --in-place")
    }
    assert sorted(c.ifc_class for c in manifest.components) == ["IfcBeam", "IfcColumn", "IfcColumn"]
    sequence = read_sequence(tmp_path / "out" / manifest.sequence_file)
    assert sorted(sequence.guids()) == sorted(c.guid for c in manifest.components)
    # converted like any other: physics builds them from their collision parts
    assert all((tmp_path / "out" / c.files.collision[0]).is_file() for c in manifest.in_place)


def test_in_place_takes_classes_and_global_ids_and_names_a_token_it_does_not_know(
    frame_ifc: Path, tmp_path: Path, convert: Convert
) -> None:
    by_class = convert(frame_ifc, tmp_path / "a", "--in-place", "IfcFooting")
    assert by_class.returncode == 0, by_class.stderr
    footings = read_manifest(tmp_path / "a").in_place
    assert sorted(c.name for c in footings) == ["Footing A1", "Footing A2"]
    column = next(c for c in read_manifest(tmp_path / "a").components if c.ifc_class == "IfcColumn")
    standing = convert(frame_ifc, tmp_path / "b", "--in-place", column.guid)
    assert standing.returncode == 0, standing.stderr
    assert [c.guid for c in read_manifest(tmp_path / "b").in_place] == [column.guid]
    # a column stands above the ground: the robots' maps do not know it, and the user is told
    assert "reach above the ground" in standing.stdout and column.name in standing.stdout
    command = ["convert", str(frame_ifc), "-o", str(tmp_path / "c"), "--in-place", "foundation"]
    unknown = bimbot_process(*command)
    assert unknown.returncode == 2 and "Traceback" not in unknown.stderr
    assert len(unknown.stderr.strip().splitlines()) == 1
    assert (
        "--in-place: neither an IFC class of IFC4 nor the GlobalId of an element in the model: foundation"
        in (unknown.stderr)
    )


def test_every_component_in_place_leaves_nothing_to_build_and_says_so(
    frame_ifc: Path, tmp_path: Path, convert: Convert
) -> None:
    result = convert(frame_ifc, tmp_path / "out", "--in-place", "IfcFooting,IfcColumn,IfcBeam")
    assert result.returncode == 1
    assert "every component converted is in place (--in-place): nothing is left to build" in result.stderr


def test_split_in_place_keeps_the_order_and_the_ground_rule(plain: Manifest) -> None:
    manifest = plain
    beam = next(c for c in manifest.components if c.ifc_class == "IfcBeam")
    build, in_place = split_in_place(manifest.components, [beam.guid], foundations=True)
    assert [c.guid for c in build] == [c.guid for c in manifest.components if c.ifc_class == "IfcColumn"]
    assert [c.guid for c in in_place] == [
        c.guid for c in manifest.components if c.ifc_class == "IfcFooting" or c.guid == beam.guid
    ]
    assert [c.guid for c in above_ground(in_place)] == [beam.guid]
    assert all(in_the_ground(c) for c in in_place if c.ifc_class == "IfcFooting")


def test_foundations_reach_below_the_ground_a_sill_flush_with_it_is_no_foundation(plain: Manifest) -> None:
    """A trial's first rule (the top at most 5 cm above the ground) also took the Revit house's four 9 kg
    curtain-wall sills, 0–5 cm high, and a robot got stuck on one (the robots' maps leave in-place
    components out). A foundation also reaches below the ground."""
    column = next(c for c in plain.components if c.ifc_class == "IfcColumn")
    box = column.bbox_world

    def spanning(low_z: float, high_z: float):
        world = box.model_copy(update={"min_m": (*box.min_m[:2], low_z), "max_m": (*box.max_m[:2], high_z)})
        return column.model_copy(update={"bbox_world": world})

    assert not in_the_ground(spanning(0.0, 0.05))  # a sill on the ground
    assert in_the_ground(spanning(-0.56, 0.0))  # a thickened slab
    assert in_the_ground(spanning(-0.5, -0.13))  # a footing below a slab
    assert not in_the_ground(spanning(-0.3, 3.0))  # a column set into its footing stands above it


def test_a_component_named_existing_is_pointed_out_as_perhaps_in_place(plain: Manifest) -> None:
    """The Revit hub's "Existing Strip Footing" states no status or phase: it was cast as new work, first
    in a chain of cures. The converter names it and the --in-place that would take it as existing."""
    column = plain.components[0]
    existing = column.model_copy(update={"name": "Existing Strip Footing:Existing Strip Footing:682677"})
    unnamed = column.model_copy(update={"name": "Coexisting"})  # a word of its own only
    assert named_existing([existing, unnamed, column]) == [existing]
    in_place = existing.model_copy(update={"method": ConstructionMethod.IN_PLACE})
    assert named_existing([in_place]) == []
