"""A component's mass, from the best source the IFC model offers, never zero or negative.

The chain, first hit wins (the manifest records which one gave each mass):

1. an ``IfcQuantityWeight`` in any ``IfcElementQuantity`` of the element or its type
   (``NetWeight`` before ``GrossWeight`` before any other weight);
2. a vendor weight property, e.g. Revit's ``Structural`` / ``Exact Weight`` or Tekla's ``Weight``
   (see :data:`VENDOR_WEIGHT_NAMES`);
3. the **mesh** volume × the material's density: ``Pset_MaterialCommon.MassDensity`` (IFC2X3:
   ``IfcGeneralMaterialProperties.MassDensity``), else :data:`DENSITY_TABLE_KG_M3` by material name or
   category, else, for a class that is almost always concrete (a floor slab, a footing, a pile), concrete's
   2400 kg/m³, and 1000 kg/m³ for any other, each with a warning. An element of layers
   (``IfcMaterialLayerSet``) or of constituents with fractions (``IfcMaterialConstituentSet``) takes the
   mean of its materials' densities weighted by thickness or fraction, each layer by the same chain; a
   layer that is mostly air is weighed as what it is (:data:`LAYER_DENSITY_KG_M3`): Revit's "Metal - Stud
   Layer" is light-gauge studs in a cavity, not solid steel.

The mesh volume is used rather than IFC volume quantities because Revit exports can mis-scale those.
A weight that implies an implausible density (outside :data:`PLAUSIBLE_DENSITY_KG_M3`, e.g. a concrete
footing of 0.126 kg) is reported and passed over in favour of the next source.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.representation
import ifcopenshell.util.unit

from bimbot.shared.manifest import MassSource

_log = logging.getLogger(__name__)

DEFAULT_DENSITY_KG_M3 = 1000.0
CONCRETE_DENSITY_KG_M3 = 2400.0  # normal-weight reinforced concrete (as the table's "concrete" below)
STEEL_DENSITY_KG_M3 = 7850.0
STEEL_SECTION_CLASSES = frozenset({"IfcBeam", "IfcColumn", "IfcMember"})
# the parametric profiles of rolled and hollow steel sections (a timber member is a rectangle)
STEEL_SECTIONS = (
    "IfcIShapeProfileDef",
    "IfcAsymmetricIShapeProfileDef",
    "IfcUShapeProfileDef",
    "IfcCShapeProfileDef",
    "IfcLShapeProfileDef",
    "IfcTShapeProfileDef",
    "IfcZShapeProfileDef",
    "IfcCircleHollowProfileDef",
    "IfcRectangleHollowProfileDef",
)
CLASS_DEFAULT_CLASSES = frozenset(
    {"IfcSlab", "IfcSlabStandardCase", "IfcSlabElementedCase", "IfcFooting", "IfcPile"}
)
PLAUSIBLE_DENSITY_KG_M3 = (10.0, 25_000.0)
# (pattern on material name or category, density kg/m³); first match wins, so specific words come first.
# Names in English, German, French, Spanish and Italian: exports keep the authoring tool's language (the
# Revit sample house names its glass "Vidrio" and "Cristal", its timber "Madera").
DENSITY_TABLE_KG_M3: tuple[tuple[re.Pattern[str], float], ...] = (
    # mineral wool, EPS, PUR/PIR boards: 15–200 kg/m³; 40 is an assumption for a typical batt or board
    (
        re.compile(
            r"insulat|mineral[-_ ]?wool|rock[-_ ]?wool|glass[-_ ]?wool|\beps\b|\bxps\b|polystyren|"
            r"polyurethan|\bpir\b|d[äa]mmung|d[äa]mmstoff|isolant|aislante",
            re.I,
        ),
        40.0,
    ),
    # gypsum concrete poured as a floor underlayment: 1.5 in. weighs 13 lb/ft² (Wikipedia, "Gypsum
    # concrete"), 104 lb/ft³
    (re.compile(r"gyp[-_ ]?cret|gypsum[-_ ]?concrete|levelrock", re.I), 1650.0),
    # hollow clay bricks and blocks (the Revit house's "Ladrillo de cerámica hueco doble"): about half
    # voids, 1000 kg/m³ gross (an assumption: a 7 cm double-hollow brick partition weighs about 70 kg/m²
    # before its plaster)
    (
        re.compile(
            r"(?=.*(?:brick|ladrillo|ziegel|brique|mattone|block|bloque))"
            r"(?=.*(?:hollow|hueco|perforat|hohl|lochziegel|creux|forat|alveol))",
            re.I,
        ),
        1000.0,
    ),
    (re.compile(r"alumin", re.I), 2700.0),
    (re.compile(r"steel|stahl|acier|acero|acciaio|\bs\d{3}\b|\bmetal", re.I), 7850.0),
    (
        re.compile(r"concrete|b[eé]ton|hormig[oó]n|calcestruzzo|\bc\d{2}/\d{2}\b", re.I),
        CONCRETE_DENSITY_KG_M3,
    ),
    (re.compile(r"timber|wood|\bholz\b|\bglulam\b|\bclt\b|madera|\bbois\b|legno", re.I), 500.0),
    (re.compile(r"glass|glazing|\bglas\b|vidrio|cristal|verre|vetro", re.I), 2500.0),
    (re.compile(r"brick|masonry|block|ladrillo|brique|mattone|ziegel|mauerwerk", re.I), 1900.0),
    # loose fill (gravel, crushed stone) about 1,600 kg/m³, natural stone 2,300–2,800: assumptions
    (re.compile(r"loose|gravel|grava|gravier|ghiaia|\bkies|crushed", re.I), 1600.0),
    (
        re.compile(
            r"stone|piedra|pierre|pietra|granit|marble|m[aá]rmol|marmo|limestone|sandstone|slate|pizarra",
            re.I,
        ),
        2600.0,
    ),
    (
        re.compile(
            r"gypsum|(?<![a-z])gyp(?![a-z])|plaster|yeso|enlucido|pl[aâ]tre|gesso|\bgips|\bputz", re.I
        ),
        900.0,
    ),
)
# Layers of a layer set that are mostly air, by name or flag: their own density, before the table (which
# would weigh a "Metal - Stud Layer" as 7,850 kg/m³ of steel). A framed layer: 3-5/8 in. steel studs at
# 16 in. centres weigh 1.31 lb/ft² of wall (1.75 lb/ft a stud), 2x4 timber studs at 16 in. 1.3 lb/ft²:
# about 70 kg/m³ of the layer's depth. An air gap (IfcMaterialLayer.IsVentilated, or so named): air.
# "Firring": the WBDG clinic's Revit walls spell furring so ("Metal - Firring", 38 mm), and were weighed as
# 38 mm of solid steel (75 t walls). A profiled metal deck layer is a sheet folded over its depth: a 1.5 in.
# 20-gauge roof deck weighs about 2.1 lb/ft² (10 kg/m²) over 38 mm, some 260 kg/m³ of the layer (the
# clinic's "Metal - Decking" under its standing-seam roofs was weighed as solid steel: 89 t roofs).
FRAMED_LAYER = re.compile(r"\bstuds?\b|framing|f[ui]rring|\bjoists?\b|\bbattens?\b|\brafters?\b", re.I)
AIR_LAYER = re.compile(r"\bair\b|cavity|\bvoid\b|luftschicht|lame d'air|c[aá]mara de aire", re.I)
METAL_DECK_LAYER = re.compile(r"(metal|steel).*\bdeck|\bdeck.*(metal|steel)", re.I)
LAYER_DENSITY_KG_M3 = ((FRAMED_LAYER, 70.0), (AIR_LAYER, 1.2), (METAL_DECK_LAYER, 260.0))
WEIGHT_QUANTITY_PREFERENCE = ("netweight", "grossweight", "weight")
# Property names (lower-case, without spaces) that vendors use for an element's weight.
VENDOR_WEIGHT_NAMES = ("exactweight", "weight", "netweight", "grossweight", "mass")


@dataclass(frozen=True)
class MassResult:
    mass_kg: float
    source: MassSource
    density_kg_m3: float | None
    warnings: tuple[str, ...] = ()


def mass_unit_kg(model: ifcopenshell.file) -> float:
    """Kilograms per unit of the project's mass unit (kg when the project declares none)."""
    if ifcopenshell.util.unit.get_project_unit(model, "MASSUNIT") is None:
        return 1.0
    return ifcopenshell.util.unit.calculate_unit_scale(model, "MASSUNIT") / 1000.0


