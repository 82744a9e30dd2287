"""What a user can do about a component that landed out of tolerance on every attempt, by what placed it and
why it missed: one line naming the fleet fields and run options that change it.

* set down into built neighbours and moved out of them by as much as it missed by: the neighbours' own
  offsets, each within tolerance, added up (tolerance stack-up);
* set by a crane's hook: no total station tracks a hook (it fixes ground robots), so the crane type's
  placement precision, and guided ends for a long load, are what land it closer;
* placed by a ground robot: its type's placement precision, or its localisation (the site's total station);
* a robot the agents do not know (no site info yet): every one of those.
"""

from __future__ import annotations

from dataclasses import dataclass

from bimbot.shared.robot_description import Capability, RobotDescription

FLEET_FIELDS = "placement_precision_m and placement_precision_yaw_deg in a fleet file, `bimbot fleet show`"
TOTAL_STATION = "`bimbot run BUILD --total-station-mm 1` for finer fixes than the rehearsal's 3 mm"
GENERIC_HINT = (
    "every attempt landed out of tolerance: the robot type's placement precision is too coarse for it "
    f"({FLEET_FIELDS}; a long member turns a small turn into centimetres at its ends), or its localisation "
    f"was off (the site's total station fixes ground robots: {TOTAL_STATION})"
)
MAX_NAMED = 3  # neighbours named in a stack-up line


@dataclass(frozen=True)
class SetAgainst:
    """The built components a placement was set into and moved out of by its release, and how far its
    centre moved (physics' pose message: ``set_against``, ``set_against_shift_m``)."""

    guids: tuple[str, ...]
    shift_m: float


def misplaced_hint(
    robot_id: str | None,
    description: RobotDescription | None,
    *,
    position_error_m: float | None = None,
    tolerance_m: float,
    set_against: SetAgainst | None = None,
) -> str:
    """The advice that ends a ``failed`` (misplaced) reason; see the module docstring."""
    if stacked_up(position_error_m, tolerance_m, set_against):
        assert set_against is not None
        named = ", ".join(set_against.guids[:MAX_NAMED]) + (
            f" and {len(set_against.guids) - MAX_NAMED} more" if len(set_against.guids) > MAX_NAMED else ""
        )
        return (
            f"set down against {named}, it was moved {1000.0 * set_against.shift_m:.1f} mm out of them: "
            "parts built within tolerance but off their own targets add up (tolerance stack-up); a finer "
            f"placement precision for what built them ({FLEET_FIELDS}) or a wider tolerance "
            "(`bimbot run BUILD --position-tolerance-m`)"
        )
    if description is None or robot_id is None:
        return GENERIC_HINT
    who = (
        f"{robot_id} ({description.name}: placement_precision_m "
        f"{1000.0 * description.placement_precision_m:g} mm, placement_precision_yaw_deg "
        f"{description.placement_precision_yaw_deg:g}°)"
    )
    if description.can(Capability.HOOK_LIFT):
        guided = (
            ""
            if description.placement_guided_ends
            else "; placement_guided_ends = true lands a long load with each end guided (tag lines, then a "
            "connector at each end)"
        )
        return (
            f"every lift by {who} landed out of tolerance; the total station fixes ground robots, not a "
            "hook: a finer precision for its type in a fleet file (`bimbot fleet show`) sets it "
            f"closer{guided}"
        )
    if description.can(Capability.DRIVE):
        return (
            f"every placement by {who} landed out of tolerance: a finer precision for its type in a fleet "
            "file (`bimbot fleet show`; a long member turns a small turn into centimetres at its ends), or a "
            f"finer localisation (the site's total station: {TOTAL_STATION})"
        )
    return (
        f"every placement by {who} landed out of tolerance: a finer precision for its type in a fleet file "
        "(`bimbot fleet show`)"
    )


def stacked_up(position_error_m: float | None, tolerance_m: float, set_against: SetAgainst | None) -> bool:
    """Whether moving out of its neighbours explains the miss: without that shift it would have been within
    ``tolerance_m`` (its error less the shift; the shift may point anywhere, so this is the best case)."""
    if set_against is None or not set_against.guids or position_error_m is None:
        return False
    return position_error_m > tolerance_m and position_error_m - set_against.shift_m <= tolerance_m
