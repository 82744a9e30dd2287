"""The one interpreter of state tables: a shared ``transitions`` machine used through its public API."""

from __future__ import annotations

import logging
from enum import StrEnum

import pytest

from bimbot.shared.table_machine import TableMachine, edges, next_state, reachable_from, triggers_from


class Door(StrEnum):
    CLOSED = "closed"
    OPEN = "open"
    LOCKED = "locked"


TABLE = (
    ("open", Door.CLOSED, Door.OPEN),
    {"trigger": "close", "source": Door.OPEN, "dest": Door.CLOSED},
    {"trigger": "lock", "source": [Door.CLOSED], "dest": Door.LOCKED},
)


class Slotted:
    __slots__ = ("state",)


class Plain:
    pass


def test_tuple_and_dict_rows_flatten_to_the_same_edges() -> None:
    assert edges(TABLE) == [
        ("open", Door.CLOSED, Door.OPEN),
        ("close", Door.OPEN, Door.CLOSED),
        ("lock", Door.CLOSED, Door.LOCKED),
    ]
    assert next_state(TABLE, Door.CLOSED, "lock") is Door.LOCKED
    assert next_state(TABLE, Door.OPEN, "lock") is None
    assert triggers_from(TABLE, Door.CLOSED) == {"open", "lock"}
    assert reachable_from(TABLE, Door.OPEN) == set(Door)
    assert reachable_from(TABLE, Door.LOCKED) == {Door.LOCKED}


def test_the_machine_runs_exactly_the_table_on_slotted_models() -> None:
    machine = TableMachine(Door, TABLE, Door.CLOSED)
    door = Slotted()
    machine.start(door)
    assert door.state is Door.CLOSED
    assert machine.fire(door, "open") and door.state is Door.OPEN
    assert not machine.fire(door, "lock") and door.state is Door.OPEN  # forbidden here: refused
    assert not machine.fire(door, "kick") and door.state is Door.OPEN  # unknown: refused
    assert machine.may_fire(door, "close") and not machine.may_fire(door, "open")


def test_models_get_no_bound_methods_and_are_not_registered(caplog: pytest.LogCaptureFixture) -> None:
    """What the scale of the agents relies on: nothing per model inside the machine or on the model, and no
    warning per model (``model_override`` would log one per skipped name)."""
    machine = TableMachine(Door, TABLE, Door.CLOSED)
    doors = [Plain() for _ in range(3)]
    with caplog.at_level(logging.DEBUG, logger="transitions"):
        for door in doors:
            machine.start(door)
        assert machine.fire(doors[1], "open")
    assert [vars(door) for door in doors] == [{"state": s} for s in (Door.CLOSED, Door.OPEN, Door.CLOSED)]
    assert machine.machine.models == []
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_no_auto_transitions_and_a_custom_state_attribute() -> None:
    machine = TableMachine(Door, TABLE, Door.CLOSED, model_attribute="door_state")
    assert set(machine.machine.events) == {"open", "close", "lock"}
    door = Plain()
    machine.start(door)
    assert machine.fire(door, "lock") and door.door_state is Door.LOCKED
