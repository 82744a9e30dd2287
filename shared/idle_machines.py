"""Which machines of a fleet have no work in a build, so that a run leaves them off site (pure).

Why: a site brings a concrete pump for concrete and a block layer for masonry. A build with nothing cast in
place or laid gives such a machine no task, yet as a process of the run it still hears every carried
component's pose each period and answers each lock step (about 2 s of CPU each on the bundled frame, where
the default fleet's pump, line pump and block layer had nothing to do). A machine that lifts (a ground
robot, a crane) always comes: every prefabricated part is its work, and it sets the temporary supports.

The rule: a type on site that neither carries nor hooks a part, and whose work in place (``pour``: cast in
place, ``lay``: laid) matches no component's method, stays off site. Deterministic: the same fleet and
methods give the same types, in the fleet's order.
"""

from __future__ import annotations

from collections.abc import Iterable

from .construction_methods import ConstructionMethod
from .fleet import Fleet
from .robot_description import Capability, RobotDescription
from .work_methods import WORK_METHOD


def lifts_parts(description: RobotDescription) -> bool:
    """A type that carries or hooks a prefabricated part and sets it at its target."""
    return description.can(Capability.PLACE) and (
        description.can(Capability.CARRY) or description.can(Capability.HOOK_LIFT)
    )


def idle_machine_types(fleet: Fleet, methods: Iterable[ConstructionMethod]) -> tuple[str, ...]:
    """The types on site in ``fleet`` that no component of ``methods`` gives work (see the module doc)."""
    needed = set(methods)
    idle = []
    for name, description in fleet.on_site().items():
        if lifts_parts(description):
            continue
        works = {method for capability, method in WORK_METHOD.items() if description.can(capability)}
        if not works & needed:
            idle.append(name)
    return tuple(idle)


def without_types(fleet: Fleet, types: Iterable[str]) -> Fleet:
    """``fleet`` with no robot of ``types`` on site (their descriptions stay: a reason may still name
    them)."""
    gone = set(types)
    if not gone:
        return fleet
    return fleet.model_copy(update={"robots": tuple(e for e in fleet.robots if e.type not in gone)})


def site_fleet(fleet: Fleet, methods: Iterable[ConstructionMethod]) -> Fleet:
    """The fleet a run puts on site for components built by ``methods``: ``fleet`` without its idle
    machines (:func:`idle_machine_types`). The converter plans the site with it too, so the crane it cuts
    parts for stands where the run's crane stands."""
    return without_types(fleet, idle_machine_types(fleet, methods))
