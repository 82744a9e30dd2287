"""The site erects as many tower cranes as its building's footprint needs, up to the fleet entry's up_to."""

from __future__ import annotations

import pytest
from component_boxes import upper_floor_beams

from bimbot.shared.crane_count import crane_count_words, sized_cranes
from bimbot.shared.fleet import Fleet, FleetEntry, default_fleet
from bimbot.shared.manifest import Component
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_machines import HookReach


def _tower_cranes(fleet: Fleet) -> int:
    return next(entry.count for entry in fleet.robots if entry.type == "tower_crane")


def _unhooked(fleet: Fleet, components: list[Component]) -> int:
    """What the site plan with ``fleet`` leaves no crane hooking (the run's own plan, not the sizing's)."""
    layout = plan_site(components, fleet=fleet.robot_types())
    types = fleet.robot_types()
    hooked = [False] * len(components)
    for item, start in zip(types, layout.robot_starts, strict=True):
        if item.crane is not None:
            for index, hit in enumerate(HookReach.of(item, components).hooked(start[:2])):
                hooked[index] = hooked[index] or bool(hit)
    return hooked.count(False)


def test_a_building_one_jib_does_not_cover_gets_more_cranes_until_each_part_is_hooked() -> None:
    """The WBDG clinic's structure: with the default fleet's one tower crane 88 of its parts were out of
    reach, with three all could be built. A 200 m long floor needs more than one 60 m jib from outside."""
    fleet = default_fleet()
    floor = upper_floor_beams(200.0)
    assert _unhooked(fleet, floor) > 0
    sized = sized_cranes(fleet, floor)
    count = _tower_cranes(sized)
    assert 1 < count <= 4
    assert _unhooked(sized, floor) == 0, "the cranes the site plan sets up hook every beam"
    assert _unhooked(fleet.with_counts({"tower_crane": count - 1}), floor) > 0, "no more cranes than needed"
    assert crane_count_words(fleet, sized) == [
        f"{count} tower_crane for the building's footprint, where the fleet file has 1 (up to 4)"
    ]
    assert list(sized.type_of().values()).count("tower_crane") == count


def test_a_building_one_jib_covers_keeps_one_crane_and_a_fleet_without_up_to_keeps_its_count() -> None:
    fleet = default_fleet()
    assert sized_cranes(fleet, upper_floor_beams(40.0)) is fleet
    fixed = fleet.model_copy(
        update={"robots": tuple(entry.model_copy(update={"up_to": None}) for entry in fleet.robots)}
    )
    assert sized_cranes(fixed, upper_floor_beams(200.0)) is fixed


def test_a_part_within_the_jib_too_heavy_at_its_radius_is_cut_lighter_not_given_another_crane() -> None:
    """The Revit office's walls within one jib, cut for its lift where they go: sized by their masses
    before the cut, the site had erected three cranes where one builds it, and moved the yard so that 32
    parts were out of reach."""
    heavy = [beam.model_copy(update={"mass_kg": 6000.0}) for beam in upper_floor_beams(40.0)]
    fleet = default_fleet()
    assert _unhooked(fleet, heavy) > 0, "the chart lifts 6 t only near the mast"
    assert sized_cranes(fleet, heavy) is fleet


def test_up_to_below_the_count_is_refused() -> None:
    with pytest.raises(ValueError, match="up_to"):
        FleetEntry(type="tower_crane", count=2, up_to=1)
