"""Collision parts are inset by Bullet's hull margin: a component set down at its BIM pose on what carries
it stays there (before, every footing was pushed up 1 mm by the margin and every column 3 mm, most of the
5 mm a placed component may move)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bimbot.services.physics.collision_margin import inset_by_margin
from bimbot.services.physics.stability import check_stability
from bimbot.shared.manifest import read_manifest
from bimbot.shared.sequence import read_sequence


def test_a_part_comes_in_by_the_margin_on_every_side_and_a_thin_axis_keeps_its_size() -> None:
    low, high = np.array([1.0, -0.05, 0.0]), np.array([1.6, -0.045, 3.0])  # a 5 mm wall, 3 m tall
    scale, position = inset_by_margin(low, high, 0.001)
    inset_low = np.array(scale) * low + position
    inset_high = np.array(scale) * high + position
    assert inset_low == pytest.approx(low + 0.001) and inset_high == pytest.approx(high - 0.001)
    sheet_low, sheet_high = np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.003])  # thinner than 4 margins
    scale, position = inset_by_margin(sheet_low, sheet_high, 0.001)
    assert scale[2] == 1.0 and position[2] == 0.0


def test_every_component_set_down_at_its_bim_pose_moves_less_than_half_a_millimetre(
    bundled_build: Path,
) -> None:
    manifest = read_manifest(bundled_build)
    order = read_sequence(bundled_build / "sequence.xml").guids()
    report = check_stability(manifest, bundled_build, order, drift_tolerance_m=0.0005)
    drifts_mm = {step.name: round(1000.0 * step.drift_m, 2) for step in report.steps}
    assert report.stands, drifts_mm
    assert max(drifts_mm.values()) < 0.5