def element_mass(
    element: ifcopenshell.entity_instance,
    volume_m3: float,
    material_name_hint: str | None = None,
    *,
    unit_kg: float | None = None,
    material_volumes: Sequence[tuple[ifcopenshell.entity_instance | None, float]] = (),
) -> MassResult:
    """Mass of ``element`` whose mesh encloses ``volume_m3`` (> 0), following the module's chain.
    ``unit_kg``: :func:`mass_unit_kg` of the model, when the caller has it already (it is per model);
    ``material_volumes``: how much of the mesh each material makes, from its faces' styles
    (:mod:`.face_materials`; None: unknown material), for an element whose materials come without shares."""
    if volume_m3 <= 0:
        raise ValueError(f"volume must be positive, got {volume_m3}")
    warnings: list[str] = []
    if unit_kg is None:
        unit_kg = mass_unit_kg(element.file)
    for source, candidate in (
        (MassSource.QUANTITY_WEIGHT, _quantity_weight(element)),
        (MassSource.VENDOR_PROPERTY, _vendor_weight(element)),
    ):
        if candidate is None:
            continue
        label, value = candidate
        mass_kg = value * unit_kg
        density = mass_kg / volume_m3
        if mass_kg > 0 and PLAUSIBLE_DENSITY_KG_M3[0] <= density <= PLAUSIBLE_DENSITY_KG_M3[1]:
            return MassResult(mass_kg, source, density, tuple(warnings))
        warnings.append(
            f"{label} = {value:g} gives {mass_kg:g} kg, an implausible density of {density:.3g} kg/m³ "
            "for the mesh volume; ignored"
        )
    density, source, note = material_density(element, material_name_hint, material_volumes)
    if note:
        warnings.append(note)
    return MassResult(volume_m3 * density, source, density, tuple(warnings))


