"""Small IFC models built with ``ifcopenshell.api``, for converter tests.

A :class:`SmallModel` is a file with a project, millimetre length units, a Model/Body context and the
spatial chain project → site → building → storey (and, in IFC2X3, the user and application an
owner history needs). Elements are added in metres (SI) and placed with
4×4 world matrices in metres; the api converts to the file's millimetres. Every helper takes the model
first and returns what it created, in the style of ``ifcopenshell.api``.
"""

from __future__ import annotations

from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.owner
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.util.unit
import numpy as np

Entity = ifcopenshell.entity_instance


@dataclass(frozen=True)
class SmallModel:
    """A tiny IFC model and the instances tests need to reach."""

    file: ifcopenshell.file
    project: Entity
    site: Entity
    building: Entity
    storey: Entity
    body: Entity  # the Model/Body/MODEL_VIEW representation subcontext


def translation(x_m: float = 0.0, y_m: float = 0.0, z_m: float = 0.0) -> np.ndarray:
    """A 4×4 placement matrix (metres) that only translates."""
    matrix = np.eye(4)
    matrix[:3, 3] = (x_m, y_m, z_m)
    return matrix


def new_model(schema: str = "IFC4") -> SmallModel:
    """A project in millimetres with a Body context and one site, building and storey ("Level 0")."""
    model = ifcopenshell.api.project.create_file(version=schema)
    if model.schema == "IFC2X3":
        add_owner(model)
    project = ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject", name="bimbot test project")
    length = ifcopenshell.api.unit.add_si_unit(model, unit_type="LENGTHUNIT", prefix="MILLI")
    area = ifcopenshell.api.unit.add_si_unit(model, unit_type="AREAUNIT")
    volume = ifcopenshell.api.unit.add_si_unit(model, unit_type="VOLUMEUNIT")
    ifcopenshell.api.unit.assign_unit(model, units=[length, area, volume])
    model_context = ifcopenshell.api.context.add_context(model, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        model, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model_context
    )
    site = _spatial(model, "IfcSite", "Site", project)
    building = _spatial(model, "IfcBuilding", "Building", site)
    storey = _spatial(model, "IfcBuildingStorey", "Level 0", building)
    return SmallModel(model, project, site, building, storey, body)


def add_owner(model: ifcopenshell.file) -> Entity:
    """A user and application, which the api's default owner settings find (IFC2X3 needs an owner history)."""
    ifcopenshell.api.owner.add_application(model)
    person = ifcopenshell.api.owner.add_person(model, identification="bimbot", family_name="Test")
    organisation = ifcopenshell.api.owner.add_organisation(model, identification="bimbot", name="bimbot")
    return ifcopenshell.api.owner.add_person_and_organisation(model, person=person, organisation=organisation)


def _spatial(model: ifcopenshell.file, ifc_class: str, name: str, parent: Entity) -> Entity:
    spatial = ifcopenshell.api.root.create_entity(model, ifc_class=ifc_class, name=name)
    ifcopenshell.api.aggregate.assign_object(model, products=[spatial], relating_object=parent)
    ifcopenshell.api.geometry.edit_object_placement(model, product=spatial, matrix=np.eye(4))
    return spatial


def place(
    small: SmallModel, product: Entity, matrix_m: np.ndarray, container: Entity | None = None
) -> Entity:
    """Place ``product`` at ``matrix_m`` and, unless it is part of something, contain it in a storey."""
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=product, matrix=matrix_m)
    if container is not None:
        ifcopenshell.api.spatial.assign_container(
            small.file, products=[product], relating_structure=container
        )
    return product


def add_wall(
    small: SmallModel,
    name: str = "Wall",
    *,
    length_m: float = 4.0,
    height_m: float = 3.0,
    thickness_m: float = 0.2,
    matrix_m: np.ndarray | None = None,
    contained: bool = True,
) -> Entity:
    """An IfcWall with an extruded rectangular body of the given size, in the storey unless told not."""
    wall = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcWall", name=name)
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=length_m, height=height_m, thickness=thickness_m
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=wall, representation=body)
    container = small.storey if contained else None
    return place(small, wall, translation() if matrix_m is None else matrix_m, container)


def add_beam(
    small: SmallModel,
    name: str = "Beam",
    *,
    length_m: float = 5.0,
    width_m: float = 0.2,
    depth_m: float = 0.4,
    matrix_m: np.ndarray | None = None,
    contained: bool = True,
    schema_class: str = "IfcBeam",
) -> Entity:
    """A member (IfcBeam by default) with a rectangular profile extruded ``length_m`` along its local Z."""
    beam = ifcopenshell.api.root.create_entity(small.file, ifc_class=schema_class, name=name)
    scale = 1.0 / ifcopenshell.util.unit.calculate_unit_scale(small.file)  # profiles are in file units
    origin = small.file.create_entity("IfcCartesianPoint", Coordinates=(0.0, 0.0))
    position = small.file.create_entity("IfcAxis2Placement2D", Location=origin)  # required in IFC2X3
    profile = small.file.create_entity(
        "IfcRectangleProfileDef",
        ProfileType="AREA",
        Position=position,
        XDim=width_m * scale,
        YDim=depth_m * scale,
    )
    body = ifcopenshell.api.geometry.add_profile_representation(
        small.file, context=small.body, profile=profile, depth=length_m
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=beam, representation=body)
    container = small.storey if contained else None
    return place(small, beam, translation() if matrix_m is None else matrix_m, container)


