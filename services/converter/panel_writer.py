"""Write one element as its components: whole, as the precast panels it is split into, or as its bays.

Once the element's mass is known, its settled method (:func:`.component_methods.settled_method`) says
whether it is panelised. A panelised element is cut by :mod:`.panelise` and each panel becomes a component of
its own, written like any other (:func:`.component_writer.write_entry`): a deterministic IFC GlobalId (a
UUID5 of the element's GlobalId and the panel's number), the name ``"<element> panel i/n"``, the element's
class, ``parent_guid`` and method ``panelised``, its own model folder, mass (the element's, split by volume),
collision parts (the converter's mesh decomposition of the panel) and mesh files, no split IFC. The panel's
frame has the element's axes, its origin at the centre of the panel's bounding box. The element gets one
:class:`PanelisedElement` entry (its panels, the joints between them, why it was split) and is no component
itself. An element that cannot be cut within the limits stays whole, with a warning saying why: cast in
place when its material is cast when too heavy (concrete), else lifted.

An element cast in place whose volume is more than one day's pour (the methods file's
``CastInPlace.day_pour_m3`` for its rates class) is poured in bays (:mod:`.bays`), written the same way:
``"<element> bay i/n"``, method ``cast_in_place``, each with its own :class:`CastWork` (its formwork
includes the stop ends at its construction joints). One that cannot be cut so is poured whole, with a
warning.
"""

from __future__ import annotations

import logging
import math
import uuid
from dataclasses import dataclass, field, replace

import ifcopenshell
import ifcopenshell.guid
import ifcopenshell.util.element
import numpy as np

from bimbot.shared.construction_methods import (
    ConstructionMethod,
    MethodDecision,
    PanelisedElement,
    PanelJoint,
)
from bimbot.shared.identifiers import guid_to_folder
from bimbot.shared.manifest import Component
from bimbot.shared.methods_file import MaterialKind, MethodsFile

from . import mass as mass_chain
from .bays import split_into_bays, split_into_stretches
from .cast_work import cast_work, rates_class
from .collision import collision_from_mesh
from .component_methods import element_limits, settled_method, target_in_ground
from .component_work import GeometryWork, PlacedElement, ShardContext
from .component_writer import EntryParts, element_mass, write_component, write_entry
from .face_slope import face_slope_deg
from .final_method import SPLIT_NOTE, default_limits
from .mass_properties import mass_properties
from .mesh import TriMesh
from .mesh_files import write_geometry_files
from .panelise import Panelisation, PanelisationError, PanelLimits, panel_kind, panelise
from .sdf_writer import ModelSpec

_log = logging.getLogger(__name__)

PANEL_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://bimbot/panel")  # panel GlobalIds: uuid5 in it


@dataclass
class WrittenElement:
    """The components one element became (one, or its panels) and its panelised entry, if split."""

    components: list[Component] = field(default_factory=list)
    specs: list[ModelSpec] = field(default_factory=list)
    bboxes_ifc_world_m: list[np.ndarray] = field(default_factory=list)
    panelised: PanelisedElement | None = None


def panel_guid(parent_guid: str, index: int) -> str:
    """The GlobalId of panel ``index`` (0-based) of ``parent_guid``: the same in every conversion."""
    return str(ifcopenshell.guid.compress(uuid.uuid5(PANEL_NAMESPACE, f"{parent_guid}/{index}").hex))


def write_element(
    model: ifcopenshell.file, item: PlacedElement, work: GeometryWork, context: ShardContext
) -> WrittenElement:
    """Write ``item`` whole or, when its final method is panelised, as its panels."""
    element = item.element
    guid = str(element.GlobalId)
    mass = element_mass(item, work, context)
    decision = settled_method(item, work, mass.mass_kg, context)
    warnings: tuple[str, ...] = ()
    if decision.method is ConstructionMethod.PANELISED:
        try:
            return write_panels(item, work, context, mass, decision)
        except PanelisationError as error:
            _log.info("%s %s not panelised: %s", element.is_a(), guid, error)
            decision = not_panelised(decision, str(error), context.methods, element)
            warnings = (f"not panelised: {error} → {decision.method.value.replace('_', ' ')}",)
    stretch_m = laid_stretch_m(context)
    if decision.method is ConstructionMethod.LAID and plan_length_m(item) > stretch_m:
        try:
            return write_stretches(item, work, context, mass, decision, stretch_m=stretch_m)
        except PanelisationError as error:
            _log.info("%s %s not laid in stretches: %s", element.is_a(), guid, error)
            warnings = (*warnings, f"laid whole, not in stretches: {error}")
    day_m3 = day_pour_m3(item, context)
    if decision.method is ConstructionMethod.CAST_IN_PLACE and work.props.volume_m3 > day_m3:
        try:
            return write_bays(item, work, context, mass, decision)
        except PanelisationError as error:
            _log.info("%s %s not poured in bays: %s", element.is_a(), guid, error)
            warnings = (*warnings, f"poured whole, not in bays: {error}")
    component, spec = write_component(
        model, item, work, context, mass=mass, warnings=warnings, decision=decision
    )
    return WrittenElement([component], [spec], [item.bbox_ifc_world_m])


