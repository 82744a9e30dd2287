"""Connections as on site, and temporary supports: the kinds, their times, and what the manifest carries.

A component set down at its target is held by its robot or crane until its connection to what supports it
is made, then let go. What that connection is decides what physics does (:mod:`bimbot.services.physics.
connections`): a bolted base, a bolted (pinned) or welded (fixed) end fixes the member once made; a
bearing holds it by friction only (no constraint: it rests on its supports), and only on a level seat: one
on a slope (a pitched roof panel) is fastened down, which fixes it; a grouted joint fixes it only once its
grout has set, and until then the member stands on temporary props. Members that cannot
stand until their frame closes (a precast wall panel, a slender column with no fixed base) get temporary
supports: placed by the robot as part of its task, removed once the member is held by connections that
reach the ground through the structure. The converter decides the kind per supporting neighbour
(``services/converter/connection_kinds.py``); the times come from the methods file (``[connections]``,
``[temporary_supports]`` in ``shared/methods/common.toml``).
"""

from __future__ import annotations

from enum import StrEnum

from pydantic import BaseModel, ConfigDict, Field


class ConnectionKind(StrEnum):
    """How a component is connected to one supporting neighbour."""

    BOLTED_BASE = "bolted_base"  # a column's base plate on anchor bolts (or a footing): fixed once bolted
    PINNED_END = "pinned_end"  # a bolted beam end (cleats, fin or end plate)
    FIXED_END = "fixed_end"  # a welded (moment) end
    BEARING = "bearing"  # a precast plank or slab on beams or walls: friction only, no constraint
    GROUTED = "grouted"  # a precast wall panel on its grout bed: fixed once the grout has set, propped until
    FASTENED = "fastened"  # a panel or member bearing on a slope, screwed or nailed down: fixed once made

    @property
    def fixes(self) -> bool:
        """Whether the connection, once made, holds the member where it is (all but a bearing)."""
        return self is not ConnectionKind.BEARING


class SupportKind(StrEnum):
    """A temporary support, as a site crew sets it."""

    PROPS = "props"  # push-pull props on a precast wall panel
    BRACES = "braces"  # raking braces or guys on a column


class SupportWhen(StrEnum):
    """When physics sets a member's temporary supports, as it is let go at its target."""

    ALWAYS = "always"  # a precast wall panel: its grout holds nothing yet
    UNANCHORED = "unanchored"  # unless its connections already reach what stands by itself
    UNCONNECTED = "unconnected"  # unless a fixing connection is made as it is set down


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class ConnectionLink(_Frozen):
    """This component's connection to one supporting neighbour (``Component.connection_links``)."""

    other_guid: str
    kind: ConnectionKind
    time_s: float = Field(ge=0, description="crew time until the robot may let go (held until then)")
    set_s: float = Field(default=0.0, ge=0, description="after that, until it holds (a grout's set)")
    source: str = Field(description="'ifc' (the IFC relates the two), 'joint', 'bearing face' or 'side'")


class TemporarySupportNeed(_Frozen):
    """What temporary supports a member needs until its connections hold it (``temporary_support``)."""

    kind: SupportKind
    count: int = Field(ge=1)
    place_s: float = Field(ge=0, description="crew time to set one (part of the robot's task)")
    when: SupportWhen = SupportWhen.ALWAYS
    why: str = ""


class ConnectionTimes(_Frozen):
    """Crew time per connection kind until the robot or crane may let go (methods file ``[connections]``)."""

    bolted_base_s: float = Field(ge=0)
    pinned_end_s: float = Field(ge=0)
    fixed_end_s: float = Field(ge=0)
    bearing_s: float = Field(ge=0)
    grouted_s: float = Field(ge=0, description="set on its grout bed and shims")
    grout_set_s: float = Field(ge=0, description="until the grout holds the panel (its props stay till then)")
    fastened_s: float = Field(ge=0, description="a roof panel on a pitch screwed down to its bearers")

    def time_s(self, kind: ConnectionKind) -> float:
        return float(getattr(self, f"{kind.value}_s"))


class TemporarySupportRules(_Frozen):
    """Which members get temporary supports and how many (methods file ``[temporary_supports]``)."""

    props_per_panel: int = Field(ge=1)
    prop_place_s: float = Field(ge=0)
    braces_per_column: int = Field(ge=1)
    brace_place_s: float = Field(ge=0)
    # a column (or vertical member) this slender (height over its least width) with no fixed base is braced
    brace_slenderness: float = Field(gt=0)