def material_density(
    element: ifcopenshell.entity_instance,
    material_name_hint: str | None = None,
    material_volumes: Sequence[tuple[ifcopenshell.entity_instance | None, float]] = (),
) -> tuple[float, MassSource, str | None]:
    """(density kg/m³, its source, a warning or None) for the element's material: of layers, constituents
    or materials whose volumes are known, their weighted mean (:func:`layered_density`) when any of them
    is known."""
    layered = layered_density(element, material_volumes)
    if layered is not None:
        return layered
    materials = _materials(element)
    for material in materials:
        density = _density_property(material)
        if density is not None:
            return density, MassSource.MATERIAL_DENSITY_PROPERTY, None
    names = [
        text
        for material in materials
        for text in (material.Name, getattr(material, "Category", None))
        if text
    ]
    if material_name_hint:
        names.append(material_name_hint)
    for name in names:
        for pattern, density in DENSITY_TABLE_KG_M3:
            if pattern.search(name):
                return density, MassSource.MATERIAL_DENSITY_TABLE, None
    what = f"material {names[0].strip()!r}" if names else "no material"
    assumed = class_default(element)
    if assumed is not None:
        kind, density = assumed
        note = f"{what}: density unknown; an {element.is_a()} is taken for {kind}, {density:g} kg/m³"
        return density, MassSource.DEFAULT_DENSITY, note
    note = f"{what}: density unknown, using {DEFAULT_DENSITY_KG_M3:g} kg/m³"
    return DEFAULT_DENSITY_KG_M3, MassSource.DEFAULT_DENSITY, note


