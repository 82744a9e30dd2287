"""The methods file: the presets load, a user's file is laid over its preset, a bad one is one line."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.errors import InputError
from bimbot.shared.methods_file import PRESETS, MaterialKind, load_methods, preset_text


@pytest.mark.parametrize("name", ["prefab", "conventional"])
def test_each_builders_preset_loads_with_rules_rates_and_transport(name: str) -> None:
    methods = load_methods(name)
    assert methods.name == name
    # steel and timber piles driven, then foundations cast, in both
    assert [rule.method for rule in methods.rules[:3]] == [
        ConstructionMethod.DRIVEN,
        ConstructionMethod.DRIVEN,
        ConstructionMethod.CAST_IN_PLACE,
    ]
    assert "IfcPile" in methods.rules[0].classes and "IfcFooting" in methods.rules[2].classes
    assert methods.transport.length_m == 13.6
    formwork, pour, setup, cure = methods.cast_in_place.rates("IfcSlab")
    assert (formwork, cure) == (1.8, 120.0)  # slab soffits, and the floor cycle
    assert (pour, setup) == (methods.cast_in_place.pour_m3_per_h, methods.cast_in_place.pour_setup_h)


def test_the_default_is_prefab_and_conventional_casts_concrete_and_lays_masonry() -> None:
    assert load_methods(None).name == "prefab"
    conventional = {
        rule.materials: rule.method for rule in load_methods("conventional").rules if rule.materials
    }
    assert conventional[(MaterialKind.CONCRETE,)] is ConstructionMethod.CAST_IN_PLACE
    assert conventional[(MaterialKind.MASONRY,)] is ConstructionMethod.LAID


def test_the_papers_preset_lifts_everything_whatever_it_weighs_or_the_ifc_says() -> None:
    lifted = load_methods("lifted")
    assert (lifted.ifc, lifted.existing_in_place, lifted.rules, lifted.default) == (
        False,
        False,
        (),
        ConstructionMethod.LIFTED,
    )
    assert (lifted.panels.classes, lifted.panels.cast_when_too_heavy) == ((), ())


def test_the_printed_preset_is_a_complete_file_that_loads_back_the_same(tmp_path: Path) -> None:
    for name in PRESETS:
        path = tmp_path / f"{name}.toml"
        path.write_text(preset_text(name), encoding="utf-8")
        assert load_methods(path).model_dump() == load_methods(name).model_dump()


def test_a_users_file_changes_only_what_it_names_over_its_preset(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(
        'preset = "conventional"\n'
        '[by_class]\nIfcWall = "laid"\n'
        "[cast_in_place.by_class.IfcSlab]\ncure_h = 48\n",
        encoding="utf-8",
    )
    mine, base = load_methods(path), load_methods("conventional")
    assert mine.by_class == {"IfcWall": ConstructionMethod.LAID}
    assert mine.rules == base.rules
    assert mine.cast_in_place.rates("IfcSlab")[3] == 48.0
    assert mine.cast_in_place.rates("IfcSlab")[0] == base.cast_in_place.rates("IfcSlab")[0]
    assert mine.source == str(path)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ('[by_class]\nIfcWall = "glued"\n', "by_class.IfcWall"),
        ('[by_class]\nWall = "laid"\n', "by_class"),
        ('[by_material]\n"bri(ck" = "laid"\n', "by_material"),
        ("[transport]\nlength_m = -1\n", "transport.length_m"),
        ("[cast_in_place]\npour_m3_per_h = 0\n", "cast_in_place.pour_m3_per_h"),
        ('preset = "modular"\n', "preset"),
        ("speed = 3\n", "speed"),
        ('[[rules]]\nmethod = "lifted"\nmaterials = ["cheese"]\n', "rules.0.materials.0"),
    ],
)
def test_a_bad_methods_file_is_one_line_naming_the_file_and_the_field(
    tmp_path: Path, text: str, field: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as caught:
        load_methods(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"methods file {path}: {field}")


def test_a_missing_or_broken_file_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"^methods file .*nope.toml does not exist \(presets: prefab"):
        load_methods(tmp_path / "nope.toml")
    broken = tmp_path / "broken.toml"
    broken.write_text("[by_class\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"^methods file .*broken.toml: not valid TOML"):
        load_methods(broken)


def test_bimbot_methods_show_prints_the_preset_as_toml() -> None:
    shown = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "methods", "show", "--preset", "conventional"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert shown == preset_text("conventional")
    assert tomllib.loads(shown)["name"] == "conventional"
