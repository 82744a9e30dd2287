"""Work in place, as one table: which capability each method built where it stands needs (pure).

Why one table: the planner (who can build it), the robots (what their site work does), physics (who may
ask it to build), the site plan (where a machine sets up for its method's work), the run (which machines
stay off site) and the observer and report (what is built where it stands) each kept their own copy of
this mapping, and a new method (``driven``) had to be added to five of them. Each now reads this one.
"""

from __future__ import annotations

from .construction_methods import ConstructionMethod
from .manifest import Component
from .robot_description import Capability

#: The capability a method built where it stands needs: pour for cast in place, lay for laid masonry,
#: pile for a driven pile.
WORK_CAPABILITY: dict[ConstructionMethod, Capability] = {
    ConstructionMethod.CAST_IN_PLACE: Capability.POUR,
    ConstructionMethod.LAID: Capability.LAY,
    ConstructionMethod.DRIVEN: Capability.PILE,
}
#: The method of the work each of those capabilities does.
WORK_METHOD: dict[Capability, ConstructionMethod] = {
    capability: method for method, capability in WORK_CAPABILITY.items()
}
#: The methods whose components are built where they stand, never carried (never in the yard).
BUILT_IN_PLACE: tuple[ConstructionMethod, ...] = tuple(WORK_CAPABILITY)


def pile_length_m(component: Component) -> float:
    """A pile's length: its height, toe to head (a pile stands upright)."""
    return component.bbox_world.max_m[2] - component.bbox_world.min_m[2]
