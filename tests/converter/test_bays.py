"""A cast slab larger than one day's pour is poured in bays: a grid in plan, each bay within the day's pour
and a cast-in-place component of its own (its formwork with the stop ends), the element listed with its
bays and construction joints, built when all its bays are (tiny models, real converter)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from ifc_builders import add_box, add_material, new_model

from bimbot.services.converter.bays import split_into_bays
from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.mesh import TriMesh
from bimbot.services.converter.panel_writer import panel_guid
from bimbot.services.converter.panelise import PanelisationError
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest
from bimbot.shared.methods_file import CastInPlace, MethodsFile, load_methods
from bimbot.shared.report.methods import panelised_elements

CAST = ConstructionMethod.CAST_IN_PLACE


def _box_mesh(size_m: tuple[float, float, float]) -> TriMesh:
    box = trimesh.creation.box(extents=size_m)
    return TriMesh(np.asarray(box.vertices) + np.array(size_m) / 2.0, np.asarray(box.faces))


def test_a_slab_is_cut_into_the_fewest_squarest_bays_within_the_days_pour() -> None:
    # 30 x 20 x 0.5 m = 300 m³ at 60 m³ a day: 5 bays at least; 6 (3 x 2) are square, 5 would be strips
    cut = split_into_bays(_box_mesh((30.0, 20.0, 0.5)), 720_000.0, 60.0)
    assert len(cut.panels) == 6
    assert cut.volumes_m3 == pytest.approx([50.0] * 6)
    assert sum(cut.masses_kg) == pytest.approx(720_000.0)
    for mesh in cut.panels:
        extents = np.ptp(mesh.vertices, axis=0)
        assert extents == pytest.approx([10.0, 10.0, 0.5])
    # 3 x 2 grid: 2 joints across each row of 3, 3 between the rows, each 10 m long
    assert len(cut.joints) == 7
    assert {joint.kind for joint in cut.joints} == {"construction"}
    assert [joint.length_m for joint in cut.joints] == pytest.approx([10.0] * 7)
    assert "poured in 6 bays (3 × 2 in plan, 10.0 × 10.0 m), 50.0 m³ at most" in cut.why


def test_a_slab_within_the_days_pour_is_one_bay_and_an_impossible_day_says_why() -> None:
    assert len(split_into_bays(_box_mesh((4.0, 3.0, 0.2)), 5760.0, 10.0).panels) == 1
    with pytest.raises(PanelisationError, match="no grid of up to 400 bays"):
        split_into_bays(_box_mesh((4.0, 3.0, 0.2)), 5760.0, 0.001)


def _small_day() -> MethodsFile:
    """The prefab preset with a day's pour of 20 m³ (1.5 h less the 0.5 h setup, at 20 m³/h)."""
    methods = load_methods()
    rates = methods.cast_in_place.model_copy(update={"pour_day_h": 1.5})
    return methods.model_copy(update={"cast_in_place": rates})


def _convert(tmp_path: Path, methods: MethodsFile) -> Manifest:
    small = new_model()
    slab = add_box(small, "IfcSlab", "Ground slab", size_m=(10.0, 6.0, 0.5), corner_m=(0.0, 0.0, -0.5))
    add_material(small, [slab], "C30/37")
    add_box(small, "IfcSlab", "Path", size_m=(3.0, 2.0, 0.2), corner_m=(12.0, 0.0, -0.2))
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    options = ConvertOptions(methods=methods, formats=(), split_ifc=False)
    return convert_model(open_model(source), source, tmp_path / "out", options)


def test_a_ground_slab_over_a_days_pour_becomes_bays_each_cast_with_its_stop_ends(tmp_path: Path) -> None:
    manifest = _convert(tmp_path, _small_day())
    slab_guid = next(entry.guid for entry in manifest.panelised)
    bays = [c for c in manifest.components if c.parent_guid == slab_guid]
    # 30 m³ at 20 m³ a day: two bays of 5 x 6 m, each 15 m³
    assert [c.name for c in bays] == ["Ground slab bay 1/2", "Ground slab bay 2/2"]
    assert [c.guid for c in bays] == [panel_guid(slab_guid, 0), panel_guid(slab_guid, 1)]
    for bay in bays:
        assert bay.method is CAST and bay.cast is not None
        assert bay.cast.volume_m3 == pytest.approx(15.0)
        # on the soil: no soffit; its three edges and the stop end at the joint, 0.5 m high
        assert bay.cast.formwork_area_m2 == pytest.approx((5.0 + 6.0 + 5.0 + 6.0) * 0.5)
        assert bay.cast.pour_s == pytest.approx((0.5 + 15.0 / 20.0) * 3600)
        assert bay.mass_kg == pytest.approx(15.0 * 2400.0, rel=0.05)
        note = "30.0 m³, more than one day's pour of 20 m³ (1 h of pouring): poured in 2 bays"
        assert note in bay.method_note
    (entry,) = manifest.panelised
    assert entry.method is CAST and entry.name == "Ground slab"
    assert entry.panel_guids == tuple(c.guid for c in bays)
    (joint,) = entry.joints
    assert (joint.kind, joint.length_m) == ("construction", pytest.approx(6.0))
    # a slab within the day's pour is cast whole, and the element is no component
    path = next(c for c in manifest.components if c.name == "Path")
    assert path.method is CAST and path.parent_guid is None
    assert slab_guid not in {c.guid for c in manifest.components}
    # the report: the slab is built once both bays are
    rows = [{"guid": c.guid, "state": "constructed", "constructed_s": 10.0 * i} for i, c in enumerate(bays)]
    rows[1]["state"] = "planned"
    (element,) = panelised_elements(manifest, rows)
    assert (element["method"], element["panels_constructed"], element["constructed"]) == (
        "cast_in_place",
        1,
        False,
    )
    rows[1]["state"] = "constructed"
    assert panelised_elements(manifest, rows)[0]["constructed"] is True


def test_with_the_default_days_pour_the_same_slab_is_cast_whole(tmp_path: Path) -> None:
    manifest = _convert(tmp_path, load_methods())
    assert manifest.panelised == []
    assert [c.name for c in manifest.components if c.method is CAST] == ["Ground slab", "Path"]


def test_a_day_no_longer_than_the_pours_setup_is_refused() -> None:
    rates = load_methods().cast_in_place.model_dump()
    with pytest.raises(ValueError, match="pour_day_h"):
        CastInPlace.model_validate({**rates, "pour_day_h": 0.5})
    assert load_methods().cast_in_place.day_pour_m3("IfcSlab") == pytest.approx((8.0 - 0.5) * 20.0)