def class_default(element: ifcopenshell.entity_instance) -> tuple[str, float] | None:
    """(what it is taken for, its density kg/m³) for an element of unknown material whose class is almost
    always of one material on a site: floor and base slabs, footings and piles are concrete. A 30 cm
    floor weighed as water (:data:`DEFAULT_DENSITY_KG_M3`) is less than half its weight, and lighter than
    any crane would find it; None: no such class (a wall may be of masonry, studs or concrete). A beam,
    column or member drawn with a rolled steel section (an I, channel, angle, tee or hollow section
    profile: :data:`STEEL_SECTIONS`) is steel (the Revit 2025 structural sample's HSS 114 tubes of
    "<Unnamed>" material weighed 13.8 kg for 4.6 m as water, an eighth of their weight)."""
    if element.is_a() in STEEL_SECTION_CLASSES and _steel_section(element):
        return "steel (its section is a rolled steel profile)", STEEL_DENSITY_KG_M3
    if element.is_a() not in CLASS_DEFAULT_CLASSES:
        return None
    predefined = str(getattr(element, "PredefinedType", None) or "")
    if predefined in ("ROOF", "USERDEFINED") and element.is_a("IfcSlab"):
        return None  # a roof may be timber or metal deck; a user-defined slab says nothing
    return "concrete", CONCRETE_DENSITY_KG_M3


def layered_density(
    element: ifcopenshell.entity_instance,
    material_volumes: Sequence[tuple[ifcopenshell.entity_instance | None, float]] = (),
) -> tuple[float, MassSource, str | None] | None:
    """The mean density of the element's layers weighted by their thicknesses (or of its constituents by
    their fractions, or of its materials by ``material_volumes``), each one's by :func:`part_density`, a
    part of unknown material at :data:`DEFAULT_DENSITY_KG_M3` with a warning naming it; None when the
    element is not made of such parts or none of them is known. Its source is that of the part that makes
    most of the element."""
    parts = _weighted_parts(element) or _volume_parts(material_volumes)
    if not parts:
        return None
    known = [(part_density(material, layer), fraction, material) for material, layer, fraction in parts]
    if all(density is None for density, _, _ in known):
        return None
    mean = 0.0
    main = (0.0, MassSource.DEFAULT_DENSITY)  # (fraction, source) of the largest part
    unknown: list[str] = []
    for found, fraction, material in known:
        density, source = found or (DEFAULT_DENSITY_KG_M3, MassSource.DEFAULT_DENSITY)
        if found is None:
            unknown.append(repr(str(getattr(material, "Name", None) or "unnamed")) if material else "none")
        mean += fraction * density
        if fraction > main[0]:
            main = (fraction, source)
    note = None
    if unknown:
        names = ", ".join(dict.fromkeys(unknown))
        note = f"material {names} of a part: density unknown, using {DEFAULT_DENSITY_KG_M3:g} kg/m³ for it"
    return mean, main[1], note


def _volume_parts(
    material_volumes: Sequence[tuple[ifcopenshell.entity_instance | None, float]],
) -> list[tuple[ifcopenshell.entity_instance | None, ifcopenshell.entity_instance | None, float]]:
    """(material, no layer, share of the volume) of ``material_volumes``; empty when they hold nothing."""
    total = sum(volume for _, volume in material_volumes)
    if not total > 0:
        return []
    return [(material, None, volume / total) for material, volume in material_volumes]


