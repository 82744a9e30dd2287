"""The method an element settles into once its mass and size are known (pure: no IFC)."""

from __future__ import annotations

from bimbot.services.converter.final_method import final_method, fits_truck, method_limits
from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodLimits, MethodSource
from bimbot.shared.fleet import Fleet, FleetEntry, default_fleet
from bimbot.shared.methods_file import load_methods
from bimbot.shared.robot_description import Capability

LIMITS = MethodLimits(
    lift_capacity_kg=10_000,
    lifted_by="crane",
    transport_length_m=13.6,
    transport_width_m=2.55,
    transport_height_m=3.7,
)
WALL = MethodDecision(
    method=ConstructionMethod.LIFTED,
    source=MethodSource.RULE,
    note="by default",
    material="concrete",
    if_too_heavy=ConstructionMethod.PANELISED,
)


def test_a_wall_within_the_lift_and_a_truck_stays_lifted_and_loses_its_alternatives() -> None:
    settled = final_method(WALL, 9_000, (6.0, 0.2, 3.0), "IfcWall", LIMITS)
    assert settled == WALL.model_copy(update={"if_too_heavy": None})


def test_a_wall_too_heavy_or_too_long_is_panelised_and_the_note_gives_the_numbers() -> None:
    heavy = final_method(WALL, 12_500, (6.0, 0.2, 3.0), "IfcWall", LIMITS)
    assert (heavy.method, heavy.source) == (ConstructionMethod.PANELISED, MethodSource.RULE)
    assert (
        heavy.note == "12,500 kg is more than the fleet lifts, 10,000 kg (crane): split into precast panels"
    )
    long = final_method(WALL, 5_000, (14.0, 0.1, 2.0), "IfcWall", LIMITS)
    assert long.note.startswith("14.00 × 2.00 × 0.10 m does not fit a truck's load of 13.6 × 2.55 × 3.7 m")


def test_the_users_word_is_kept_whatever_the_mass() -> None:
    mine = WALL.model_copy(update={"source": MethodSource.USER, "if_too_heavy": None})
    assert final_method(mine, 50_000, (20.0, 0.3, 3.0), "IfcWall", LIMITS).method is ConstructionMethod.LIFTED


def test_in_the_ground_the_decision_takes_its_ground_answer() -> None:
    cast = MethodDecision(method=ConstructionMethod.CAST_IN_PLACE, source=MethodSource.RULE, note="ground")
    slab = WALL.model_copy(update={"if_in_ground": cast})
    assert final_method(slab, 100, (2.0, 2.0, 0.2), "IfcSlab", LIMITS, in_ground=True).note == "ground"
    assert final_method(slab, 100, (2.0, 2.0, 0.2), "IfcSlab", LIMITS).method is ConstructionMethod.LIFTED
    assert final_method(None, 100, (1.0, 1.0, 1.0), "IfcSlab", LIMITS).method is ConstructionMethod.LIFTED


def test_a_truck_carries_a_storey_high_panel_standing_but_not_a_wide_slab() -> None:
    assert fits_truck((12.0, 0.2, 3.5), LIMITS)
    assert fits_truck((12.0, 2.4, 0.3), LIMITS)
    assert not fits_truck((12.0, 4.0, 0.3), LIMITS)
    assert not fits_truck((3.0, 3.0, 3.0), LIMITS)  # a box wider than a truck both ways


def test_the_lift_capacity_is_the_largest_payload_of_the_fleet_on_site() -> None:
    fleet = default_fleet()
    limits = method_limits(fleet, load_methods())
    lifters = [  # not the piling rig: it hangs its hammer and a pile from its hook, it sets no part
        description for description in fleet.on_site().values() if description.can(Capability.PLACE)
    ]
    strongest = max(lifters, key=lambda description: description.payload_kg)
    assert (limits.lift_capacity_kg, limits.lifted_by) == (strongest.payload_kg, strongest.name)
    only_husky = fleet.model_copy(update={"robots": (FleetEntry(type="husky", count=1),)})
    husky_only = method_limits(only_husky, load_methods())
    assert (husky_only.lift_capacity_kg, husky_only.lifted_by) == (fleet.types["husky"].payload_kg, "husky")
    assert limits.transport_size_m == (13.6, 2.55, 3.7)


def test_a_machine_that_only_pours_is_no_lift_however_heavy_its_payload() -> None:
    pump = {
        "urdf": "carrier.urdf",
        "payload_kg": 50_000,
        "reach_m": 30.0,
        "max_place_height_m": 30.0,
        "length_m": 2.0,
        "width_m": 2.0,
        "max_speed_mps": 0,
        "max_turn_radps": 0,
        "capabilities": ["stand_fixed", "pour"],
    }
    carrier = {**pump, "payload_kg": 3_000, "max_speed_mps": 0.8, "max_turn_radps": 1.0, "capabilities": []}
    fleet = Fleet.model_validate(
        {
            "types": {"pump": pump, "carrier": carrier},
            "robots": [{"type": "pump", "count": 1}, {"type": "carrier", "count": 1}],
        }
    )
    limits = method_limits(fleet, load_methods())
    assert (limits.lift_capacity_kg, limits.lifted_by) == (3_000, "carrier")


def test_a_slab_of_unknown_material_cast_when_too_heavy_says_it_is_taken_for_concrete() -> None:
    unknown = WALL.model_copy(
        update={"material": "unknown", "if_too_heavy": ConstructionMethod.CAST_IN_PLACE}
    )
    cast = final_method(unknown, 37_518, (16.9, 7.4, 0.3), "IfcSlab", LIMITS)
    assert (cast.method, cast.source) == (ConstructionMethod.CAST_IN_PLACE, MethodSource.RULE)
    assert cast.note.endswith("an IfcSlab of unknown material, cast in place as concrete instead")
    concrete = unknown.model_copy(update={"material": "concrete"})
    assert final_method(concrete, 37_518, (16.9, 7.4, 0.3), "IfcSlab", LIMITS).note.endswith(
        "a concrete IfcSlab cast in place instead"
    )
