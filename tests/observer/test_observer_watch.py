"""``bimbot watch``'s table: rows from state messages and twins, problems first, trimmed to the terminal."""

from __future__ import annotations

from bimbot.services.observer.watch import WatchTable, change_line
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg, PoseMsg, TwinMsg


def _state(guid: str, state: ComponentState, previous: ComponentState | None, robot: str | None = None):
    return ComponentStateMsg(
        guid=guid, state=state, previous=previous, event="e", robot_id=robot, sim_time_s=1.0, wall_time_s=0.0
    )


def test_state_changes_update_the_row_and_repeats_do_not_count(frame_manifest: Manifest) -> None:
    table = WatchTable(frame_manifest)
    guid = frame_manifest.components[0].guid
    assert table.apply_state(_state(guid, ComponentState.PICKING, ComponentState.RELEASED, "r1"))
    assert not table.apply_state(_state(guid, ComponentState.PICKING, ComponentState.RELEASED, "r1"))
    row = table.rows[guid]
    assert (row.state, row.robot_id, row.name, row.ifc_class) == (
        ComponentState.PICKING,
        "r1",
        "Footing A1",
        "IfcFooting",
    )


def test_the_table_shows_problems_and_work_first_and_fits_the_height(frame_manifest: Manifest) -> None:
    table = WatchTable(frame_manifest)
    guids = [c.guid for c in frame_manifest.components]
    for guid in guids:
        table.apply_state(_state(guid, ComponentState.PLANNED, None))
    table.apply_state(_state(guids[5], ComponentState.FAILED, ComponentState.VERIFYING, "r2"))
    table.apply_state(_state(guids[7], ComponentState.TRANSPORTING, ComponentState.PICKING, "r1"))
    lines = table.render(height=10, color=False)
    assert len(lines) == 10
    assert lines[0].startswith("28 components, 28 reporting: failed 1, transporting 1, planned 26")
    assert lines[1].split() == ["GUID", "NAME", "CLASS", "METHOD", "STATE", "ROBOT"]
    assert guids[5] in lines[2] and "failed" in lines[2] and "r2" in lines[2]
    assert guids[7] in lines[3] and "transporting" in lines[3]
    assert lines[-1] == "… 21 more"


def test_each_row_and_change_line_says_how_its_component_is_built(frame_manifest: Manifest) -> None:
    footing = frame_manifest.components[0].model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE})
    manifest = frame_manifest.model_copy(update={"components": [footing, *frame_manifest.components[1:]]})
    table = WatchTable(manifest)
    column = table.render(color=False)[1].index("METHOD")
    forming = _state(footing.guid, ComponentState.FORMING, ComponentState.RELEASED, "r2")
    table.apply_state(forming)
    lifted = manifest.components[1].guid
    table.apply_state(_state(lifted, ComponentState.PICKING, ComponentState.RELEASED, "r1"))
    lines = table.render(color=False)
    (cast_row,) = [line for line in lines if footing.guid in line]
    (lifted_row,) = [line for line in lines if lifted in line]
    assert cast_row[column:].startswith("cast in place") and "forming" in cast_row
    assert lifted_row[column:].startswith("lifted")
    assert "(cast in place)  released -> forming" in change_line(forming, table.rows[footing.guid])


def test_colours_are_ansi_only_when_asked(frame_manifest: Manifest) -> None:
    table = WatchTable(frame_manifest)
    table.apply_state(_state(frame_manifest.components[0].guid, ComponentState.CONSTRUCTED, None))
    assert "\x1b[32m" in "\n".join(table.render(color=True))
    assert "\x1b[" not in "\n".join(table.render(color=False))


def test_a_twin_names_an_unknown_component_unless_a_state_message_was_newer() -> None:
    table = WatchTable()  # --site only: no manifest
    pose = PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    history = [
        ComponentStateMsg(
            guid="2O2Fr$t4X7Zf8NOew3FLOH",
            previous=ComponentState.PLANNED,
            state=ComponentState.RELEASED,
            event="release",
            sim_time_s=3.0,
            wall_time_s=0.0,
        )
    ]
    twin = TwinMsg(
        guid="2O2Fr$t4X7Zf8NOew3FLOH",
        key="2O2Fr-t4X7Zf8NOew3FLOH",
        ifc_class="IfcBeam",
        name="Beam",
        storey=None,
        material=None,
        mass_kg=10.0,
        target_pose=pose,
        current_pose=None,
        current_pose_sim_time_s=None,
        state=ComponentState.RELEASED,
        attempt=0,
        robot_id=None,
        history=history,
    )
    assert table.apply_twin(twin)
    row = table.rows[twin.guid]
    assert (row.name, row.ifc_class, row.state) == ("Beam", "IfcBeam", ComponentState.RELEASED)
    other = twin.model_copy(update={"guid": "3zDHqKvPPOq8qH9UHytLYU"})
    table.apply_state(_state(other.guid, ComponentState.PICKING, ComponentState.RELEASED, "r1"))
    assert not table.apply_twin(other)  # the state message is newer than the twin's answer
    assert table.rows[other.guid].state == ComponentState.PICKING and table.rows[other.guid].name == "Beam"


def test_a_change_line_names_guid_name_class_states_and_robot(frame_manifest: Manifest) -> None:
    table = WatchTable(frame_manifest)
    component = frame_manifest.components[0]
    message = _state(component.guid, ComponentState.CONSTRUCTED, ComponentState.VERIFYING, "r1")
    table.apply_state(message)
    line = change_line(message, table.rows[component.guid])
    assert all(
        part in line
        for part in (component.guid, "Footing A1", "IfcFooting", "verifying -> constructed", "robot=r1")
    )
