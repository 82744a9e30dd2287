"""Shards (services/converter/shards.py): how elements are split between worker processes, and that a
conversion in several processes writes what one process writes."""

from __future__ import annotations

import filecmp
from collections import Counter
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.type
import pytest
from ifc_builders import SmallModel, new_model, place, translation

from bimbot.services.converter import convert as convert_module
from bimbot.services.converter import shards
from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.ifc_input import open_model
from bimbot.services.converter.selection import select_elements
from bimbot.services.converter.shards import geometry_group, plan_shards
from bimbot.shared.manifest import Manifest

GROUPS = ((10, 5.0), (9, 3.0), (9, 2.0))  # (beams, length m) per beam type: three mapped geometries


def typed_beams(small: SmallModel) -> None:
    """28 beams of three types whose bodies map their type's representation (as a frame's members do)."""
    model = small.file
    for index, (count, length_m) in enumerate(GROUPS):
        beam_type = ifcopenshell.api.root.create_entity(model, ifc_class="IfcBeamType", name=f"T{index}")
        profile = model.create_entity("IfcRectangleProfileDef", ProfileType="AREA", XDim=200.0, YDim=400.0)
        body = ifcopenshell.api.geometry.add_profile_representation(
            model, context=small.body, profile=profile, depth=length_m
        )
        ifcopenshell.api.geometry.assign_representation(model, product=beam_type, representation=body)
        beams = []
        for number in range(count):
            beam = ifcopenshell.api.root.create_entity(model, ifc_class="IfcBeam", name=f"B{index}-{number}")
            beams.append(place(small, beam, translation(6.0 * number, 3.0 * index, 0.0), small.storey))
        ifcopenshell.api.type.assign_type(model, related_objects=beams, relating_type=beam_type)


@pytest.fixture(scope="module")
def model_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    small = new_model()
    typed_beams(small)
    path = tmp_path_factory.mktemp("typed") / "typed_beams.ifc"
    small.file.write(str(path))
    return path


@pytest.fixture(scope="module")
def frame_elements(model_file: Path) -> list[ifcopenshell.entity_instance]:
    return list(select_elements(ifcopenshell.open(str(model_file))).elements)


def test_elements_mapping_one_representation_are_one_geometry_group(
    frame_elements: list[ifcopenshell.entity_instance],
) -> None:
    assert sorted(Counter(geometry_group(e) for e in frame_elements).values()) == [9, 9, 10]


@pytest.mark.parametrize("count", [1, 2, 3, 6, 28, 40])
def test_every_element_is_in_exactly_one_shard(
    frame_elements: list[ifcopenshell.entity_instance], count: int
) -> None:
    planned = plan_shards(frame_elements, count)
    ids = [step_id for shard in planned for step_id in shard]
    assert sorted(ids) == sorted(e.id() for e in frame_elements)
    assert len(planned) <= count and all(shard == sorted(shard) for shard in planned)


def test_groups_that_fit_a_share_stay_whole(frame_elements: list[ifcopenshell.entity_instance]) -> None:
    group_of = {e.id(): geometry_group(e) for e in frame_elements}
    planned = plan_shards(frame_elements, 3)  # a share is 10: every group fits
    assert sorted(len(shard) for shard in planned) == [9, 9, 10]
    assert all(len({group_of[step_id] for step_id in shard}) == 1 for shard in planned)


def test_a_group_larger_than_a_share_is_cut_so_workers_stay_busy(
    frame_elements: list[ifcopenshell.entity_instance],
) -> None:
    planned = plan_shards(frame_elements, 6)  # a share is 5: each group of 9-10 is cut in two
    sizes = sorted(len(shard) for shard in planned)
    assert len(planned) == 6 and sizes[-1] - sizes[0] <= 1


def _files(folder: Path) -> list[str]:
    return [path.relative_to(folder).as_posix() for path in folder.rglob("*") if path.is_file()]


def _files(folder: Path) -> list[str]:
    return [path.relative_to(folder).as_posix() for path in folder.rglob("*") if path.is_file()]


def _convert(source: Path, out: Path, threads: int) -> Manifest:
    return convert_model(open_model(source), source, out, ConvertOptions(threads=threads))


def test_several_processes_write_what_one_process_writes(
    model_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(shards, "MIN_ELEMENTS_PER_WORKER", 8)  # fork for these 28 elements
    monkeypatch.setattr(shards, "MIN_ELEMENTS_PER_SHARD", 4)  # six shards for two workers: cut groups
    results: list[int] = []
    run_shards = convert_module.run_shards

    def counted(*args: object, **kwargs: object) -> list[shards.ShardResult]:
        done = run_shards(*args, **kwargs)
        results.append(len(done))
        return done

    monkeypatch.setattr(convert_module, "run_shards", counted)
    one, two = _convert(model_file, tmp_path / "one", 1), _convert(model_file, tmp_path / "two", 2)
    assert results == [1, 6] and len(one.components) == 28
    assert one.model_dump(exclude={"source"}) == two.model_dump(exclude={"source"})
    for component in one.components:
        folder_one = tmp_path / "one" / component.files.model_dir
        folder_two = tmp_path / "two" / component.files.model_dir
        names = sorted(_files(folder_one))
        assert names == sorted(_files(folder_two)), component.guid
        _, mismatch, errors = filecmp.cmpfiles(folder_one, folder_two, names, shallow=False)
        assert not mismatch and not errors, (component.guid, mismatch, errors)
    assert filecmp.cmp(tmp_path / "one" / one.world_file, tmp_path / "two" / two.world_file, shallow=False)
