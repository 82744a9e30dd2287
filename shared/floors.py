"""What a ground robot drives on once it is built: a floor no higher than the robot's step.

Why: on a site the trades drive onto a ground slab and its flooring over the slab's edge, not round them;
the restaurant's 5 cm floors would otherwise cut 245 of its 470 components off. Only floors count: a
slab, a floor covering, a ramp. A 5 cm curtain-wall sill member is no floor: the Husky drove over the
house's and was shut in beside a 30 cm floor. The robots' map (once the floor is constructed and cured)
and the planner's access check ask the same question.
"""

from __future__ import annotations

from .manifest import Component

FLOOR_CLASSES = ("IfcSlab", "IfcCovering", "IfcRamp", "IfcRampFlight")


def drives_onto(component: Component, top_z_m: float, step_m: float) -> bool:
    """Whether a ground robot whose step is ``step_m`` drives onto ``component`` standing with its top at
    ``top_z_m`` (world): a floor (its class or a subclass named so) no higher than the step."""
    return top_z_m <= step_m and component.ifc_class.startswith(FLOOR_CLASSES)
