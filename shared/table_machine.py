"""A state table as data, and the one ``transitions`` machine that interprets it (component agents, robots).

A table is a sequence of rows, each either a ``{"trigger", "source", "dest"}`` dict (``source`` one state or
a list of states) or a ``(trigger, source, dest)`` tuple, over the members of one :class:`enum.Enum`. The
pure functions (:func:`edges`, :func:`next_state`, :func:`triggers_from`, :func:`reachable_from`) read the
table itself, so tests check it without a machine; :class:`TableMachine` runs it with ``transitions``.

Why the machine is used this way (public ``transitions`` 0.9.3 API only):

* ``Machine(model=None, …, auto_transitions=False, ignore_invalid_triggers=False)``: one machine per table
  per process, shared by all its models; no ``to_<state>`` triggers, and a trigger the table forbids raises
  ``MachineError``, which :meth:`TableMachine.fire` turns into ``False`` with the model unchanged.
* Models are never registered with ``add_model``: a model is any object with a writable state attribute
  (``__slots__`` are fine), put in its initial state by :meth:`TableMachine.start`, and triggered through
  the public ``machine.events[trigger].trigger(model)`` (what a bound ``model.<trigger>()`` calls).
  ``add_model`` would bind ~36 convenience partials onto each model and test membership in a plain list,
  which makes registration quadratic. Registering 10,000 models on one machine (2-core reference
  machine): stock ``add_model`` 3.6 s and 10 KB per model; ``model_override=True`` 7.2 s (it logs a
  skipped-binding warning per name and model); the former subclass that overrode the private
  ``_checked_assignment`` and replaced ``Machine.models`` 1.3 s; without registration 0.02 s and nothing per
  model. A trigger costs ~6 µs in every case. 10,000 whole agents are built in 0.1 s (1.35 s before).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence
from enum import Enum
from typing import Any

from transitions import Machine, MachineError

Row = Mapping[str, Any] | tuple[str, Any, Any]
Edge = tuple[str, Any, Any]


def _row_dict(row: Row) -> dict[str, Any]:
    if isinstance(row, Mapping):
        return dict(row)
    trigger, source, dest = row
    return {"trigger": trigger, "source": source, "dest": dest}


def edges(table: Sequence[Row]) -> list[Edge]:
    """The table flattened to ``(trigger, source, dest)`` triples, one per source state."""
    flat: list[Edge] = []
    for row in map(_row_dict, table):
        sources = row["source"] if isinstance(row["source"], list | tuple) else [row["source"]]
        flat.extend((str(row["trigger"]), source, row["dest"]) for source in sources)
    return flat


def next_state(table: Sequence[Row], state: Enum, trigger: str) -> Any | None:
    """Where ``trigger`` leads from ``state``, or None when the table does not allow it."""
    for name, source, dest in edges(table):
        if name == trigger and source == state:
            return dest
    return None


def triggers_from(table: Sequence[Row], state: Enum) -> set[str]:
    """The triggers the table accepts in ``state``."""
    return {name for name, source, _ in edges(table) if source == state}


def reachable_from(table: Sequence[Row], start: Enum) -> set[Any]:
    """Every state some sequence of triggers reaches from ``start`` (``start`` included)."""
    seen = {start}
    todo = deque([start])
    flat = edges(table)
    while todo:
        state = todo.popleft()
        for _, source, dest in flat:
            if source == state and dest not in seen:
                seen.add(dest)
                todo.append(dest)
    return seen


class TableMachine:
    """One ``transitions`` machine built from a table, shared by any number of models (see module doc)."""

    def __init__(
        self,
        states: type[Enum],
        table: Sequence[Row],
        initial: Enum,
        model_attribute: str = "state",
    ) -> None:
        rows = [{**row, "trigger": str(row["trigger"])} for row in map(_row_dict, table)]
        self.initial = initial
        self.machine = Machine(
            model=None,
            states=states,
            transitions=rows,
            initial=initial,
            auto_transitions=False,
            ignore_invalid_triggers=False,
            model_attribute=model_attribute,
        )

    def start(self, model: object, state: Enum | None = None) -> None:
        """Put ``model`` in ``state`` (default: the table's initial state) without a transition."""
        self.machine.set_state(self.initial if state is None else state, model=model)

    def may_fire(self, model: object, trigger: str) -> bool:
        """True when the table allows ``trigger`` in the model's current state."""
        return str(trigger) in self.machine.get_triggers(self.machine.get_model_state(model))

    def fire(self, model: object, trigger: str) -> bool:
        """Apply ``trigger`` to ``model``; False (and the model unchanged) when the table forbids it."""
        event = self.machine.events.get(str(trigger))
        if event is None:
            return False
        try:
            return bool(event.trigger(model))
        except MachineError:
            return False
