"""Panelisation geometry: where a wall and a slab are cut, openings kept, every panel within the limits."""

from __future__ import annotations

import itertools

import manifold3d
import numpy as np
import pytest

from bimbot.services.converter.mesh import TriMesh, manifold_to_mesh
from bimbot.services.converter.panelise import (
    PANEL_JOINT_M,
    PanelisationError,
    PanelKind,
    PanelLimits,
    panel_kind,
    panelise,
)

LIMITS = PanelLimits(max_mass_kg=4000.0, transport_m=(13.6, 2.55, 3.6))
CONCRETE_KG_M3 = 2400.0
# x ranges of the openings of the test wall: two windows and a door, each where an equal-width cut of six
# panels would fall (17/6 = 2.83 m: cuts at 5.67, 8.50 and 11.33 m)
WINDOWS_X = ((5.0, 6.5), (10.8, 12.3))
DOOR_X = (8.0, 9.0)


def _box(low: tuple[float, float, float], size: tuple[float, float, float]) -> manifold3d.Manifold:
    return manifold3d.Manifold.cube(list(size)).translate(list(low))


def _wall() -> manifold3d.Manifold:
    """17 × 0.2 × 3 m with two windows (1.5 × 1.2 m, sill 0.9 m) and a door (1 × 2.1 m)."""
    wall = _box((0, 0, 0), (17.0, 0.2, 3.0))
    for a, b in WINDOWS_X:
        wall -= _box((a, -0.5, 0.9), (b - a, 1.2, 1.2))
    return wall - _box((DOOR_X[0], -0.5, -0.5), (DOOR_X[1] - DOOR_X[0], 1.2, 2.6))


def _x_ranges(panels: tuple[TriMesh, ...]) -> list[tuple[float, float]]:
    return sorted((float(p.bounds[0, 0]), float(p.bounds[1, 0])) for p in panels)


def test_a_wall_is_cut_into_storey_high_panels_beside_its_openings() -> None:
    wall = _wall()
    mass_kg = CONCRETE_KG_M3 * wall.volume()  # about 23.9 t: six panels at least
    cut = panelise(manifold_to_mesh(wall), PanelKind.WALL, mass_kg, LIMITS)

    assert len(cut.panels) >= 6
    assert max(cut.masses_kg) <= LIMITS.max_mass_kg
    assert sum(cut.masses_kg) == pytest.approx(mass_kg * sum(cut.volumes_m3) / wall.volume())
    assert sum(cut.volumes_m3) == pytest.approx(wall.volume(), rel=0.01)  # less the joints
    assert sum(p.volume for p in cut.panels) == pytest.approx(sum(cut.volumes_m3))
    ranges = _x_ranges(cut.panels)
    # a joint between neighbours (grouted on site): a neighbour set within its tolerance does not push one
    assert [b[0] - a[1] for a, b in itertools.pairwise(ranges)] == pytest.approx(
        [PANEL_JOINT_M] * (len(ranges) - 1)
    )
    cuts = [a for a, _ in ranges[1:]]
    for a, b in (*WINDOWS_X, DOOR_X):  # no cut through an opening, none on its jamb
        assert all(c <= a - 0.09 or c >= b + 0.09 for c in cuts), (cuts, (a, b))
    for panel in cut.panels:
        assert panel.is_volume
        assert panel.extents[2] == pytest.approx(3.0)  # storey-high
        assert LIMITS.fits(panel.extents)
    assert [(j.first, j.second, j.kind) for j in cut.joints] == [
        (i, i + 1, "vertical") for i in range(len(cut.panels) - 1)
    ]
    assert all(j.length_m == pytest.approx(3.0) for j in cut.joints)
    assert "over the 4,000 kg lift capacity" in cut.why


