"""A thin panel hung on a wall's face is screwed or anchored to it across that face (``fastened``), which
holds it; a single pinned end would be a hinge, and the Janesville restaurant's 23 mm board, 2.4 m square,
hung 0.56 m above the floor on its brick wall, fell off it three times.
"""

from __future__ import annotations

from component_boxes import box_component

from bimbot.services.converter.connection_kinds import decide_connections
from bimbot.shared.connection_hold import plan_connections
from bimbot.shared.connection_kinds import ConnectionKind
from bimbot.shared.manifest import Component
from bimbot.shared.methods_file import load_methods

WALL = box_component("wall", (6.0, 0.2, 3.7), (0.0, 0.0, 0.0)).model_copy(update={"ifc_class": "IfcWall"})


def _linked(item: Component) -> dict[str, ConnectionKind]:
    methods = load_methods()
    (decided,) = decide_connections([item], [WALL, item], [], methods.connections, methods.temporary_supports)
    return {link.other_guid: link.kind for link in decided.connection_links}


def test_a_board_hung_flat_on_the_wall_face_is_fastened_to_it_and_held() -> None:
    board = box_component("board", (2.4, 0.023, 2.44), (1.0, 0.2, 0.56))
    assert _linked(board) == {"wall": ConnectionKind.FASTENED}
    methods = load_methods()
    (decided,) = decide_connections(
        [board], [WALL, board], [], methods.connections, methods.temporary_supports
    )
    links = {link.other_guid: link for link in decided.connection_links}
    plan = plan_connections(["wall"], links, [], 60.0)
    assert plan.fixed_to == ("wall",)  # held once its fixings are in: not a hinge
    assert plan.connection_s == methods.connections.fastened_s


def test_what_is_not_a_panel_flat_on_the_wall_keeps_its_bolted_end() -> None:
    block = box_component("block", (0.5, 0.5, 0.5), (1.0, 0.2, 0.56))  # a cabinet-like block beside the wall
    assert _linked(block) == {"wall": ConnectionKind.PINNED_END}
    mullion = box_component("mullion", (0.064, 0.127, 2.0), (1.0, 0.2, 0.56))
    assert _linked(mullion.model_copy(update={"ifc_class": "IfcMember"})) == {
        "wall": ConnectionKind.PINNED_END
    }
    # a sign standing out from the wall's end, against it over a fifth of its face only
    sign = box_component("sign", (2.4, 0.023, 2.44), (5.5, 0.2, 0.56))
    assert _linked(sign) == {"wall": ConnectionKind.PINNED_END}
    # a wall is not a panel, however thin: walls meet as walls do
    lining = box_component("lining", (2.4, 0.05, 2.44), (1.0, 0.2, 0.0)).model_copy(
        update={"ifc_class": "IfcWall"}
    )
    assert ConnectionKind.FASTENED not in _linked(lining).values()
