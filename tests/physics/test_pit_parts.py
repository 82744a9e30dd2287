"""The excavation follows the foundations' parts, and goes down to the deepest pit where pits overlap.

On the Revit structural hub a strip footing (a ring of strips at two depths) had one pit, its bounding
box, 0.56 m deep under the whole building, and the 125 mm ground slab's floor covered the 559 mm thickened
slab's pit: the thickened slab, released at its target, was pushed up out of that floor, 3 times, and
failed `unstable`. Here with real pybullet floors (ray tests from above), and on the hub itself.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from wall_clock import bound_s

from bimbot.services.physics.client import BulletClient, p
from bimbot.services.physics.pits import Box, Pits, subtract
from bimbot.shared.site_plan import Rect


def _foundation(guid: str, boxes: list[Box]) -> Any:
    """What :class:`Pits` reads of a component: its GUID and world bounding box (its parts come apart)."""
    low = tuple(min(box[0][i] for box in boxes) for i in range(3))
    high = tuple(max(box[1][i] for box in boxes) for i in range(3))
    return SimpleNamespace(guid=guid, bbox_world=SimpleNamespace(min_m=low, max_m=high), parts=boxes)


def _floor_below(client_id: int, x: float, y: float) -> float | None:
    """The height of the first floor a ray straight down at ``(x, y)`` meets (None: no floor there)."""
    (hit,) = p.rayTestBatch([(x, y, 1.0)], [(x, y, -5.0)], physicsClientId=client_id)
    return None if hit[0] < 0 else hit[3][2]


RING = [  # a strip footing round a 10 × 10 m building, 0.5 m wide, 0.6 m deep; one strip 0.3 m deep
    ((0.0, 0.0, -0.6), (10.0, 0.5, -0.1)),
    ((0.0, 9.5, -0.6), (10.0, 10.0, -0.1)),
    ((0.0, 0.5, -0.6), (0.5, 9.5, -0.1)),
    ((9.5, 0.5, -0.3), (10.0, 9.5, -0.1)),
]
GROUND_SLAB = [((0.0, 0.0, -0.125), (10.0, 10.0, 0.0))]
THICKENED = [((4.0, 4.0, -0.56), (5.5, 4.6, 0.0))]  # a thickened strip of the slab, inside it


def test_pits_follow_the_parts_and_the_deepest_pit_sets_the_floor() -> None:
    foundations = [
        _foundation("ring", RING),
        _foundation("slab", GROUND_SLAB),
        _foundation("thick", THICKENED),
    ]
    with BulletClient() as client:
        pits = Pits(client.id, foundations, filled=lambda guid: False, part_boxes=lambda c: c.parts)
        assert sorted(pit.owner for pit in pits.pits) == ["ring"] * 4 + ["slab", "thick"]
        # inside the ring, under the ground slab: the slab's floor, not the ring's box 0.6 m deep
        assert _floor_below(client.id, 2.0, 7.0) == pytest.approx(-0.125, abs=1e-6)
        # under the thickened strip: its own floor, not the ground slab's above it
        assert _floor_below(client.id, 4.8, 4.3) == pytest.approx(-0.56, abs=1e-6)
        # under the ring's strips: their own depths
        assert _floor_below(client.id, 5.0, 0.2) == pytest.approx(-0.6, abs=1e-6)
        assert _floor_below(client.id, 9.8, 5.0) == pytest.approx(-0.3, abs=1e-6)
        assert [pit.owner for pit in pits.open_around((4.8, 4.3))] == ["slab", "thick"]
        assert [pit.owner for pit in pits.open_around((2.0, 7.0))] == ["slab"]


def test_without_part_boxes_a_pit_is_the_bounding_box() -> None:
    with BulletClient() as client:
        pits = Pits(client.id, [_foundation("ring", RING)], filled=lambda guid: False)
        assert len(pits.pits) == 1
        assert _floor_below(client.id, 5.0, 5.0) == pytest.approx(-0.6, abs=1e-6)


def test_subtract_leaves_what_the_holes_do_not_cover() -> None:
    outer = Rect((0.0, 0.0), (10.0, 10.0))
    pieces = subtract(outer, [Rect((2.0, 3.0), (4.0, 5.0)), Rect((8.0, -1.0), (11.0, 11.0))])
    area = sum(piece.size[0] * piece.size[1] for piece in pieces)
    assert area == pytest.approx(100.0 - 4.0 - 20.0)
    assert all(not a.overlaps(b) for i, a in enumerate(pieces) for b in pieces[i + 1 :])
    assert subtract(outer, [Rect((-1.0, -1.0), (11.0, 11.0))]) == []
    assert subtract(outer, [Rect((20.0, 20.0), (30.0, 30.0))]) == [outer]


def test_the_hub_stands_in_the_derived_order_its_overlaps_joints(samples_dir: Path, tmp_path: Path) -> None:
    """The whole hub stands in its derived order, as built by default: its foundations (before: the
    thickened slab, step 1, did not), its footing drawn 229 mm into the strip footing (a joint), and the two
    proxy beams the model runs into its walls (clashes while the walls were lifted: the walls are cast in
    place now, and a member drawn into cast work is cast in, a joint)."""
    build = tmp_path / "hub"

    def bimbot(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "bimbot.cli", *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=bound_s(300), check=False)

    converted = bimbot("convert", str(samples_dir / "revit2021_structural_hub.ifc"), "-o", str(build))
    assert converted.returncode == 0, converted.stderr
    assert " 0 clash(es)" in converted.stdout, converted.stdout
    checked = bimbot("run", str(build), "--check-stability")
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "every partial structure stands: 115 step(s)" in checked.stdout
    assert "does not stand" not in checked.stdout and "over the open pit" not in checked.stdout
    assert "into each other" not in checked.stdout  # no clash left to list


def _dropped_box(client_id: int, low: tuple[float, float, float], high: tuple[float, float, float]) -> int:
    """A dynamic 500 kg box with these world corners, as a released component is (Bullet's default group)."""
    half = [(b - a) / 2.0 for a, b in zip(low, high, strict=True)]
    centre = [(a + b) / 2.0 for a, b in zip(low, high, strict=True)]
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client_id)
    return p.createMultiBody(500.0, shape, basePosition=centre, physicsClientId=client_id)


