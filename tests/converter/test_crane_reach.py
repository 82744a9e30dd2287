"""Parts sized for the crane's lift where they go: the converter's second look, after the site is planned."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from ifc_builders import add_box, add_material, new_model

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.crane_reach import crane_lift_limits
from bimbot.shared import site_layout
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import Fleet
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Component
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import Rect

CHART = ((10.0, 8000.0), (20.0, 4000.0), (40.0, 1000.0), (60.0, 500.0))  # radius m, payload kg


def _fleet() -> Fleet:
    """A carrier that sets 500 kg up to 3.5 m, and a tower crane whose chart falls steeply with radius."""
    carrier = {
        "urdf": "carrier.urdf",
        "payload_kg": 500,
        "reach_m": 1.8,
        "max_place_height_m": 3.5,
        "length_m": 1.4,
        "width_m": 0.9,
        "max_speed_mps": 0.8,
        "max_turn_radps": 1.0,
    }
    crane = {
        "urdf": "tower_crane.urdf",
        "payload_kg": 8000,
        "reach_m": 60.0,
        "max_place_height_m": 36.0,
        "length_m": 4.5,
        "width_m": 4.5,
        "max_speed_mps": 0,
        "max_turn_radps": 0,
        "crane": {
            "jib_height_m": 40.0,
            "min_radius_m": 2.5,
            "slew_radps": 0.08,
            "trolley_mps": 1.0,
            "hoist_mps": 1.0,
            "load_chart": [{"radius_m": r, "payload_kg": kg} for r, kg in CHART],
        },
    }
    return Fleet.model_validate(
        {
            "types": {"carrier": carrier, "tower_crane": crane},
            "robots": [{"type": "carrier", "count": 1}, {"type": "tower_crane", "count": 1}],
        }
    )


def test_a_slab_far_from_the_crane_is_cut_into_planks_the_chart_lifts_there(tmp_path: Path) -> None:
    """Two 3 t concrete slabs 4 m up, one at the middle of a 65 m building and one at its end, with a light
    beam at the other end: each slab is lighter than the crane's 8 t and fits a truck, so each used to be
    lifted whole, and the far one lay beyond the radius at which the chart lifts 3 t. The converter plans
    the site, finds it, and cuts that slab into planks the chart lifts at the slab's far side; the middle
    one stays whole."""
    small = new_model()
    beam = add_box(small, "IfcBeam", "Beam", size_m=(2.0, 0.2, 0.2), corner_m=(0.0, 0.0, 4.0))
    near = add_box(small, "IfcSlab", "Near slab", size_m=(5.0, 2.5, 0.1), corner_m=(30.0, 0.0, 4.0))
    far = add_box(small, "IfcSlab", "Far slab", size_m=(5.0, 2.5, 0.1), corner_m=(60.0, 0.0, 4.0))
    add_material(small, [beam, near, far], "Precast concrete")
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    fleet = _fleet()
    options = ConvertOptions(fleet=fleet, formats=(), split_ifc=False)
    manifest = convert_model(open_model(source), source, tmp_path / "out", options)

    whole = [c for c in manifest.components if c.name == "Near slab"]
    planks = [c for c in manifest.components if c.parent_guid == far.GlobalId]
    assert len(whole) == 1 and whole[0].method is ConstructionMethod.LIFTED
    assert len(planks) >= 2 and {c.method for c in planks} == {ConstructionMethod.PANELISED}
    assert 0.99 * 3000.0 < sum(c.mass_kg for c in planks) < 3000.0  # the slab's, less its joints' grout
    assert "tower_crane r2 at" in (planks[0].method_note or "")
    layout = plan_site(manifest.components, fleet=fleet.robot_types())
    mast = layout.robot_starts[1][:2]
    spec = fleet.types["tower_crane"].crane
    assert spec is not None
    for component in manifest.components:  # every part is within the chart where the crane sets it
        assert component.mass_kg <= spec.payload_at(math.dist(mast, _centre(component))) + 1e-6, (
            component.name
        )


def _centre(component: Component) -> tuple[float, float]:
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    return ((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0)


def test_a_part_the_crane_sets_but_cannot_pick_from_its_far_yard_slot_is_cut_to_a_pickable_lift(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 3 t slab 4 m up, 8 m from the crane's mast: the chart lifts it there. Its yard slot is moved 45 m
    from the mast, where the chart lifts 875 kg, and the carrier takes 500 kg to the crane: a precaster
    sizes its parts for the harder lift, so the slab gets the limit of the lift at its slot."""
    small = new_model()
    slab = add_box(small, "IfcSlab", "Slab", size_m=(5.0, 2.5, 0.1), corner_m=(0.0, 0.0, 4.0))
    add_material(small, [slab], "Precast concrete")
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    fleet = _fleet()
    options = ConvertOptions(fleet=fleet, formats=(), split_ifc=False)
    manifest = convert_model(open_model(source), source, tmp_path / "out", options)
    [whole] = manifest.components
    assert whole.method is ConstructionMethod.LIFTED  # the crane lifts it where it goes and in its slot
    real_plan = site_layout.plan_site
    layout = real_plan(manifest.components, fleet=fleet.robot_types())
    mast = layout.robot_starts[1][:2]
    assert fleet.types["tower_crane"].crane.payload_at(math.dist(mast, _centre(whole))) >= 3000.0
    far = Rect((mast[0] + 44.0, mast[1] - 1.0), (mast[0] + 46.0, mast[1] + 1.0))  # centre 45 m off
    moved = dataclasses.replace(layout.slots[whole.guid], footprint=far)
    layout = dataclasses.replace(layout, slots={**layout.slots, whole.guid: moved})
    monkeypatch.setattr(site_layout, "plan_site", lambda *args, **kwargs: layout)

    [(element, limit)] = crane_lift_limits(manifest.components, fleet.robot_types()).items()
    assert element == whole.guid
    assert limit.lift_kg == pytest.approx(875.0) and "yard slot, 45.0 m" in limit.lifted_by
