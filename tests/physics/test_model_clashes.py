"""Every clash in the model at once (services/physics/model_clashes.py), on real pybullet bodies."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from bimbot.services.physics.handling_state import target_frame
from bimbot.services.physics.model_clashes import model_clashes
from bimbot.services.physics.scene import Frame, component_pose
from bimbot.services.physics.simulation import Simulation
from bimbot.services.physics.stability import StabilityReport, describe
from bimbot.shared.manifest import Component, Manifest


def _named(manifest: Manifest, name: str) -> Component:
    return next(c for c in manifest.components if c.name == name)


def _scan(sim: Simulation) -> list:
    items = sim.handling.items
    return model_clashes(
        sim.client_id,
        {guid: item.body for guid, item in items.items()},
        {guid: target_frame(item.component) for guid, item in items.items()},
    )


def test_the_bundled_frame_has_no_clash_and_every_body_goes_back_where_it_lay(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(robots=0)
    before: dict[str, Frame] = {
        g: component_pose(sim.client_id, i.body) for g, i in sim.handling.items.items()
    }
    assert _scan(sim) == []  # members meet at contacts, no deeper
    for guid, item in sim.handling.items.items():
        position = component_pose(sim.client_id, item.body)[0]
        assert position == pytest.approx(before[guid][0], abs=1e-6), guid


def test_two_components_the_model_puts_into_each_other_are_one_clash_with_its_depth(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Every pair is found before the replay, not one per run: a second, shallower clash is listed too."""
    sim = make_sim(robots=0)
    first, second = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Footing A2")
    third, fourth = _named(frame_manifest, "Footing B1"), _named(frame_manifest, "Footing B2")
    for moved, into, shift_m in ((second, first, 0.3), (fourth, third, 0.5)):  # 0.6 m wide footings
        x, y, z = into.target_pose_world.position_m
        target = moved.target_pose_world.model_copy(update={"position_m": (x + shift_m, y, z)})
        sim.handling.items[moved.guid].component = moved.model_copy(update={"target_pose_world": target})
    clashes = _scan(sim)
    assert [{c.first, c.second} for c in clashes] == [{first.guid, second.guid}, {third.guid, fourth.guid}]
    assert [c.depth_m for c in clashes] == pytest.approx([0.3, 0.1], abs=0.01)  # deepest first
    names = {c.guid: c.name for c in frame_manifest.components}
    lines = describe(StabilityReport(28, [], clashes=clashes), names)
    assert lines[0].startswith("the model puts 2 pair(s) of components into each other")
    pair = sorted(
        [f"Footing A1 ({first.guid})", f"Footing A2 ({second.guid})"], key=lambda n: n.split("(")[1]
    )
    assert f"{pair[0]} and {pair[1]}: 300 mm deep" in lines[1]  # in GUID order