def test_a_wall_rotated_in_its_frame_is_cut_across_its_length_and_at_storey_levels() -> None:
    yaw = np.radians(30.0)
    turn = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    wall = manifold_to_mesh(_box((0, 0, 0), (0.3, 10.0, 6.0)))  # its length along its local y
    mass_kg = CONCRETE_KG_M3 * 18.0  # 43.2 t
    cut = panelise(wall, PanelKind.WALL, mass_kg, LIMITS, rotation=turn, levels_m=[3.0, 6.0])

    assert max(cut.masses_kg) <= LIMITS.max_mass_kg
    heights = {round(float(p.extents[2]), 6) for p in cut.panels}
    assert heights == {3.0}  # cut at the storey level inside it, not at its top
    assert all(p.extents[0] == pytest.approx(0.3) for p in cut.panels)  # never cut along its thickness
    kinds = [j.kind for j in cut.joints]
    columns = len(cut.panels) // 2
    assert kinds.count("horizontal") == columns
    assert kinds.count("vertical") == 2 * (columns - 1)


def test_a_slab_is_cut_into_planks_along_its_span() -> None:
    slab = manifold_to_mesh(_box((0, 0, 0), (7.4, 16.9, 0.3)))  # span: the short side, along x
    yaw = np.radians(20.0)
    turn = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    mass_kg = 37_518.0  # the Revit house's slab, as converted
    cut = panelise(slab, PanelKind.SLAB, mass_kg, LIMITS, rotation=turn)

    assert len(cut.panels) == 10  # 9 planks of 1.88 m would weigh 4,169 kg each
    for plank in cut.panels:  # element frame: the span along x, planks side by side along y
        assert plank.extents[0] == pytest.approx(7.4)
        assert 1.2 <= plank.extents[1] <= 2.4
        assert plank.extents[2] == pytest.approx(0.3)
    assert max(cut.masses_kg) <= LIMITS.max_mass_kg
    assert sum(cut.volumes_m3) == pytest.approx(7.4 * (16.9 - 9 * PANEL_JOINT_M) * 0.3, rel=1e-6)
    assert {j.kind for j in cut.joints} == {"longitudinal"}
    assert len(cut.joints) == 9
    assert all(j.length_m == pytest.approx(7.4, abs=1e-3) for j in cut.joints)
    assert "10 planks along the 7.40 m span" in cut.why


def test_a_ceiling_wider_than_a_truck_is_long_is_cut_into_rows_of_planks_that_fit_one() -> None:
    """The Revit restaurant's acoustical ceiling, 31.1 m × 28.7 m: planks as long as its span (28.7 m) fit no
    truck, so it was lifted whole (5.9 t, out of the crane's reach); its span is cut across into rows that
    fit a truck, each row cut into planks."""
    ceiling = manifold_to_mesh(_box((0, 0, 0), (31.1, 28.7, 0.054)))
    mass_kg = 18.6 * 31.1 * 28.7  # 18.6 kg/m²: gypsum board on a stud layer
    cut = panelise(ceiling, PanelKind.SLAB, mass_kg, LIMITS)

    spans = {round(float(p.extents[1]), 3) for p in cut.panels}  # planks side by side along x (31.1 m)
    assert spans == {round(28.7 / 3, 3)}  # three rows of 9.57 m
    for plank in cut.panels:
        assert 1.2 <= plank.extents[0] <= 2.4
        assert LIMITS.fits(plank.extents)
    assert len(cut.panels) == 3 * 13  # 31.1 m in 13 planks of 2.39 m
    assert sum(cut.volumes_m3) == pytest.approx((31.1 - 12 * PANEL_JOINT_M) * 28.7 * 0.054, rel=1e-6)
    kinds = [j.kind for j in cut.joints]
    assert kinds.count("longitudinal") == 3 * 12 and kinds.count("transverse") == 2 * 13
    transverse = [j.length_m for j in cut.joints if j.kind == "transverse"]
    assert sum(transverse) == pytest.approx(2 * 31.1, abs=0.02)  # each row joint runs the whole width
    assert "39 planks along the 28.70 m span in 3 rows of 9.57 m" in cut.why


