"""How each component is built on site: the construction methods and the work records the manifest carries.

A real building is not only lifted: concrete is cast in place, masonry is laid course by course, a wall too
heavy to lift is split into precast panels, an anchor bolt goes in with its footing. The converter decides
one method per component (from what the IFC says, then rules, then the user's methods file) and writes it
to the manifest; the planner, the robots, physics and the report act on it. This module is the vocabulary
every service shares; how a method is decided lives in the converter, how it is executed in the services
that own each step.

Methods:

================  ========================================================================================
``lifted``        a prefabricated part carried and set by a robot or a crane (the paper's one method)
``panelised``     a panel cut from an element too heavy or too large to lift or transport whole; each
                  panel is lifted; the element counts as built when all its panels are
``cast_in_place`` formwork, pour and cure: a timed task of a concrete crew; it appears at its BIM pose when
                  poured, and what rests on it waits for its curing; an element larger than one day's
                  pour is poured in bays, each a component, built when all its bays are
``laid``          masonry built course by course by a block-laying robot standing within its boom's reach
``driven``        a steel, timber or precast pile driven into the ground by a piling rig (a crawler crane
                  with a vibratory hammer) from a set-up within its reach: pitched, then driven to its toe
``with_host``     a fastener, anchor, embed or shop-welded plate: built into its host (cast into the
                  footing, carried with the column), never a task of its own
``in_place``      existing work, or built by others before the robots come
================  ========================================================================================
"""

from __future__ import annotations

from enum import StrEnum

from pydantic import BaseModel, ConfigDict, Field

from .geometry import Quat, Vec3


class ConstructionMethod(StrEnum):
    LIFTED = "lifted"
    PANELISED = "panelised"
    CAST_IN_PLACE = "cast_in_place"
    LAID = "laid"
    DRIVEN = "driven"
    WITH_HOST = "with_host"
    IN_PLACE = "in_place"


class MethodSource(StrEnum):
    """Who decided a component's method: the IFC said so, a rule did, or the user's methods file."""

    IFC = "ifc"
    RULE = "rule"
    USER = "user"


class CastWork(BaseModel):
    """A cast-in-place element's work, from its geometry and the methods file's rates (SI units)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    formwork_area_m2: float = Field(ge=0, description="faces that need formwork (not the top, not in soil)")
    volume_m3: float = Field(ge=0)
    formwork_s: float = Field(ge=0, description="setting the formwork and reinforcement")
    pour_s: float = Field(ge=0, description="placing the concrete")
    cure_s: float = Field(ge=0, description="until what rests on it may be placed (struck and loaded)")


class GuestElement(BaseModel):
    """An element built into its host (``with_host``): its geometry and mass are part of the host's body.

    Its own model folder stays, with its visual meshes (paths relative to the build folder, empty when not
    written), so a viewer can draw it at the host's pose composed with ``position_in_host_m`` /
    ``quat_in_host_xyzw`` (the guest's frame in the host's frame)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    guid: str
    ifc_class: str
    name: str | None = None
    mass_kg: float = Field(ge=0)
    relation: str = Field(description="how the host was found: an IFC relationship or 'embedded'/'contact'")
    visual_glb: str = ""
    visual_obj: str = ""
    position_in_host_m: Vec3 = (0.0, 0.0, 0.0)
    quat_in_host_xyzw: Quat = (0.0, 0.0, 0.0, 1.0)


class PanelJoint(BaseModel):
    """A joint between two panels cut from one element: where the cut runs and how long it is."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    guids: tuple[str, str]
    length_m: float = Field(ge=0)
    kind: str = Field(
        description="vertical (wall panels side by side), horizontal (stacked at a storey), longitudinal "
        "(slab planks side by side), transverse (rows of planks end to end) or construction (between two "
        "bays of a pour)"
    )


class PanelisedElement(BaseModel):
    """An element split into parts, each a component: precast panels (``panelised``), bays poured one a
    day (``cast_in_place``: a slab too large for one day's pour), or stretches laid one from each set-up of
    the block layer (``laid``: a wall longer than its boom covers from one). The element is built when all
    are."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    guid: str
    ifc_class: str
    name: str | None = None
    mass_kg: float = Field(gt=0)
    method: ConstructionMethod = Field(
        default=ConstructionMethod.PANELISED,
        description="its parts': panelised, cast_in_place (bays) or laid (stretches)",
    )
    panel_guids: tuple[str, ...] = Field(min_length=1, description="its parts, panels, bays or stretches")
    joints: tuple[PanelJoint, ...] = ()
    why: str = Field(description="the sentence with the numbers: why it was split")


class MethodDecision(BaseModel):
    """The converter's decision for one element, before its geometry is known, and what it turns into once
    it is: ``if_in_ground`` applies when its target lies in the ground (a ground slab is cast), then
    ``if_too_heavy`` when it is heavier than the fleet lifts or larger than a truck carries (a wall is
    panelised, a concrete column cast); ``material`` is the kind its material was read as (concrete,
    masonry, steel, …), for the notes."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    method: ConstructionMethod
    source: MethodSource
    note: str = ""
    host_guid: str | None = Field(default=None, description="with_host: the host the IFC relations name")
    material: str | None = None
    if_in_ground: MethodDecision | None = None
    if_too_heavy: ConstructionMethod | None = None


class MethodLimits(BaseModel):
    """What a prefabricated part may weigh and measure: the fleet's largest lift, and a road truck's load."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    lift_capacity_kg: float = Field(gt=0)
    lifted_by: str = Field(default="", description="the robot type with that capacity (for the notes)")
    transport_length_m: float = Field(gt=0)
    transport_width_m: float = Field(gt=0)
    transport_height_m: float = Field(gt=0, description="of the load itself, above the trailer's deck")
    lay_reach_m: float | None = Field(
        default=None,
        gt=0,
        description="the longest boom of the types that lay: a longer wall is laid in stretches",
    )

    @property
    def transport_size_m(self) -> tuple[float, float, float]:
        """(length, width, height) of a truck's load."""
        return (self.transport_length_m, self.transport_width_m, self.transport_height_m)
