"""What is built: building elements and their parts by default, in IFC2X3, IFC4 and IFC4X3 alike; every
other element is listed with a reason; --include/--exclude/--only change it by class."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.classification
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import pytest
from cli_runs import Ended, bimbot_in_process, bimbot_process
from ifc_builders import (
    SmallModel,
    add_assembly,
    add_beam,
    add_opening,
    add_pset,
    add_wall,
    new_model,
    translation,
)

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.selection import check_exclusions, reason_head, select_elements
from bimbot.shared.manifest import Manifest

SCHEMAS = ["IFC2X3", "IFC4", "IFC4X3"]

# class → built by default?, per schema (None: the class does not exist in that schema)
BUILT = {
    "IfcWall": (True, True, True),
    "IfcBuildingElementProxy": (True, True, True),
    "IfcCovering": (True, True, True),
    "IfcFastener": (True, True, True),
    "IfcDiscreteAccessory": (True, True, True),
    "IfcBuildingElementPart": (True, True, True),  # IFC2X3: under IfcBuildingElementComponent
    "IfcFurnishingElement": (False, None, None),
    "IfcFurniture": (None, False, False),
    "IfcFlowTerminal": (False, False, False),  # MEP: IfcDistributionElement
    "IfcElectricalElement": (False, None, None),
    "IfcTransportElement": (False, False, False),
    "IfcGeographicElement": (None, False, False),
    "IfcCivilElement": (None, False, False),
    "IfcVirtualElement": (False, False, False),
}


def _element(small: SmallModel, ifc_class: str, name: str, x_m: float = 0.0) -> ifcopenshell.entity_instance:
    element = ifcopenshell.api.root.create_entity(small.file, ifc_class=ifc_class, name=name)
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=1.0, height=1.0, thickness=1.0
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=element, representation=body)
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=element, matrix=translation(x_m))
    ifcopenshell.api.spatial.assign_container(small.file, products=[element], relating_structure=small.storey)
    return element


def _the_one_left_out(small: SmallModel, kept: str) -> str:
    """The reason of the one element ``small``'s selection leaves out, the element named ``kept`` being the
    one it keeps."""
    selection = select_elements(small.file)
    assert [element.Name for element in selection.elements] == [kept]
    (rejected,) = selection.rejected
    return rejected.reason


def _classes_model(schema: str) -> tuple[SmallModel, dict[str, bool]]:
    small = new_model(schema)
    expected: dict[str, bool] = {}
    schema_index = SCHEMAS.index(schema)
    for number, (ifc_class, built) in enumerate(BUILT.items()):
        if built[schema_index] is None:
            continue
        _element(small, ifc_class, ifc_class, x_m=2.0 * number)
        expected[ifc_class] = bool(built[schema_index])
    return small, expected


@pytest.mark.parametrize("schema", SCHEMAS)
def test_building_elements_and_parts_are_built_the_rest_is_listed_with_its_reason(schema: str) -> None:
    small, expected = _classes_model(schema)
    wall = small.file.by_type("IfcWall")[0]
    add_opening(small, wall)
    selection = select_elements(small.file)
    built = {element.Name for element in selection.elements}
    assert built == {name for name, is_built in expected.items() if is_built}
    reasons = {rejection.element.Name: rejection.reason for rejection in selection.rejected}
    assert set(reasons) == {name for name, is_built in expected.items() if not is_built} | {"Opening"}
    furniture = "IfcFurnishingElement" if schema == "IFC2X3" else "IfcFurniture"
    assert reasons[furniture] == (
        "not a building element (IfcFurnishingElement); --include IfcFurnishingElement to build it"
    )
    assert reasons["IfcFlowTerminal"].startswith("not a building element (IfcDistributionElement)")
    assert reasons["Opening"].startswith("feature element (IfcOpeningElement)")
    assert reasons["IfcVirtualElement"].startswith("virtual element (IfcVirtualElement)")


@pytest.mark.parametrize("schema", SCHEMAS)
def test_include_adds_a_class_back_exclude_takes_one_away_only_replaces_the_rule(schema: str) -> None:
    small, _ = _classes_model(schema)
    furniture = "IfcFurnishingElement"
    with_furniture = select_elements(small.file, include=(furniture,))
    names = {element.Name for element in with_furniture.elements}
    assert {"IfcWall", "IfcFastener"} <= names and ({"IfcFurnishingElement", "IfcFurniture"} & names)
    without_walls = select_elements(small.file, exclude=("IfcWall",))
    reasons = {rejection.element.Name: rejection.reason for rejection in without_walls.rejected}
    assert reasons["IfcWall"] == "left out by --exclude IfcWall"
    only = select_elements(small.file, only=("IfcWall", "IfcFlowTerminal"))
    assert {element.Name for element in only.elements} == {"IfcWall", "IfcFlowTerminal"}
    reasons = {rejection.element.Name: rejection.reason for rejection in only.rejected}
    assert reasons["IfcFastener"].startswith("not in --only IfcWall,IfcFlowTerminal")
    every = {element.id() for element in small.file.by_type("IfcElement")}
    for selection in (with_furniture, without_walls, only):  # nothing is dropped silently
        listed = [e.id() for e in selection.elements] + [r.element.id() for r in selection.rejected]
        assert sorted(listed) == sorted(every)


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4"])
def test_a_proxy_classified_as_equipment_or_planting_is_left_out_as_its_own_class_would_be(
    schema: str,
) -> None:
    """Revit exports the restaurant's walk-in refrigerator (17 t as its open mesh's hull, too heavy for any
    crane), its ranges and its trees as proxies; their UniFormat codes say what IFC classes would: equipment,
    services and planting, installed by their trades and left out like furniture. A proxy coded as a
    building element (C1010: partitions) or not coded at all is built; --include builds them all."""
    small = new_model(schema)
    fridge = _element(small, "IfcBuildingElementProxy", "Refrigerator-Walk-In")
    add_pset(
        small,
        [fridge],
        "PSet_Revit_Type_Identity Data",
        {"Assembly Code": "E1090330", "Assembly Description": "Food Service - Walk-in Refrigerators"},
    )
    sink = _element(small, "IfcBuildingElementProxy", "Sink", x_m=2.0)
    add_pset(small, [sink], "PSet_Revit_Type_Identity Data", {"Assembly Code": "D2010440"})
    shrub = _element(small, "IfcBuildingElementProxy", "Shrub", x_m=4.0)
    reference = ifcopenshell.api.classification.add_reference(
        small.file,
        products=[shrub],
        identification="G2050500",
        name="Planting",
        classification=ifcopenshell.api.classification.add_classification(
            small.file, classification="UniFormat"
        ),
    )
    assert reference is not None
    stalls = _element(small, "IfcBuildingElementProxy", "Toilet partitions", x_m=6.0)
    add_pset(small, [stalls], "PSet_Revit_Type_Identity Data", {"Assembly Code": "C1010400"})
    _element(small, "IfcBuildingElementProxy", "Generic model", x_m=8.0)
    selection = select_elements(small.file)
    assert {element.Name for element in selection.elements} == {"Toilet partitions", "Generic model"}
    reasons = {rejection.element.Name: rejection.reason for rejection in selection.rejected}
    assert reasons["Refrigerator-Walk-In"] == (
        "not a building element (a proxy classified as equipment); UniFormat E1090330 'Food Service - "
        "Walk-in Refrigerators', installed by its vendor or trade, not built by the robots; --include "
        "IfcBuildingElementProxy to build it"
    )
    assert reason_head(reasons["Sink"]) == "not a building element (a proxy classified as services)"
    assert reason_head(reasons["Shrub"]) == "not a building element (a proxy classified as landscaping)"
    included = select_elements(small.file, include=("IfcBuildingElementProxy",))
    assert len(included.elements) == 5


def test_a_proxy_of_no_category_with_revits_electrical_loads_is_equipment_another_is_built() -> None:
    """The Revit restaurant (a 2012 export, no categories) draws a fire-extinguisher cabinet 305 mm into a
    sign;
    both carry Revit's "Electrical - Loads" parameters, as its ranges and fryer do, and the run failed the
    cabinet "unstable" three times. That group marks an equipment family: left out. A proxy with an empty
    "Electrical - Loads"-like set of other names, or with the group and a category Revit builds, is built."""
    small = new_model("IFC2X3")
    cabinet = _element(small, "IfcBuildingElementProxy", "Fire Extinguishers and Cabinet:711290")
    add_pset(small, [cabinet], "PSet_Revit_Electrical - Loads", {"Panel": "", "Circuit Number": ""})
    add_pset(small, [cabinet], "PSet_Revit_Phasing", {"Phase Created": "New Construction"})
    plinth = _element(small, "IfcBuildingElementProxy", "Plinth", x_m=2.0)
    add_pset(small, [plinth], "PSet_Revit_Electrical - Loads", {"Load Classification": "Other"})
    block = _element(small, "IfcBuildingElementProxy", "Generic block", x_m=4.0)
    add_pset(small, [block], "PSet_Revit_Electrical - Loads", {"Panel": ""})
    add_pset(small, [block], "Pset_ProductRequirements", {"Category": "Generic Models"})
    selection = select_elements(small.file)
    assert {element.Name for element in selection.elements} == {"Plinth", "Generic block"}
    (rejected,) = selection.rejected
    assert rejected.element.Name == "Fire Extinguishers and Cabinet:711290"
    assert rejected.reason == (
        "not a building element (a proxy of an equipment family); it carries Revit's 'Electrical - Loads' "
        "parameters (Panel, Circuit Number), which Revit gives to equipment and fixtures, installed by their "
        "vendor or trade, not built by the robots; --include IfcBuildingElementProxy to build it"
    )
    assert reason_head(rejected.reason) == "not a building element (a proxy of an equipment family)"
    assert len(select_elements(small.file, include=("IfcBuildingElementProxy",)).elements) == 3


def test_an_rpc_person_is_entourage_left_out_and_a_proxy_with_another_appearance_is_built() -> None:
    """The Revit restaurant's "RPC Male" and "RPC Female" figures are proxies with no classification whose
    render appearance is an ArchVision RPC item: people drawn for renderings, not building elements."""
    small = new_model("IFC2X3")
    person = _element(small, "IfcBuildingElementProxy", "RPC Male:Alex:Alex:447066")
    add_pset(
        small,
        [person],
        "PSet_Revit_Type_Identity Data",
        {"Render Appearance": "RPC-8-X9C2-NGU9-LXF5-4", "Assembly Code": ""},
    )
    bench = _element(small, "IfcBuildingElementProxy", "Bench", x_m=2.0)
    appearance = {"Render Appearance": "Concrete - Cast-in-Place"}
    add_pset(small, [bench], "PSet_Revit_Type_Identity Data", appearance)
    reason = _the_one_left_out(small, kept="Bench")
    assert reason == (
        "not a building element (entourage); rendered as RPC-8-X9C2-NGU9-LXF5-4 of ArchVision's RPC content, "
        "a person, vehicle or plant drawn for renderings, not built by the robots; --include "
        "IfcBuildingElementProxy to build it"
    )
    assert reason_head(reason) == "not a building element (entourage)"
    assert len(select_elements(small.file, include=("IfcBuildingElementProxy",)).elements) == 2


@pytest.mark.parametrize("schema", SCHEMAS)
def test_an_aggregate_whose_parts_are_built_is_left_out_once_with_the_count(schema: str) -> None:
    small = new_model(schema)
    curtain = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcCurtainWall", name="Curtain")
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=curtain, matrix=translation())
    ifcopenshell.api.spatial.assign_container(small.file, products=[curtain], relating_structure=small.storey)
    plate = add_beam(small, "Plate", schema_class="IfcPlate", contained=False)
    mullion = add_beam(small, "Mullion", schema_class="IfcMember", contained=False)
    ifcopenshell.api.aggregate.assign_object(small.file, products=[plate, mullion], relating_object=curtain)
    roof = _element(small, "IfcRoof", "Roof", x_m=5.0)  # a body of its own and a built part
    slab = add_beam(small, "Roof slab", schema_class="IfcSlab", contained=False)
    ifcopenshell.api.aggregate.assign_object(small.file, products=[slab], relating_object=roof)
    beam = add_beam(small, "Truss chord", contained=False)
    add_assembly(small, [beam], name="Truss")  # no body of its own
    lone = _element(small, "IfcElementAssembly", "Precast unit", x_m=9.0)  # a body, no parts
    selection = select_elements(small.file)
    assert {e.Name for e in selection.elements} == {"Plate", "Mullion", "Roof slab", "Truss chord", lone.Name}
    reasons = {rejection.element.Name: rejection.reason for rejection in selection.rejected}
    assert reasons["Curtain"] == "no geometry of its own; its 2 part(s) are built as components"
    assert reasons["Roof"].startswith("an aggregate; its 1 part(s) are built")
    assert reasons["Truss"].startswith("no geometry of its own; its 1 part(s)")
    only_roof = select_elements(small.file, only=("IfcRoof",))  # its parts are not built: the roof is
    assert [e.Name for e in only_roof.elements] == ["Roof"]


def test_reason_head_is_the_text_before_the_first_semicolon_or_colon() -> None:
    assert (
        reason_head("not a building element (IfcFurniture); --include X")
        == "not a building element (IfcFurniture)"
    )
    assert reason_head("no triangulated geometry: curve-only") == "no triangulated geometry"
    assert reason_head("left out by --exclude IfcWall") == "left out by --exclude IfcWall"


# --- through the CLI -------------------------------------------------------------------------------------


def _chairs_and_a_wall(schema: str, source: Path) -> None:
    small = new_model(schema)
    add_wall(small, "W")
    furniture_class = "IfcFurnishingElement" if schema == "IFC2X3" else "IfcFurniture"
    for number in range(2):
        _element(small, furniture_class, f"Chair {number}", x_m=2.0 + 2.0 * number)
    small.file.write(str(source))


@pytest.mark.parametrize("schema", SCHEMAS)
def test_cli_summary_counts_what_was_left_out_by_reason_and_include_adds_it(
    schema: str, tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    source = tmp_path / "m.ifc"
    _chairs_and_a_wall(schema, source)

    def bimbot(*args: str) -> Ended:
        return bimbot_in_process(*args, capfd=capfd, caplog=caplog)

    result = bimbot("convert", str(source), "-o", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    assert (
        "converted 1 component(s), skipped 2 (2 not a building element (IfcFurnishingElement))"
        in result.stdout
    )
    manifest = Manifest.model_validate_json((tmp_path / "out" / "manifest.json").read_text())
    assert {s.name for s in manifest.skipped} == {"Chair 0", "Chair 1"}
    result = bimbot("convert", str(source), "-o", str(tmp_path / "all"), "--include", "IfcFurnishingElement")
    assert result.returncode == 0, result.stderr
    assert "converted 3 component(s), skipped 0," in result.stdout
    result = bimbot("convert", str(source), "-o", str(tmp_path / "only"), "--only", "IfcWall")
    assert "converted 1 component(s), skipped 2 (2 not in --only IfcWall)" in result.stdout, result.stdout
    assert "Chair" not in result.stderr  # what the selection leaves out is counted, not listed one by one


def test_ifc4x3_model_converts_through_the_cli_and_its_summary_counts_what_was_left_out(
    tmp_path: Path,
) -> None:
    """The real command, once: exit 0, the summary on stdout, the chairs the selection leaves out not on
    stderr (the logging ``main`` configures in a process of its own)."""
    source = tmp_path / "m.ifc"
    _chairs_and_a_wall("IFC4X3", source)
    result = bimbot_process("convert", str(source), "-o", str(tmp_path / "out"), "--exclude", "IfcBeam")
    assert result.returncode == 0, result.stderr
    assert (
        "converted 1 component(s), skipped 2 (2 not a building element (IfcFurnishingElement))"
        in result.stdout
    )
    assert "Chair" not in result.stderr


# --- the public samples ----------------------------------------------------------------------------------


def _selected_classes(model: ifcopenshell.file, **options: tuple[str, ...]) -> dict[str, int]:
    selection = select_elements(model, **options)
    counts: dict[str, int] = {}
    for element in selection.elements:
        counts[element.is_a()] = counts.get(element.is_a(), 0) + 1
    return counts


def test_sample_house_builds_its_building_elements_and_lists_the_furniture(samples_dir: Path) -> None:
    model = ifcopenshell.open(str(samples_dir / "revit2021_sample_project.ifc"))
    assert _selected_classes(model) == {
        "IfcMember": 31, "IfcPlate": 12, "IfcWindow": 9, "IfcWallStandardCase": 3, "IfcSlab": 2, "IfcDoor": 1
    }  # fmt: skip
    rejected = select_elements(model).rejected
    heads: dict[str, int] = {}
    for rejection in rejected:
        heads[reason_head(rejection.reason)] = heads.get(reason_head(rejection.reason), 0) + 1
    assert heads == {
        "not a building element (IfcFurnishingElement)": 35,
        "feature element (IfcOpeningElement)": 10,
        "no geometry of its own": 1,  # the curtain wall: its 12 plates and 31 members are built
    }
    with_furniture = _selected_classes(model, include=("IfcFurnishingElement",))
    assert with_furniture["IfcFurnishingElement"] == 35 and sum(with_furniture.values()) == 93


@pytest.mark.parametrize(
    ("name", "components", "classes"),
    [
        ("revit2021_structural_hub.ifc", 115, {"IfcBuildingElementProxy": 4, "IfcSlab": 9, "IfcBeam": 43}),
        ("acad2010_objects.ifc", 52, {"IfcBuildingElementProxy": 11, "IfcStair": 2, "IfcRoof": 1}),
        ("IfcIShapeProfileDef.ifc", 3, {"IfcBuildingElementProxy": 3}),
        ("standard_case_element_beam.ifc", 18, {"IfcBeamStandardCase": 18}),
        ("construction_scheduling_task.ifc", 5, {"IfcSlabStandardCase": 1, "IfcWallStandardCase": 4}),
    ],
)
def test_samples_build_every_building_element_and_proxy(
    samples_dir: Path, name: str, components: int, classes: dict[str, int]
) -> None:
    model = ifcopenshell.open(str(samples_dir / name))
    counts = _selected_classes(model)
    assert sum(counts.values()) == components
    assert {cls: counts.get(cls, 0) for cls in classes} == classes


def test_convert_model_takes_only_include_and_exclude_options(tmp_path: Path) -> None:
    small = new_model()
    add_wall(small, "W")
    _element(small, "IfcFurniture", "Sofa", x_m=3.0)
    source = tmp_path / "m.ifc"
    small.file.write(str(source))
    model = ifcopenshell.open(str(source))
    manifest = convert_model(model, source, tmp_path / "a", ConvertOptions(include=("IfcFurniture",)))
    assert sorted(c.name for c in manifest.components) == ["Sofa", "W"] and manifest.skipped == []
    manifest = convert_model(model, source, tmp_path / "b", ConvertOptions(only=("IfcFurniture",)))
    assert [c.name for c in manifest.components] == ["Sofa"]
    assert [(s.name, s.reason.split(";")[0]) for s in manifest.skipped] == [
        ("W", "not in --only IfcFurniture")
    ]


def test_exclude_takes_a_single_element_by_its_global_id_and_names_what_it_does_not_know(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """The advice for a clash in the IFC is to leave one of the two out: --exclude takes its GlobalId
    (it took classes only, so the advice could not be followed); a token that is neither is one line, from
    the real command."""
    small = new_model()
    first, second = add_wall(small, "W1"), add_wall(small, "W2", matrix_m=translation(0.0, 5.0, 0.0))
    source = tmp_path / "m.ifc"
    small.file.write(str(source))
    out = tmp_path / "out"
    exclude = f"{second.GlobalId},IfcBeam"
    result = bimbot_in_process(
        "convert", str(source), "-o", str(out), "--exclude", exclude, capfd=capfd, caplog=caplog
    )
    assert result.returncode == 0, result.stderr
    manifest = Manifest.model_validate_json((out / "manifest.json").read_text())
    assert [c.guid for c in manifest.components] == [first.GlobalId]
    assert [(s.guid, s.reason) for s in manifest.skipped] == [
        (second.GlobalId, f"left out by --exclude {second.GlobalId}")
    ]
    unknown = bimbot_process("convert", str(source), "-o", str(out), "--exclude", "0000000000000000000000")
    assert unknown.returncode == 2 and "Traceback" not in unknown.stderr
    (line,) = unknown.stderr.strip().splitlines()
    assert line == (
        "bimbot convert: error: --exclude: neither an IFC class of IFC4 nor the GlobalId of an element in "
        "the model: 0000000000000000000000"
    )


def test_a_global_id_the_shell_cut_at_its_dollar_is_named_with_the_quoting_that_keeps_it() -> None:
    """``--exclude 0sfBnoLAb0R9H9P$iaZWkY`` unquoted reaches bimbot as ``0sfBnoLAb0R9H9P`` (the shell
    expands ``$iaZWkY`` to nothing): the error says so and shows the quoted GlobalId."""
    small = new_model()
    wall = add_wall(small, "W")
    wall.GlobalId = "0sfBnoLAb0R9H9P$iaZWkY"
    assert check_exclusions(small.file, [wall.GlobalId, "IfcBeam"]) == (("IfcBeam",), (wall.GlobalId,))
    cut = r"which the shell cut off: quote the GlobalId, --exclude '0sfBnoLAb0R9H9P\$iaZWkY'"
    with pytest.raises(ValueError, match=cut):
        check_exclusions(small.file, ["0sfBnoLAb0R9H9P"])
    # several elements share that start (Revit's GlobalIds do): none is picked for the user
    other = add_wall(small, "W2")
    other.GlobalId = "0sfBnoLAb0R9H9P$iaZdP4"
    with pytest.raises(ValueError, match=r"the start of 2 GlobalId\(s\).*--exclude '…\$…'"):
        check_exclusions(small.file, ["0sfBnoLAb0R9H9P"])


def test_a_marker_of_a_virtual_material_is_left_out() -> None:
    """SketchUp's IFC-manager exports a model's coordination origin as a 1 m cube of material
    ``virtual_white`` (ifc-mcp's Building-Structural): the crane lifted it as a 1 t part. A proxy whose
    every material is named virtual is a marker; one of a real material is built."""
    small = new_model("IFC4")
    origin = _element(small, "IfcBuildingElementProxy", "origin")
    origin.Description = "The local position for coordination of aspect models."
    virtual = ifcopenshell.api.material.add_material(small.file, name="virtual_white")
    ifcopenshell.api.material.assign_material(small.file, products=[origin], material=virtual)
    block = _element(small, "IfcBuildingElementProxy", "Block", x_m=3.0)
    concrete = ifcopenshell.api.material.add_material(small.file, name="concrete")
    ifcopenshell.api.material.assign_material(small.file, products=[block], material=concrete)
    reason = _the_one_left_out(small, kept="Block")
    assert reason == (
        "not a building element (a marker); its material 'virtual_white' is virtual: The local position for "
        "coordination of aspect models.; --include IfcBuildingElementProxy to build it"
    )
    assert reason_head(reason) == "not a building element (a marker)"
