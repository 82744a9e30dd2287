"""Build the bundled sample model: an IFC4 light steel frame like the paper's greenhouse shelter (§5.1).

Why: the paper's case study is a light steel frame of 9 concrete footings, 9 steel columns and 10 steel
beams (28 components). bimbot ships a generated stand-in (``bimbot/data/light_steel_frame.ifc``) as the
demo's default input, and the same builder makes larger frames for benchmarks (100 to 10,000 elements).
The model is deliberately varied so that it exercises the converter: shared type geometry through
``IfcMappedItem``, rotated placements, a material with a density and one without, weights on some
elements only, connections and a 4D erection schedule.

Grid. ``build_light_steel_frame(N, M)`` (CLI ``--bays NxM``) makes an N×M grid of *columns* (3x3 → 9
columns, as the paper counts them). Column lines along x are numbered 1…N, rows along y are lettered
A…Z, AA, AB, … The column at x index ``i`` and y index ``j`` is ``Column <letter(j)><i+1>`` and stands at
``(i·spacing_x_mm, j·spacing_y_mm, 0)``; its footing is ``Footing <letter(j)><i+1>``.

Members, for N = ``columns_x`` and M = ``columns_y``:

* one footing under every column: N·M footings, N·M columns;
* longitudinal beams (along x) on every row between neighbouring columns: (N−1)·M, named ``Beam A1-A2``;
* transverse beams (along y) only on the two end frames x = first and x = last: 2·(M−1), named
  ``Beam A1-B1``; with N = 1 there is only one end frame, so M−1.

3x3 therefore gives 9 footings, 9 columns and 6 + 4 = 10 beams, 28 elements; 58x58 gives 10,148.

Dimensions (the project length unit is the millimetre; z up; origin at column A1's axis on the footing
top):

* footings: concrete pads 600×600×300 (``IfcRectangleProfileDef`` extruded up), top at z = 0; the
  footing's placement is the centre of its underside, at z = −300;
* columns: square hollow section SHS 100×100×5 (``IfcRectangleHollowProfileDef``) of ``height_mm``,
  standing on the footing top; placement at the column axis, z = 0;
* beams: IPE 160 (``IfcIShapeProfileDef``, without root fillets so an I-section is exactly three boxes)
  spanning column centre to column centre. Beams along x sit with their bottom flange on the column tops
  (z = ``height_mm``); the end-frame beams along y sit on the ends of the beams along x (z = ``height_mm``
  + 160), so no two beams overlap above a corner column (with N = 1 there are no beams along x and they
  sit on the column tops). Where there are beams along y, a beam along x that ends at an end frame runs
  on to the end column's outer face (50 mm past its axis), so the beam along y bears on it with its whole
  flange: a beam resting on the edge of another tips off in the simulation (issue 11). A beam's placement
  is at its start (the start column's axis, or that column's outer face) at its bottom with local x along
  the span, so beams along y carry a 90° rotation about z. Beams of one length share one type.

Semantics:

* types (``IfcFootingType``, ``IfcColumnType``, one ``IfcBeamType`` per span length) hold the body
  geometry as representation maps; occurrences map them (``IfcMappedItem``);
* the footings are precast (``Pset_ConcreteElementGeneral.CastingMethod`` = ``PRECAST`` on their type), so
  they are lifted like the steel rather than cast in place;
* materials "S235 Steel" (``Pset_MaterialCommon.MassDensity`` = 7850 kg/m³, with an explicit kg/m³
  density unit) and "C30/37 Concrete" (no density: the converter must fall back to its material table),
  associated with every occurrence (and its type);
* quantities: beams carry ``Qto_BeamBaseQuantities`` with ``Length`` (mm) and ``NetWeight`` (kg, section
  area × length × 7850); columns carry ``Qto_ColumnBaseQuantities`` with ``Length`` only; footings carry
  none — so every mass fallback of the converter is exercised;
* ``IfcRelConnectsElements``: footing → column, and column → beam for both end columns of each beam;
* a work plan with the ``IfcWorkSchedule`` "Erection": one ``IfcTask`` per element ("Erect Column A1",
  identification T001…), assigned to its product, with an ``IfcTaskTime`` duration, chained by
  ``IfcRelSequence`` FINISH_START in erection order: all footings, then all columns, then all beams
  (longitudinal row by row, then the transverse end-frame beams). So a column never precedes its footing
  and a beam never precedes its columns.

Every rooted entity gets a deterministic GlobalId (UUID5 of a fixed namespace and a stable key: class and
name for objects, class and creation index for relationships and property sets), dates and the header
time stamp are fixed, so regenerating a model gives the same file. No file I/O here; see ``sample_cli``.
"""

