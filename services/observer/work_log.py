"""Work in place in the live twin: a cast, laid or driven component drawn where it is built, when it is built.

A cast-in-place, laid or driven component never lies in the yard: physics keeps it out of sight until a
pump pours it, a block layer lays it or a piling rig drives it, and publishes its pose only once it stands
built at its target. So the twin (:mod:`.twin_log`) logs its mesh not at the start (a mesh without a pose
is drawn at the world's origin) but with that first pose, on the timeline: scrubbed back, it is not there
yet. While it is worked on, its BIM box is drawn at ``world/work/<guid>`` in the state's colour, labelled
with its name, the step and the machine (``Footing A2: formwork, r2 (pump)``):

* ``forming``: the box's outline (the formwork going up), navy; ``pouring``: the outline in teal;
  ``driving``: the outline in khaki (a pile going in);
* ``laying``: the outline in magenta, its label counting the courses standing (``Wall W1: laying 2/8
  courses, r3 (block_layer)``), and in it at ``world/work/<guid>/courses`` a solid box up to them.
  Physics does not publish a wall's height; the block layer's state says ``course k/n`` while it lays
  course k, and courses 1…k−1 stand by then (physics raises the wall at the end of each course). The
  solid box is the component's bounding box cut at (k−1)/n of its height: the wall's own shape for a
  straight wall, a box round anything else — cheap, and what the site shows;
* out of work (verifying, constructed, given back, failed) the work box is cleared.

Each component also carries its method as values the viewer shows when it is selected (``method``,
``method_source``, ``method_note``; ``resource``: the robot types that worked on it so far).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

import rerun as rr

from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentPoseMsg, ComponentState, ComponentStateMsg, RobotStateMsg
from bimbot.shared.state_colors import STATE_COLORS
from bimbot.shared.work_methods import BUILT_IN_PLACE

from .twin_items import LogItem, component_path, mesh_archetype

WORK_STEPS = {  # a working state → the step's word on its label
    ComponentState.FORMING: "formwork",
    ComponentState.POURING: "pour",
    ComponentState.LAYING: "laying",
    ComponentState.DRIVING: "driving",
}
COURSE = re.compile(r"\bcourse (\d+)/(\d+)\b")  # the block layer's activity (services/robot/site_work.py)
MIN_COURSES_HEIGHT_M = 0.01
Mesh = tuple[bytes, str]


def work_path(guid: str) -> str:
    return f"world/work/{rr.escape_entity_path_part(guid)}"


def courses_laid(activity: str) -> tuple[int, int] | None:
    """``(courses standing, courses in all)`` from a block layer's activity ``course k/n`` (k−1 stand while
    it lays course k); None for any other activity."""
    match = COURSE.search(activity)
    if match is None:
        return None
    course, courses = int(match.group(1)), int(match.group(2))
    return (max(0, min(course - 1, courses)), courses) if courses > 0 else None


def method_values(component: Component, resources: Iterable[str] = ()) -> rr.AnyValues:
    """A component's method as values shown when it is selected in the viewer."""
    return rr.AnyValues(
        method=component.method.value,
        method_source=component.method_source.value,
        method_note=component.method_note or "-",
        resource=", ".join(resources) or "-",
    )


def robot_label(robot_id: str | None, robot_type_of: Mapping[str, str]) -> str:
    """``r2 (pump)``; the id alone when its type is not known."""
    if not robot_id:
        return ""
    type_name = robot_type_of.get(robot_id)
    return f"{robot_id} ({type_name})" if type_name else robot_id


def _box(component: Component, top_fraction: float = 1.0) -> tuple[list[float], list[float]]:
    """(min corner, size) of the component's BIM box, cut at ``top_fraction`` of its height."""
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    size = [hi - lo for lo, hi in zip(low, high, strict=True)]
    size[2] = max(size[2] * top_fraction, MIN_COURSES_HEIGHT_M)
    return list(low), size


