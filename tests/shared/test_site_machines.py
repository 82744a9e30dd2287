"""Where the machines that stand fixed are set up (shared/site_machines.py): the tower crane where its hook
covers the building (then the yard), the pump and the block layer where their booms cover their work, none on
a lane, the yard or the depot; the ground robots' site stays as it was."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from component_boxes import box_component

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Component, read_manifest
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_layout import LANE_M, plan_site
from bimbot.shared.site_machines import HookReach, covered_by_boom, farthest_m, keep_clear, plan_machines
from bimbot.shared.site_plan import Rect, SiteLayout

FLEET = default_fleet()
TYPES = FLEET.types
CRANE, PUMP, LAYER = TYPES["tower_crane"], TYPES["concrete_pump"], TYPES["block_layer"]


@pytest.fixture(scope="module")
def frame(bundled_build: Path) -> list[Component]:
    return read_manifest(bundled_build).components


def long_building(length_m: float = 60.0, cast_west_m: float = 0.0) -> list[Component]:
    """A 60 m × 8 m row of 2 m bays: columns and beams along x (y 0..8); the bays within ``cast_west_m``
    of its west end are cast in place."""
    components = []
    for bay in range(int(length_m / 2.0)):
        x = 2.0 * bay
        method = ConstructionMethod.CAST_IN_PLACE if x < cast_west_m else ConstructionMethod.LIFTED
        components.append(box_component(f"col{bay:03d}", (0.3, 0.3, 3.0), (x, 0.0, 0.0), method))
        components.append(box_component(f"beam{bay:03d}", (2.0, 0.3, 0.4), (x, 7.7, 3.0), method))
    return components


def _machines(layout: SiteLayout) -> dict[str, tuple[float, float, float]]:
    """Type name → set-up pose of each machine of the default fleet (one of each)."""
    names = [item.name for item in FLEET.robot_types()]
    return {name: pose for name, pose in zip(names, layout.robot_starts, strict=True) if name in TYPES}


def _corners(component: Component) -> list[tuple[float, float]]:
    (x0, y0, _), (x1, y1, _) = component.bbox_world.min_m, component.bbox_world.max_m
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def test_the_crane_on_the_bundled_frame_reaches_the_building_and_the_yard_with_every_component(
    frame: list[Component],
) -> None:
    layout = plan_site(frame, fleet=FLEET.robot_types())
    crane = _machines(layout)["tower_crane"]
    chart = CRANE.crane
    assert chart is not None
    needed_m = farthest_m(crane[:2], layout.building, layout.yard)
    heaviest = max(component.mass_kg for component in frame)
    assert needed_m <= chart.radius_for(heaviest)  # 23 m: its chart lifts 259 kg out to 60 m
    assert chart.radius_for(chart.payload_at(needed_m)) >= needed_m  # and 5 t everywhere on the site
    assert chart.payload_at(needed_m) > 5000
    staging = layout.staging[0]
    assert farthest_m(crane[:2], staging) <= chart.radius_for(8000)  # its staging area at full load


def test_on_a_long_building_the_crane_stands_at_its_long_side_not_at_its_end() -> None:
    """A fixed spot east of a 60 m building would leave its west end 66 m from the mast, beyond the jib;
    the rule puts the crane at the middle of the north side (south is the yard), 30-odd m from either end."""
    components = long_building()
    layout = plan_site(components, fleet=FLEET.robot_types())
    x, y, _ = _machines(layout)["tower_crane"]
    building = layout.building
    assert y > building.max_xy[1]
    assert x == pytest.approx((building.min_xy[0] + building.max_xy[0]) / 2.0)
    assert farthest_m((x, y), building, layout.yard) <= CRANE.reach_m
    east = (building.max_xy[0] + LANE_M + CRANE.length_m / 2.0, (building.min_xy[1] + building.max_xy[1]) / 2)
    assert farthest_m(east, building) > CRANE.reach_m  # what the old fixed spot east of it would have had


def test_the_pump_and_the_block_layer_cover_the_bundled_frame_from_where_they_stand(
    frame: list[Component],
) -> None:
    layout = plan_site(frame, fleet=FLEET.robot_types())
    machines = _machines(layout)
    for machine in (PUMP, LAYER):
        pose = machines[machine.name]
        assert all(machine.boom_covers(pose[:2], _corners(component)) for component in frame), machine.name


def test_the_pump_stands_where_its_boom_covers_what_is_cast_in_place() -> None:
    """The west 12 m of a 60 m building are cast in place: the pump (28 m boom) goes where it covers all of
    them; when nothing is cast it stands elsewhere (the north side's middle covers the most)."""
    cast = long_building(cast_west_m=12.0)
    pump = _machines(plan_site(cast, fleet=FLEET.robot_types()))["concrete_pump"]
    poured = [c for c in cast if c.method is ConstructionMethod.CAST_IN_PLACE]
    assert all(PUMP.boom_covers(pump[:2], _corners(component)) for component in poured)
    lifted = long_building()
    other = _machines(plan_site(lifted, fleet=FLEET.robot_types()))["concrete_pump"]
    assert not all(PUMP.boom_covers(other[:2], _corners(component)) for component in poured)


@pytest.mark.parametrize("model", ["frame", "long"])
def test_no_machine_stands_on_a_lane_the_yard_the_depot_or_another_machine(
    model: str, request: pytest.FixtureRequest
) -> None:
    components = request.getfixturevalue("frame") if model == "frame" else long_building()
    layout = plan_site(components, fleet=FLEET.robot_types())
    lane_m = LANE_M
    forbidden = keep_clear(layout.building, layout.yard, layout.depot, lane_m)
    street = Rect(  # the main street between the building and the yard, from the depot's far side
        (layout.depot.min_xy[0] - lane_m, layout.yard.max_xy[1]),
        (layout.fence.max_xy[0], layout.building.min_xy[1]),
    )
    assert len(layout.machines) == 5 and len(layout.staging) == 1  # only the crane has a staging area
    crane, pump, layer, line, rig = layout.machines  # robot id order: r3, r4, r5, r6, r7
    groups = [(crane, layout.staging[0]), (pump,), (layer,), (line,), (rig,)]  # its staging area beside it
    inner = layout.fence.grown(-lane_m)  # the fence's lane stays around them
    for number, group in enumerate(groups):
        others = [rect for other in groups[number + 1 :] for rect in other]
        for rect in group:
            assert not any(rect.overlaps(other) for other in [*forbidden, street]), rect
            assert not any(rect.overlaps(other.grown(lane_m)) for other in others), rect  # a lane between
            assert inner.min_xy[0] <= rect.min_xy[0] and rect.max_xy[0] <= inner.max_xy[0] + 1e-9
            assert inner.min_xy[1] <= rect.min_xy[1] and rect.max_xy[1] <= inner.max_xy[1] + 1e-9
    for x, y, _ in layout.robot_starts[2:]:  # each machine's base is its set-up rectangle's centre
        assert any(m.min_xy[0] < x < m.max_xy[0] and m.min_xy[1] < y < m.max_xy[1] for m in layout.machines)


def test_the_machines_leave_the_ground_robots_site_as_it_was(frame: list[Component]) -> None:
    """The yard, its aisles, the depot and the robots' starts are what they are without any machine."""
    ground = [item for item in FLEET.robot_types() if item.can(Capability.DRIVE)]
    with_machines = plan_site(frame, fleet=FLEET.robot_types())
    without = plan_site(frame, fleet=ground)
    assert with_machines.slots == without.slots and with_machines.aisles == without.aisles
    assert (with_machines.yard, with_machines.depot) == (without.yard, without.depot)
    assert with_machines.robot_starts[:2] == without.robot_starts and without.machines == ()


def test_the_boom_rule_covers_a_component_only_when_every_corner_is_within_reach() -> None:
    near = box_component("near", (2.0, 2.0, 1.0), (20.0, 0.0, 0.0))  # far corner at 22.1 m
    far = box_component("far", (2.0, 2.0, 1.0), (26.0, 0.0, 0.0))  # near corner 26 m, far corner 28.07 m
    corners = [[list(xy) for xy in _corners(c)] for c in (near, far)]
    assert covered_by_boom(PUMP, (0.0, 0.0), np.array(corners)).tolist() == [True, False]
    assert math.hypot(28.0, 2.0) > PUMP.reach_m  # the rule the physics and planner apply (reaches())
    assert not PUMP.reaches((0.0, 0.0), np.array(corners[1]))


def test_the_site_plan_is_deterministic_with_machines(frame: list[Component]) -> None:
    fleet = FLEET.robot_types()
    assert plan_site(frame, fleet=fleet) == plan_site([c.model_copy() for c in frame], fleet=fleet)


def test_the_crane_covers_the_whole_building_first_and_the_yard_only_between_equal_sides() -> None:
    """The restaurant's plan: a 70 m × 64 m building and a 138 m × 72 m yard south of it (its cast bays lie
    there too). Beside the east side the crane is nearer the yard's far corner, but 82 m from the
    building's; beside the north side every placement is within 77 m: it stands there."""
    building = Rect((66.7, -35.3), (136.7, 28.4))
    yard = Rect((33.9, -110.2), (172.0, -38.3))
    depot = Rect((-36.8, -39.2), (-33.6, -36.0))
    corner = [box_component("slab", (1.0, 1.0, 0.2), (100.0, 0.0, 0.0))]
    (crane,) = plan_machines([CRANE], corner, building=building, yard=yard, depot=depot, lane_m=LANE_M)
    assert crane.pose[1] > building.max_xy[1]  # north, across the building from the yard
    assert farthest_m(crane.pose[:2], building) == pytest.approx(77.2, abs=0.5)
    east = (building.max_xy[0] + LANE_M + 4.5 / 2.0, (building.min_xy[1] + building.max_xy[1]) / 2.0)
    assert farthest_m(east, building) > farthest_m(crane.pose[:2], building) + 4.0
    assert farthest_m(east, building, yard) < farthest_m(crane.pose[:2], building, yard)  # the yard's pick


def _hooked(layout: SiteLayout, fleet: list, components: list[Component]) -> list[np.ndarray]:
    """Per crane of ``fleet`` (in robot id order): which components it hooks where the plan sets it up."""
    return [
        HookReach.of(item, components).hooked(pose[:2])
        for item, pose in zip(fleet, layout.robot_starts, strict=True)
        if item.crane is not None
    ]


def test_a_further_crane_stands_where_it_hooks_what_the_cranes_before_it_do_not() -> None:
    """A 160 m building: the first crane's jib (60 m) hooks its middle from the north side, not its ends. A
    second and a third crane stand at the ends the first leaves out (a second crane used to stand behind
    the first, hooking what the first hooked): together the three hook every part."""
    components = long_building(length_m=160.0)
    one = FLEET.robot_types()
    first = _hooked(plan_site(components, fleet=one), one, components)[0]
    assert 0 < first.sum() < len(components)
    three = [*one, CRANE, CRANE]
    layout = plan_site(components, fleet=three)
    hooked = _hooked(layout, three, components)
    assert np.array_equal(hooked[0], first)  # the first crane stands where it stood alone
    assert (hooked[1] & ~hooked[0]).any() and (hooked[2] & ~(hooked[0] | hooked[1])).any()
    assert np.logical_or.reduce(hooked).all()
    masts = [
        pose[:2] for item, pose in zip(three, layout.robot_starts, strict=True) if item.crane is not None
    ]
    assert min(math.dist(a, b) for i, a in enumerate(masts) for b in masts[i + 1 :]) > 40.0
