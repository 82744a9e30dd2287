"""A roof panel on a pitch is fastened down, not left on friction (services/converter/face_slope.py,
connection_kinds.py); a wall drawn into the roof it carries bears it (overlaps.Overlap.bottoms_under_m)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from component_boxes import box_component
from scipy.spatial.transform import Rotation

from bimbot.services.converter.connection_kinds import decide_connections
from bimbot.services.converter.face_slope import face_slope_deg
from bimbot.services.converter.overlaps import Overlap
from bimbot.shared.connection_kinds import ConnectionKind
from bimbot.shared.manifest import Component
from bimbot.shared.methods_file import load_methods


def _plate(pitch_deg: float, *, flip: bool = False) -> trimesh.Trimesh:
    plate = trimesh.creation.box(extents=(2.4, 5.4, 0.2))
    plate.apply_transform(trimesh.transformations.rotation_matrix(np.radians(pitch_deg), (1, 0, 0)))
    if flip:  # every face wound the other way: the normals point inward
        plate = trimesh.Trimesh(plate.vertices, plate.faces[:, ::-1], process=False)
    return plate


@pytest.mark.parametrize("pitch_deg", [0.0, 3.0, 14.0, 35.0])
def test_the_face_slope_of_a_plate_is_its_pitch_whichever_way_its_faces_are_wound(pitch_deg: float) -> None:
    """Steeper than 30°, its edges count among its broad faces too: within a degree."""
    for flip in (False, True):
        slope = face_slope_deg(_plate(pitch_deg, flip=flip), np.eye(3))
        assert slope == pytest.approx(pitch_deg, abs=0.01 if pitch_deg < 30.0 else 1.0)


def test_the_face_slope_is_taken_in_the_world_through_the_component_rotation() -> None:
    """A plate flat in its own frame, turned 14° by its placement, lies at 14° in the world."""
    rotation = Rotation.from_euler("x", 14.0, degrees=True).as_matrix()
    assert face_slope_deg(_plate(0.0), rotation) == pytest.approx(14.0, abs=0.01)
    wall = trimesh.creation.box(extents=(4.0, 0.2, 2.5))  # its broad faces stand upright: top and bottom
    assert face_slope_deg(wall, np.eye(3)) == pytest.approx(0.0, abs=1e-9)


def _house(slope_deg: float, roof_class: str = "IfcSlab") -> tuple[Component, Component]:
    wall = box_component("wall", (6.0, 0.2, 2.5), (0.0, 0.0, 0.0))
    wall = wall.model_copy(update={"ifc_class": "IfcWall"})
    roof = box_component("roof", (2.4, 5.4, 1.4), (0.0, -0.2, 2.5))
    roof = roof.model_copy(update={"ifc_class": roof_class, "face_slope_deg": slope_deg})
    return wall, roof


def _kinds(wall: Component, roof: Component) -> dict[str, ConnectionKind]:
    methods = load_methods()
    (decided,) = decide_connections([roof], [wall, roof], [], methods.connections, methods.temporary_supports)
    return {link.other_guid: link.kind for link in decided.connection_links}


def test_a_roof_panel_on_a_pitch_is_fastened_to_its_wall_and_a_level_one_bears_on_it() -> None:
    assert _kinds(*_house(14.0)) == {"wall": ConnectionKind.FASTENED}
    assert _kinds(*_house(2.0)) == {"wall": ConnectionKind.BEARING}  # a flat roof's fall
    assert _kinds(*_house(14.0, "IfcBeam")) == {"wall": ConnectionKind.FASTENED}  # a rafter on its plate
    # a window's sloped sill says nothing of how it is seated
    assert _kinds(*_house(7.0, "IfcWindow")) == {"wall": ConnectionKind.BEARING}


def test_the_fastened_time_comes_from_the_methods_file() -> None:
    methods = load_methods()
    wall, roof = _house(14.0)
    (decided,) = decide_connections([roof], [wall, roof], [], methods.connections, methods.temporary_supports)
    assert decided.connection_links[0].time_s == methods.connections.fastened_s > 0.0


def _box(low: tuple[float, float, float], high: tuple[float, float, float]) -> np.ndarray:
    corners = zip(low, high, strict=True)
    return np.array(np.meshgrid(*corners, indexing="ij")).reshape(3, -1).T


def test_a_wall_drawn_into_its_roof_with_the_lintel_over_a_window_reaches_lower_than_the_roof() -> None:
    """The wall's lintel, 2.42 m up, penetrates the roof panel whose underside lies at 2.40 m; under the
    lintel the wall goes on to the ground beside its window. The wall bears the roof."""
    lintel = _box((0.0, 0.0, 2.42), (1.0, 0.2, 2.6))
    pier = _box((-0.5, 0.0, 0.0), (0.3, 0.2, 2.42))  # reaches under the overlap at its left
    elsewhere = _box((3.0, 0.0, 0.0), (4.0, 0.2, 2.6))  # another pier, away from the overlap
    roof = _box((-1.0, -0.5, 2.40), (2.0, 0.5, 2.60))
    overlap = Overlap(
        first="roof",
        second="wall",
        depth_m=0.18,
        part_pairs=((roof, lintel),),
        first_parts=(roof,),
        second_parts=(lintel, pier, elsewhere),
    )
    assert overlap.bottoms_under_m() == (2.4, 0.0)
    only_penetrating = Overlap("roof", "wall", 0.18, ((roof, lintel),))  # no parts given: as it penetrates
    assert only_penetrating.bottoms_under_m() == (2.4, 2.42)
