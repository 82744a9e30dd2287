"""``bimbot convert``'s summary line adds up: the elements the progress line counted become the components
it counts (a panelised wall is one element and several components), and its clash count is the warning's.

Read from the Revit house sample's conversion of this test run (tests/sample_builds.py): 58 elements to
convert, two walls of them cut into panels, 46 left out by the class selection.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from sample_builds import converted_sample, sample_conversion_ended

from bimbot.services.converter.summary_line import clash_summary, elements_summary
from bimbot.shared.manifest import Clash, SkippedElement

HOUSE = "revit2021_sample_project.ifc"


def test_the_elements_converted_add_up_to_the_progress_lines_count(
    samples_dir: Path, tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    from bimbot.services.converter.convert import convert_model
    from bimbot.shared.ifc_input import open_model

    totals: set[int] = set()  # what "N IFC elements to convert" says
    convert_model(
        open_model(samples_dir / HOUSE),
        samples_dir / HOUSE,
        tmp_path / "build",
        progress=lambda stage, done, total: totals.add(total) if stage == "convert" else None,
    )
    ended = sample_conversion_ended(HOUSE, tmp_path_factory)
    _, manifest = converted_sample(HOUSE, tmp_path_factory)
    said = re.search(r"converted (\d+) component\(s\) from (\d+) IFC element\(s\) \(([^)]*)\)", ended.stdout)
    assert said is not None, ended.stdout
    components, elements, parts = int(said[1]), int(said[2]), said[3]
    assert totals == {elements} and components == len(manifest.components) > elements
    counted = [int(n) for n in re.findall(r"(\d+) (?:as one component each|cut into)", parts)]
    assert sum(counted) == elements  # each element said once: whole, or cut into panels
    panels = sum(1 for c in manifest.components if c.parent_guid is not None)
    assert f"cut into {panels} panels in all" in parts and panels > 0


def test_each_element_as_one_component_says_nothing_more(
    samples_dir: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    _, manifest = converted_sample(HOUSE, tmp_path_factory)
    whole = manifest.model_copy(
        update={"components": [c for c in manifest.components if c.parent_guid is None], "panelised": []}
    )
    assert elements_summary(whole) == ""
    assert elements_summary(manifest).startswith(" from 58 IFC element(s) (")
    # an element read but not converted counts among those read (the restaurant's 7 drawn twice and 2
    # without triangles made its 742 of the 751 it read); one the selection left out does not
    twice = SkippedElement(guid="x", ifc_class="IfcWall", reason="the model draws it twice: the same as y")
    mixed = manifest.model_copy(update={"skipped": [*manifest.skipped, twice]})
    assert elements_summary(mixed).startswith(" from 59 IFC element(s) (")
    assert "1 not converted (skipped, below)" in elements_summary(mixed)
    assert any(item.reason.startswith("not a building element") for item in manifest.skipped)


def test_the_clash_count_leaves_the_pairs_in_place_apart(
    samples_dir: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    _, manifest = converted_sample(HOUSE, tmp_path_factory)
    built, other = manifest.components[0].guid, manifest.components[1].guid
    in_place = manifest.components[2:4]
    clashes = [
        Clash(guids=(built, other), depth_m=0.3),
        Clash(guids=(in_place[0].guid, in_place[1].guid), depth_m=0.2),
        Clash(guids=(built, in_place[0].guid), depth_m=0.1),
    ]
    mixed = manifest.model_copy(update={"clashes": clashes, "in_place": in_place})
    assert clash_summary(mixed) == "2 clash(es) (1 more between two parts in place)"
    assert clash_summary(manifest.model_copy(update={"clashes": clashes[:1]})) == "1 clash(es)"
