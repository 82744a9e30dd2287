"""How long a robot or crane holds a member it set down at its target: its connections and its temporary
supports (pure).

A member let go at its target is held by its robot until its connections to the built neighbours are made
(the crew time of the slowest, :func:`plan_connections`) and, when it needs them, its temporary supports
are set (:func:`sets_supports`: each takes its ``place_s``). Physics holds it that long
(:mod:`bimbot.services.physics.releasing`); the planner counts the same time in its estimate of the task
(:func:`expected_hold_s`, :mod:`bimbot.services.planner.capability`), so a robot's bid and the time it is
taken to be busy agree with what it will do. One rule for both, here, so the two cannot drift apart.

A neighbour the manifest links no connection to (an older build, a contact physics found at the member's
side) is connected as a bolted end in :data:`UNLINKED_CONNECTION_S`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from bimbot.shared.connection_kinds import ConnectionKind, ConnectionLink, SupportWhen, TemporarySupportNeed
from bimbot.shared.manifest import Component

#: crew time of a connection the manifest does not link (sim s): physics' default, the planner's too
UNLINKED_CONNECTION_S = 20.0


@dataclass(frozen=True)
class ConnectionPlan:
    """What is made as a member is let go at its target (:func:`plan_connections`)."""

    kinds: dict[str, ConnectionKind]  # every neighbour it is connected to → how
    fixed_to: tuple[str, ...]  # those that hold it where it was put (all but bearings on a contact)
    holds_at_s: dict[str, float]  # fixing ones → after how long they hold (sim s from the release)
    connection_s: float  # the crew time while its robot holds it (the longest of the kinds made)


def plan_connections(
    made: Sequence[str],
    links: Mapping[str, ConnectionLink],
    jointed: Sequence[str],
    fallback_s: float,
) -> ConnectionPlan:
    """Kinds and times for the neighbours ``made`` (GUIDs in order): a neighbour the manifest links is
    connected as its link says; one it does not (an older build, a contact physics found) as a bolted end
    in ``fallback_s``. A bearing holds by friction only, except on a joint partner (no contact between
    the two: it would pass into it), which holds it as a fixed connection would; a single pinned end holds
    it only with something else (:func:`hinged_only`)."""
    kinds: dict[str, ConnectionKind] = {}
    holds_at_s: dict[str, float] = {}
    connection_s = 0.0
    for guid in made:
        link = links.get(guid)
        kind = link.kind if link is not None else ConnectionKind.PINNED_END
        time_s = link.time_s if link is not None else fallback_s
        kinds[guid] = kind
        connection_s = max(connection_s, time_s)
        if kind.fixes or guid in jointed:
            holds_at_s[guid] = time_s + (link.set_s if link is not None else 0.0)
    if hinged_only(holds_at_s, kinds, jointed):
        holds_at_s = {}  # one pinned end is a hinge: the member turns about it unless something else holds it
    return ConnectionPlan(kinds, tuple(holds_at_s), holds_at_s, connection_s)


def hinged_only(
    holds: Mapping[str, float], kinds: Mapping[str, ConnectionKind], jointed: Sequence[str]
) -> bool:
    """Whether the member is held by a single pinned end and nothing else: a bolted shear end lets it turn,
    so it stands only with a second end (or a fixed connection, a joint, a support) holding it.

    A bearing made on another neighbour is such a second support: the member lies on it, so it cannot turn
    about its pin, and the pin keeps it from sliding off (a pin and a roller: simply supported), as a
    curtain wall's bottom transom lying on its slab and bolted to the wall it abuts is held."""
    pinned = [guid for guid in holds if kinds[guid] is ConnectionKind.PINNED_END and guid not in jointed]
    bears = any(kind is ConnectionKind.BEARING for guid, kind in kinds.items() if guid not in holds)
    return len(holds) == 1 and len(pinned) == 1 and not bears


def sets_supports(
    need: TemporarySupportNeed | None, plan: ConnectionPlan, anchored: Callable[[], bool]
) -> bool:
    """Whether a member with temporary support ``need``, connected as ``plan`` says, gets its supports as
    it is let go: always (a precast wall panel), when no fixing connection holds it (``unconnected``), or
    when its connections do not yet reach what stands by itself (``unanchored``: ``anchored`` says)."""
    if need is None:
        return False
    if need.when is SupportWhen.ALWAYS:
        return True
    if need.when is SupportWhen.UNCONNECTED:
        return not plan.holds_at_s
    return not anchored()


def supports_s(need: TemporarySupportNeed) -> float:
    """The crew time to set all of ``need``'s supports (while the robot holds the member)."""
    return need.count * need.place_s


def longest_hold_s(component: Component, fallback_s: float) -> float:
    """The longest its robot may hold it: its slowest connection and all its temporary supports."""
    need = component.temporary_support
    slowest = max((link.time_s for link in component.connection_links), default=0.0)
    return max(slowest, fallback_s) + (supports_s(need) if need is not None else 0.0)


def expected_hold_s(component: Component, fallback_s: float = UNLINKED_CONNECTION_S) -> float:
    """How long its robot is expected to hold it once it is set down at its target, by physics' rules: the
    connections its manifest links all made (:func:`plan_connections`; the partners its links name as
    joints are its joint partners), or one connection in ``fallback_s`` when it links none; plus its
    temporary supports when those connections leave it needing them (:func:`sets_supports`; a member
    braced ``unanchored`` is expected braced: it is set before the members that would anchor it)."""
    links = {link.other_guid: link for link in component.connection_links}
    jointed = tuple(guid for guid, link in links.items() if link.source == "joint")
    plan = plan_connections(tuple(links), links, jointed, fallback_s)
    connection_s = plan.connection_s if links else fallback_s
    need = component.temporary_support
    if need is not None and sets_supports(need, plan, anchored=lambda: False):
        return connection_s + supports_s(need)
    return connection_s
