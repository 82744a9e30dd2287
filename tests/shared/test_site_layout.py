"""Site layout: yard slots never overlap, never lie on the building, lie flat on the ground, face an aisle."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.site_layout import AISLE_M, GROUND_CLEARANCE_M, Rect, lying_rotation, plan_site


@pytest.fixture(scope="module")
def frame(bundled_build: Path) -> Manifest:
    return read_manifest(bundled_build)


def _laid_corners(component, slot) -> np.ndarray:
    low, high = np.array(component.bbox_local.min_m), np.array(component.bbox_local.max_m)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    return Rotation.from_quat(slot.quat_xyzw).apply(corners) + np.array(slot.position_m)


def test_every_component_gets_a_slot_and_no_two_overlap(frame: Manifest) -> None:
    site = plan_site(frame.components, robots=3)
    assert set(site.slots) == {c.guid for c in frame.components}
    slots = list(site.slots.values())
    for i, a in enumerate(slots):
        for b in slots[i + 1 :]:
            assert not a.footprint.overlaps(b.footprint), (a.guid, b.guid)


def test_no_slot_lies_on_the_building_footprint_or_outside_the_fence(frame: Manifest) -> None:
    site = plan_site(frame.components)
    for slot in site.slots.values():
        assert not slot.footprint.overlaps(site.building)
        assert (
            site.fence.min_xy[0] < slot.footprint.min_xy[0]
            and slot.footprint.max_xy[0] < site.fence.max_xy[0]
        )
        assert (
            site.fence.min_xy[1] < slot.footprint.min_xy[1]
            and slot.footprint.max_xy[1] < site.fence.max_xy[1]
        )
    for component in frame.components:  # the building footprint covers the structure
        assert site.building.min_xy[0] <= component.bbox_world.min_m[0]
        assert component.bbox_world.max_m[1] <= site.building.max_xy[1]


def test_components_lie_flat_on_the_ground_inside_their_footprint(frame: Manifest) -> None:
    site = plan_site(frame.components)
    for component in frame.components:
        slot = site.slots[component.guid]
        corners = _laid_corners(component, slot)
        assert corners[:, 2].min() == pytest.approx(GROUND_CLEARANCE_M, abs=1e-9)
        assert corners[:, 0].min() == pytest.approx(slot.footprint.min_xy[0], abs=1e-9)
        assert corners[:, 1].max() == pytest.approx(slot.footprint.max_xy[1], abs=1e-9)
        extents = corners.max(axis=0) - corners.min(axis=0)
        assert extents[0] >= extents[1] - 1e-9 >= extents[2] - 2e-9  # longest along x, shortest vertical


def test_every_slot_faces_a_free_aisle_north_or_south(frame: Manifest) -> None:
    site = plan_site(frame.components)
    for slot in site.slots.values():
        x0, x1 = slot.footprint.min_xy[0], slot.footprint.max_xy[0]
        north = Rect((x0, slot.footprint.max_xy[1]), (x1, slot.footprint.max_xy[1] + AISLE_M))
        south = Rect((x0, slot.footprint.min_xy[1] - AISLE_M), (x1, slot.footprint.min_xy[1]))
        others = [other.footprint for other in site.slots.values() if other is not slot]
        assert any(not any(aisle.overlaps(other) for other in others) for aisle in (north, south)), slot.guid


def test_the_yard_is_compact(frame: Manifest) -> None:
    site = plan_site(frame.components)
    used = sum(slot.footprint.size[0] * slot.footprint.size[1] for slot in site.slots.values())
    assert site.yard.size[1] < 15.0 and used > 0  # 28 components of the bundled frame


def test_robots_start_in_the_depot_apart_from_each_other(frame: Manifest) -> None:
    site = plan_site(frame.components, robots=3)
    starts = np.array(site.robot_starts)
    assert len(starts) == 3
    assert np.all((starts[:, 0] > site.depot.min_xy[0]) & (starts[:, 0] < site.depot.max_xy[0]))
    assert np.all((starts[:, 1] > site.depot.min_xy[1]) & (starts[:, 1] < site.depot.max_xy[1]))
    assert np.min(np.linalg.norm(starts[:, None, :2] - starts[None, :, :2], axis=2) + np.eye(3) * 9) >= 1.5
    assert not site.depot.overlaps(site.yard) and not site.depot.overlaps(site.building)


@pytest.mark.parametrize("extents", [(3.0, 0.1, 0.1), (0.1, 0.1, 3.0), (0.6, 0.6, 0.3), (0.2, 5.0, 1.0)])
def test_lying_rotation_is_proper_and_puts_the_longest_extent_along_x(
    extents: tuple[float, float, float],
) -> None:
    rotation = lying_rotation(extents)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    laid = np.abs(rotation @ np.array(extents))
    assert laid[0] == max(extents) and laid[2] == min(extents)