from __future__ import annotations

import itertools
import logging
import re
import uuid
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, TypedDict

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.control
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.sequence
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

if TYPE_CHECKING:
    from ifcopenshell.api.pset.edit_qto import PROP_VALUE_TYPE

_log = logging.getLogger(__name__)


# --- constants (millimetres unless named otherwise) ------------------------------------------------------

DEFAULT_SPACING_X_MM = 3000.0
DEFAULT_SPACING_Y_MM = 3000.0
DEFAULT_HEIGHT_MM = 3000.0
MAX_COLUMNS_PER_SIDE = 200  # 200x200 is ~120,000 elements: a guard against typos, not a physical limit

FOOTING_SIZE_MM = 600.0
FOOTING_DEPTH_MM = 300.0


class ColumnSection(TypedDict):
    name: str
    size_mm: float
    wall_mm: float


class BeamSection(TypedDict):
    name: str
    depth_mm: float
    width_mm: float
    web_mm: float
    flange_mm: float


COLUMN_SECTION: ColumnSection = {"name": "SHS100x100x5", "size_mm": 100.0, "wall_mm": 5.0}
BEAM_SECTION: BeamSection = {
    "name": "IPE160",
    "depth_mm": 160.0,
    "width_mm": 82.0,
    "web_mm": 5.0,
    "flange_mm": 7.4,
}

STEEL_NAME = "S235 Steel"
STEEL_DENSITY_KG_PER_M3 = 7850.0
CONCRETE_NAME = "C30/37 Concrete"

PROJECT_NAME = "bimbot light steel frame"
SITE_NAME = "Greenhouse Site"
BUILDING_NAME = "Light steel frame shelter"
STOREY_NAME = "Level 0"
WORK_PLAN_NAME = "Light steel frame construction"
WORK_SCHEDULE_NAME = "Erection"
SCHEDULE_START = "2024-03-04T08:00:00"  # fixed, so regenerating gives the same file
TASK_DURATIONS = {"footing": "PT2H", "column": "PT1H", "beam": "PT1H"}

# UUID5 namespace of every GlobalId in the sample models (itself a UUID5 of a fixed URL).
GUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://github.com/bimbot/samples/light-steel-frame")

MemberKind = Literal["footing", "column", "beam"]


# --- pure layout -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Member:
    """One component of the frame, before it becomes IFC: its pose and what it stands on."""

    kind: MemberKind
    name: str
    matrix_mm: np.ndarray = field(compare=False)  # 4×4 placement in the storey frame, translation in mm
    length_mm: float = 0.0  # span of a beam, height of a column, depth of a footing
    # names of the members it rests on: the footing of a column, the two columns of a beam
    supports: tuple[str, ...] = ()