def _settle(client_id: int, seconds: float = 3.0) -> None:
    for _ in range(int(seconds * 240)):
        p.stepSimulation(physicsClientId=client_id)


def test_a_slab_set_down_off_its_pit_inside_a_shallower_one_rests_on_that_floor_not_in_it() -> None:
    """The hub's thickened slab (0.56 m deep, 0.6 m wide, inside the 125 mm ground slab's pit), set down
    0.3 m off its own pit by a robot that was 0.3 m off: before, it was released half inside the ground
    slab's floor, thrown out by the contact solver, and fell through the ground, 7 m away. Now it is lifted
    onto that floor and settles there or tips into its pit, where it was set down."""
    foundations = [_foundation("slab", GROUND_SLAB), _foundation("thick", THICKENED)]
    with BulletClient() as client:
        p.setGravity(0.0, 0.0, -9.81, physicsClientId=client.id)
        pits = Pits(client.id, foundations, filled=lambda guid: False, part_boxes=lambda c: c.parts)
        (x0, y0, z0), (x1, y1, z1) = THICKENED[0]
        body = _dropped_box(client.id, (x0, y0 + 0.3, z0), (x1, y1 + 0.3, z1))
        lift = pits.lift_onto_ground(body)
        bottom = p.getAABB(body, -1, physicsClientId=client.id)[0][2]
        assert lift == pytest.approx(0.56 - 0.125, abs=0.03) and bottom == pytest.approx(-0.125, abs=0.03)
        released = p.getBasePositionAndOrientation(body, physicsClientId=client.id)[0]
        _settle(client.id)
        rest = p.getBasePositionAndOrientation(body, physicsClientId=client.id)[0]
        assert math.dist(rest, released) < 0.8, rest  # not thrown anywhere
        assert p.getAABB(body, -1, physicsClientId=client.id)[0][2] > -0.6  # above its pit's floor
        # centred over its pit it goes in, untouched
        centred = _dropped_box(client.id, (x0, y0, z0), (x1, y1, z1))
        assert pits.lift_onto_ground(centred) == 0.0


def test_a_footing_hanging_over_its_pit_s_edge_rests_on_the_rim_and_never_falls_through() -> None:
    """No ground plane here at all (as for a body released over an open pit, which the plane does not
    touch): a footing 0.3 m off its pit, its centre still over it, is lifted onto the rim of ground round
    the pit and tips in or stays on the edge; a few millimetres off (within the excavation's working
    space) it goes in untouched."""
    footing = [((0.0, 0.0, -0.5), (1.0, 1.0, 0.0))]
    with BulletClient() as client:
        p.setGravity(0.0, 0.0, -9.81, physicsClientId=client.id)
        pits = Pits(
            client.id, [_foundation("f", footing)], filled=lambda guid: False, part_boxes=lambda c: c.parts
        )
        near = _dropped_box(client.id, (0.005, 0.0, -0.5), (1.005, 1.0, 0.0))
        assert pits.lift_onto_ground(near) == 0.0
        p.removeBody(near, physicsClientId=client.id)
        off = _dropped_box(client.id, (0.3, 0.0, -0.5), (1.3, 1.0, 0.0))
        assert pits.lift_onto_ground(off) == pytest.approx(0.5, abs=0.03)
        _settle(client.id)
        (x, y, _), _ = p.getBasePositionAndOrientation(off, physicsClientId=client.id)
        assert p.getAABB(off, -1, physicsClientId=client.id)[0][2] > -0.55  # on the floor at worst
        assert math.dist((x, y), (0.8, 0.5)) < 0.6  # where it was set down, not thrown off
