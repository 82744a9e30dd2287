"""sequence.xml: round trip, clear errors for unknown predecessors, duplicates and cycles."""

from __future__ import annotations

import pytest

from bimbot.shared.sequence import (
    ConstructionSequence,
    SequenceError,
    SequenceTask,
    priority_topological_order,
    sequence_from_predecessors,
    sequence_from_xml,
    sequence_to_xml,
)


def test_sequence_round_trips_through_xml() -> None:
    sequence = sequence_from_predecessors(
        ["g1", "g2", "g3"], {"g2": {"g1"}, "g3": {"g1", "g2"}}, source="derived", names={"g1": "Erect A"}
    )
    again = sequence_from_xml(sequence_to_xml(sequence))
    assert again == sequence
    assert again.predecessor_guids() == {"g1": set(), "g2": {"g1"}, "g3": {"g1", "g2"}}


def test_plain_ordered_list_without_predecessors_is_accepted() -> None:
    xml = b'<construction_sequence source="user"><task guid="a"/><task guid="b"/></construction_sequence>'
    sequence = sequence_from_xml(xml)
    assert sequence.guids() == ["a", "b"]
    assert not sequence.has_explicit_predecessors


def test_unknown_predecessor_is_named_in_the_error() -> None:
    xml = (
        b'<construction_sequence><task id="T1" guid="a"><predecessor task="T9"/></task>'
        b"</construction_sequence>"
    )
    with pytest.raises(SequenceError, match=r"T1.*unknown predecessor.*T9"):
        sequence_from_xml(xml)


def test_cycle_is_reported_with_its_tasks() -> None:
    xml = (
        b'<construction_sequence><task id="T1" guid="a"><predecessor task="T2"/></task>'
        b'<task id="T2" guid="b"><predecessor task="T1"/></task></construction_sequence>'
    )
    with pytest.raises(SequenceError, match=r"cycle.*T[12].*T[12]"):
        sequence_from_xml(xml)


def test_component_with_two_tasks_is_refused() -> None:
    xml = b'<construction_sequence><task guid="a"/><task guid="a"/></construction_sequence>'
    with pytest.raises(SequenceError, match="two tasks"):
        sequence_from_xml(xml)


@pytest.mark.parametrize(
    "data", [b"<not closed", b"<other/>", b'<construction_sequence schema_version="7"/>']
)
def test_malformed_documents_get_a_clear_error(data: bytes) -> None:
    with pytest.raises(SequenceError, match="origin-name"):
        sequence_from_xml(data, origin="origin-name")


def test_priority_order_respects_predecessors_and_breaks_ties_by_key() -> None:
    preds = {"c": {"a"}, "b": set(), "a": set(), "d": {"b", "c"}}
    assert priority_topological_order(preds, key=lambda item: item) == ["a", "b", "c", "d"]
    assert priority_topological_order(preds, key=lambda item: -ord(item)) == ["b", "a", "c", "d"]


def test_task_model_is_frozen() -> None:
    task = SequenceTask(task_id="T1", guid="a")
    with pytest.raises(ValueError, match="frozen"):
        task.guid = "b"  # type: ignore[misc]
    assert ConstructionSequence(source="x", tasks=(task,)).guids() == ["a"]


def test_an_ifc_given_as_a_sequence_says_to_give_it_as_from_ifc() -> None:
    with pytest.raises(SequenceError, match=r"an IFC model, not a sequence: .* give it as --from-ifc m\.ifc"):
        sequence_from_xml(b"ISO-10303-21;\nHEADER;\n", origin="m.ifc")