def part_density(
    material: ifcopenshell.entity_instance | None, layer: ifcopenshell.entity_instance | None = None
) -> tuple[float, MassSource] | None:
    """The density of one layer or constituent's material: its MassDensity, a layer that is mostly air by
    its flag or name (:data:`LAYER_DENSITY_KG_M3`), the table by name or category; None when unknown."""
    if material is not None:
        density = _density_property(material)
        if density is not None:
            return density, MassSource.MATERIAL_DENSITY_PROPERTY
    names = [
        str(text)
        for text in (
            getattr(material, "Name", None),
            getattr(material, "Category", None),
            getattr(layer, "Name", None),
        )
        if text
    ]
    if layer is not None:
        if getattr(layer, "IsVentilated", None) is True:
            return LAYER_DENSITY_KG_M3[1][1], MassSource.MATERIAL_DENSITY_TABLE
        for pattern, density in LAYER_DENSITY_KG_M3:
            if any(pattern.search(name) for name in names):
                return density, MassSource.MATERIAL_DENSITY_TABLE
    for name in names:
        for pattern, density in DENSITY_TABLE_KG_M3:
            if pattern.search(name):
                return density, MassSource.MATERIAL_DENSITY_TABLE
    return None


def _weighted_parts(
    element: ifcopenshell.entity_instance,
) -> list[tuple[ifcopenshell.entity_instance | None, ifcopenshell.entity_instance | None, float]]:
    """(material, its layer or None, fraction of the element) of a layer set with thicknesses or a
    constituent set with fractions; empty for anything else."""
    try:
        material = ifcopenshell.util.element.get_material(element, should_skip_usage=True)
    except (AttributeError, RuntimeError, TypeError):  # malformed material associations
        return []
    if material is None:
        return []
    if material.is_a("IfcMaterialLayerSet"):
        layers = [layer for layer in material.MaterialLayers or () if (layer.LayerThickness or 0.0) > 0]
        total = sum(float(layer.LayerThickness) for layer in layers)
        return [(layer.Material, layer, float(layer.LayerThickness) / total) for layer in layers]
    if material.is_a("IfcMaterialConstituentSet"):
        parts = list(material.MaterialConstituents or ())
        given = [getattr(part, "Fraction", None) for part in parts]
        fractions = [float(value) for value in given if isinstance(value, int | float) and value > 0]
        if not parts or len(fractions) != len(parts):
            return []
        total = sum(fractions)
        return [(part.Material, None, value / total) for part, value in zip(parts, fractions, strict=True)]
    return []


def material_label(element: ifcopenshell.entity_instance) -> str | None:
    """A human name for the element's material (set name, or material names joined)."""
    material = ifcopenshell.util.element.get_material(element, should_skip_usage=True)
    if material is None:
        return None
    own_name = getattr(material, "Name", None) or getattr(material, "LayerSetName", None)
    if own_name:
        return str(own_name)
    names = [item.Name for item in _materials(element) if item.Name]
    return ", ".join(dict.fromkeys(names)) or None