def parse_bays(text: str) -> tuple[int, int]:
    """Parse ``"NxM"`` (also ``N×M``, ``NXM``) into a column grid ``(N, M)``, each 1…MAX_COLUMNS_PER_SIDE."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if match is None:
        raise ValueError(f"bays must look like NxM (e.g. 3x3, a grid of N×M columns), got {text!r}")
    columns_x, columns_y = int(match.group(1)), int(match.group(2))
    for count in (columns_x, columns_y):
        if not 1 <= count <= MAX_COLUMNS_PER_SIDE:
            raise ValueError(
                f"bays {text!r}: each side must have 1 to {MAX_COLUMNS_PER_SIDE} columns, got {count}"
            )
    return columns_x, columns_y


def row_letter(index: int) -> str:
    """Grid row label for a zero-based index: 0 → A, 25 → Z, 26 → AA, 27 → AB (spreadsheet style)."""
    letters = ""
    index += 1
    while index > 0:
        index, remainder = divmod(index - 1, 26)
        letters = chr(ord("A") + remainder) + letters
    return letters


def grid_label(i: int, j: int) -> str:
    """Label of the grid point at x index ``i`` and y index ``j``, e.g. (0, 0) → ``A1``."""
    return f"{row_letter(j)}{i + 1}"


def _pose_mm(origin_mm: Sequence[float], x_axis: Sequence[float] = (1.0, 0.0, 0.0)) -> np.ndarray:
    """A z-up 4×4 pose with the given origin (mm) and horizontal local x axis."""
    x = np.asarray(x_axis, dtype=float)
    z = np.array([0.0, 0.0, 1.0])
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2] = x, np.cross(z, x), z
    matrix[:3, 3] = origin_mm
    return matrix


def plan_members(
    columns_x: int, columns_y: int, spacing_x_mm: float, spacing_y_mm: float, height_mm: float
) -> list[Member]:
    """All members of the frame in erection order: footings, columns, beams along x, beams along y."""
    points = [(i, j) for j in range(columns_y) for i in range(columns_x)]
    at = {(i, j): (i * spacing_x_mm, j * spacing_y_mm) for i, j in points}
    members = [
        Member(
            "footing",
            f"Footing {grid_label(i, j)}",
            _pose_mm((*at[i, j], -FOOTING_DEPTH_MM)),
            FOOTING_DEPTH_MM,
        )
        for i, j in points
    ]
    members += [
        Member(
            "column",
            f"Column {grid_label(i, j)}",
            _pose_mm((*at[i, j], 0.0)),
            height_mm,
            (f"Footing {grid_label(i, j)}",),
        )
        for i, j in points
    ]
    spans = [
        ((i, j), (i + 1, j), (1.0, 0.0, 0.0), spacing_x_mm)
        for j in range(columns_y)
        for i in range(columns_x - 1)
    ]
    end_frames = sorted({0, columns_x - 1})
    spans += [
        ((i, j), (i, j + 1), (0.0, 1.0, 0.0), spacing_y_mm) for i in end_frames for j in range(columns_y - 1)
    ]
    overhang_mm = COLUMN_SECTION["size_mm"] / 2.0
    for start, end, direction, span_mm in spans:
        start_label, end_label = grid_label(*start), grid_label(*end)
        length_mm = span_mm
        # End-frame beams along y rest on the ends of the beams along x (when there are any), so that
        # no two beams occupy the same space above a corner column. A beam along x that ends at an end
        # frame runs on to the end column's outer face: the beam along y above it then bears on it with
        # its whole flange (ending at the column axis, half the flange hung over the edge, and a beam
        # tipped off as soon as it was placed a millimetre outwards).
        on_top_mm = BEAM_SECTION["depth_mm"] if direction[1] and columns_x > 1 else 0.0
        origin = [*at[start], height_mm + on_top_mm]
        if direction[0] and columns_y > 1:
            before = overhang_mm if start[0] == 0 else 0.0
            after = overhang_mm if end[0] == columns_x - 1 else 0.0
            origin[0] -= before
            length_mm += before + after
        members.append(
            Member(
                "beam",
                f"Beam {start_label}-{end_label}",
                _pose_mm(origin, direction),
                length_mm,
                (f"Column {start_label}", f"Column {end_label}"),
            )
        )
    return members


def element_counts(columns_x: int, columns_y: int) -> dict[str, int]:
    """Number of footings, columns and beams of an N×M column grid (see the module docstring)."""
    end_frames = 1 if columns_x == 1 else 2
    beams = (columns_x - 1) * columns_y + end_frames * (columns_y - 1)
    return {"footing": columns_x * columns_y, "column": columns_x * columns_y, "beam": beams}


def i_section_area_mm2() -> float:
    """Cross-section area of the beam's I-section (no root fillets), mm²."""
    s = BEAM_SECTION
    return 2 * s["width_mm"] * s["flange_mm"] + (s["depth_mm"] - 2 * s["flange_mm"]) * s["web_mm"]


