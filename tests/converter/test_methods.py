"""A construction method for every component, decided at conversion: what the IFC says, then the methods
file's rules against the fleet's lift, and the user's own word over both (tiny models, real converter)."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from cli_runs import bimbot_in_process, bimbot_process
from ifc_builders import SmallModel, add_box, add_layers, add_material, add_pset, new_model

from bimbot.data.light_steel_frame import build_light_steel_frame
from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.material_kind import CAST_IN_PLACE_WORDS, PRECAST_WORDS, kind_of
from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.fleet import Fleet
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.methods_file import MaterialKind, MethodsFile, load_methods
from bimbot.shared.sequence import read_sequence

LIFT_KG = 2000.0
CAST, LIFTED, PANELISED, LAID = (
    ConstructionMethod.CAST_IN_PLACE,
    ConstructionMethod.LIFTED,
    ConstructionMethod.PANELISED,
    ConstructionMethod.LAID,
)


def _fleet(payload_kg: float = LIFT_KG) -> Fleet:
    """One ground robot that lifts ``payload_kg``: the fleet's largest lift, whatever bimbot's default is."""
    lifter = {
        "urdf": "carrier.urdf",
        "payload_kg": payload_kg,
        "reach_m": 1.8,
        "max_place_height_m": 3.5,
        "length_m": 1.4,
        "width_m": 0.9,
        "max_speed_mps": 0.8,
        "max_turn_radps": 1.0,
    }
    return Fleet.model_validate({"types": {"lifter": lifter}, "robots": [{"type": "lifter", "count": 1}]})


def _convert(
    small: SmallModel, tmp_path: Path, methods: MethodsFile | None = None, **options: object
) -> Manifest:
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    chosen = ConvertOptions(methods=methods, fleet=_fleet(), formats=(), split_ifc=False, **options)  # type: ignore[arg-type]
    return convert_model(open_model(source), source, tmp_path / "out", chosen)


def _by_name(manifest: Manifest) -> dict[str, Component]:
    return {str(c.name): c for c in [*manifest.components, *manifest.in_place]}


def test_a_slab_the_ifc_says_is_cast_insitu_is_cast_with_its_formwork_pour_and_cure(tmp_path: Path) -> None:
    small = new_model()
    slab = add_box(small, "IfcSlab", "Slab", size_m=(4.0, 3.0, 0.2), corner_m=(0.0, 0.0, 3.0))
    footing = add_box(small, "IfcFooting", "Footing", size_m=(1.0, 1.0, 0.5), corner_m=(0.0, 0.0, -0.5))
    add_material(small, [slab, footing], "C30/37")
    add_pset(small, [slab], "Pset_ConcreteElementGeneral", {"CastingMethod": "INSITU"})
    components = _by_name(_convert(small, tmp_path))
    rates = load_methods().cast_in_place

    cast = components["Slab"]
    assert (cast.method, cast.method_source) == (CAST, MethodSource.IFC)
    assert cast.method_note == "Pset_ConcreteElementGeneral.CastingMethod = INSITU"
    assert cast.cast is not None
    area = 4.0 * 3.0 + 2 * (4.0 + 3.0) * 0.2  # soffit and sides, not the top
    formwork, pour, setup, cure = rates.rates("IfcSlab")
    assert cast.cast.formwork_area_m2 == pytest.approx(area)
    assert cast.cast.volume_m3 == pytest.approx(2.4)
    assert cast.cast.formwork_s == pytest.approx(area / formwork * 3600)
    assert cast.cast.pour_s == pytest.approx((setup + 2.4 / pour) * 3600)
    assert cast.cast.cure_s == pytest.approx(cure * 3600)
    # a footing in the ground, cast by the prefab rule, is cast on the soil: its sides only are formed
    pad = components["Footing"]
    assert (pad.method, pad.method_source, pad.method_note) == (
        CAST,
        MethodSource.RULE,
        "a foundation is cast in place",
    )
    assert pad.cast is not None and pad.cast.formwork_area_m2 == pytest.approx(4 * 1.0 * 0.5)
    assert pad.cast.cure_s == pytest.approx(rates.rates("IfcFooting")[3] * 3600)
    assert components["Slab"].cast != pad.cast


def test_a_poured_underlayment_is_cast_on_the_floor_beneath_it_not_lifted(tmp_path: Path) -> None:
    """The Revit restaurant's "Floor:J_Floor_Concrete_PouredUnderlayment" of "J_Floor_Gyp_Crete", 32 m × 29 m
    and 5 cm thick, was lifted whole (28 t, too heavy for every machine); its material says it is poured:
    cast in place, on the floor beneath it (no soffit form: only its edges)."""
    small = new_model()
    topping = add_box(small, "IfcSlab", "Underlayment", size_m=(8.0, 6.0, 0.05), corner_m=(0.0, 0.0, 3.2))
    add_layers(
        small, [topping], [("J_Floor_Gyp_Crete", 0.05)], name="Floor:J_Floor_Concrete_PouredUnderlayment"
    )
    cast = _by_name(_convert(small, tmp_path))["Underlayment"]
    assert (cast.method, cast.method_source) == (CAST, MethodSource.IFC)
    assert cast.method_note == "material 'J_Floor_Gyp_Crete': poured on the floor beneath"
    assert cast.cast is not None
    assert cast.cast.formwork_area_m2 == pytest.approx(2 * (8.0 + 6.0) * 0.05)  # edges, no soffit
    assert cast.mass_kg == pytest.approx(8.0 * 6.0 * 0.05 * 1650.0)  # gypsum concrete


def test_prefab_panelises_a_heavy_wall_and_casts_a_heavy_concrete_column_with_the_numbers(
    tmp_path: Path,
) -> None:
    small = new_model()
    wall = add_box(small, "IfcWall", "Heavy wall", size_m=(6.0, 0.2, 3.0))  # 8.64 t of concrete
    light = add_box(
        small, "IfcWall", "Light wall", size_m=(1.0, 0.1, 2.0), corner_m=(0.0, 3.0, 0.0)
    )  # 0.48 t
    column = add_box(small, "IfcColumn", "Column", size_m=(0.5, 0.5, 4.0), corner_m=(8.0, 0.0, 0.0))  # 2.4 t
    beam = add_box(
        small, "IfcBeam", "Steel beam", size_m=(15.0, 0.2, 0.3), corner_m=(0.0, 6.0, 3.0)
    )  # too long
    add_material(small, [wall, light, column], "Concrete")
    add_material(small, [beam], "S355 steel", category="steel")
    manifest = _convert(small, tmp_path)
    components = _by_name(manifest)

    # the heavy wall is split into panels, each within the lift: it is listed once, with why
    (heavy,) = manifest.panelised
    assert heavy.guid == wall.GlobalId and heavy.mass_kg == pytest.approx(8640)
    assert heavy.why.startswith("8,640 kg, over the 2,000 kg lift capacity")
    panels = [c for c in manifest.components if c.parent_guid == wall.GlobalId]
    assert len(panels) >= 5 and max(c.mass_kg for c in panels) <= LIFT_KG
    assert {(c.method, c.method_source) for c in panels} == {(PANELISED, MethodSource.RULE)}
    assert (components["Light wall"].method, components["Light wall"].method_source) == (
        LIFTED,
        MethodSource.RULE,
    )
    cast = components["Column"]
    assert (cast.method, cast.method_source) == (CAST, MethodSource.RULE)
    assert (
        "2,400 kg is more than the fleet lifts" in cast.method_note
        and "concrete IfcColumn" in cast.method_note
    )
    # a steel beam longer than a truck: no other method, so lifted, and the note says why it may not be
    long = components["Steel beam"]
    assert long.method is LIFTED
    assert "15.00 × 0.30 × 0.20 m does not fit a truck's load of 13.6 × 2.55 × 3.7 m" in long.method_note


def test_conventional_lays_a_brick_wall_and_casts_concrete_where_prefab_lifts_them(tmp_path: Path) -> None:
    small = new_model()
    brick = add_box(small, "IfcWall", "Brick wall", size_m=(1.0, 0.1, 1.0))
    concrete = add_box(small, "IfcWall", "Concrete wall", size_m=(1.0, 0.1, 1.0), corner_m=(0.0, 2.0, 0.0))
    add_material(small, [brick], "Ladrillo de cerámica hueco doble", category="brick")
    add_material(small, [concrete], "Concrete")
    conventional = _by_name(_convert(small, tmp_path / "conventional", load_methods("conventional")))
    assert (conventional["Brick wall"].method, conventional["Brick wall"].method_note) == (
        LAID,
        "masonry is laid",
    )
    assert conventional["Concrete wall"].method is CAST and conventional["Concrete wall"].cast is not None
    prefab = _by_name(_convert(small, tmp_path / "prefab"))
    assert {prefab["Brick wall"].method, prefab["Concrete wall"].method} == {LIFTED}


def test_conventional_casts_a_slab_of_unknown_material_too_heavy_to_lift_where_prefab_cuts_planks(
    tmp_path: Path,
) -> None:
    """The Revit house's upper floor ("Suelos por defecto", 16.9 × 7.4 × 0.3 m, 90 t as concrete) was cut
    into 8 precast planks by both presets: a site that casts its concrete casts such a slab. A light one of
    unknown material stays lifted, and a wall of unknown material is still panelised."""
    small = new_model()
    add_box(small, "IfcSlab", "Floor", size_m=(6.0, 3.0, 0.2), corner_m=(0.0, 0.0, 3.0))  # 8.6 t (concrete)
    add_box(small, "IfcSlab", "Landing", size_m=(1.0, 1.0, 0.1), corner_m=(8.0, 0.0, 1.5))  # 0.24 t
    add_box(small, "IfcWall", "Wall", size_m=(6.0, 0.2, 3.0), corner_m=(0.0, 5.0, 0.0))  # 3.6 t
    conventional = _by_name(_convert(small, tmp_path / "conventional", load_methods("conventional")))
    floor = conventional["Floor"]
    assert (floor.method, floor.method_source) == (CAST, MethodSource.RULE) and floor.cast is not None
    assert floor.method_note == (
        "8,640 kg is more than the fleet lifts, 2,000 kg (lifter): "
        "an IfcSlab of unknown material, cast in place as concrete instead"
    )
    assert floor.cast.cure_s == 120 * 3600  # a suspended slab's decking
    assert conventional["Landing"].method is LIFTED
    assert "Wall" not in conventional  # listed by its panels
    prefab = _convert(small, tmp_path / "prefab")
    assert {c.method for c in prefab.components if c.parent_guid is not None} == {PANELISED}
    assert {p.name for p in prefab.panelised} == {"Floor", "Wall"}


def test_the_users_file_overrides_the_ifc_and_the_rules_by_global_id_class_and_material(
    tmp_path: Path,
) -> None:
    small = new_model()
    cast = add_box(small, "IfcSlab", "Insitu slab", size_m=(2.0, 2.0, 0.2), corner_m=(0.0, 0.0, 3.0))
    add_pset(small, [cast], "Pset_ConcreteElementGeneral", {"CastingMethod": "INSITU"})
    add_box(small, "IfcWall", "Wall", size_m=(1.0, 0.1, 1.0), corner_m=(3.0, 0.0, 0.0))
    block = add_box(small, "IfcColumn", "Block pier", size_m=(0.3, 0.3, 1.0), corner_m=(5.0, 0.0, 0.0))
    add_material(small, [block], "CMU block")
    methods_file = tmp_path / "mine.toml"
    methods_file.write_text(
        f'[by_guid]\n"{cast.GlobalId}" = "lifted"\n'
        '[by_class]\nIfcWall = "laid"\n'
        '[by_material]\nmasonry = "laid"\n',
        encoding="utf-8",
    )
    components = _by_name(_convert(small, tmp_path, load_methods(methods_file)))
    assert {name: (c.method, c.method_source) for name, c in components.items()} == {
        "Insitu slab": (LIFTED, MethodSource.USER),
        "Wall": (LAID, MethodSource.USER),
        "Block pier": (LAID, MethodSource.USER),
    }
    assert components["Insitu slab"].method_note == f"by GlobalId in {methods_file}"
    assert components["Wall"].method_note == f"by class IfcWall in {methods_file}"
    assert components["Block pier"].method_note == f"by material 'masonry' (masonry) in {methods_file}"


def test_a_slab_in_the_ground_is_cast_and_existing_work_is_in_place(tmp_path: Path) -> None:
    small = new_model()
    add_box(small, "IfcSlab", "Ground slab", size_m=(3.0, 3.0, 0.2), corner_m=(0.0, 0.0, -0.2))
    add_box(small, "IfcSlab", "Floor", size_m=(2.0, 2.0, 0.2), corner_m=(0.0, 0.0, 3.0))
    add_box(
        small,
        "IfcSlab",
        "Base",
        size_m=(2.0, 2.0, 0.5),
        corner_m=(0.0, 4.0, -0.5),
        predefined_type="BASESLAB",
    )
    old = add_box(small, "IfcWall", "Old wall", size_m=(2.0, 0.2, 2.0), corner_m=(5.0, 0.0, 0.0))
    add_pset(small, [old], "Pset_WallCommon", {"Status": ["EXISTING"]})
    manifest = _convert(small, tmp_path)
    components = _by_name(manifest)
    ground = components["Ground slab"]
    assert (ground.method, ground.method_note) == (CAST, "concrete in the ground is cast in place")
    assert components["Floor"].method is LIFTED
    # a slab drawn as a base (a footing, a slab on grade) cures as a footing, not as a floor's decking
    base = components["Base"]
    assert (base.method, base.method_note) == (CAST, "a ground slab is cast in place")
    assert base.cast is not None and ground.cast is not None
    assert base.cast.cure_s == load_methods().cast_in_place.rates("IfcSlab.BASESLAB")[3] * 3600 == 72 * 3600
    # a slab lying in the ground is a ground slab whatever its type says (the Revit house's is a FLOOR)
    assert ground.cast.cure_s == 72 * 3600
    assert components["Floor"].cast is None
    assert [c.name for c in manifest.in_place] == ["Old wall"]
    assert (manifest.in_place[0].method, manifest.in_place[0].method_source) == (
        ConstructionMethod.IN_PLACE,
        MethodSource.IFC,
    )


def test_the_bundled_frame_stays_all_lifted_its_footings_precast_as_its_ifc_says(tmp_path: Path) -> None:
    source = tmp_path / "frame.ifc"
    build_light_steel_frame(2, 1).write(str(source))
    manifest = convert_model(open_model(source), source, tmp_path / "out", ConvertOptions(formats=()))
    assert {c.method for c in manifest.components} == {LIFTED}
    footings = [c for c in manifest.components if c.ifc_class == "IfcFooting"]
    assert [(c.method_source, c.method_note) for c in footings] == [
        (MethodSource.IFC, "Pset_ConcreteElementGeneral.CastingMethod = PRECAST")
    ] * 2


def test_convert_takes_a_preset_or_a_file_counts_by_method_and_names_a_bad_file_in_one_line(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """The preset through ``main`` in this process; the bad file through the real command."""
    small = new_model()
    brick = add_box(small, "IfcWall", "Brick wall", size_m=(1.0, 0.1, 1.0))
    add_material(small, [brick], "Brick")
    add_box(small, "IfcSlab", "Ground slab", size_m=(3.0, 3.0, 0.2), corner_m=(0.0, 2.0, -0.2))
    source = tmp_path / "model.ifc"
    small.file.write(str(source))

    command = ["convert", str(source), "-o", str(tmp_path / "out"), "--no-progress"]
    done = bimbot_in_process(*command, "--methods", "conventional", capfd=capfd, caplog=caplog)
    assert done.returncode == 0, done.stderr
    assert done.stdout.rstrip().endswith("; to be built: 1 cast_in_place, 1 laid"), done.stdout
    bad = tmp_path / "bad.toml"
    bad.write_text('[by_class]\nIfcWall = "glued"\n', encoding="utf-8")
    refused = bimbot_process(*command, "--methods", str(bad))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert refused.stderr.startswith(
        f"bimbot convert: error: methods file {bad}: by_class.IfcWall: Input should be"
    )
    assert len(refused.stderr.strip().splitlines()) == 1


def test_the_panels_of_a_scheduled_wall_take_its_place_in_the_ifc_schedule(
    samples_dir: Path, tmp_path: Path
) -> None:
    source = samples_dir / "construction_scheduling_task.ifc"  # a ground slab, then four block walls in turn
    if not source.is_file():
        pytest.skip(f"{source} is absent")
    options = ConvertOptions(fleet=_fleet(), formats=(), split_ifc=False)
    manifest = convert_model(open_model(source), source, tmp_path / "out", options)
    sequence = read_sequence(tmp_path / "out" / manifest.sequence_file)
    assert (manifest.sequence_source, len(manifest.panelised)) == ("ifc_schedule", 4)
    wall_of = {c.guid: c.parent_guid for c in manifest.components}
    slab, *panels = sequence.tasks
    assert wall_of[slab.guid] is None and slab.name == "Slab #1"
    walls = list(dict.fromkeys(wall_of[task.guid] for task in panels))  # in the order they come
    tasks_of = {wall: [t for t in panels if wall_of[t.guid] == wall] for wall in walls}
    assert [task.name for task in panels] == [
        f"Wall #{i}" for i, w in enumerate(walls, 1) for _ in tasks_of[w]
    ]
    assert [t for wall in walls for t in tasks_of[wall]] == panels  # each wall's panels together
    for earlier, later in itertools.pairwise(walls):  # a wall's panels wait for the one before
        before = {task.task_id for task in tasks_of[earlier]}
        assert all(before <= set(task.predecessors) for task in tasks_of[later])


def test_material_names_in_chinese_and_other_languages_say_the_kind_and_how_it_is_made() -> None:
    """A Chinese Revit model's columns are "混凝土 - 现场浇注混凝土" (concrete - cast-in-place
    concrete): read as lifted concrete, 9 columns and 9 beams went to the machines, not the concrete crew."""
    assert kind_of("混凝土 - 现场浇注混凝土") is MaterialKind.CONCRETE
    assert CAST_IN_PLACE_WORDS.search("混凝土 - 现场浇注混凝土")
    assert kind_of("钢筋混凝土") is MaterialKind.CONCRETE, "rebar (钢筋) in concrete is no steel member"
    assert kind_of("型钢 Q345") is MaterialKind.STEEL and kind_of("Stahl") is MaterialKind.STEEL
    assert kind_of("Stahlbeton") is MaterialKind.CONCRETE, "FZK-Haus: reinforced concrete, not steel"
    assert kind_of("玻璃") is MaterialKind.GLASS and kind_of("粘土砖") is MaterialKind.MASONRY
    assert kind_of("Бетон B25") is MaterialKind.CONCRETE and CAST_IN_PLACE_WORDS.search("монолитный")
    assert PRECAST_WORDS.search("预制混凝土") and not CAST_IN_PLACE_WORDS.search("预制混凝土")
    assert kind_of("默认墙") is MaterialKind.UNKNOWN


def test_concrete_blocks_are_masonry_not_concrete() -> None:
    """The Revit duplex's walls are "Masonry - Concrete Block" and "Concrete Masonry Units": laid on a site,
    not cast; read as concrete, its two brick-on-block walls no panel fits were cast in place."""
    for name in ("Masonry - Concrete Block", "Concrete Masonry Units", "CMU 8in", "Betonstein", "Parpaing"):
        assert kind_of(name) is MaterialKind.MASONRY, name
    for name in ("Concrete, Cast-in-Place gray", "Precast Concrete", "Stahlbeton", "Concrete"):
        assert kind_of(name) is MaterialKind.CONCRETE, name


def test_a_steel_pile_is_driven_and_so_is_a_steel_pile_family_drawn_as_a_slab_in_the_ground(
    tmp_path: Path,
) -> None:
    """The Revit 2025 structural sample draws its 216 steel pipe piles as IfcSlab BASESLAB of "Metal - Steel":
    cast in place by the ground-slab rule, they were steel poured like concrete. A steel or timber pile is
    driven by a piling rig; a concrete one, or a concrete slab in the ground, is still cast; a pile the IFC
    says is prefabricated steel is driven whatever its material."""
    small = new_model()
    boxes = {  # name: class, size, corner, predefined type
        "Pipe pile": ("IfcPile", (0.4, 0.4, 6.0), (0.0, 0.0, -7.2), None),
        "Pile drawn as a slab": ("IfcSlab", (0.4, 0.4, 6.0), (3.0, 0.0, -7.2), "BASESLAB"),
        "Bored pile": ("IfcPile", (0.6, 0.6, 8.0), (6.0, 0.0, -8.0), None),
        "Ground slab": ("IfcSlab", (4.0, 3.0, 0.2), (0.0, 3.0, -0.2), "BASESLAB"),
        "Declared pile": ("IfcPile", (0.3, 0.3, 5.0), (9.0, 0.0, -5.0), None),
    }
    pile, as_slab, bored, ground, declared = (
        add_box(small, ifc_class, name, size_m=size, corner_m=corner, predefined_type=kind)
        for name, (ifc_class, size, corner, kind) in boxes.items()
    )
    declared.ConstructionType = "PREFAB_STEEL"
    add_material(small, [pile, as_slab], "Metal - Steel - 345 MPa", "steel")
    add_material(small, [bored, ground, declared], "Concrete C30/37", "concrete")
    components = _by_name(_convert(small, tmp_path))
    driven = ConstructionMethod.DRIVEN
    assert (components["Pipe pile"].method, components["Pipe pile"].method_note) == (
        driven,
        "a steel or timber pile is driven",
    )
    assert components["Pile drawn as a slab"].method is driven
    assert components["Pile drawn as a slab"].method_source is MethodSource.RULE
    assert components["Bored pile"].method is CAST and components["Ground slab"].method is CAST
    assert (components["Declared pile"].method, components["Declared pile"].method_source) == (
        driven,
        MethodSource.IFC,
    )
    assert components["Declared pile"].method_note == "IfcPile.ConstructionType = PREFAB_STEEL"
