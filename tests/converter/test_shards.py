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
import numpy as np
import pytest
from ifc_builders import SmallModel, add_beam, new_model, place, translation

from bimbot.services.converter import convert as convert_module
from bimbot.services.converter import shards
from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.selection import select_elements
from bimbot.services.converter.shards import geometry_group, plan_shards, representation_size
from bimbot.shared.ifc_input import open_model
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


def polygon_profile(model: ifcopenshell.file, corners: int) -> ifcopenshell.entity_instance:
    """A closed profile of ``corners`` points on a 200 × 400 mm ellipse: a representation of many parts."""
    angles = np.linspace(0.0, 2.0 * np.pi, corners, endpoint=False)
    points = [
        model.create_entity("IfcCartesianPoint", Coordinates=(100.0 * np.cos(a), 200.0 * np.sin(a)))
        for a in angles
    ]
    curve = model.create_entity("IfcPolyline", Points=[*points, points[0]])
    return model.create_entity("IfcArbitraryClosedProfileDef", ProfileType="AREA", OuterCurve=curve)


def mixed_elements(plain: int, heavy_group: int) -> tuple[list[ifcopenshell.entity_instance], list[int]]:
    """``plain`` beams of their own small geometry, then ``heavy_group`` beams mapping one type's
    400-corner section (one heavy beam without a type when ``heavy_group`` is 1); and the heavy ids."""
    small = new_model()
    model = small.file
    for number in range(plain):
        add_beam(
            small, f"plain-{number}", length_m=2.0 + 0.1 * number, matrix_m=translation(0.0, number, 0.0)
        )
    body = ifcopenshell.api.geometry.add_profile_representation(
        model, context=small.body, profile=polygon_profile(model, 400), depth=3.0
    )
    heavy = []
    for number in range(heavy_group):
        beam = ifcopenshell.api.root.create_entity(model, ifc_class="IfcBeam", name=f"heavy-{number}")
        heavy.append(place(small, beam, translation(10.0, number, 0.0), small.storey))
    if heavy_group == 1:
        ifcopenshell.api.geometry.assign_representation(model, product=heavy[0], representation=body)
    else:
        beam_type = ifcopenshell.api.root.create_entity(model, ifc_class="IfcBeamType", name="heavy")
        ifcopenshell.api.geometry.assign_representation(model, product=beam_type, representation=body)
        ifcopenshell.api.type.assign_type(model, related_objects=heavy, relating_type=beam_type)
    return list(select_elements(model).elements), [beam.id() for beam in heavy]


def test_the_costliest_element_is_a_shard_of_its_own_and_handed_out_first() -> None:
    elements, (heavy,) = mixed_elements(plain=20, heavy_group=1)
    assert representation_size(next(e for e in elements if e.id() == heavy)) > 400
    planned = plan_shards(elements, 6, workers=2)
    assert planned[0] == [heavy]  # a 0.2 s element handed out last would idle the other worker
    assert sorted(i for shard in planned for i in shard) == sorted(e.id() for e in elements)
    # before, shards were planned by element count only: the heavy beam was one member of an equal shard
    assert max(len(shard) for shard in planned[1:]) <= 4


def test_a_costly_group_within_a_workers_share_is_not_cut() -> None:
    """Cutting would decompose its heavy geometry once per piece (the Revit house's windows: 0.29 s)."""
    elements, heavy = mixed_elements(plain=30, heavy_group=6)
    planned = plan_shards(elements, 6, workers=2)
    assert [shard for shard in planned if set(heavy) & set(shard)] == [sorted(heavy)]
    assert planned[0] == sorted(heavy)


def _files(folder: Path) -> list[str]:
    return [path.relative_to(folder).as_posix() for path in folder.rglob("*") if path.is_file()]


def _convert(source: Path, out: Path, threads: int) -> Manifest:
    return convert_model(open_model(source), source, out, ConvertOptions(threads=threads))


def test_several_processes_write_what_one_process_writes(
    model_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(shards, "MIN_ELEMENTS_PER_WORKER", 8)  # fork for these 28 elements
    monkeypatch.setattr(shards, "MIN_ELEMENTS_PER_SHARD", 4)  # up to nine shards for three workers
    results: list[int] = []
    run_shards = convert_module.run_shards

    def counted(*args: object, **kwargs: object) -> list[shards.ShardResult]:
        done = run_shards(*args, **kwargs)
        results.append(len(done))
        return done

    monkeypatch.setattr(convert_module, "run_shards", counted)
    # three workers: each of the three groups is more than a worker's share, so they are cut
    one, two = _convert(model_file, tmp_path / "one", 1), _convert(model_file, tmp_path / "two", 3)
    assert results[0] == 1 and results[1] > len(GROUPS) and len(one.components) == 28
    assert one.model_dump(exclude={"source"}) == two.model_dump(exclude={"source"})
    for component in one.components:
        folder_one = tmp_path / "one" / component.files.model_dir
        folder_two = tmp_path / "two" / component.files.model_dir
        names = sorted(_files(folder_one))
        assert names == sorted(_files(folder_two)), component.guid
        _, mismatch, errors = filecmp.cmpfiles(folder_one, folder_two, names, shallow=False)
        assert not mismatch and not errors, (component.guid, mismatch, errors)
    assert filecmp.cmp(tmp_path / "one" / one.world_file, tmp_path / "two" / two.world_file, shallow=False)
