"""The connection rule physics and the planner share (shared/connection_hold.py): which connections made
as a member is let go hold it where it was set."""

from __future__ import annotations

from bimbot.shared.connection_hold import plan_connections
from bimbot.shared.connection_kinds import ConnectionKind, ConnectionLink


def _links(**kinds: ConnectionKind) -> dict[str, ConnectionLink]:
    return {
        guid: ConnectionLink(other_guid=guid, kind=kind, time_s=60.0 if kind.fixes else 20.0, source="side")
        for guid, kind in kinds.items()
    }


def test_one_pinned_end_alone_is_a_hinge_and_holds_nothing() -> None:
    plan = plan_connections(("wall",), _links(wall=ConnectionKind.PINNED_END), (), 20.0)
    assert plan.fixed_to == () and plan.holds_at_s == {}
    assert plan.kinds == {"wall": ConnectionKind.PINNED_END} and plan.connection_s == 60.0


def test_a_bearing_alone_holds_by_friction_only() -> None:
    plan = plan_connections(("slab",), _links(slab=ConnectionKind.BEARING), (), 20.0)
    assert plan.fixed_to == ()


def test_a_pinned_end_and_a_bearing_hold_it_as_a_pin_and_a_roller() -> None:
    """A curtain wall's bottom transom lying on its slab, bolted to the wall it abuts: the bearing keeps it
    from turning about its pin, the pin keeps it from sliding. Held where it was set (fixed by its pin)."""
    links = _links(wall=ConnectionKind.PINNED_END, slab=ConnectionKind.BEARING)
    plan = plan_connections(("wall", "slab"), links, (), 20.0)
    assert plan.fixed_to == ("wall",) and plan.holds_at_s == {"wall": 60.0}
    assert plan.connection_s == 60.0


def test_two_pinned_ends_hold_it_and_a_joint_holds_as_a_fixed_connection() -> None:
    links = _links(left=ConnectionKind.PINNED_END, right=ConnectionKind.PINNED_END)
    assert plan_connections(("left", "right"), links, (), 20.0).fixed_to == ("left", "right")
    jointed = plan_connections(("left",), links, ("left",), 20.0)
    assert jointed.fixed_to == ("left",), "a joint partner (no contact between the two) holds it"


def test_a_roof_panel_fastened_down_on_a_pitch_is_held_by_that_one_connection() -> None:
    """Screwed down to its wall plate, a pitched roof panel is fixed where it was set: one fastened
    connection is not a hinge."""
    plan = plan_connections(("wall",), _links(wall=ConnectionKind.FASTENED), (), 20.0)
    assert plan.fixed_to == ("wall",) and plan.kinds == {"wall": ConnectionKind.FASTENED}