class WorkLog:
    """Keeps the meshes of components built in place until they are built; draws the work on them."""

    def __init__(self, components: Iterable[Component], robot_type_of: Mapping[str, str]) -> None:
        self.components = {c.guid: c for c in components}
        self.robot_type_of = robot_type_of  # the twin's, filled once physics' site info arrives
        self._meshes: dict[str, Mesh | None] = {}
        self._resources: dict[str, list[str]] = {}
        self._state: dict[str, ComponentState] = {}

    def built_in_place(self, guid: str) -> bool:
        component = self.components.get(guid)
        return component is not None and component.method in BUILT_IN_PLACE

    def hold_mesh(self, guid: str, mesh: Mesh | None) -> None:
        """Keep ``guid``'s mesh until physics says it stands built (see the module)."""
        self._meshes[guid] = mesh

    def component_pose(self, msg: ComponentPoseMsg) -> list[LogItem]:
        """The mesh of a component built in place, with its first pose (it stands built from then on)."""
        if msg.guid not in self._meshes:
            return []
        mesh = self._meshes.pop(msg.guid)
        return [LogItem(component_path(msg.guid), mesh_archetype(*mesh))] if mesh is not None else []

    def component_state(self, msg: ComponentStateMsg) -> list[LogItem]:
        """The component's method values when a new robot type worked on it; its work box (see the
        module)."""
        component = self.components.get(msg.guid)
        if component is None:
            return []
        items: list[LogItem] = []
        resources = self._resources.setdefault(msg.guid, [])
        type_name = self.robot_type_of.get(msg.robot_id or "")
        if type_name is not None and type_name not in resources:
            resources.append(type_name)
            items.append(LogItem(component_path(msg.guid), method_values(component, resources)))
        previous = self._state.get(msg.guid)
        self._state[msg.guid] = msg.state
        step = WORK_STEPS.get(msg.state)
        if step is None:
            if previous in WORK_STEPS:
                items.append(LogItem(work_path(msg.guid), rr.Clear(recursive=True)))
            return items
        return [*items, LogItem(work_path(msg.guid), self._outline(component, msg.state, msg.robot_id))]

    def _outline(
        self, component: Component, state: ComponentState, robot_id: str | None, courses: str = ""
    ) -> rr.Boxes3D:
        """The work box's outline in the state's colour, labelled (see the module)."""
        label = f"{component.name or component.guid}: {WORK_STEPS[state]}{courses}"
        if robot_id:
            label += f", {robot_label(robot_id, self.robot_type_of)}"
        mins, sizes = _box(component)
        return rr.Boxes3D(
            mins=[mins],
            sizes=[sizes],
            colors=[STATE_COLORS[state]],
            radii=0.03,
            labels=[label],
            fill_mode="majorwireframe",
        )

    def robot_state(self, msg: RobotStateMsg) -> list[LogItem]:
        """A laid component's courses standing, from its block layer's activity (see the module)."""
        if msg.guid is None or self._state.get(msg.guid) is not ComponentState.LAYING:
            return []
        laid = courses_laid(msg.activity)
        component = self.components.get(msg.guid)
        if laid is None or component is None:
            return []
        standing, courses = laid
        mins, sizes = _box(component, standing / courses)
        courses_box = rr.Boxes3D(
            mins=[mins], sizes=[sizes], colors=[STATE_COLORS[ComponentState.LAYING]], fill_mode="solid"
        )
        counted = f" {standing}/{courses} courses"
        outline = self._outline(component, ComponentState.LAYING, msg.robot_id, counted)
        return [LogItem(work_path(msg.guid), outline), LogItem(f"{work_path(msg.guid)}/courses", courses_box)]

    def initial(self) -> list[LogItem]:
        """Every component's method values, for sim time 0 (before any robot worked on it)."""
        return [LogItem(component_path(guid), method_values(c)) for guid, c in self.components.items()]


def yard_kept(component: Component) -> bool:
    """Whether a component waits in the yard (lifted, panels); one built in place never does."""
    return component.method not in BUILT_IN_PLACE
