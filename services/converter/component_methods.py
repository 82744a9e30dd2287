"""A component's method fields, written by the component writer once the element's mass is known.

:func:`settled_method` takes the element's decision from the shard context (a GlobalId without one is
lifted by the default rule) and settles it against the fleet's lift and a truck's load
(:func:`.final_method.final_method`, the element's own bounding box and whether its target lies in the
ground), with a smaller lift where the converter found that a crane lifts less where the element goes
(:mod:`.crane_reach`). :func:`method_fields` gives the :class:`Component` fields: method, source, note
and, for an element cast in place, its :class:`CastWork`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodLimits

from .cast_work import cast_work
from .final_method import default_limits, final_method
from .in_place import lies_in_ground

if TYPE_CHECKING:
    from .component_work import GeometryWork, PlacedElement, ShardContext


def target_in_ground(item: PlacedElement, context: ShardContext) -> bool:
    """Whether the element's target (world frame, after the local-origin shift) lies in the ground."""
    low = float(item.bbox_ifc_world_m[0][2] - context.origin[2])
    high = float(item.bbox_ifc_world_m[1][2] - context.origin[2])
    return lies_in_ground(low, high)


def element_limits(guid: str, context: ShardContext) -> MethodLimits:
    """What a part of the element ``guid`` may weigh and measure: the context's limits (none: the default
    fleet's and methods'), with the lift a crane has where the element goes when the converter found it
    smaller (:mod:`.crane_reach`)."""
    limits = context.limits or default_limits()
    reach = context.lift_limits.get(guid)
    return reach.applied(limits) if reach is not None else limits


def settled_method(
    item: PlacedElement, work: GeometryWork, mass_kg: float, context: ShardContext
) -> MethodDecision:
    """The element's decision settled with its mass and size, against :func:`element_limits`."""
    guid = str(item.element.GlobalId)
    box = np.asarray(work.props.bbox_local_m, dtype=float)
    return final_method(
        context.decisions.get(guid),
        mass_kg,
        tuple(box[1] - box[0]),
        item.element.is_a(),
        element_limits(guid, context),
        in_ground=target_in_ground(item, context),
    )


def method_fields(
    decision: MethodDecision, item: PlacedElement, work: GeometryWork, context: ShardContext
) -> dict[str, Any]:
    """The :class:`Component` fields for ``decision``: method, method_source, method_note, cast."""
    cast = None
    if decision.method is ConstructionMethod.CAST_IN_PLACE and context.methods is not None:
        cast = cast_work(
            item.element,
            work.mesh,
            item.rotation,
            work.props.volume_m3,
            context.methods.cast_in_place,
            in_ground=target_in_ground(item, context),
        )
    return {
        "method": decision.method,
        "method_source": decision.source,
        "method_note": decision.note,
        "cast": cast,
    }
