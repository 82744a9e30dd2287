"""Messages for the run monitor's tests: a component's state changes and twin as its agent makes them,
and physics' answer of every pose (the synthetic manifest of the agent tests, no conversion needed)."""

from __future__ import annotations

import math
import threading
from typing import cast

from component_agents.agent_builders import GUIDS, SITE, manifest, quat_z
from twins import twin_message

from bimbot.run.loop import LoopLimits, RunWatch, StopSignals
from bimbot.run.monitor import RunMonitor
from bimbot.run.progress import NoProgress
from bimbot.run.restarts import Restarter
from bimbot.run.watchdog import StallWatchdog
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    SitePosesMsg,
    TwinMsg,
)
from bimbot.supervisor import ServiceProcess

__all__ = ["GUIDS", "SITE", "manifest", "pose", "poses", "state", "twin", "walk", "watch_of"]

S = ComponentState
# the path of a first-time placement: (event, state reached)
FIRST_PLACEMENT = (
    ("release", S.RELEASED),
    ("pick", S.PICKING),
    ("attach", S.TRANSPORTING),
    ("arrive", S.ASSEMBLING),
    ("place", S.VERIFYING),
    ("verified", S.CONSTRUCTED),
)


def state(
    guid: str, to: ComponentState, previous: ComponentState | None, event: str, sim_time_s: float = 1.0
) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid,
        state=to,
        previous=previous,
        event=event,
        attempt=1,
        robot_id="r1",
        sim_time_s=sim_time_s,
        wall_time_s=1000.0 + sim_time_s,
    )


def walk(guid: str, until: ComponentState) -> list[ComponentStateMsg]:
    """The state changes an agent publishes from ``planned`` to ``until`` (one sim second apart)."""
    messages, previous = [], S.PLANNED
    for index, (event, reached) in enumerate(FIRST_PLACEMENT):
        messages.append(state(guid, reached, previous, event, sim_time_s=float(index + 1)))
        previous = reached
        if reached == until:
            return messages
    raise ValueError(f"{until} is not on the path of a first placement")


def twin(site_manifest: Manifest, guid: str, at: ComponentState) -> TwinMsg:
    """The twin an agent answers for ``guid`` once it is ``at`` (its history: the walk there)."""
    planned = at == S.PLANNED
    return twin_message(
        site_manifest.component(guid),
        at,
        [] if planned else walk(guid, at),
        attempt=0 if planned else 1,
        robot_id=None if planned else "r1",
    )


def pose(
    component: Component, offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0), extra_yaw_deg: float = 0.0
) -> ComponentPoseMsg:
    """``component`` at its BIM target, shifted by ``offset_m`` and turned about Z by ``extra_yaw_deg``."""
    target = component.target_pose_world
    position = tuple(p + d for p, d in zip(target.position_m, offset_m, strict=True))
    yaw = target.rpy_rad[2] + math.radians(extra_yaw_deg)
    return ComponentPoseMsg(
        guid=component.guid, pose=PoseMsg(position_m=position, quat_xyzw=quat_z(yaw)), sim_time_s=50.0
    )


def poses(
    site_manifest: Manifest,
    moved: dict[str, tuple[tuple[float, float, float], float]] | None = None,
    missing: tuple[str, ...] = (),
) -> SitePosesMsg:
    """Physics' answer: every component at its target except the ``moved`` ones (GUID → offset in m, extra
    yaw in degrees) and the ``missing`` ones (not in the answer)."""
    moved = moved or {}
    components = {
        component.guid: pose(component, *moved.get(component.guid, ((0.0, 0.0, 0.0), 0.0)))
        for component in site_manifest.components
        if component.guid not in missing
    }
    return SitePosesMsg(step=5000, epoch=0, sim_time_s=50.0, components=components, robots={})


def watch_of(
    planner: object, everyone: list, monitor: object, restarter: Restarter | None = None
) -> RunWatch:
    """A run loop over stand-in services and monitor (anything with the methods the loop calls), never
    stopped by a signal, writing no report."""
    stop = StopSignals()
    stop.event = threading.Event()
    return RunWatch(
        planner=cast(ServiceProcess, planner),
        everyone=cast(list[ServiceProcess], everyone),
        monitor=cast(RunMonitor, monitor),
        limits=LoopLimits(timeout_s=100.0, report_every_s=0.0),
        watchdog=StallWatchdog(0.0, 0.0),
        progress=NoProgress(),
        stop=stop,
        write_report=lambda _ending: None,
        restarter=restarter,
    )
