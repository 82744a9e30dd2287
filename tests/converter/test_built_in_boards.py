"""A board drawn inside a wall's thickness (blocking, a backing board) is built into that wall, not set by a
robot on its own: the Janesville restaurant's 23 mm board lies 21 mm inside its 190 mm restroom walls."""

from __future__ import annotations

from component_boxes import box_component

from bimbot.services.converter.built_in_boards import build_in_boards
from bimbot.shared.construction_methods import ConstructionMethod, MethodSource

WALL = box_component("wall", (0.19, 8.17, 3.7), (0.0, 0.0, 0.0)).model_copy(update={"ifc_class": "IfcWall"})


def _method(board_size: tuple[float, float, float], at: tuple[float, float, float], **update: object) -> str:
    board = box_component("board", board_size, at).model_copy(update=update)
    decided = {c.guid: c for c in build_in_boards([WALL, board])}
    assert decided["wall"] == WALL  # the wall itself is untouched
    return decided["board"].method.value


def test_a_board_inside_the_wall_is_built_with_it_and_says_why() -> None:
    board = box_component("board", (0.023, 8.0, 0.38), (0.021, 0.1, 2.69))
    decided = {c.guid: c for c in build_in_boards([WALL, board])}["board"]
    assert decided.method is ConstructionMethod.WITH_HOST and decided.method_source is MethodSource.RULE
    assert "inside the thickness of" in decided.method_note


def test_a_board_on_the_wall_face_a_block_inside_it_or_the_users_word_stay_as_they_were() -> None:
    assert _method((0.023, 8.0, 0.38), (0.19, 0.1, 2.69)) == "lifted"  # on its face: hung on it
    assert _method((0.023, 8.0, 0.38), (0.0, 0.1, 2.69)) == "lifted"  # a trim drawn into its face
    assert _method((0.15, 0.5, 0.5), (0.02, 0.1, 1.0)) == "lifted"  # not a board
    assert _method((0.023, 8.0, 0.38), (0.021, 0.1, 2.69), ifc_class="IfcMember") == "lifted"  # a stud
    user = {"method_source": MethodSource.USER}
    assert _method((0.023, 8.0, 0.38), (0.021, 0.1, 2.69), **user) == "lifted"


def test_a_board_inside_existing_work_stays_new_work_of_its_own() -> None:
    """The restaurant's 23 mm panels set into its existing brick wall are new construction: built in with
    an in-place wall they would vanish from the build."""
    existing = WALL.model_copy(update={"method": ConstructionMethod.IN_PLACE})
    board = box_component("board", (0.023, 1.6, 1.8), (0.05, 0.1, 0.15))
    decided = {c.guid: c for c in build_in_boards([existing, board])}
    assert decided["board"].method is ConstructionMethod.LIFTED
