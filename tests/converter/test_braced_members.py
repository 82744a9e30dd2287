"""Which robot-set members get braces until their frame holds them (services/converter/connection_kinds.py):
a slender column with no fixed base, and a member standing on a narrow edge, such as a stair's stringer;
not a column bolted to its base plate, nor a member lying flat, nor a glazing panel set into its frame."""

from __future__ import annotations

from component_boxes import box_component

from bimbot.services.converter.connection_kinds import decide_connections
from bimbot.shared.connection_kinds import ConnectionKind, SupportKind, SupportWhen, TemporarySupportNeed
from bimbot.shared.manifest import Component
from bimbot.shared.methods_file import load_methods


def _on_slab(ifc_class: str, size_m: tuple[float, float, float]) -> tuple[Component, Component]:
    slab = box_component("slab", (8.0, 8.0, 0.2), (-4.0, -4.0, -0.2))
    slab = slab.model_copy(update={"ifc_class": "IfcSlab"})
    member = box_component("member", size_m, (0.0, 0.0, 0.0)).model_copy(update={"ifc_class": ifc_class})
    return slab, member


def _decided(slab: Component, member: Component, *more: Component) -> Component:
    methods = load_methods()
    decided = decide_connections(
        [member], [slab, member, *more], [], methods.connections, methods.temporary_supports
    )
    return decided[0]


def test_a_stair_stringer_standing_on_its_edge_is_braced_until_what_it_is_framed_to_holds_it() -> None:
    """The Revit duplex's stringer: 50 mm wide, 3.75 m long, 3.1 m tall, set on its slab. Unbraced it
    tipped over onto the carrier that set it and walled it in."""
    stringer = _decided(*_on_slab("IfcMember", (0.05, 3.75, 3.1)))
    need = stringer.temporary_support
    assert isinstance(need, TemporarySupportNeed)
    assert need.kind is SupportKind.BRACES and need.when is SupportWhen.UNANCHORED
    assert need.count == load_methods().temporary_supports.braces_per_column
    assert "62× its least width" in need.why


def test_a_member_lying_flat_a_glazing_panel_or_a_column_on_its_base_plate_is_not_braced() -> None:
    purlin = _decided(*_on_slab("IfcMember", (4.0, 0.1, 0.2)))
    assert purlin.temporary_support is None
    glazing = _decided(*_on_slab("IfcPlate", (1.5, 0.025, 3.0)))  # set into the pockets of its mullions
    assert glazing.temporary_support is None
    column = _decided(*_on_slab("IfcColumn", (0.2, 0.2, 3.0)))  # on anchor bolts in its slab
    assert {link.kind for link in column.connection_links} == {ConnectionKind.BOLTED_BASE}
    assert column.temporary_support is None


def test_a_spiral_stair_on_its_post_is_bolted_to_the_floor_a_straight_flight_bears() -> None:
    """The ArchiCAD 14 export of the FZK-Haus: its 3.56 m spiral stair on a 1.7 m × 1.6 m plan, set bearing
    on the floor, tipped three times and 76 components that rest on it were blocked (33 of 110 built). A
    spiral stair stands on its central post, whose base plate a site bolts down; a straight flight runs
    longer than it rises and bears on what carries it."""
    spiral = _decided(*_on_slab("IfcStair", (1.7, 1.6, 3.56)))
    assert {link.kind for link in spiral.connection_links} == {ConnectionKind.BOLTED_BASE}
    flight = _decided(*_on_slab("IfcStair", (1.1, 4.2, 2.9)))
    assert {link.kind for link in flight.connection_links} == {ConnectionKind.BEARING}
