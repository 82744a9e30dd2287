"""The set-up positions of a truck-mounted machine that relocates (shared/site_setups.py): on a building
longer than its boom, every footing it pours is covered from some set-up, each clear of lanes, yard, depot
and the other machines; a machine that does not relocate keeps one set-up."""

from __future__ import annotations

import pytest
from component_boxes import box_component
from pydantic import TypeAdapter

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Component
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_machines import base_rect, keep_clear
from bimbot.shared.site_plan import SiteLayout

FLEET = default_fleet()
TYPES = FLEET.types
PUMP = TYPES["concrete_pump"]
CAST = ConstructionMethod.CAST_IN_PLACE


def footing_row(length_m: float = 90.0) -> list[Component]:
    """Cast footings (1.5 m square) every 6 m along a building ``length_m`` long and 8 m deep, with a
    lifted column on each (what makes it a building to the site plan)."""
    components = []
    for number in range(int(length_m / 6.0) + 1):
        x = 6.0 * number
        for y in (0.0, 6.5):
            name = f"f{number:02d}{int(y)}"
            components.append(box_component(name, (1.5, 1.5, 0.5), (x, y, -0.5), CAST, 2500.0))
            components.append(box_component(f"c{name}", (0.3, 0.3, 3.0), (x + 0.6, y + 0.6, 0.0)))
    return components


def _pump_index(fleet: list[RobotDescription], name: str = "concrete_pump") -> int:
    """The index of machine type ``name`` among the machines that stand fixed (``SiteLayout.setups``)."""
    machines = [item for item in fleet if item.can(Capability.STAND_FIXED)]
    return next(number for number, item in enumerate(machines) if item.name == name)


def _covered(description: RobotDescription, setups: tuple, component: Component) -> bool:
    (x0, y0, _), (x1, y1, _) = component.bbox_world.min_m, component.bbox_world.max_m
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return any(description.boom_covers(pose[:2], corners) for pose in setups)


def test_on_a_building_longer_than_the_boom_every_footing_is_covered_from_some_set_up() -> None:
    components = footing_row()
    fleet = FLEET.robot_types()
    layout = plan_site(components, fleet=fleet)
    pump_setups = layout.setups[_pump_index(fleet)]
    footings = [component for component in components if component.method is CAST]
    main = pump_setups[0]
    assert main == layout.robot_starts[[item.name for item in fleet].index("concrete_pump")]
    assert not all(_covered(PUMP, (main,), footing) for footing in footings)  # one position is not enough
    assert len(pump_setups) > 1
    assert all(_covered(PUMP, pump_setups, footing) for footing in footings)
    # each set-up clear of the lanes round building, yard and depot, the main street and the other machines
    bases = [base_rect(PUMP, pose) for pose in pump_setups]
    others = [rect for number, rect in enumerate(layout.machines) if number != _pump_index(fleet)]
    for base in bases:
        assert not any(
            base.overlaps(rect) for rect in keep_clear(layout.building, layout.yard, layout.depot, 3.0)
        )
        assert not any(base.overlaps(rect.grown(3.0)) for rect in [*others, *layout.staging])
        assert layout.fence.min_xy <= base.min_xy and base.max_xy <= layout.fence.max_xy
    assert len(layout.setups[_pump_index(fleet, "tower_crane")]) == 1  # a crane does not relocate
    assert plan_site(components, fleet=fleet) == layout  # deterministic


def test_a_pump_that_does_not_relocate_keeps_its_one_set_up() -> None:
    fixed_pump = PUMP.model_copy(update={"capabilities": PUMP.capabilities - {Capability.RELOCATE}})
    fleet = [fixed_pump if item.name == "concrete_pump" else item for item in FLEET.robot_types()]
    layout = plan_site(footing_row(), fleet=fleet)
    assert len(layout.setups[_pump_index(fleet)]) == 1


def test_the_set_ups_travel_in_the_site_plan_as_plain_data() -> None:
    layout = plan_site(footing_row(), fleet=FLEET.robot_types())
    adapter = TypeAdapter(SiteLayout)
    again = adapter.validate_json(adapter.dump_json(layout))
    assert again.setups == layout.setups and len(again.setups[_pump_index(FLEET.robot_types())]) > 1


def test_relocation_takes_the_set_up_time_and_the_drive_along_the_site_axes() -> None:
    assert PUMP.relocation_s((0.0, 0.0), (0.0, 0.0)) == 0.0
    drive_s = (30.0 + 40.0) / PUMP.relocation_speed_mps
    assert PUMP.relocation_s((0.0, 0.0), (30.0, -40.0)) == pytest.approx(PUMP.setup_s + drive_s)
    setups = ((0.0, 0.0, 0.0), (50.0, 0.0, 0.0), (60.0, 0.0, 0.0))
    far = [(70.0, 0.0), (71.0, 0.0), (71.0, 1.0), (70.0, 1.0)]
    assert PUMP.setup_for(setups, (0.0, 0.0), far) == (50.0, 0.0, 0.0)  # both cover it: the nearer
    assert PUMP.setup_for(setups, (60.0, 0.0), far) == (60.0, 0.0, 0.0)  # where it stands
    assert PUMP.setup_for(setups, (0.0, 0.0), [(200.0, 0.0)]) is None


def test_only_a_boom_machine_that_stands_fixed_and_has_a_speed_relocates() -> None:
    with pytest.raises(ValueError, match="relocate"):
        RobotDescription.model_validate({**PUMP.model_dump(), "relocation_speed_mps": 0.0})
    crane = TYPES["tower_crane"].model_dump()
    with pytest.raises(ValueError, match="relocate"):
        RobotDescription.model_validate(
            {**crane, "capabilities": [*crane["capabilities"], "relocate"], "relocation_speed_mps": 1.0}
        )


def test_a_piling_rig_tracks_in_over_the_open_ground_to_piles_no_set_up_round_the_building_reaches() -> None:
    """Piles under the middle of a building 80 m square: from the ring round it a 35 m hook reaches only the
    outer ones (the Revit 2025 structural sample: 43 of its 216 piles failed out_of_reach). Piles are driven
    into open ground before anything stands there: the rig's extra set-ups may lie over the building's own
    ground, and every pile is covered."""
    driven = ConstructionMethod.DRIVEN
    components = [
        box_component(f"p{i}{j}", (0.4, 0.4, 6.0), (10.0 * i, 10.0 * j, -7.0), driven, 1000.0)
        for i in range(9)
        for j in range(9)
    ]
    components.append(box_component("roof", (80.4, 80.4, 0.3), (0.0, 0.0, 4.0)))
    fleet = FLEET.robot_types()
    layout = plan_site(components, fleet=fleet)
    rig = TYPES["piling_rig"]
    setups = layout.setups[_pump_index(fleet, "piling_rig")]
    piles = [component for component in components if component.method is driven]
    main = setups[0]
    assert not all(_covered(rig, (main,), pile) for pile in piles)
    assert all(_covered(rig, setups, pile) for pile in piles)
    (x0, y0), (x1, y1) = layout.building.min_xy, layout.building.max_xy
    inside = [pose for pose in setups[1:] if x0 <= pose[0] <= x1 and y0 <= pose[1] <= y1]
    assert inside  # tracked in over the building's ground