def beam_weight_kg(length_mm: float) -> float:
    """Steel mass of a beam of ``length_mm``: section area × length × density."""
    return i_section_area_mm2() * 1e-6 * length_mm * 1e-3 * STEEL_DENSITY_KG_PER_M3


# --- IFC: project, units, contexts, spatial structure -----------------------------------------------------


@dataclass
class _Setup:
    """What the element writers need from the model's set-up."""

    body: ifcopenshell.entity_instance
    storey: ifcopenshell.entity_instance
    steel: ifcopenshell.entity_instance
    concrete: ifcopenshell.entity_instance


def _new_file() -> ifcopenshell.file:
    model = ifcopenshell.api.project.create_file(version="IFC4")
    model.header.file_name.name = "light_steel_frame.ifc"
    model.header.file_name.time_stamp = SCHEDULE_START
    model.header.file_name.author = ("bimbot",)
    model.header.file_name.organization = ("bimbot",)
    model.header.file_name.authorization = "bimbot sample generator"
    return model


def _assign_units(model: ifcopenshell.file) -> None:
    """Millimetre lengths, m² areas, m³ volumes, kg masses, radians, seconds and a kg/m³ density unit."""
    add = ifcopenshell.api.unit.add_si_unit
    kilogram = add(model, unit_type="MASSUNIT", prefix="KILO")
    metre = add(model, unit_type="LENGTHUNIT")
    # None: no user-defined type, as the function documents; its annotation says str only
    density = ifcopenshell.api.unit.add_derived_unit(
        model,
        "MASSDENSITYUNIT",
        None,  # type: ignore[arg-type]
        {kilogram: 1, metre: -3},
    )
    units = [
        add(model, unit_type="LENGTHUNIT", prefix="MILLI"),
        add(model, unit_type="AREAUNIT"),
        add(model, unit_type="VOLUMEUNIT"),
        kilogram,
        add(model, unit_type="PLANEANGLEUNIT"),
        add(model, unit_type="TIMEUNIT"),
        density,
    ]
    ifcopenshell.api.unit.assign_unit(model, units=units)


def _add_spatial_structure(
    model: ifcopenshell.file, project: ifcopenshell.entity_instance
) -> ifcopenshell.entity_instance:
    """Site, building and storey (identity placements, nested); returns the storey."""
    parent = project
    for ifc_class, name in (
        ("IfcSite", SITE_NAME),
        ("IfcBuilding", BUILDING_NAME),
        ("IfcBuildingStorey", STOREY_NAME),
    ):
        element = ifcopenshell.api.root.create_entity(model, ifc_class=ifc_class, name=name)
        ifcopenshell.api.aggregate.assign_object(model, products=[element], relating_object=parent)
        ifcopenshell.api.geometry.edit_object_placement(model, product=element, matrix=np.eye(4), is_si=False)
        parent = element
    parent.Elevation = 0.0
    return parent


def _add_materials(
    model: ifcopenshell.file,
) -> tuple[ifcopenshell.entity_instance, ifcopenshell.entity_instance]:
    """Steel with a mass density, concrete deliberately without one."""
    steel = ifcopenshell.api.material.add_material(model, name=STEEL_NAME, category="steel")
    pset = ifcopenshell.api.pset.add_pset(model, product=steel, name="Pset_MaterialCommon")
    ifcopenshell.api.pset.edit_pset(model, pset=pset, properties={"MassDensity": STEEL_DENSITY_KG_PER_M3})
    concrete = ifcopenshell.api.material.add_material(model, name=CONCRETE_NAME, category="concrete")
    return steel, concrete