def test_a_slab_whose_narrowest_plank_is_too_heavy_is_not_cut_and_says_why() -> None:
    slab = manifold_to_mesh(_box((0, 0, 0), (7.4, 16.9, 0.3)))
    mass_kg = CONCRETE_KG_M3 * 7.4 * 16.9 * 0.3  # 90 t: a 1.2 m plank weighs 6.4 t
    with pytest.raises(PanelisationError, match=r"a 1\.2 m plank would weigh 6,394 kg, over the 4,000 kg"):
        panelise(slab, PanelKind.SLAB, mass_kg, LIMITS)


def test_a_slab_opening_is_not_cut_through() -> None:
    slab = _box((0, 0, 0), (6.0, 12.0, 0.25)) - _box((2.0, 5.4, -1.0), (1.5, 1.2, 3.0))  # a shaft
    cut = panelise(manifold_to_mesh(slab), PanelKind.SLAB, 20_000.0, LIMITS)
    shaft = (5.4, 6.6)
    sides = sorted(float(p.bounds[0, 1]) for p in cut.panels)[1:]
    assert all(y <= shaft[0] or y >= shaft[1] for y in sides), sides
    joints_m3 = sum(PANEL_JOINT_M * 6.0 * 0.25 for _ in sides)  # each joint across the whole 6 m span
    assert sum(cut.volumes_m3) == pytest.approx(slab.volume() - joints_m3, rel=1e-6)


def test_a_mesh_with_a_hole_is_closed_and_cut_an_open_surface_is_not() -> None:
    """The WBDG clinic's Revit roofs tessellate with open edges and could not be cut into panels: a hole
    is filled (trimesh), and the panels hold the whole volume; a lone surface encloses nothing."""
    box = manifold_to_mesh(_box((0, 0, 0), (17.0, 0.2, 3.0)))
    holed = TriMesh(box.vertices, box.faces[:-1])
    cut = panelise(holed, PanelKind.WALL, 20_000.0, LIMITS)
    assert len(cut.panels) > 1
    joints_m3 = (len(cut.panels) - 1) * PANEL_JOINT_M * 0.2 * 3.0
    assert sum(cut.volumes_m3) == pytest.approx(17.0 * 0.2 * 3.0 - joints_m3, rel=1e-6)
    sheet = TriMesh(
        np.array([[0, 0, 0], [17, 0, 0], [17, 0, 3], [0, 0, 3]], float), np.array([[0, 1, 2], [0, 2, 3]])
    )
    with pytest.raises(PanelisationError, match="not a closed solid"):
        panelise(sheet, PanelKind.WALL, 20_000.0, LIMITS)


def test_what_is_cut_into_panels() -> None:
    assert panel_kind("IfcWallStandardCase") is PanelKind.WALL
    assert panel_kind("IfcCurtainWall") is None
    assert panel_kind("IfcSlab") is PanelKind.SLAB
    assert panel_kind("IfcRoof") is PanelKind.SLAB
    assert panel_kind("IfcPlate", "Precast concrete") is PanelKind.SLAB
    assert panel_kind("IfcPlate", "Glass") is None
    assert panel_kind("IfcColumn", "Concrete") is None
    assert panel_kind("IfcCovering", "Gypsum", "CEILING") is PanelKind.SLAB
    assert panel_kind("IfcCovering", None, "CLADDING") is PanelKind.WALL
    assert panel_kind("IfcCovering", None, "INSULATION") is None


def test_a_panel_fits_a_truck_in_any_orientation() -> None:
    assert LIMITS.fits((3.6, 8.0, 0.2))  # a wall panel standing on an inloader
    assert LIMITS.fits((7.4, 2.4, 0.3))  # a plank lying flat
    assert not LIMITS.fits((16.9, 1.7, 0.3))  # longer than the deck
    assert not LIMITS.fits((8.0, 3.0, 2.8))  # too wide and too high whichever way it lies
