"""Sequence sources: the build's sequence.xml, a hand-written XML, the IFC 4D schedule, the support graph."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from bimbot.services.planner.sources import Plan, PlanError, PlanSource, SourceKind, load_plan
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.support_graph import support_predecessors, support_violations

SLAB = "20WrgxqpbDtferON_k1P2X"
WALLS = [
    "26tmERtwL8G8UQn5BoglEh",
    "2qqyx9mIf27vQuEGt7ts8$",
    "0edwXkNgP03AySQjQQlat2",
    "27D5wuD5z86hr07xvbZLKW",
]


def _write_xml(path: Path, guids: list[str], preds: dict[int, list[int]] | None = None) -> Path:
    """A sequence XML with tasks T1… naming ``guids``; ``preds`` maps task index → predecessor indices."""
    lines = ['<construction_sequence schema_version="1" source="user">']
    for index, guid in enumerate(guids):
        inner = "".join(f'<predecessor task="T{pred}"/>' for pred in (preds or {}).get(index, []))
        lines.append(f'  <task id="T{index}" guid="{guid}">{inner}</task>')
    lines.append("</construction_sequence>")
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _by_class(manifest: Manifest, ifc_class: str) -> list[str]:
    return [item.guid for item in manifest.components if item.ifc_class == ifc_class]


def _assert_complete_and_supported(plan: Plan, manifest: Manifest) -> None:
    assert sorted(plan.order) == sorted(item.guid for item in manifest.components)
    assert len(plan.order) == 28
    assert support_violations(plan.order, support_predecessors(manifest.components)) == []
    assert plan.violations == ()
    assert set(plan.predecessors) == set(plan.order)
    position = {guid: index for index, guid in enumerate(plan.order)}
    for guid, preds in plan.predecessors.items():
        assert all(position[pred] < position[guid] for pred in preds), guid


def test_build_sequence_xml_plans_all_28_components_in_support_order(frame_build: Path) -> None:
    manifest = read_manifest(frame_build)
    plan = load_plan(manifest, frame_build, PlanSource())
    _assert_complete_and_supported(plan, manifest)
    assert plan.explicit
    assert plan.warnings == ()
    assert "sequence.xml" in plan.source
    assert len(set(plan.task_ids.values())) == 28


def test_hand_written_plain_list_uses_the_support_graph_as_its_dag(frame_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(frame_build)
    guids = [item.guid for item in manifest.components]
    plan = load_plan(
        manifest, frame_build, PlanSource(SourceKind.SEQUENCE, _write_xml(tmp_path / "s.xml", guids))
    )
    _assert_complete_and_supported(plan, manifest)
    assert not plan.explicit
    assert plan.order == tuple(guids)  # the list order is the release priority
    support = support_predecessors(manifest.components)
    assert plan.predecessors == {guid: frozenset(support[guid]) for guid in guids}
    assert plan.task_ids[guids[0]] == "T0"


def test_ifc_schedule_of_the_bundled_model_plans_all_28_components(frame_build: Path) -> None:
    manifest = read_manifest(frame_build)
    plan = load_plan(manifest, frame_build, PlanSource(SourceKind.IFC))  # the build's source IFC
    _assert_complete_and_supported(plan, manifest)
    assert plan.source.startswith("IFC schedule")
    assert plan.order == tuple(load_plan(manifest, frame_build, PlanSource()).order)


def test_derived_plan_releases_every_footing_first_and_waits_for_supports(frame_build: Path) -> None:
    manifest = read_manifest(frame_build)
    plan = load_plan(manifest, frame_build, PlanSource(SourceKind.DERIVE))
    _assert_complete_and_supported(plan, manifest)
    footings = _by_class(manifest, "IfcFooting")
    assert len(footings) == 9
    assert set(plan.order[:9]) == set(footings)
    assert {guid for guid, preds in plan.predecessors.items() if not preds} == set(footings)
    for column in _by_class(manifest, "IfcColumn"):
        assert plan.predecessors[column] & set(footings)


def test_ifc_schedule_of_construction_scheduling_task_follows_its_rel_sequence(
    scheduling_build: tuple[Path, Path],
) -> None:
    build, source = scheduling_build
    manifest = read_manifest(build)
    plan = load_plan(manifest, build, PlanSource(SourceKind.IFC, source))
    assert plan.order == (SLAB, *WALLS)
    assert plan.explicit
    assert plan.predecessors == {
        SLAB: frozenset(),
        WALLS[0]: frozenset({SLAB}),
        WALLS[1]: frozenset({SLAB, WALLS[0]}),
        WALLS[2]: frozenset({SLAB, WALLS[1]}),
        WALLS[3]: frozenset({SLAB, WALLS[2]}),
    }
    assert plan.names[WALLS[1]] == "Wall #2"
    assert plan.violations == ()


def test_ifc_without_a_schedule_for_the_build_is_a_clear_error(frame_build: Path, samples_dir: Path) -> None:
    manifest = read_manifest(frame_build)
    other = samples_dir / "slab-standard-case.ifc"
    with pytest.raises(PlanError, match="no IfcTask"):
        load_plan(manifest, frame_build, PlanSource(SourceKind.IFC, other))


def test_sequence_naming_unknown_guids_is_a_one_line_error_naming_them(
    frame_build: Path, tmp_path: Path
) -> None:
    manifest = read_manifest(frame_build)
    guids = [manifest.components[0].guid, "0000000000000000000000", "3zzzzzzzzzzzzzzzzzzzzz"]
    with pytest.raises(UserError) as caught:
        load_plan(
            manifest, frame_build, PlanSource(SourceKind.SEQUENCE, _write_xml(tmp_path / "u.xml", guids))
        )
    message = str(caught.value)
    assert "0000000000000000000000" in message and "3zzzzzzzzzzzzzzzzzzzzz" in message
    assert "not in the build" in message and "\n" not in message


def test_sequence_with_a_cycle_is_a_clear_error_naming_its_tasks(frame_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(frame_build)
    guids = [item.guid for item in manifest.components[:3]]
    path = _write_xml(tmp_path / "c.xml", guids, {0: [2], 1: [0], 2: [1]})
    with pytest.raises(PlanError, match=r"cycle.*T\d.*T\d.*T\d"):
        load_plan(manifest, frame_build, PlanSource(SourceKind.SEQUENCE, path))


def test_missing_sequence_file_is_a_clear_error(frame_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(frame_build)
    with pytest.raises(PlanError, match="no such sequence file"):
        load_plan(manifest, frame_build, PlanSource(SourceKind.SEQUENCE, tmp_path / "absent.xml"))


def test_component_sequenced_before_its_support_is_a_warning_naming_both_guids(
    frame_build: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    manifest = read_manifest(frame_build)
    column = _by_class(manifest, "IfcColumn")[0]
    footing = next(iter(support_predecessors(manifest.components)[column]))
    rest = [item.guid for item in manifest.components if item.guid not in (column, footing)]
    path = _write_xml(tmp_path / "v.xml", [column, footing, *rest])
    with caplog.at_level(logging.WARNING, logger="bimbot.services.planner.sources"):
        plan = load_plan(manifest, frame_build, PlanSource(SourceKind.SEQUENCE, path))
    assert plan.violations == ((column, footing),)
    texts = [warning for warning in plan.warnings if column in warning and footing in warning]
    assert len(texts) == 1 and "before" in texts[0]
    assert any(column in record.getMessage() and footing in record.getMessage() for record in caplog.records)
    assert plan.predecessors[column] == {footing}  # the plain list still waits for the support


def test_explicit_predecessors_that_skip_a_support_are_reported(frame_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(frame_build)
    column = _by_class(manifest, "IfcColumn")[0]
    footing = next(iter(support_predecessors(manifest.components)[column]))
    others = [item.guid for item in manifest.components if item.guid not in (column, footing)]
    # footing listed first, but the column's only predecessor is some other component
    path = _write_xml(tmp_path / "d.xml", [footing, others[0], column, *others[1:]], {2: [1]})
    plan = load_plan(manifest, frame_build, PlanSource(SourceKind.SEQUENCE, path))
    assert (column, footing) in plan.violations
    assert any(column in text and footing in text and "wait" in text for text in plan.warnings)


def test_components_missing_from_the_sequence_are_appended_with_a_warning(
    frame_build: Path, tmp_path: Path
) -> None:
    manifest = read_manifest(frame_build)
    footings = _by_class(manifest, "IfcFooting")
    plan = load_plan(
        manifest, frame_build, PlanSource(SourceKind.SEQUENCE, _write_xml(tmp_path / "f.xml", footings))
    )
    _assert_complete_and_supported(plan, manifest)
    assert plan.order[:9] == tuple(footings)
    assert any("19 component(s)" in warning and "appended" in warning for warning in plan.warnings)
    support = support_predecessors(manifest.components)
    assert all(plan.predecessors[guid] == support[guid] for guid in plan.order[9:])
    assert len(set(plan.task_ids.values())) == 28