def _set_up_model() -> tuple[ifcopenshell.file, _Setup]:
    model = _new_file()
    project = ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject", name=PROJECT_NAME)
    _assign_units(model)
    model3d = ifcopenshell.api.context.add_context(model, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        model, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model3d
    )
    storey = _add_spatial_structure(model, project)
    steel, concrete = _add_materials(model)
    return model, _Setup(body=body, storey=storey, steel=steel, concrete=concrete)


# --- IFC: types with shared geometry ----------------------------------------------------------------------


def _axis3(
    model: ifcopenshell.file,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    axis: Sequence[float] | None = None,
    ref: Sequence[float] | None = None,
) -> ifcopenshell.entity_instance:
    location = model.createIfcCartesianPoint([float(v) for v in origin])
    axis_dir = model.createIfcDirection([float(v) for v in axis]) if axis else None
    ref_dir = model.createIfcDirection([float(v) for v in ref]) if ref else None
    return model.createIfcAxis2Placement3D(location, axis_dir, ref_dir)


def _profile_position(model: ifcopenshell.file) -> ifcopenshell.entity_instance:
    return model.createIfcAxis2Placement2D(model.createIfcCartesianPoint([0.0, 0.0]), None)


def _extrusion(
    model: ifcopenshell.file,
    body: ifcopenshell.entity_instance,
    profile: ifcopenshell.entity_instance,
    position: ifcopenshell.entity_instance,
    depth_mm: float,
) -> ifcopenshell.entity_instance:
    """A Body/SweptSolid shape representation: ``profile`` extruded along the position's z by ``depth_mm``."""
    up = model.createIfcDirection([0.0, 0.0, 1.0])
    solid = model.createIfcExtrudedAreaSolid(profile, position, up, float(depth_mm))
    return model.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid])


def _make_type(
    model: ifcopenshell.file,
    *,
    ifc_class: str,
    name: str,
    predefined_type: str,
    representation: ifcopenshell.entity_instance,
    material: ifcopenshell.entity_instance,
) -> ifcopenshell.entity_instance:
    element_type = ifcopenshell.api.root.create_entity(
        model, ifc_class=ifc_class, name=name, predefined_type=predefined_type
    )
    ifcopenshell.api.geometry.assign_representation(
        model, product=element_type, representation=representation
    )
    ifcopenshell.api.material.assign_material(model, products=[element_type], material=material)
    return element_type


def _footing_type(model: ifcopenshell.file, setup: _Setup) -> ifcopenshell.entity_instance:
    name = f"Pad {FOOTING_SIZE_MM:.0f}x{FOOTING_SIZE_MM:.0f}x{FOOTING_DEPTH_MM:.0f}"
    profile = model.createIfcRectangleProfileDef(
        "AREA", name, _profile_position(model), FOOTING_SIZE_MM, FOOTING_SIZE_MM
    )
    representation = _extrusion(model, setup.body, profile, _axis3(model), FOOTING_DEPTH_MM)
    footing_type = _make_type(
        model,
        ifc_class="IfcFootingType",
        name=name,
        predefined_type="PAD_FOOTING",
        representation=representation,
        material=setup.concrete,
    )
    # precast pads, set by the robots like the steel (the paper's prefabricated case study)
    pset = ifcopenshell.api.pset.add_pset(model, product=footing_type, name="Pset_ConcreteElementGeneral")
    ifcopenshell.api.pset.edit_pset(model, pset=pset, properties={"CastingMethod": "PRECAST"})
    return footing_type


