"""The site erects its tower cranes as high as the building needs, up to the mast's free-standing limit,
and the crane's URDF is drawn and loaded that much taller."""

from __future__ import annotations

from pathlib import Path

import pybullet
import pytest
from component_boxes import box_component
from lxml import etree
from pydantic import ValidationError

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.crane_erection import erected_for, erection_words, highest_lifted_top_m
from bimbot.shared.crane_mast import raised_mast_urdf
from bimbot.shared.fleet import default_fleet
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.robot_description import CraneSpec

DEFAULT = default_fleet()
CRANE = DEFAULT.types["tower_crane"]
assert CRANE.crane is not None


def _top_at(top_m: float, method: ConstructionMethod = ConstructionMethod.LIFTED) -> list:
    """A ground slab and one part whose top is at ``top_m``."""
    return [
        box_component("slab", (20.0, 20.0, 0.3), (0.0, 0.0, 0.0), ConstructionMethod.CAST_IN_PLACE),
        box_component("part", (4.0, 1.0, 0.5), (5.0, 5.0, top_m - 0.5), method, mass_kg=1500.0),
    ]


def test_a_low_building_keeps_the_fleet_files_crane() -> None:
    assert erected_for(DEFAULT, _top_at(9.0)) is DEFAULT  # the samples' buildings: nothing changes
    assert erected_for(DEFAULT, _top_at(36.0)) is DEFAULT  # exactly the placement height: still enough


def test_a_taller_building_gets_the_crane_erected_as_high_as_its_highest_lifted_part_needs() -> None:
    components = _top_at(46.5)  # the Revit office's roof
    assert CRANE.refusal(1500.0, 46.5) is not None  # as the file erects it, the part is too high
    fleet = erected_for(DEFAULT, components)
    crane = fleet.types["tower_crane"]
    assert crane.crane is not None
    assert crane.crane.jib_height_m == 51.0  # 46.5 m + the 4 m it keeps under its hook, whole metres
    assert crane.max_place_height_m == 47.0
    assert crane.crane.mast_raised_m == 11.0
    assert crane.refusal(1500.0, 46.5) is None
    assert crane.crane.load_chart == CRANE.crane.load_chart  # a taller mast, the same jib and chart
    assert fleet.types["carrier"] is DEFAULT.types["carrier"]  # only cranes are erected
    assert erection_words(DEFAULT, fleet) == [
        "tower_crane erected at 51 m under hook for the building (fleet file: 40 m; free-standing up to "
        "55.8 m)"
    ]


def test_above_its_free_standing_limit_it_stands_at_the_limit_and_says_why_it_cannot_set_the_top() -> None:
    crane = erected_for(DEFAULT, _top_at(60.0)).types["tower_crane"]
    assert crane.crane is not None and crane.crane.jib_height_m == 55.8
    reason = crane.refusal(1500.0, 60.0)
    assert reason is not None and reason.code is ReasonCode.OUT_OF_REACH
    assert "placement height of 51.80 m" in reason.message


def test_only_what_a_crane_lifts_sets_the_height() -> None:
    assert highest_lifted_top_m(_top_at(46.5, ConstructionMethod.CAST_IN_PLACE)) == 0.0  # both cast
    assert highest_lifted_top_m(_top_at(46.5, ConstructionMethod.PANELISED)) == 46.5
    assert erected_for(DEFAULT, _top_at(46.5, ConstructionMethod.LAID)) is DEFAULT


def test_a_crane_without_a_free_standing_limit_is_never_raised() -> None:
    crawler = DEFAULT.types["crawler_crane"]
    assert crawler.crane is not None and crawler.crane.max_jib_height_m is None
    assert erected_for(DEFAULT, _top_at(46.5)).types["crawler_crane"] is crawler


def test_a_limit_below_the_erected_height_is_refused() -> None:
    assert CRANE.crane is not None
    data = CRANE.crane.model_dump()
    with pytest.raises(ValidationError, match="max_jib_height_m must be at least jib_height_m"):
        CraneSpec.model_validate({**data, "max_jib_height_m": 30.0})


def _hook_height_m(urdf: Path) -> tuple[float, float, float]:
    """(the hook's height at hoist 0, the top of the mast's collision box, the hoist's travel) as pybullet
    loads ``urdf``."""
    client = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
        names = {
            pybullet.getJointInfo(body, i, physicsClientId=client)[1].decode(): i
            for i in range(pybullet.getNumJoints(body, physicsClientId=client))
        }
        hook = pybullet.getLinkState(body, names["hoist"], physicsClientId=client)[4][2]
        mast_top = pybullet.getAABB(body, names["mast_joint"], physicsClientId=client)[1][2]
        travel = pybullet.getJointInfo(body, names["hoist"], physicsClientId=client)[9]
        return float(hook), float(mast_top), float(travel)
    finally:
        pybullet.disconnect(client)


def test_the_raised_urdf_hangs_the_hook_and_tops_the_mast_that_much_higher(tmp_path: Path) -> None:
    source = DEFAULT.resolve_urdf(CRANE.urdf)
    raised = tmp_path / "tower_crane.urdf"
    raised.write_bytes(raised_mast_urdf(source.read_bytes(), 11.0, source=source))
    hook, mast_top, travel = _hook_height_m(source)
    assert hook == pytest.approx(CRANE.crane.jib_height_m, abs=0.01)
    raised_hook, raised_top, raised_travel = _hook_height_m(raised)
    assert raised_hook == pytest.approx(hook + 11.0, abs=1e-6)
    assert raised_top == pytest.approx(mast_top + 11.0, abs=1e-3)
    assert raised_travel == pytest.approx(travel + 11.0)  # the hook still reaches the ground


def test_a_relative_mesh_of_the_crane_is_found_from_the_raised_copy(tmp_path: Path) -> None:
    urdf = (
        b'<robot name="c"><link name="base"/><link name="mast"><visual><geometry>'
        b'<mesh filename="meshes/mast.obj"/></geometry></visual></link>'
        b'<joint name="mast_joint" type="fixed"><parent link="base"/><child link="mast"/></joint>'
        b'<link name="top"/><joint name="slew" type="revolute"><parent link="mast"/><child link="top"/>'
        b'<origin xyz="0 0 10"/></joint><link name="hook"/>'
        b'<joint name="hoist" type="prismatic"><parent link="top"/><child link="hook"/>'
        b'<limit lower="0" upper="10"/></joint></robot>'
    )
    raised = etree.fromstring(raised_mast_urdf(urdf, 5.0, source=tmp_path / "c.urdf"))
    assert raised.find("link/visual/geometry/mesh").get("filename") == str(tmp_path / "meshes" / "mast.obj")
    assert raised.find("joint[@name='slew']/origin").get("xyz") == "0 0 15"
    assert raised.find("link/visual/origin") is None  # a mesh mast stays as drawn
    assert raised.find("joint[@name='hoist']/limit").get("upper") == "15"
