"""What the planner's parts share: the task, component and robot records, the site and the clocks (state).

Why one object passed to each part: release, follow-up, give-backs, failures, dispatch and the quiet-site
check all read and change the same records. Each part receives this object when it is built, instead of
declaring the attributes of a common host class. It makes no decision; it answers small questions about
its records (a component's name, where it lies, whether every task is final) that several parts ask.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from bimbot.shared.identifiers import named_guid
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.site_plan import YardSlot

from .assignment import staged_where
from .capability import SiteRobot, Where
from .feasibility import slot_where
from .records import FINAL, ComponentRecord, Phase, PlannerLimits, RobotRecord, TaskRecord
from .sources import Plan


@dataclass
class PlannerState:
    """The planner's records and clocks; ``revision`` is bumped by every change of a component's state or
    a task's phase, so the passes over every task run again only when something they read has changed."""

    manifest: dict[str, Component]  # GUID → component
    plan: Plan
    limits: PlannerLimits
    site: Mapping[str, SiteRobot] | None  # the robots on site with their types; None: nearest idle robot
    slots: Mapping[str, YardSlot]  # the yard slots of the site plan (where a component lies before any pose)
    tasks: dict[str, TaskRecord]  # GUID → its task, in plan order
    components: dict[str, ComponentRecord]  # GUID → what the planner knows of it, in plan order
    robots: dict[str, RobotRecord] = field(default_factory=dict)
    sim_time_s: float = 0.0
    wall_s: float = 0.0  # the wall time of the current step
    synced: bool = False  # the start-up sync is over
    revision: int = 1
    # phase → (the revision it was taken at, its tasks in plan order): see tasks_in
    _in_phase: dict[Phase, tuple[int, list[TaskRecord]]] = field(default_factory=dict, repr=False)

    @classmethod
    def start(
        cls,
        manifest: Manifest,
        plan: Plan,
        limits: PlannerLimits,
        robots: list[SiteRobot] | None,
        slots: Mapping[str, YardSlot],
    ) -> PlannerState:
        """Every task of ``plan`` waiting, every component planned, no robot heard from yet."""
        return cls(
            manifest={item.guid: item for item in manifest.components},
            plan=plan,
            limits=limits,
            site={robot.robot_id: robot for robot in robots} if robots is not None else None,
            slots=slots,
            tasks={
                guid: TaskRecord(guid, plan.task_ids[guid], priority)
                for priority, guid in enumerate(plan.order)
            },
            components={guid: ComponentRecord() for guid in plan.order},
        )

    @property
    def done(self) -> bool:
        """Every task is final (done, failed or blocked)."""
        return all(task.phase in FINAL for task in self.tasks.values())

    def tasks_in(self, phase: Phase) -> list[TaskRecord]:
        """The tasks in ``phase``, in plan order, kept as of the revision (a phase changes only with one):
        a pass that runs every step, as sim time moves, goes through the few it concerns (every task of the
        9,802-component frame each step was 12 % of its planner's time in the watchdog, 8 % in the search
        for failed bodies). The list is not changed afterwards: a pass may change phases as it goes."""
        kept = self._in_phase.get(phase)
        if kept is None or kept[0] != self.revision:
            in_phase = [task for task in self.tasks.values() if task.phase is phase]
            kept = self._in_phase[phase] = (self.revision, in_phase)
        return kept[1]

    def robot(self, robot_id: str) -> RobotRecord:
        """The record of ``robot_id`` (a new one the first time it is heard of)."""
        return self.robots.setdefault(robot_id, RobotRecord(robot_id))

    def free_robot(self, task: TaskRecord, *, keep_task_robot: bool = False) -> None:
        """The task's robot holds it no more; ``keep_task_robot``: the task still names it (verifying)."""
        if task.robot_id is not None:
            robot = self.robots.get(task.robot_id)
            if robot is not None and robot.task_guid == task.guid:
                robot.task_guid = None
        if not keep_task_robot:
            task.robot_id = None

    def describe(self, guid: str) -> str:
        """The component's name (or IFC class) with its GUID, for log lines and reasons."""
        component = self.manifest.get(guid)
        name = (component.name or component.ifc_class) if component is not None else None
        return named_guid(guid, name)

    def lies(self, guid: str) -> Where:
        """Where ``guid`` lies now: its last pose, else its yard slot (else its target)."""
        item, xy = self.manifest[guid], self.components[guid].position_xy
        return staged_where(item, xy) if xy is not None else slot_where(item, self.slots.get(guid))
