"""All the agents of one shard of a build: dispatch of validated bus input to agents, journal, outputs.

No Zenoh here: the adapter (:mod:`.app`) hands in validated messages with the key they arrived on and
publishes the :class:`Outgoing` messages returned, so the whole protocol is testable without a bus.

Sharding: component ``guid`` belongs to shard ``shard_of(guid, n)`` in ``1..n`` (CRC-32 of the GUID's
UTF-8 bytes, the same in every process and on every host; Python's ``hash`` is salted per process). Each
shard's process subscribes to the wildcard keys and drops what belongs to other shards, which costs each
process all the event/pose traffic but only three subscribers, whatever its number of agents.

A host needs only its own shard's components (:func:`shard_manifest`); messages for a component it does
not own are dropped and counted as ``other_shard`` when the message's GUID belongs to another shard, else
as ``unknown_component``. (The agents never import ``bimbot.shared.identifiers``: it loads ifcopenshell,
~50 MB per process.)

A host resumes from a :class:`~.journal.Replay`: every agent found there continues in its last state with
its attempts, robot, history and applied event ids; :meth:`AgentHost.start` then announces every agent's
state once (event ``resume`` for those, ``start`` for the others).
"""

from __future__ import annotations

import logging
import math
import time
import zlib
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Protocol

from bimbot.shared.bus import Received
from bimbot.shared.clock_guard import ClockGuard
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    COMPONENT_STATE_KEY,
    COMPONENT_TWIN_KEY,
    ClockMsg,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    TwinMsg,
    key,
)
from bimbot.shared.robot_description import RobotDescription
from bimbot.shared.state_table import ComponentMachine
from bimbot.shared.verification import Tolerances

from .agent import AgentConfig, ComponentAgent, SimClock, clip
from .journal import JournalRecord, Replay

_log = logging.getLogger(__name__)


def shard_of(guid: str, n_shards: int) -> int:
    """The shard (1..n) that owns ``guid``: CRC-32 of its UTF-8 bytes, stable across processes and hosts."""
    if n_shards < 1:
        raise ValueError(f"number of shards must be ≥ 1, got {n_shards}")
    return zlib.crc32(guid.encode("utf-8")) % n_shards + 1


def shard_manifest(manifest: Manifest, shard: int, n_shards: int) -> Manifest:
    """``manifest`` with only the components of shard ``shard`` (a process keeps no other shard's data)."""
    owned = [component for component in manifest.components if shard_of(component.guid, n_shards) == shard]
    return manifest.model_copy(update={"components": owned})


def parse_shard(text: str) -> tuple[int, int]:
    """``"i/n"`` → ``(i, n)`` with ``1 ≤ i ≤ n``; ValueError with a readable message otherwise."""
    parts = text.strip().split("/")
    if len(parts) != 2 or not all(part.strip().isdigit() for part in parts):
        raise ValueError(f"--shard {text!r}: expected i/n with whole numbers, e.g. 1/1 or 2/4")
    index, count = (int(part) for part in parts)
    if count < 1 or not 1 <= index <= count:
        raise ValueError(f"--shard {text!r}: need 1 ≤ i ≤ n (shards are numbered from 1)")
    return index, count


class JournalSink(Protocol):
    def append(self, record: JournalRecord) -> None: ...


@dataclass(frozen=True)
class Outgoing:
    """A state message to publish on ``key_expr``."""

    key_expr: str
    message: ComponentStateMsg