def _column_type(model: ifcopenshell.file, setup: _Setup, height_mm: float) -> ifcopenshell.entity_instance:
    section = COLUMN_SECTION
    profile = model.createIfcRectangleHollowProfileDef(
        "AREA",
        section["name"],
        _profile_position(model),
        section["size_mm"],
        section["size_mm"],
        section["wall_mm"],
    )
    representation = _extrusion(model, setup.body, profile, _axis3(model), height_mm)
    name = f"{section['name']} H{height_mm:.0f}"
    return _make_type(
        model,
        ifc_class="IfcColumnType",
        name=name,
        predefined_type="COLUMN",
        representation=representation,
        material=setup.steel,
    )


def _beam_type(model: ifcopenshell.file, setup: _Setup, length_mm: float) -> ifcopenshell.entity_instance:
    """An I-beam along local +x from the origin, bottom flange on z = 0, web in the local xz plane."""
    s = BEAM_SECTION
    profile = model.createIfcIShapeProfileDef(
        "AREA", s["name"], _profile_position(model), s["width_mm"], s["depth_mm"], s["web_mm"], s["flange_mm"]
    )
    # Extrude along local x; the profile's x runs along local y and its y (the section depth) along local z.
    position = _axis3(model, (0.0, 0.0, s["depth_mm"] / 2), axis=(1.0, 0.0, 0.0), ref=(0.0, 1.0, 0.0))
    representation = _extrusion(model, setup.body, profile, position, length_mm)
    name = f"{s['name']} L{length_mm:.0f}"
    return _make_type(
        model,
        ifc_class="IfcBeamType",
        name=name,
        predefined_type="BEAM",
        representation=representation,
        material=setup.steel,
    )


# --- IFC: occurrences ---------------------------------------------------------------------------------------

_OCCURRENCE = {
    "footing": ("IfcFooting", "PAD_FOOTING"),
    "column": ("IfcColumn", "COLUMN"),
    "beam": ("IfcBeam", "BEAM"),
}


def _types_for(
    model: ifcopenshell.file, setup: _Setup, members: Sequence[Member], height_mm: float
) -> dict[tuple[MemberKind, float], ifcopenshell.entity_instance]:
    """One type per (kind, length): one footing type, one column type, one beam type per span length."""
    types: dict[tuple[MemberKind, float], ifcopenshell.entity_instance] = {}
    for member in members:
        key = (member.kind, round(member.length_mm, 3))
        if key in types:
            continue
        if member.kind == "footing":
            types[key] = _footing_type(model, setup)
        elif member.kind == "column":
            types[key] = _column_type(model, setup, height_mm)
        else:
            types[key] = _beam_type(model, setup, member.length_mm)
    return types


def _add_occurrences(
    model: ifcopenshell.file,
    setup: _Setup,
    members: Sequence[Member],
    types: dict[tuple[MemberKind, float], ifcopenshell.entity_instance],
) -> dict[str, ifcopenshell.entity_instance]:
    """Create, contain, type, place and give material to every member; returns elements by name."""
    elements: dict[str, ifcopenshell.entity_instance] = {}
    for member in members:
        ifc_class, predefined_type = _OCCURRENCE[member.kind]
        elements[member.name] = ifcopenshell.api.root.create_entity(
            model, ifc_class=ifc_class, name=member.name, predefined_type=predefined_type
        )
    ifcopenshell.api.spatial.assign_container(
        model, products=list(elements.values()), relating_structure=setup.storey
    )
    by_type: dict[ifcopenshell.entity_instance, list[ifcopenshell.entity_instance]] = {}
    for member in members:
        by_type.setdefault(types[member.kind, round(member.length_mm, 3)], []).append(elements[member.name])
    for element_type, occurrences in by_type.items():
        # Batch the type relationship, then map the type's geometry occurrence by occurrence: assign_type
        # maps in set order, which would number the entities differently on every run.
        ifcopenshell.api.type.assign_type(
            model, related_objects=occurrences, relating_type=element_type, should_map_representations=False
        )
        for occurrence in occurrences:
            ifcopenshell.api.type.map_type_representations(
                model, related_object=occurrence, relating_type=element_type
            )
    for member in members:
        ifcopenshell.api.geometry.edit_object_placement(
            model, product=elements[member.name], matrix=member.matrix_mm.copy(), is_si=False
        )
    for material, kinds in ((setup.concrete, {"footing"}), (setup.steel, {"column", "beam"})):
        products = [elements[m.name] for m in members if m.kind in kinds]
        if products:
            ifcopenshell.api.material.assign_material(model, products=products, material=material)
    return elements


