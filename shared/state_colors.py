"""The observer's colours of component and robot states, one table for the live viewer and ``report.png``.

Apart from :mod:`.twin_items` so the report's chart (matplotlib only) draws formwork, pour and laying in
the colours the viewer gives those states, without importing rerun.
"""

from __future__ import annotations

from bimbot.shared.messages import ComponentState, RobotState

Rgba = tuple[int, int, int, int]

# One colour per component state; "carried" (picking/transporting) and the failure path stand out.
STATE_COLORS: dict[ComponentState, Rgba] = {
    ComponentState.PLANNED: (170, 170, 170, 255),  # grey: waiting in the yard
    ComponentState.RELEASED: (33, 150, 243, 255),  # blue: ready, waiting for a robot
    ComponentState.PICKING: (0, 229, 255, 255),  # cyan: a robot is coming for it
    ComponentState.TRANSPORTING: (255, 152, 0, 255),  # orange: carried
    ComponentState.ASSEMBLING: (156, 39, 176, 255),  # purple: being put in place
    ComponentState.FORMING: (0, 0, 195, 255),  # navy: formwork going up around it
    ComponentState.POURING: (0, 150, 136, 255),  # teal: concrete going in
    ComponentState.LAYING: (255, 90, 255, 255),  # magenta: courses going up
    ComponentState.DRIVING: (160, 140, 60, 255),  # khaki: a pile going into the ground
    ComponentState.VERIFYING: (255, 235, 59, 255),  # yellow: checking its own pose
    ComponentState.CONSTRUCTED: (46, 160, 67, 255),  # green: done
    ComponentState.MISPLACED: (244, 67, 54, 255),  # red: off target, will be retried
    ComponentState.FAILED: (80, 0, 0, 255),  # dark red: given up
    ComponentState.BLOCKED: (90, 60, 40, 255),  # brown: a predecessor failed, never released
}
ROBOT_COLORS: dict[RobotState, Rgba] = {
    RobotState.IDLE: (120, 120, 120, 255),
    RobotState.DETECT_COMPONENT_POSITION: (33, 150, 243, 255),
    RobotState.PICK_UP: (0, 229, 255, 255),
    RobotState.IDENTIFY_TARGET_LOCATION: (255, 152, 0, 255),
    RobotState.ASSEMBLE: (156, 39, 176, 255),
    RobotState.WORK_IN_PLACE: (0, 150, 136, 255),
}


def unit_rgb(color: Rgba) -> tuple[float, float, float]:
    """An 8-bit colour as matplotlib's 0–1 RGB."""
    return (color[0] / 255.0, color[1] / 255.0, color[2] / 255.0)