class AgentHost:
    """The agents of shard ``shard`` of ``n_shards`` for one manifest, with one shared state machine."""

    def __init__(
        self,
        manifest: Manifest,
        shard: int = 1,
        n_shards: int = 1,
        *,
        config: AgentConfig | None = None,
        journal: JournalSink | None = None,
        resume: Replay | None = None,
        now_wall_s: float | None = None,
    ) -> None:
        if not 1 <= shard <= n_shards:
            raise ValueError(f"shard {shard} of {n_shards}: need 1 ≤ shard ≤ n_shards")
        self.site = manifest.site
        self.shard = shard
        self.n_shards = n_shards
        self.config = config or AgentConfig()
        self.clock = SimClock()
        self.clock_guard = ClockGuard(f"agents {shard}/{n_shards} clock")
        self.machine = ComponentMachine()
        self._journal = journal
        self.agents: dict[str, ComponentAgent] = {}
        for component in manifest.components:
            if shard_of(component.guid, n_shards) == shard:
                self.agents[component.key] = ComponentAgent(component, self.config, self.machine, self.clock)
        self._twin_keys = {k: key(COMPONENT_TWIN_KEY, site=self.site, key=k) for k in self.agents}
        self._state_keys = {k: key(COMPONENT_STATE_KEY, site=self.site, key=k) for k in self.agents}
        self._verifying: set[str] = set()
        self.resumed: set[str] = set()
        self.counts: Counter[str] = Counter()
        if resume is not None:
            self._resume(resume, time.time() if now_wall_s is None else now_wall_s)

    def use_tolerances(self, tolerances: Tolerances) -> None:
        """Verify with ``tolerances`` from now on: the ones in force on the site (physics' site info)."""
        if tolerances == self.config.tolerances and self.config.tolerances_known:
            return
        self.config = replace(self.config, tolerances=tolerances, tolerances_known=True)
        for agent in self.agents.values():
            agent.use_config(self.config)
        _log.info(
            "placement tolerances in force: %g mm, %g°, drift %g mm",
            1000.0 * tolerances.position_m,
            math.degrees(tolerances.angle_rad),
            1000.0 * tolerances.drift_m,
        )

    def use_fleet(
        self, robot_type_of: Mapping[str, str], robot_types: Mapping[str, RobotDescription]
    ) -> None:
        """Who is on site, of which type (physics' site info): a failed placement's advice names them."""
        robots = {rid: robot_types[name] for rid, name in robot_type_of.items() if name in robot_types}
        self.config = replace(self.config, robots=robots)
        for agent in self.agents.values():
            agent.use_config(self.config)

    def assume_own_tolerances(self, waited_s: float) -> None:
        """No site info yet (no physics on this bus, or a slow one): judge with the agents' own tolerances
        until it comes, and say so once."""
        if self.config.tolerances_known:
            return
        self.config = replace(self.config, tolerances_known=True)
        for agent in self.agents.values():
            agent.use_config(self.config)
        _log.warning(
            "physics did not say the site's tolerances within %.0f s: verifying with the agents' own "
            "(%g mm, %g°) until it does",
            waited_s,
            1000.0 * self.config.tolerances.position_m,
            math.degrees(self.config.tolerances.angle_rad),
        )

    # --- start ---------------------------------------------------------------------------------------------

    def _resume(self, replay: Replay, now: float) -> None:
        by_guid = {agent.guid: agent for agent in self.agents.values()}
        latest_sim = 0.0
        for guid, last in replay.last.items():
            agent = by_guid.get(guid)
            if agent is None:
                self.counts["journal_not_owned"] += 1
                continue
            change = last.change
            agent.restore(
                change.state,
                attempt=change.attempt,
                robot_id=change.robot_id,
                place_sim_time_s=last.place_sim_time_s,
                history=[record.change for record in replay.records.get(guid, [])],
                event_ids=replay.event_ids.get(guid, ()),
                reason=change.reason,
                now_wall_s=now,
            )
            self.resumed.add(agent.key)
            latest_sim = max(latest_sim, change.sim_time_s)
            if change.state is ComponentState.VERIFYING:
                self._verifying.add(agent.key)
        if self.counts["journal_not_owned"]:
            _log.warning(
                "journal names %d components this shard does not own (manifest or shard count changed?)",
                self.counts["journal_not_owned"],
            )
        self.clock.sim_time_s = latest_sim
        _log.info("resumed %d of %d agents from the journal", len(self.resumed), len(self.agents))

    def start(self, now_wall_s: float | None = None) -> list[Outgoing]:
        """Every agent's current state, once: ``resume`` (from the journal) or ``start`` (fresh)."""
        now = time.time() if now_wall_s is None else now_wall_s
        out = []
        for k, agent in self.agents.items():
            if k in self.resumed:
                message = agent.announce("resume", "agent process restarted; state from its journal", now)
            else:
                message = agent.announce("start", "agent started", now)
            out.append(Outgoing(self._state_keys[k], message))
        return out

    def restate(self, now_wall_s: float | None = None) -> list[Outgoing]:
        """Every agent's current state again (``restate``), as at start-up: the bus was cut and a state
        message sent meanwhile may never have arrived (:mod:`.reconnect`)."""
        now = time.time() if now_wall_s is None else now_wall_s
        cause = "the bus was cut: the state again, in case its message was lost"
        return [
            Outgoing(self._state_keys[k], agent.announce("restate", cause, now))
            for k, agent in self.agents.items()
        ]

    # --- input ---------------------------------------------------------------------------------------------

    def handle(self, item: object, now_wall_s: float | None = None) -> list[Outgoing]:
        """Dispatch one inbox item: a :class:`~bimbot.shared.bus.Received` event, pose or clock message;
        anything else is counted as ``unknown_item``."""
        match item:
            case Received(message=ComponentEventMsg() as message, key=key_expr):
                return self.on_event(key_expr, message, now_wall_s)
            case Received(message=ComponentPoseMsg() as message, key=key_expr):
                return self.on_pose(key_expr, message, now_wall_s)
            case Received(message=ClockMsg() as message):
                self.on_clock(message)
                return []
        self.counts["unknown_item"] += 1
        return []

    def on_event(
        self, key_expr: str, msg: ComponentEventMsg, now_wall_s: float | None = None
    ) -> list[Outgoing]:
        agent = self._agent_for(key_expr, "event", msg.guid)
        if agent is None:
            return []
        self.counts["events"] += 1
        messages = agent.apply_event(msg, now_wall_s)
        if not messages:
            self.counts["events_not_applied"] += 1
        return self._commit(agent, messages, msg.event_id, msg.event.value)

    def on_pose(
        self, key_expr: str, msg: ComponentPoseMsg, now_wall_s: float | None = None
    ) -> list[Outgoing]:
        agent = self._agent_for(key_expr, "pose", msg.guid)
        if agent is None:
            return []
        self.counts["poses"] += 1
        return self._commit(agent, agent.observe_pose(msg, now_wall_s))

    def on_clock(self, msg: ClockMsg) -> None:
        """Sim time from a believable clock only (:mod:`bimbot.shared.clock_guard`)."""
        if self.clock_guard.check(msg, time.monotonic()).accepted:
            self.clock.observe(msg.sim_time_s)

    def tick(self, now_wall_s: float | None = None) -> list[Outgoing]:
        """Verification timeouts: agents in ``verifying`` whose wait for a fresh pose is over decide."""
        now = time.time() if now_wall_s is None else now_wall_s
        out: list[Outgoing] = []
        for k in list(self._verifying):
            agent = self.agents[k]
            out.extend(self._commit(agent, agent.try_verify(now)))
        return out

    def twins(self, query_key_expr: str, intersects: Callable[[str, str], bool]) -> list[tuple[str, TwinMsg]]:
        """``(reply key, twin)`` for every owned component whose twin key matches the query's key expression
        (``intersects(query, twin_key)``; an exact key is looked up directly)."""
        if "*" not in query_key_expr and "$" not in query_key_expr:
            k = self._component_key(query_key_expr, "twin")
            agent = self.agents.get(k) if k is not None else None
            return [(query_key_expr, agent.twin())] if agent is not None else []
        return [
            (twin_key, self.agents[k].twin())
            for k, twin_key in self._twin_keys.items()
            if intersects(query_key_expr, twin_key)
        ]

    # --- internals -----------------------------------------------------------------------------------------

    def _component_key(self, key_expr: str, leaf: str) -> str | None:
        parts = key_expr.split("/")
        if len(parts) != 5 or parts[0] != "bimbot" or parts[1] != self.site or parts[2] != "components":
            return None
        return parts[3] if parts[4] == leaf else None

    def _agent_for(self, key_expr: str, leaf: str, guid: str) -> ComponentAgent | None:
        k = self._component_key(key_expr, leaf)
        agent = self.agents.get(k) if k is not None else None
        if agent is None:
            if k is not None and shard_of(guid, self.n_shards) != self.shard:
                self.counts["other_shard"] += 1
            else:
                self.counts["unknown_component"] += 1
                _log.debug("%s on %s: no such component in the manifest", leaf, clip(key_expr, 120))
            return None
        if guid != agent.guid:
            self.counts["guid_mismatch"] += 1
            _log.warning("%s on %s names GUID %s, not %s: ignored", leaf, key_expr, clip(guid), agent.guid)
            return None
        return agent

    def _commit(
        self,
        agent: ComponentAgent,
        messages: list[ComponentStateMsg],
        event_id: str | None = None,
        event: str | None = None,
    ) -> list[Outgoing]:
        """Journal the transitions (before anything is published), track verifying agents, address output."""
        if not messages:
            return []
        for message in messages:
            self.counts["transitions"] += 1
            if self._journal is not None:
                own_event_id = event_id if message.event == event else None
                place_time = agent.place_sim_time_s if message.state is ComponentState.VERIFYING else None
                try:
                    self._journal.append(JournalRecord.from_message(message, own_event_id, place_time))
                except OSError as error:
                    self.counts["journal_errors"] += 1
                    _log.error(
                        "journal write failed for %s: %s (a restart may lose this change)", agent.guid, error
                    )
        if agent.state is ComponentState.VERIFYING:
            self._verifying.add(agent.key)
        else:
            self._verifying.discard(agent.key)
        state_key = self._state_keys[agent.key]
        return [Outgoing(state_key, message) for message in messages]
