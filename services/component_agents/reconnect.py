"""When the agents say every state again: once physics, out of their reach, is back (pure).

Why: a state message published while the bus was cut (a router that restarted, a link between routers
that broke) never arrives, and nothing sends it again: the agents ignore a repeated event, so a robot
waiting for the confirmation of its event or for a verdict, and the planner waiting to release what rests
on a component, waited until the site was declared stalled. Physics' liveliness token going and coming
back is what a shard sees of such a cut; then it announces every agent's state as a restarted shard does
(:meth:`.host.AgentHost.restate`): receivers take what follows from what they know and ask the twin of the
rest.
"""

from __future__ import annotations

from dataclasses import dataclass

from bimbot.shared.bus import LivelinessChange


@dataclass
class PhysicsReach:
    """Whether physics' liveliness went since it was last seen (a token reported at start is no return)."""

    lost: bool = False

    def back(self, change: LivelinessChange) -> bool:
        """Take a change of a liveliness token; True when it is physics', back after it went."""
        if change.kind != "physics":
            return False
        if not change.alive:
            self.lost = True
            return False
        returned, self.lost = self.lost, False
        return returned