def not_panelised(
    decision: MethodDecision,
    error: str,
    methods: MethodsFile | None,
    element: ifcopenshell.entity_instance | None = None,
) -> MethodDecision:
    """What an element that cannot be cut into panels becomes: cast in place when its material is one the
    methods file casts when too heavy (concrete: a slab with a stair opening no cut avoids is formed and
    poured where it stands, as a site would), or when its material is unknown and its class one the file
    casts then (a solid floor slab too heavy for any machine is concrete on a site); laid when its material
    is one the file lays then (a brick-on-block wall no panel fits is laid course by course); else lifted
    whole (and the fleet check says if no machine can lift it)."""
    castable = methods is not None and decision.material in {
        kind.value for kind in methods.panels.cast_when_too_heavy
    }
    unknown = (
        methods is not None
        and element is not None
        and decision.material == MaterialKind.UNKNOWN.value
        and any(element.is_a(name) for name in methods.panels.cast_unknown_classes)
    )
    layable = methods is not None and decision.material in {
        kind.value for kind in methods.panels.lay_when_not_panelised
    }
    if castable or unknown:
        method = ConstructionMethod.CAST_IN_PLACE
        then = "cast in place" if castable else "material unknown, cast in place as concrete"
    elif layable:
        method, then = ConstructionMethod.LAID, "laid where it stands"
    else:
        method, then = ConstructionMethod.LIFTED, "lifted whole"
    # the decision's note ends with what it meant to do (final_method.SPLIT_NOTE): say it was tried
    meant = decision.note.removesuffix(SPLIT_NOTE)
    tried = f"{meant}: a split into precast panels was tried" if meant != decision.note else decision.note
    note = f"{tried}; not panelised ({error}): {then}" if decision.note else f"not panelised: {then}"
    return decision.model_copy(update={"method": method, "note": note})


def write_panels(
    item: PlacedElement,
    work: GeometryWork,
    context: ShardContext,
    mass: mass_chain.MassResult,
    decision: MethodDecision,
) -> WrittenElement:
    """Cut ``item`` into panels and write each as a component (see the module); PanelisationError when it
    cannot be cut within ``context.limits``."""
    element = item.element
    parent_guid = str(element.GlobalId)
    predefined = ifcopenshell.util.element.get_predefined_type(element)
    kind = panel_kind(element.is_a(), mass_chain.material_label(element), predefined)
    if kind is None:
        raise PanelisationError(
            f"an {element.is_a()} is not cut into panels (walls, slabs, ceilings and claddings are)"
        )
    given = element_limits(parent_guid, context)
    truck = (given.transport_length_m, given.transport_width_m, given.transport_height_m)
    reach = parent_guid in context.lift_limits  # the crane's lift where it goes: the notes name it
    limits = PanelLimits(given.lift_capacity_kg, truck, given.lifted_by if reach else "")
    levels = [level - float(item.translation_m[2]) for level in context.storey_levels_m]
    cut = panelise(
        work.mesh, kind, mass.mass_kg, limits, rotation=item.rotation, levels_m=levels, reason=decision.note
    )
    return _write_parts(item, context, mass, cut, decision, method=ConstructionMethod.PANELISED)


def _rates_key(item: PlacedElement, context: ShardContext) -> str | None:
    """``item``'s ``cast_in_place.by_class`` key (:func:`.cast_work.rates_class`; a methods file given)."""
    assert context.methods is not None
    in_ground = target_in_ground(item, context)
    return rates_class(item.element, context.methods.cast_in_place, in_ground=in_ground)


def day_pour_m3(item: PlacedElement, context: ShardContext) -> float:
    """What one day's pour places for ``item`` (its rates class's; infinite without a methods file)."""
    if context.methods is None:
        return math.inf
    return context.methods.cast_in_place.day_pour_m3(_rates_key(item, context))


def write_bays(
    item: PlacedElement,
    work: GeometryWork,
    context: ShardContext,
    mass: mass_chain.MassResult,
    decision: MethodDecision,
) -> WrittenElement:
    """Cut ``item``, cast in place, into bays of one day's pour and write each as a component (see the
    module); PanelisationError when it cannot be cut so."""
    assert context.methods is not None  # bays are cut only when a day's pour is finite (a methods file)
    rates, key = context.methods.cast_in_place, _rates_key(item, context)
    day_m3 = rates.day_pour_m3(key)
    cut = split_into_bays(work.mesh, mass.mass_kg, day_m3, rotation=item.rotation)
    hours = rates.pour_day_h - rates.rates(key)[2]
    why = (
        f"{work.props.volume_m3:,.1f} m³, more than one day's pour of {day_m3:,.0f} m³ ({hours:g} h of "
        f"pouring): {cut.why}"
    )
    cut = replace(cut, why=why)
    note = f"{decision.note}; {why}" if decision.note else why
    return _write_parts(
        item,
        context,
        mass,
        cut,
        decision.model_copy(update={"note": note}),
        method=ConstructionMethod.CAST_IN_PLACE,
        in_ground=target_in_ground(item, context),
    )


