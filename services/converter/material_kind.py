"""What an element is made of, as the construction-method rules see it: its main material's kind.

The main material is the one that makes most of the element: the thickest layer of a layer set (a brick
wall plastered both sides is masonry), the largest fraction of a constituent set, the first profile of a
profile set, the first of a list or the material itself (the element's own association, else its
type's). Its kind comes from its name and category (IFC4), in the languages exports keep (the Revit
sample house's "Ladrillo de cerámica hueco doble" is masonry, its "Cristal" glass; a Chinese Revit
model's "混凝土 - 现场浇注混凝土", concrete - cast-in-place concrete, is concrete cast in place); a
material whose name says nothing (Revit's "<Unnamed>", "Default Floor") is :attr:`MaterialKind.UNKNOWN`.
A name may also say how the element is made: "Concrete, Cast-in-Place gray" (the Revit hub's) is cast
in place, "Precast Concrete" lifted, and a poured floor ("Floor:J_Floor_Concrete_PouredUnderlayment" of gypsum
concrete, "J_Floor_Gyp_Crete", in the Revit restaurant; a screed) is cast in place on the floor beneath
it (:data:`POURED_WORDS`).
"""

from __future__ import annotations

import math
import re

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.unit

from bimbot.shared.methods_file import MaterialKind

# A plaster coat is 10-25 mm, a gypsum block or a drywall partition drawn as one layer up to about 150 mm:
# a "plaster" layer thicker than this says what the wall is finished with, not what it is made of (the
# Revit office's "MockUp Exterior", 600 mm of "Plaster" and 30 mm of "Leather, weathered" over five
# storeys). Such a layer is left out of the main material; with nothing else said, the kind is unknown.
MAX_FINISH_LAYER_M = 0.25

# (pattern on a material name or category, kind); the first match wins, so specific words come first
KIND_PATTERNS: tuple[tuple[re.Pattern[str], MaterialKind], ...] = (
    # concrete blocks are masonry: "Masonry - Concrete Block", "Concrete Masonry Units" (the Revit duplex's)
    (
        re.compile(r"masonry|concrete[-_ ]?block|\bcmu\b|blockwork|mauerwerk|betonstein|parpaing", re.I),
        MaterialKind.MASONRY,
    ),
    (re.compile(r"alumin", re.I), MaterialKind.ALUMINIUM),
    # 钢 is steel, 钢筋 its rebar (钢筋混凝土: reinforced concrete), as Stahlbeton is concrete
    (
        re.compile(
            r"steel|stahl(?!beton)|acier|acero|acciaio|\bs\d{3}\b|metal|钢(?!筋)|鋼(?!筋)|сталь", re.I
        ),
        MaterialKind.STEEL,
    ),
    (
        re.compile(
            r"concrete|b[eé]ton|hormig[oó]n|calcestruzzo|\bc\d{2}/\d{2}\b|混凝土|砼|コンクリート|бетон", re.I
        ),
        MaterialKind.CONCRETE,
    ),
    (
        re.compile(
            r"brick|block|ladrillo|brique|mattone|ziegel|stone|piedra|pierre|pietra|"
            r"砖|砌块|砌体|煉瓦|レンガ|кирпич",
            re.I,
        ),
        MaterialKind.MASONRY,
    ),
    (re.compile(r"timber|wood|\bholz\b|glulam|\bclt\b|madera|\bbois\b|legno", re.I), MaterialKind.TIMBER),
    (
        re.compile(r"glass|glazing|\bglas\b|vidrio|cristal|verre|vetro|玻璃|ガラス|стекло", re.I),
        MaterialKind.GLASS,
    ),
    (re.compile(r"gypsum|plaster|yeso|enlucido|pl[aâ]tre|gesso|\bgips|\bputz", re.I), MaterialKind.GYPSUM),
)
CAST_IN_PLACE_WORDS = re.compile(
    r"cast[-_ ]?in[-_ ]?(place|situ)|\bin[-_ ]?situ\b|insitu|ortbeton|coul[ée] en place|in opera|in loco|"
    r"现场浇|現場打|现浇|монолит",
    re.I,
)
# poured onto what lies beneath (a topping, an underlayment, a screed): cast in place with no soffit form
POURED_WORDS = re.compile(
    r"(?<![a-z])poured(?![a-z])|gyp[-_ ]?cret|gypsum[-_ ]?concrete|levelrock|(?<![a-z])screed|"
    r"self[-_ ]?level|estrich|(?<![a-z])chape(?![a-z])|massetto|solado",
    re.I,
)
PRECAST_WORDS = re.compile(
    r"pre[-_ ]?cast|pre[-_ ]?fab|fertigteil|pr[eé]fabriqu|prefabricad|预制|プレキャスト", re.I
)


