"""The twin record an agent answers on ``components/<key>/twin``, built for tests from a manifest component
(the robot's fake site and the run's builders both answer twin questions)."""

from __future__ import annotations

from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentState, ComponentStateMsg, PoseMsg, TwinMsg


def twin_message(
    component: Component,
    state: ComponentState,
    history: list[ComponentStateMsg],
    *,
    attempt: int,
    robot_id: str | None,
) -> TwinMsg:
    """``component``'s twin in ``state`` with the transitions that led there, not posed by physics yet."""
    target = component.target_pose_world
    return TwinMsg(
        guid=component.guid,
        key=component.key,
        ifc_class=component.ifc_class,
        name=component.name,
        storey=component.storey,
        material=component.material,
        mass_kg=component.mass_kg,
        target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
        current_pose=None,
        current_pose_sim_time_s=None,
        state=state,
        attempt=attempt,
        robot_id=robot_id,
        history=history,
    )
