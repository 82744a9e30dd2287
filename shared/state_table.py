"""A smart component's state table, as data (paper Fig. 12 with a failure path; docs/architecture.md).

The table is what the ``transitions`` machine is built from and what the tests check on their own, so it is
a plain tuple of ``{"trigger", "source", "dest"}`` dicts over :class:`bimbot.shared.messages.ComponentState`.

Two kinds of trigger:

* **external** — the :class:`bimbot.shared.messages.ComponentEvent` values the planner and robots send on
  ``components/<key>/event``: release, pick, attach, arrive, place, retry, abandon, hand_off, fail, block,
  form, pour, lay, drive;
* **internal** — the agent's own verification verdict after a placement (:class:`Verdict`): verified,
  misplaced_placement, failed_placement. They are never accepted from the bus.

Choices:

* ``place`` is accepted from ``assembling`` only, not from ``transporting``. A robot that places without
  saying ``arrive`` has broken the protocol; since Zenoh keeps the order of one sender's messages on one key,
  a ``place`` can only precede its ``arrive`` when the ``arrive`` was lost, and the sender repeats it (at
  least once delivery) before it repeats ``place``. Being strict keeps a robot's progress observable.
* Work in place has its own path from ``released``: a cast-in-place component goes ``form`` → ``forming``,
  ``pour`` → ``pouring``, a laid one ``lay`` → ``laying``, a driven pile ``drive`` → ``driving``; ``place``
  (it stands, poured, laid or driven) leads from each to ``verifying`` like a placement, so the agent
  verifies every component the same way.
* ``hand_off`` (a robot's hand-off task: it carried the component to a crane's staging spot and put it
  down there) is accepted from ``transporting``: the component is released again, now within the crane's
  reach, and the planner assigns its build task.
* ``abandon`` (robot lost) is accepted while a robot holds the component (picking, transporting,
  assembling) or works on it in place (forming, pouring, laying, driving). Once placed (verifying) the
  component judges itself whatever happened to the robot.
* ``fail`` (the planner: the component cannot be built, e.g. too heavy for every robot, or given back by
  robots too often) is accepted while no robot holds it (planned, released, misplaced); ``block`` (a
  predecessor failed) while it was never picked (planned, released). Both carry a reason.
* ``constructed``, ``failed`` and ``blocked`` are terminal: nothing leaves them, so nothing is constructed
  twice.

The table is interpreted by :class:`bimbot.shared.table_machine.TableMachine`, the same mechanism as the
robot's task table: one ``transitions`` machine per process shared by every agent, public API only (its
module doc gives the cost at 10,000 agents).
"""

from __future__ import annotations

from enum import StrEnum

from bimbot.shared import table_machine
from bimbot.shared.messages import ComponentEvent, ComponentState
from bimbot.shared.table_machine import TableMachine

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
    {
        "trigger": _E.PLACE.value,
        "source": [_S.ASSEMBLING, _S.POURING, _S.LAYING, _S.DRIVING],
        "dest": _S.VERIFYING,
    },
    {"trigger": _E.FORM.value, "source": _S.RELEASED, "dest": _S.FORMING},
    {"trigger": _E.POUR.value, "source": _S.FORMING, "dest": _S.POURING},
    {"trigger": _E.LAY.value, "source": _S.RELEASED, "dest": _S.LAYING},
    {"trigger": _E.DRIVE.value, "source": _S.RELEASED, "dest": _S.DRIVING},
    {"trigger": _E.RETRY.value, "source": _S.MISPLACED, "dest": _S.RELEASED},
    {
        "trigger": _E.ABANDON.value,
        "source": [
            _S.PICKING,
            _S.TRANSPORTING,
            _S.ASSEMBLING,
            _S.FORMING,
            _S.POURING,
            _S.LAYING,
            _S.DRIVING,
        ],
        "dest": _S.RELEASED,
    },
    {"trigger": _E.HAND_OFF.value, "source": _S.TRANSPORTING, "dest": _S.RELEASED},
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


def edges() -> list[tuple[str, ComponentState, ComponentState]]:
    """The table flattened to ``(trigger, source, dest)`` triples."""
    return table_machine.edges(TRANSITIONS)


def next_state(state: ComponentState, trigger: str) -> ComponentState | None:
    """Where ``trigger`` leads from ``state``, or None when the table does not allow it."""
    return table_machine.next_state(TRANSITIONS, state, trigger)


def triggers_from(state: ComponentState) -> set[str]:
    """The triggers the table accepts in ``state``."""
    return table_machine.triggers_from(TRANSITIONS, state)


def reachable_from(start: ComponentState = INITIAL) -> set[ComponentState]:
    """Every state some sequence of triggers reaches from ``start`` (``start`` included)."""
    return table_machine.reachable_from(TRANSITIONS, start)


class ComponentMachine(TableMachine):
    """The component state table as one machine, shared by many agents (enum states, no auto transitions;
    an illegal trigger is refused: :meth:`fire` returns False and the agent logs a rejection)."""

    def __init__(self) -> None:
        super().__init__(STATES, TRANSITIONS, INITIAL)