def _materials(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    try:
        return list(ifcopenshell.util.element.get_materials(element))
    except (AttributeError, RuntimeError, TypeError):  # malformed material associations
        return []


def _quantity_weight(element: ifcopenshell.entity_instance) -> tuple[str, float] | None:
    """The preferred IfcQuantityWeight of the element (then of its type)."""
    found: dict[str, tuple[str, float]] = {}
    for definition in _property_definitions(element):
        if not definition.is_a("IfcElementQuantity"):
            continue
        for quantity in definition.Quantities or ():
            if quantity.is_a("IfcQuantityWeight") and quantity.WeightValue is not None:
                key = quantity.Name.replace(" ", "").lower() if quantity.Name else "weight"
                value = float(quantity.WeightValue) * _own_unit_factor(quantity)
                found.setdefault(key, (f"{definition.Name}.{quantity.Name}", value))
    for key in WEIGHT_QUANTITY_PREFERENCE:
        if key in found:
            return found[key]
    return next(iter(found.values()), None)


def _vendor_weight(element: ifcopenshell.entity_instance) -> tuple[str, float] | None:
    """A weight property from an authoring tool's property set; ``Structural`` sets first."""
    candidates: list[tuple[int, str, float]] = []
    for definition in _property_definitions(element):
        if not definition.is_a("IfcPropertySet"):
            continue
        rank = 0 if "structural" in (definition.Name or "").lower() else 1
        for prop in definition.HasProperties or ():
            if not prop.is_a("IfcPropertySingleValue") or prop.NominalValue is None:
                continue
            key = (prop.Name or "").replace(" ", "").lower()
            value = prop.NominalValue.wrappedValue
            if key in VENDOR_WEIGHT_NAMES and isinstance(value, int | float):
                order = rank * 10 + VENDOR_WEIGHT_NAMES.index(key)
                candidates.append(
                    (order, f"{definition.Name}.{prop.Name}", float(value) * _own_unit_factor(prop))
                )
    if not candidates:
        return None
    _, label, value = min(candidates)
    return label, value


def _property_definitions(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    """Property sets and quantity sets of the element, then of its type."""
    definitions = [
        rel.RelatingPropertyDefinition
        for rel in getattr(element, "IsDefinedBy", ()) or ()
        if rel.is_a("IfcRelDefinesByProperties")
    ]
    element_type = ifcopenshell.util.element.get_type(element)
    if element_type is not None:
        definitions.extend(element_type.HasPropertySets or ())
    return [item for item in definitions if item is not None and hasattr(item, "is_a")]


def _own_unit_factor(item: ifcopenshell.entity_instance) -> float:
    """1 unless a quantity/property names its own mass unit (then its factor to the project unit)."""
    unit = getattr(item, "Unit", None)
    if unit is None:
        return 1.0
    try:
        return ifcopenshell.util.unit.get_unit_scale(unit) / (1000.0 * mass_unit_kg(item.file))
    except (AttributeError, TypeError, ValueError):
        return 1.0


def _density_property(material: ifcopenshell.entity_instance) -> float | None:
    """MassDensity from Pset_MaterialCommon (IFC4) or IfcGeneralMaterialProperties (IFC2X3), kg/m³."""
    values: list[float] = []
    psets = ifcopenshell.util.element.get_psets(material)
    for name, props in psets.items():
        if "MassDensity" in props and (name == "Pset_MaterialCommon" or name.endswith("MaterialCommon")):
            values.append(props["MassDensity"])
    for inverse in material.file.get_inverse(material):
        if inverse.is_a("IfcGeneralMaterialProperties") and getattr(inverse, "MassDensity", None):
            values.append(inverse.MassDensity)
    for value in values:
        if (
            isinstance(value, int | float)
            and PLAUSIBLE_DENSITY_KG_M3[0] <= value <= PLAUSIBLE_DENSITY_KG_M3[1]
        ):
            return float(value)
        _log.warning("material %r: MassDensity %r is implausible; ignored", material.Name, value)
    return None


def _steel_section(element: ifcopenshell.entity_instance) -> bool:
    """Whether the element is drawn with a steel section profile (:data:`STEEL_SECTIONS`): its material
    profile set's, or the swept area of a solid of its shape (through mapped items and booleans too:
    ifcopenshell's ``resolve_base_items``)."""
    material = ifcopenshell.util.element.get_material(element, should_skip_usage=True)
    profiles = [item.Profile for item in getattr(material, "MaterialProfiles", None) or () if item.Profile]
    if any(profile.is_a() in STEEL_SECTIONS for profile in profiles):
        return True
    representations = getattr(getattr(element, "Representation", None), "Representations", None) or ()
    return any(
        item.is_a("IfcSweptAreaSolid") and item.SweptArea.is_a() in STEEL_SECTIONS
        for representation in representations
        for item in ifcopenshell.util.representation.resolve_base_items(representation)
    )
