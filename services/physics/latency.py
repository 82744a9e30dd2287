"""Commands and requests held until their turn: the lock-step's sensing-to-actuation latency, kept exact.

Why: in plain lock-step (latency 0) physics publishes step ``k``, waits for every robot's command answering
``k``, then steps. Physics and robots take turns, each waiting for the other: on two cores half the
machine sleeps. With a latency of one control period, a command answering step ``k`` acts during the period
from ``k + 1``: physics steps ``k → k + 1`` with the commands answering ``k − 1`` (already there) while
the robots compute their answers to ``k`` on the other core, and each robot plans from where its previous
command will have carried it (:mod:`bimbot.services.robot.navigator`). Nothing about the outcome depends on
who is faster: a command, and a robot's attach, place or drop request stamped with the step it answered,
takes effect exactly ``latency`` periods after that step, however early it arrives. Pure bookkeeping.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from bimbot.shared.messages import CmdVelMsg

T = TypeVar("T")


@dataclass
class Held(Generic[T]):
    step: int  # the clock step the robot answered
    item: T


@dataclass
class Pipeline(Generic[T]):
    """``latency_steps`` periods between a robot's answer to a step and its effect; requests of type ``T``
    (the adapter's incoming queries) wait with the commands."""

    latency_steps: int = 0
    _commands: dict[str, list[CmdVelMsg]] = field(default_factory=dict)
    _requests: list[Held[T]] = field(default_factory=list)

    def target(self, step: int) -> int:
        """The step every robot must have answered before physics advances from ``step``."""
        return step - self.latency_steps

    def command_now(self, command: CmdVelMsg) -> bool:
        """Whether ``command`` acts at once (no latency, or not a lock-step command); else it is held."""
        if self.latency_steps == 0 or command.step is None:
            return True
        self._commands.setdefault(command.robot_id, []).append(command)
        return False

    def due_commands(self, step: int) -> list[CmdVelMsg]:
        """Before advancing from ``step``: per robot the latest held command answering ``target(step)`` or
        earlier (older ones are superseded, later ones stay held)."""
        due: list[CmdVelMsg] = []
        limit = self.target(step)
        for robot_id, held in self._commands.items():
            ready = [command for command in held if command.step is not None and command.step <= limit]
            if ready:
                due.append(max(ready, key=lambda command: command.step or 0))
                self._commands[robot_id] = [command for command in held if command not in ready]
        return due

    def request_now(self, step: int | None, current_step: int, item: T) -> bool:
        """Whether a request stamped ``step`` is handled at once at ``current_step`` (only one that came too
        late for its advance); else it is held, also when its turn is the coming advance: it is then
        handled there after the step's inputs, as one that came earlier is, not before them."""
        if self.latency_steps == 0 or step is None or step < self.target(current_step):
            return True
        self._requests.append(Held(step, item))
        return False

    def due_requests(self, step: int) -> list[T]:
        """Before advancing from ``step``: the held requests now due, in the order they came."""
        limit = self.target(step)
        due = [held.item for held in self._requests if held.step <= limit]
        self._requests = [held for held in self._requests if held.step > limit]
        return due

    def forget(self, robot_ids: Iterable[str]) -> None:
        """A robot left (lost, or physics restarted): its held commands go."""
        for robot_id in robot_ids:
            self._commands.pop(robot_id, None)