def _add_quantities(
    model: ifcopenshell.file, members: Sequence[Member], elements: dict[str, ifcopenshell.entity_instance]
) -> None:
    """Beams: length and net weight; columns: length only; footings: nothing (mass fallbacks)."""
    for member in members:
        properties: dict[str, PROP_VALUE_TYPE]
        if member.kind == "beam":
            name = "Qto_BeamBaseQuantities"
            properties = {"Length": member.length_mm, "NetWeight": round(beam_weight_kg(member.length_mm), 3)}
        elif member.kind == "column":
            name, properties = "Qto_ColumnBaseQuantities", {"Length": member.length_mm}
        else:
            continue
        qto = ifcopenshell.api.pset.add_qto(model, product=elements[member.name], name=name)
        ifcopenshell.api.pset.edit_qto(model, qto=qto, properties=properties)


def _add_connections(
    model: ifcopenshell.file, members: Sequence[Member], elements: dict[str, ifcopenshell.entity_instance]
) -> None:
    """``IfcRelConnectsElements`` from each support (relating) to what rests on it (related)."""
    for member in members:
        for support in member.supports:
            ifcopenshell.api.geometry.connect_element(
                model,
                relating_element=elements[support],
                related_element=elements[member.name],
                description=f"{member.name} rests on {support}",
            )


def _add_schedule(
    model: ifcopenshell.file, members: Sequence[Member], elements: dict[str, ifcopenshell.entity_instance]
) -> ifcopenshell.entity_instance:
    """Work plan → work schedule "Erection" with one task per member, chained FINISH_START in member order."""
    plan = ifcopenshell.api.sequence.add_work_plan(model, name=WORK_PLAN_NAME, start_time=SCHEDULE_START)
    schedule = ifcopenshell.api.sequence.add_work_schedule(
        model, name=WORK_SCHEDULE_NAME, predefined_type="PLANNED", start_time=SCHEDULE_START, work_plan=plan
    )
    for control in (plan, schedule):
        control.CreationDate = SCHEDULE_START
    plan.StartTime = SCHEDULE_START
    tasks = []
    for number, member in enumerate(members, start=1):
        task = ifcopenshell.api.sequence.add_task(
            model,
            name=f"Erect {member.name}",
            identification=f"T{number:03d}",
            predefined_type="CONSTRUCTION",
        )
        task_time = ifcopenshell.api.sequence.add_task_time(model, task=task)
        task_time.ScheduleDuration = TASK_DURATIONS[member.kind]
        ifcopenshell.api.sequence.assign_product(
            model, relating_product=elements[member.name], related_object=task
        )
        tasks.append(task)
    ifcopenshell.api.control.assign_control(model, relating_control=schedule, related_objects=tasks)
    for predecessor, successor in itertools.pairwise(tasks):
        ifcopenshell.api.sequence.assign_sequence(
            model, relating_process=predecessor, related_process=successor, sequence_type="FINISH_START"
        )
    return schedule


# --- determinism -------------------------------------------------------------------------------------------

# Relationship lists that ifcopenshell.api fills from sets (so in a different order on every run) and whose
# order means nothing in IFC; IfcRelNests, whose order is meaningful, is not among them.
_UNORDERED_LISTS = {
    "IfcRelAggregates": "RelatedObjects",
    "IfcRelContainedInSpatialStructure": "RelatedElements",
    "IfcRelDefinesByType": "RelatedObjects",
    "IfcRelDefinesByProperties": "RelatedObjects",
    "IfcRelAssociatesMaterial": "RelatedObjects",
    "IfcRelAssignsToControl": "RelatedObjects",
    "IfcRelAssignsToProduct": "RelatedObjects",
    "IfcUnitAssignment": "Units",
}


