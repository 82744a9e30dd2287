"""A smart component's state table, as data (paper Fig. 12 with a failure path; docs/architecture.md).

The table is what the ``transitions`` machine is built from and what the tests check on their own, so it is
a plain tuple of ``{"trigger", "source", "dest"}`` dicts over :class:`bimbot.shared.messages.ComponentState`.

Two kinds of trigger:

* **external** — the :class:`bimbot.shared.messages.ComponentEvent` values the planner and robots send on
  ``components/<key>/event``: release, pick, attach, arrive, place, retry, abandon;
* **internal** — the agent's own verification verdict after a placement (:class:`Verdict`): verified,
  misplaced_placement, failed_placement. They are never accepted from the bus.

Choices:

* ``place`` is accepted from ``assembling`` only, not from ``transporting``. A robot that places without
  saying ``arrive`` has broken the protocol; since Zenoh keeps the order of one sender's messages on one key,
  a ``place`` can only precede its ``arrive`` when the ``arrive`` was lost, and the sender repeats it (at
  least once delivery) before it repeats ``place``. Being strict keeps a robot's progress observable.
* ``abandon`` (robot lost) is accepted while a robot holds the component (picking, transporting,
  assembling). Once placed (verifying) the component judges itself whatever happened to the robot.
* ``fail`` (the planner: the component cannot be built, e.g. too heavy for every robot, or given back by
  robots too often) is accepted while no robot holds it (planned, released, misplaced); ``block`` (a
  predecessor failed) while it was never picked (planned, released). Both carry a reason.
* ``constructed``, ``failed`` and ``blocked`` are terminal: nothing leaves them, so nothing is constructed
  twice.

Performance: :class:`ComponentMachine` is the table as one ``transitions`` machine shared by every agent
of a process (``add_model``). Measured for 10,000 agents on the 2-core reference machine: one ``Machine``
per agent costs 7.8 s and 22 KB per agent; one shared machine with stock ``add_model`` 3.3 s and 9 KB (31
bound convenience methods per model, and a list membership test that makes registration quadratic); the
shared :class:`ComponentMachine` below 0.3 s and ~0.2 KB. Agents call
``machine.events[trigger].trigger(agent)``, which is what the bound methods would do (~9 µs per trigger).
"""

from __future__ import annotations

from collections import deque
from enum import StrEnum

from transitions import Machine, MachineError

from bimbot.shared.messages import ComponentEvent, ComponentState

STATES = ComponentState
INITIAL = ComponentState.PLANNED


class Verdict(StrEnum):
    """Internal triggers: the agent's decision after checking its own placement."""

    VERIFIED = "verified"  # within tolerances → constructed
    MISPLACED = "misplaced_placement"  # out of tolerance, attempts left → misplaced (the planner retries)
    FAILED = "failed_placement"  # out of tolerance, no attempts left → failed (reported)


_S = ComponentState
_E = ComponentEvent

TRANSITIONS: tuple[dict, ...] = (
    {"trigger": _E.RELEASE.value, "source": _S.PLANNED, "dest": _S.RELEASED},
    {"trigger": _E.PICK.value, "source": _S.RELEASED, "dest": _S.PICKING},
    {"trigger": _E.ATTACH.value, "source": _S.PICKING, "dest": _S.TRANSPORTING},
    {"trigger": _E.ARRIVE.value, "source": _S.TRANSPORTING, "dest": _S.ASSEMBLING},
    {"trigger": _E.PLACE.value, "source": _S.ASSEMBLING, "dest": _S.VERIFYING},
    {"trigger": _E.RETRY.value, "source": _S.MISPLACED, "dest": _S.RELEASED},
    {
        "trigger": _E.ABANDON.value,
        "source": [_S.PICKING, _S.TRANSPORTING, _S.ASSEMBLING],
        "dest": _S.RELEASED,
    },
    {"trigger": _E.FAIL.value, "source": [_S.PLANNED, _S.RELEASED, _S.MISPLACED], "dest": _S.FAILED},
    {"trigger": _E.BLOCK.value, "source": [_S.PLANNED, _S.RELEASED], "dest": _S.BLOCKED},
    {"trigger": Verdict.VERIFIED.value, "source": _S.VERIFYING, "dest": _S.CONSTRUCTED},
    {"trigger": Verdict.MISPLACED.value, "source": _S.VERIFYING, "dest": _S.MISPLACED},
    {"trigger": Verdict.FAILED.value, "source": _S.VERIFYING, "dest": _S.FAILED},
)

EXTERNAL_TRIGGERS: frozenset[str] = frozenset(event.value for event in ComponentEvent)
INTERNAL_TRIGGERS: frozenset[str] = frozenset(verdict.value for verdict in Verdict)
TERMINAL: frozenset[ComponentState] = frozenset(
    {ComponentState.CONSTRUCTED, ComponentState.FAILED, ComponentState.BLOCKED}
)


def _sources(row: dict) -> list[ComponentState]:
    source = row["source"]
    return list(source) if isinstance(source, list | tuple) else [source]


def edges() -> list[tuple[str, ComponentState, ComponentState]]:
    """The table flattened to ``(trigger, source, dest)`` triples."""
    return [(row["trigger"], source, row["dest"]) for row in TRANSITIONS for source in _sources(row)]


def next_state(state: ComponentState, trigger: str) -> ComponentState | None:
    """Where ``trigger`` leads from ``state``, or None when the table does not allow it."""
    for name, source, dest in edges():
        if name == trigger and source == state:
            return dest
    return None


def triggers_from(state: ComponentState) -> set[str]:
    """The triggers the table accepts in ``state``."""
    return {name for name, source, _ in edges() if source == state}


def reachable_from(start: ComponentState = INITIAL) -> set[ComponentState]:
    """Every state some sequence of triggers reaches from ``start`` (``start`` included)."""
    seen = {start}
    todo = deque([start])
    while todo:
        state = todo.popleft()
        for _, source, dest in edges():
            if source == state and dest not in seen:
                seen.add(dest)
                todo.append(dest)
    return seen


class _ModelRegistry(list):
    """``Machine.models`` with an O(1) identity membership test (the stock list makes add_model O(n))."""

    def __init__(self) -> None:
        super().__init__()
        self._ids: set[int] = set()

    def __contains__(self, model: object) -> bool:
        return id(model) in self._ids

    def append(self, model: object) -> None:
        self._ids.add(id(model))
        super().append(model)

    def remove(self, model: object) -> None:
        self._ids.discard(id(model))
        super().remove(model)


class ComponentMachine(Machine):
    """The component state table as one ``transitions`` machine, shared by many agents (``add_model``).

    Enum states, ``auto_transitions=False``, ``ignore_invalid_triggers=False`` (an illegal trigger raises
    ``MachineError``, which the agent turns into a logged rejection). It binds no convenience methods onto
    its models: agents trigger through ``machine.events[name].trigger(agent)``.
    """

    def __init__(self) -> None:
        super().__init__(
            model=[],
            states=STATES,
            transitions=list(TRANSITIONS),
            initial=INITIAL,
            auto_transitions=False,
            ignore_invalid_triggers=False,
        )
        self.models = _ModelRegistry()

    def _checked_assignment(self, model: object, name: str, func: object) -> None:
        """Bind nothing onto models (31 partials per agent otherwise)."""
        return None

    def fire(self, model: object, trigger: str) -> bool:
        """Apply ``trigger`` to ``model``; False (and the model unchanged) when the table forbids it."""
        try:
            return bool(self.events[trigger].trigger(model))
        except MachineError:
            return False
