"""Access holds: a ready component waits while placing it now would cut off work still to be done.

Why: the plan's access check (:mod:`.access_plan`) orders the plan so that, built in the plan's order, no
placement cuts off later work. The robots do not build in exactly that order: a component whose
predecessors are done early, or one that follows a failed part, is released before work the plan put
ahead of it. A courtyard's gate can then close before the wall in the room behind it is up, and the wall
can never be reached. A site manager holds the gate. So does the release. On the robots' 0.1 m grid
(:mod:`bimbot.shared.site_access`; the plan check's 0.2 m grid finds a way through the restaurant's
courtyard that the robots do not), with what is constructed, and what is released, standing at its
target, a ready component whose placement would cut off the target or yard slot of a component still to
be built waits until that component is built, failed or blocked. A component that needs the ready one
first (a path in the plan leads from one to the other) does not hold it: that cut-off cannot be helped.

Bounds: a hold is looked at again only when a component it waits for is final; and when nothing else is
in flight (no task released or assigned, no curing hold), the first held component goes anyway, logged,
so a hold never stops a run. Cost: one placement and one labelling of the grid per component made ready,
and per end of its waits.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass

from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import SiteInfoMsg
from bimbot.shared.site_access import Candidates, SiteAccess

from .access_plan import FINE, site_robot
from .work_in_place import works_in_place

_log = logging.getLogger(__name__)


class AccessGuard:
    """The site as built so far, asked what a placement would cut off (owns its :class:`SiteAccess`)."""

    def __init__(
        self, access: SiteAccess, predecessors: Mapping[str, Iterable[str]], driven_to: Iterable[str]
    ) -> None:
        """``predecessors``: the plan's; ``driven_to``: the components a robot drives to (work in place is
        reached by its machine's boom, so it is never cut off)."""
        self._access = access
        self._successors: dict[str, set[str]] = {}
        for guid, preds in predecessors.items():
            for pred in preds:
                self._successors.setdefault(pred, set()).add(guid)
        self._driven_to = frozenset(driven_to)
        self._after: dict[str, frozenset[str]] = {}  # GUID → every component that needs it first
        self._standing: set[str] = set()
        self._gone: set[str] = set()

    @classmethod
    def for_site(
        cls,
        manifest: Manifest,
        info: SiteInfoMsg,
        predecessors: Mapping[str, Iterable[str]],
        on_step: Callable[[int, int], None] | None = None,
    ) -> AccessGuard:
        """The guard for the robots on site (the widest ground type, as the plan's check); ``on_step``
        hears how far its grid is."""
        components = list(manifest.components)
        robot = site_robot(info)
        access = SiteAccess(components, info.layout, robot, FINE, in_place=manifest.in_place, on_step=on_step)
        driven_to = [item.guid for item in components if not works_in_place(item)]
        return cls(access, predecessors, driven_to)

    def observe(self, standing: Iterable[str], gone: Iterable[str]) -> None:
        """``standing``: at their targets (constructed, or released to be built now); ``gone`` (failed):
        neither in the yard nor placed; every other component lies in its yard slot."""
        standing, gone = set(standing), set(gone) - set(standing)
        for guid in sorted(self._standing - standing):
            self._standing.discard(guid)
            if guid not in gone:
                self._access.remove(guid)
        for guid in sorted(self._gone - gone):
            self._gone.discard(guid)
            if guid not in standing:
                self._access.remove(guid)
        for guid in sorted(standing - self._standing):
            self._standing.add(guid)
            self._access.place(guid)
        for guid in sorted(gone - self._gone):
            self._gone.add(guid)
            self._access.clear(guid)

    def stand(self, guid: str) -> None:
        """``guid`` was released: it stands at its target for the questions that follow."""
        if guid not in self._standing:
            self._standing.add(guid)
            self._gone.discard(guid)
            self._access.place(guid)

    def cut_off(self, guid: str, to_build: Candidates) -> list[str]:
        """Which of ``to_build`` placing ``guid`` now would cut off (those that need it first left out)."""
        return self._access.cut_off_by(guid, _MayBeCutOff(to_build, self._driven_to, self._needs_first(guid)))

    def shuts_in(self, guid: str, robots_xy_m: Mapping[str, tuple[float, float]]) -> list[str]:
        """Which robots (id → where it stands), with no way out to the depot in the site as released, would
        have one if ``guid`` were not standing: placing ``guid`` now would shut them in."""
        ids = sorted(robots_xy_m)
        return [ids[i] for i in self._access.frees(guid, [robots_xy_m[robot] for robot in ids])]

    def _needs_first(self, guid: str) -> frozenset[str]:
        """Every component a path in the plan leads to from ``guid``."""
        known = self._after.get(guid)
        if known is None:
            seen: set[str] = set()
            stack = list(self._successors.get(guid, ()))
            while stack:
                item = stack.pop()
                if item not in seen:
                    seen.add(item)
                    stack.extend(self._successors.get(item, ()))
            known = self._after[guid] = frozenset(seen)
        return known


@dataclass(frozen=True)
class _MayBeCutOff:
    """The components a placement may cut off: still to be built, driven to, and not needing it first.
    Asked of the few components near the placement, gone through whole only when the site splits (a list
    made for every released task was 32 million entries at the start of a 9,802-component frame)."""

    to_build: Candidates
    driven_to: frozenset[str]
    needs_it_first: frozenset[str]

    def __contains__(self, guid: object) -> bool:
        return guid in self.to_build and guid in self.driven_to and guid not in self.needs_it_first

    def __iter__(self) -> Iterator[str]:
        return (guid for guid in self.to_build if guid in self)