def material_texts(element: ifcopenshell.entity_instance) -> list[str]:
    """Names and categories of the element's materials, the one that makes most of it first (see the
    module docstring), then the name of its material set."""
    try:
        material = ifcopenshell.util.element.get_material(element, should_skip_usage=True)
    except (AttributeError, RuntimeError, TypeError):  # a malformed association
        return []
    if material is None:
        return []
    texts: list[str] = []
    for item in main_materials(material, too_thick_m=_too_thick_m(element)):
        texts += [str(text) for text in (item.Name, getattr(item, "Category", None)) if text]
    own = getattr(material, "LayerSetName", None) or (
        None if material.is_a("IfcMaterial") else getattr(material, "Name", None)
    )
    if own:
        texts.append(str(own))
    return list(dict.fromkeys(texts))


def main_materials(
    material: ifcopenshell.entity_instance, *, too_thick_m: float = math.inf
) -> list[ifcopenshell.entity_instance]:
    """The ``IfcMaterial``\\ s of a material or material set, the one that makes most of it first; a layer
    of a finish (plaster, gypsum) thicker than ``too_thick_m`` (in the model's length unit) left out."""
    if material.is_a("IfcMaterial"):
        return [material]
    if material.is_a("IfcMaterialLayerSet"):
        layers = sorted(material.MaterialLayers or (), key=lambda layer: -(layer.LayerThickness or 0.0))
        return [
            layer.Material
            for layer in layers
            if layer.Material is not None
            and not ((layer.LayerThickness or 0.0) > too_thick_m and _is_finish(layer.Material))
        ]
    if material.is_a("IfcMaterialConstituentSet"):
        parts = sorted(material.MaterialConstituents or (), key=lambda part: -(part.Fraction or 0.0))
        return [part.Material for part in parts if part.Material is not None]
    if material.is_a("IfcMaterialProfileSet"):
        return [profile.Material for profile in material.MaterialProfiles or () if profile.Material]
    if material.is_a("IfcMaterialList"):
        return [item for item in material.Materials or () if item is not None]
    return []


def _too_thick_m(element: ifcopenshell.entity_instance) -> float:
    """:data:`MAX_FINISH_LAYER_M` in the model's length unit."""
    return MAX_FINISH_LAYER_M / ifcopenshell.util.unit.calculate_unit_scale(element.file)


def _is_finish(material: ifcopenshell.entity_instance) -> bool:
    texts = [str(text) for text in (material.Name, getattr(material, "Category", None)) if text]
    return material_kind(texts) is MaterialKind.GYPSUM


def is_poured(texts: list[str]) -> bool:
    """Whether a material or material set's name (:func:`material_texts`) says the element is poured onto
    what lies beneath it (:data:`POURED_WORDS`)."""
    return any(POURED_WORDS.search(text) for text in texts)


def kind_of(text: str) -> MaterialKind:
    for pattern, kind in KIND_PATTERNS:
        if pattern.search(text):
            return kind
    return MaterialKind.UNKNOWN


def material_kind(texts: list[str]) -> MaterialKind:
    """The kind of the first of ``texts`` (:func:`material_texts`) that says one."""
    for text in texts:
        kind = kind_of(text)
        if kind is not MaterialKind.UNKNOWN:
            return kind
    return MaterialKind.UNKNOWN