def add_opening(
    small: SmallModel,
    element: Entity,
    *,
    width_m: float = 1.0,
    height_m: float = 1.0,
    depth_m: float = 0.6,
    matrix_m: np.ndarray | None = None,
) -> Entity:
    """An IfcOpeningElement (a box, placed at ``matrix_m`` in world metres) that voids ``element``."""
    opening = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcOpeningElement", name="Opening")
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=width_m, height=height_m, thickness=depth_m
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=opening, representation=body)
    place(small, opening, translation() if matrix_m is None else matrix_m)
    ifcopenshell.api.feature.add_feature(small.file, feature=opening, element=element)
    return opening


def add_pset(small: SmallModel, products: list[Entity], name: str, properties: dict[str, object]) -> Entity:
    """One property set shared by all ``products`` (one IfcRelDefinesByProperties)."""
    pset = ifcopenshell.api.pset.add_pset(small.file, product=products[0], name=name)
    ifcopenshell.api.pset.edit_pset(small.file, pset=pset, properties=properties)
    if len(products) > 1:
        ifcopenshell.api.pset.assign_pset(small.file, products=products[1:], pset=pset)
    return pset


def add_qto(small: SmallModel, product: Entity, name: str, quantities: dict[str, float]) -> Entity:
    """An IfcElementQuantity on ``product``."""
    qto = ifcopenshell.api.pset.add_qto(small.file, product=product, name=name)
    ifcopenshell.api.pset.edit_qto(small.file, qto=qto, properties=quantities)
    return qto


def add_material(small: SmallModel, products: list[Entity], name: str, category: str = "concrete") -> Entity:
    """One IfcMaterial associated with all ``products`` (one IfcRelAssociatesMaterial)."""
    category_or_none = None if small.file.schema == "IFC2X3" else category  # no Category in IFC2X3
    material = ifcopenshell.api.material.add_material(small.file, name=name, category=category_or_none)
    ifcopenshell.api.material.assign_material(small.file, products=products, material=material)
    return material


def add_layers(
    small: SmallModel, products: list[Entity], layers: list[tuple[str, float]], name: str = "Layers"
) -> Entity:
    """An IfcMaterialLayerSet of ``layers`` (material name, thickness in metres; one IfcMaterial per distinct
    name), associated with all ``products`` through a layer set usage, as Revit exports walls."""
    file = small.file
    layer_set = ifcopenshell.api.material.add_material_set(file, name=name, set_type="IfcMaterialLayerSet")
    scale = 1.0 / ifcopenshell.util.unit.calculate_unit_scale(file)  # thicknesses are in file units
    materials: dict[str, Entity] = {}
    for material_name, thickness_m in layers:
        if material_name not in materials:
            materials[material_name] = ifcopenshell.api.material.add_material(file, name=material_name)
        layer = ifcopenshell.api.material.add_layer(
            file, layer_set=layer_set, material=materials[material_name]
        )
        ifcopenshell.api.material.edit_layer(
            file, layer=layer, attributes={"LayerThickness": thickness_m * scale}
        )
    ifcopenshell.api.material.assign_material(
        file, products=products, type="IfcMaterialLayerSetUsage", material=layer_set
    )
    return layer_set


def add_faceted(
    small: SmallModel,
    ifc_class: str,
    name: str,
    *,
    vertices_m: list[tuple[float, float, float]],
    faces: list[tuple[int, ...]],
) -> Entity:
    """An element of ``ifc_class`` whose body is the polygons ``faces`` (vertex indices, wound as given, so
    a test can flip or leave out faces as exports do) over ``vertices_m`` (world metres), in the storey."""
    element = ifcopenshell.api.root.create_entity(small.file, ifc_class=ifc_class, name=name)
    body = ifcopenshell.api.geometry.add_mesh_representation(
        small.file, context=small.body, vertices=[vertices_m], faces=[faces]
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=element, representation=body)
    return place(small, element, translation(), small.storey)


def add_type(small: SmallModel, products: list[Entity], ifc_class: str, name: str) -> Entity:
    """One type object of ``ifc_class`` typing all ``products`` (one IfcRelDefinesByType)."""
    element_type = ifcopenshell.api.root.create_entity(small.file, ifc_class=ifc_class, name=name)
    ifcopenshell.api.type.assign_type(small.file, related_objects=products, relating_type=element_type)
    return element_type


def add_assembly(small: SmallModel, parts: list[Entity], name: str = "Assembly") -> Entity:
    """An IfcElementAssembly contained in the storey, aggregating ``parts`` (which are not contained)."""
    assembly = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcElementAssembly", name=name)
    place(small, assembly, translation(), small.storey)
    ifcopenshell.api.aggregate.assign_object(small.file, products=parts, relating_object=assembly)
    return assembly


def add_box(
    small: SmallModel,
    ifc_class: str,
    name: str,
    *,
    size_m: tuple[float, float, float],
    corner_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    predefined_type: str | None = None,
    contained: bool = True,
) -> Entity:
    """An element of ``ifc_class`` whose body is a box of ``size_m`` (x, y, z) from ``corner_m`` (world)."""
    element = ifcopenshell.api.root.create_entity(
        small.file, ifc_class=ifc_class, name=name, predefined_type=predefined_type
    )
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=size_m[0], height=size_m[2], thickness=size_m[1]
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=element, representation=body)
    return place(small, element, translation(*corner_m), small.storey if contained else None)
