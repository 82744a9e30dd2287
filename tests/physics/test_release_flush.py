"""A member set down turned against the neighbour it abuts seats flush (the contact turns it about its
centre) instead of being shoved sideways off its target: real pybullet bodies (DIRECT), two walls at an
L corner."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from bimbot.services.physics.client import p
from bimbot.services.physics.release import clear_overlap
from bimbot.services.physics.scene import ComponentBody, Frame, quat_multiply, yaw_quat

IDENTITY = (0.0, 0.0, 0.0, 1.0)
LENGTH_M, THICK_M, HEIGHT_M = 7.0, 0.1, 3.0


@pytest.fixture
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


def _wall(cid: int, guid: str, centre_xy_m: tuple[float, float], along_y: bool = False) -> ComponentBody:
    """A 7 m wall along x (or y), its frame at its centre."""
    half = [LENGTH_M / 2, THICK_M / 2, HEIGHT_M / 2]
    if along_y:
        half[0], half[1] = half[1], half[0]
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
    body = p.createMultiBody(0.0, shape, basePosition=[*centre_xy_m, HEIGHT_M / 2], physicsClientId=cid)
    return ComponentBody(guid, body, ((0.0, 0.0, 0.0), IDENTITY), 1000.0, (1.0, 1.0, 1.0))


def _yaw(frame: Frame) -> float:
    x, y, z, w = frame[1]
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _turned_frame(turn_deg: float) -> Frame:
    """The new wall runs along x from 0 to 7 m; the hand turned it about its centre."""
    return (LENGTH_M / 2, 0.0, HEIGHT_M / 2), quat_multiply(yaw_quat(math.radians(turn_deg)), IDENTITY)


def test_a_wall_turned_into_the_wall_it_abuts_seats_flush_and_its_centre_stays_on_target(client: int) -> None:
    # along y under the new wall's end: its end face 1 mm below the new wall's side (an L corner)
    standing = _wall(client, "standing", (THICK_M / 2, -THICK_M / 2 - 0.001 - LENGTH_M / 2), along_y=True)
    new = _wall(client, "new", (LENGTH_M / 2, 0.0))
    others = {standing.body_id: "standing"}
    turned = _turned_frame(0.4)  # its end dips 24 mm into the standing wall's end

    shoved = clear_overlap(client, new, turned, others, max_cleared_m=0.1)
    seated = clear_overlap(client, new, turned, others, max_cleared_m=0.1, meant_quat_xyzw=IDENTITY)

    assert math.dist(shoved.frame[0], turned[0]) > 0.005, "moved out only, it is shoved centimetres off"
    assert shoved.against == ("standing",), "what it was moved out of (its agent's stack-up advice)"
    assert _yaw(shoved.frame) == pytest.approx(math.radians(0.4))
    assert _yaw(seated.frame) == pytest.approx(0.0, abs=1e-9), "the contact turned it flush"
    assert math.dist(seated.frame[0], turned[0]) < 0.002, "its centre stays where the hand set it"


def test_a_turned_wall_with_nothing_beside_it_keeps_the_hands_turn(client: int) -> None:
    _wall(client, "far", (-20.0, 0.0))
    new = _wall(client, "new", (LENGTH_M / 2, 0.0))
    turned = _turned_frame(0.4)
    kept = clear_overlap(client, new, turned, {}, max_cleared_m=0.1, meant_quat_xyzw=IDENTITY)
    assert kept.frame == turned, "no contact turns it: the hand's error stands"
    assert kept.against == ()