def _sort_unordered_lists(model: ifcopenshell.file) -> None:
    """Put set-filled relationship lists in creation order, so that the written file is reproducible."""
    for ifc_class, attribute in _UNORDERED_LISTS.items():
        for entity in model.by_type(ifc_class, include_subtypes=False):
            setattr(entity, attribute, sorted(getattr(entity, attribute), key=lambda item: item.id()))


# --- deterministic GlobalIds --------------------------------------------------------------------------------


def deterministic_guid(key: str) -> str:
    """The IFC GlobalId for a stable key: UUID5(GUID_NAMESPACE, key), compressed to 22 characters."""
    return ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, key).hex)


def _guid_keys(model: ifcopenshell.file) -> Iterator[tuple[ifcopenshell.entity_instance, str]]:
    """A stable key per rooted entity: class and name for objects, class and creation index for the rest."""
    index: Counter[str] = Counter()
    for entity in sorted(model.by_type("IfcRoot"), key=lambda e: e.id()):
        ifc_class = entity.is_a()
        if entity.is_a("IfcObjectDefinition") and entity.Name:
            yield entity, f"{ifc_class}:{entity.Name}"
        else:
            index[ifc_class] += 1
            yield entity, f"{ifc_class}#{index[ifc_class]}"


def _assign_deterministic_guids(model: ifcopenshell.file) -> None:
    seen: set[str] = set()
    for entity, key in _guid_keys(model):
        if key in seen:
            raise RuntimeError(f"two entities share the GlobalId key {key!r}")
        seen.add(key)
        entity.GlobalId = deterministic_guid(key)


# --- entry point -------------------------------------------------------------------------------------------


def _check_arguments(
    columns_x: int, columns_y: int, spacing_x_mm: float, spacing_y_mm: float, height_mm: float
) -> None:
    for name, count in (("columns_x", columns_x), ("columns_y", columns_y)):
        if not isinstance(count, int) or not 1 <= count <= MAX_COLUMNS_PER_SIDE:
            raise ValueError(f"{name} must be an integer from 1 to {MAX_COLUMNS_PER_SIDE}, got {count!r}")
    for name, value in (
        ("spacing_x_mm", spacing_x_mm),
        ("spacing_y_mm", spacing_y_mm),
        ("height_mm", height_mm),
    ):
        if not value > 0:
            raise ValueError(f"{name} must be positive, got {value!r}")
    if min(spacing_x_mm, spacing_y_mm) <= COLUMN_SECTION["size_mm"] and columns_x * columns_y > 1:
        raise ValueError("column spacing must exceed the column size")


def build_light_steel_frame(
    columns_x: int = 3,
    columns_y: int = 3,
    *,
    spacing_x_mm: float = DEFAULT_SPACING_X_MM,
    spacing_y_mm: float = DEFAULT_SPACING_Y_MM,
    height_mm: float = DEFAULT_HEIGHT_MM,
) -> ifcopenshell.file:
    """An IFC4 model (millimetres) of a light steel frame with a ``columns_x × columns_y`` column grid.

    See the module docstring for the layout, dimensions and semantics. Deterministic: the same arguments
    give the same entities, GlobalIds and placements.
    """
    _check_arguments(columns_x, columns_y, spacing_x_mm, spacing_y_mm, height_mm)
    members = plan_members(columns_x, columns_y, spacing_x_mm, spacing_y_mm, height_mm)
    model, setup = _set_up_model()
    types = _types_for(model, setup, members, height_mm)
    elements = _add_occurrences(model, setup, members, types)
    _add_quantities(model, members, elements)
    _add_connections(model, members, elements)
    _add_schedule(model, members, elements)
    _sort_unordered_lists(model)
    _assign_deterministic_guids(model)
    _log.debug("built a %dx%d light steel frame: %d elements", columns_x, columns_y, len(elements))
    return model