def laid_stretch_m(context: ShardContext) -> float:
    """The longest stretch of wall a block layer lays from one set-up: half its boom's reach (from a set-up
    a lane off the wall beside the stretch's middle, the boom covers both ends); unbounded without one."""
    reach_m = (context.limits or default_limits()).lay_reach_m
    return math.inf if reach_m is None else reach_m / 2.0


def plan_length_m(item: PlacedElement) -> float:
    """The diagonal of the element's plan box: the longest a stretch of it may run (a wall on the skew, or
    with a return, runs as far as its box's diagonal)."""
    low, high = item.bbox_ifc_world_m
    return float(math.hypot(high[0] - low[0], high[1] - low[1]))


def write_stretches(
    item: PlacedElement,
    work: GeometryWork,
    context: ShardContext,
    mass: mass_chain.MassResult,
    decision: MethodDecision,
    *,
    stretch_m: float,
) -> WrittenElement:
    """Cut ``item``, laid, into stretches no longer than ``stretch_m`` along its length (vertical cuts, as
    bays are cut: :func:`.bays.split_into_stretches`) and write each as a component; PanelisationError when
    it cannot be cut so."""
    count = math.ceil(plan_length_m(item) / stretch_m)
    cut = split_into_stretches(work.mesh, mass.mass_kg, count, rotation=item.rotation)
    why = (
        f"{plan_length_m(item):,.1f} m long, more than a block layer lays from one set-up ({stretch_m:,.1f} "
        f"m, half its boom's reach): {cut.why}"
    )
    cut = replace(cut, why=why)
    note = f"{decision.note}; {why}" if decision.note else why
    return _write_parts(
        item, context, mass, cut, decision.model_copy(update={"note": note}), method=ConstructionMethod.LAID
    )


def _write_parts(
    item: PlacedElement,
    context: ShardContext,
    mass: mass_chain.MassResult,
    cut: Panelisation,
    decision: MethodDecision,
    *,
    method: ConstructionMethod,
    in_ground: bool = False,
) -> WrittenElement:
    """Each part of ``cut`` (panels, or bays when ``method`` is cast in place) as a component of its own,
    and the element's :class:`PanelisedElement` entry."""
    element = item.element
    parent_guid = str(element.GlobalId)
    count = len(cut.panels)
    guids = [panel_guid(parent_guid, index) for index in range(count)]
    label = element.Name or element.is_a()
    part = {ConstructionMethod.CAST_IN_PLACE: "bay", ConstructionMethod.LAID: "stretch"}.get(method, "panel")
    written = WrittenElement()
    for index, (mesh, mass_kg) in enumerate(zip(cut.panels, cut.masses_kg, strict=True)):
        centre = mesh.bounds.mean(axis=0)
        local = TriMesh(mesh.vertices - centre, mesh.faces)
        collision = collision_from_mesh(local)
        model_dir = context.out_dir / "models" / guid_to_folder(guids[index])
        files = write_geometry_files(model_dir, local, collision.parts, context.formats)
        translation = item.translation_m + item.rotation @ centre
        world = local.vertices @ item.rotation.T + translation
        bbox = np.array([world.min(axis=0), world.max(axis=0)])
        notes = list(mass.warnings) if index == 0 else []  # the element's mass notes, once
        if collision.note:
            notes.append(collision.note)
        cast = None
        if method is ConstructionMethod.CAST_IN_PLACE and context.methods is not None:
            volume_m3 = cut.volumes_m3[index]
            cast = cast_work(
                element, local, item.rotation, volume_m3, context.methods.cast_in_place, in_ground=in_ground
            )
        component, spec = write_entry(
            element,
            EntryParts(
                guid=guids[index],
                name=f"{label} {part} {index + 1}/{count}",
                rotation=item.rotation,
                translation_m=translation,
                bbox_ifc_world_m=bbox,
                props=mass_properties(local),
                mass_kg=mass_kg,
                mass_source=mass.source,
                collision=collision,
                files=files,
                face_slope_deg=face_slope_deg(local, item.rotation),
                warnings=notes,
                extra={
                    "method": method,
                    "method_source": decision.source,
                    "method_note": cut.why if method is ConstructionMethod.PANELISED else decision.note,
                    "parent_guid": parent_guid,
                    "cast": cast,
                },
            ),
            context,
        )
        written.components.append(component)
        written.specs.append(spec)
        written.bboxes_ifc_world_m.append(bbox)
    written.panelised = PanelisedElement(
        guid=parent_guid,
        ifc_class=element.is_a(),
        name=element.Name,
        mass_kg=mass.mass_kg,
        method=method,
        panel_guids=tuple(guids),
        joints=tuple(
            PanelJoint(
                guids=(guids[joint.first], guids[joint.second]), length_m=joint.length_m, kind=joint.kind
            )
            for joint in cut.joints
        ),
        why=cut.why,
    )
    return written
