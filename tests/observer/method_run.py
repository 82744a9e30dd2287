"""A synthetic run with work in place on the bundled frame, as the bus would carry it (times in sim s).

The frame's first two footings are cast in place (4 h of formwork, 30 min of pour, 3 days of curing), its
third is laid by a block layer, Column A1 (on the first footing) carries a base plate built with it, and
two components are panels of one element. A pump (r2) forms and pours both footings; the planner holds
Column A1 for the first footing's curing (its progress says so); nothing rests on the second in this run,
so the planner never names it (the report takes its cure from the manifest). A block layer (r3) lays the
third footing; a carrier (r1) sets Column A1 once the first footing has cured:

    r2 pump         0.8 → 16201.4   Footing A1: forming 1.0, pouring 14401.0, verifying 16201.0
                    16202 → 32402.6 Footing A2: forming 16202.2, pouring 30602.2, verifying 32402.2
    r3 block layer  0.8 → 7201.4    Footing A3: laying 1.0 (courses 1/3 … 3/3), verifying 7201.0
    r1 carrier      275402 → 275431 Column A1 (released 275401.2 when the cure ends), 4 mm off target
"""

from __future__ import annotations

from pydantic import BaseModel

from bimbot.shared.construction_methods import (
    CastWork,
    ConstructionMethod,
    GuestElement,
    MethodSource,
    PanelisedElement,
)
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import (
    ComponentStateMsg,
    CuringHold,
    ProgressMsg,
    RobotState,
    RobotStateMsg,
)

CAST = CastWork(formwork_area_m2=4.0, volume_m3=0.1, formwork_s=14400.0, pour_s=1800.0, cure_s=259200.0)
TYPES = {"r1": "carrier", "r2": "pump", "r3": "block_layer"}
FIRST_CURED_S = 16201.2 + 259200.0
END_S = 275431.0


def method_manifest(frame: Manifest) -> Manifest:
    """The frame with the methods of this run (see the module)."""
    items = list(frame.components)
    first, second, third, column = items[0], items[1], items[2], items[9]
    panels = items[12:14]
    cast = {"method": ConstructionMethod.CAST_IN_PLACE, "method_source": MethodSource.RULE, "cast": CAST}
    items[0] = first.model_copy(update=cast)  # the frame's footings say PRECAST: here a rule casts them
    items[1] = second.model_copy(update=cast)
    items[2] = third.model_copy(update={"method": ConstructionMethod.LAID, "method_note": "masonry pier"})
    plate = GuestElement(
        guid="3BasePlate0000000000A1", ifc_class="IfcPlate", mass_kg=12.0, relation="contact"
    )
    items[9] = column.model_copy(update={"guests": [plate]})
    element = PanelisedElement(
        guid="2WallElement0000000000",
        ifc_class="IfcWall",
        mass_kg=sum(p.mass_kg for p in panels),
        panel_guids=tuple(p.guid for p in panels),
        why="too heavy to lift whole",
    )
    for index, panel in zip((12, 13), panels, strict=True):
        items[index] = panel.model_copy(
            update={"method": ConstructionMethod.PANELISED, "parent_guid": element.guid}
        )
    return frame.model_copy(update={"components": items, "panelised": [element]})


def _state(
    guid: str, previous: S, state: S, t: float, robot: str | None = None, *, error_m: float | None = None
) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid,
        previous=previous,
        state=state,
        event="e",
        attempt=1,
        robot_id=robot,
        sim_time_s=t,
        wall_time_s=t,
        position_error_m=error_m,
        angle_error_rad=0.0 if error_m is not None else None,
        drift_m=0.0 if error_m is not None else None,
    )


def _robot(
    robot: str, state: RobotState, t: float, guid: str | None = None, activity: str = ""
) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot,
        state=state,
        task_id=f"T-{guid}" if guid else None,
        guid=guid,
        pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=t,
        wall_time_s=t,
        activity=activity,
    )


def _progress(manifest: Manifest, t: float, curing: list[CuringHold], *, done: bool = False) -> ProgressMsg:
    total = len(manifest.components)
    return ProgressMsg(
        total=total,
        counts={},
        percent_constructed=0.0,
        sim_time_s=t,
        estimated_finish_sim_time_s=None,
        curing=curing,
        done=done,
    )


def method_messages(manifest: Manifest) -> list[BaseModel]:
    """The run's messages in publication order (see the module)."""
    first, second, third, column = (manifest.components[i].guid for i in (0, 1, 2, 9))
    work, idle = RobotState.WORK_IN_PLACE, RobotState.IDLE
    hold = CuringHold(guid=column, cast_guid=first, until_s=FIRST_CURED_S)

    def cast(guid: str, start: float) -> list[BaseModel]:
        formwork = start + 14400.0
        placed = formwork + 1800.0
        return [
            _robot("r2", work, start - 0.2, guid),
            _state(guid, S.RELEASED, S.FORMING, start, "r2"),
            _robot("r2", work, start, guid, "formwork and reinforcement"),
            _state(guid, S.FORMING, S.POURING, formwork, "r2"),
            _robot("r2", work, formwork, guid, "pour"),
            _state(guid, S.POURING, S.VERIFYING, placed, "r2"),
            _state(guid, S.VERIFYING, S.CONSTRUCTED, placed + 0.2, "r2", error_m=0.0),
            _robot("r2", idle, placed + 0.4),
        ]

    return [
        *(_state(guid, S.PLANNED, S.RELEASED, 0.6) for guid in (first, second, third)),
        *cast(first, 1.0),
        _robot("r3", work, 0.8, third),
        _state(third, S.RELEASED, S.LAYING, 1.0, "r3"),
        *(_robot("r3", work, 1.0 + 2400.0 * k, third, f"course {k + 1}/3") for k in range(3)),
        _state(third, S.LAYING, S.VERIFYING, 7201.0, "r3"),
        _state(third, S.VERIFYING, S.CONSTRUCTED, 7201.2, "r3", error_m=0.0),
        _robot("r3", idle, 7201.4),
        _progress(manifest, 16202.0, [hold]),
        *cast(second, 16202.2),
        _progress(manifest, 32403.0, [hold]),
        _state(column, S.PLANNED, S.RELEASED, FIRST_CURED_S),
        _robot("r1", RobotState.DETECT_COMPONENT_POSITION, 275402.0, column),
        _state(column, S.RELEASED, S.PICKING, 275402.0, "r1"),
        _state(column, S.PICKING, S.TRANSPORTING, 275410.0, "r1"),
        _state(column, S.TRANSPORTING, S.ASSEMBLING, 275420.0, "r1"),
        _state(column, S.ASSEMBLING, S.VERIFYING, 275430.0, "r1"),
        _state(column, S.VERIFYING, S.CONSTRUCTED, 275430.2, "r1", error_m=0.004),
        _robot("r1", idle, END_S),
        _progress(manifest, END_S, [], done=True),
    ]
