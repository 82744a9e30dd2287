"""Where an overlap lies on the member drawn into a part: at one of its ends, along it inside the part's
thickness, or through the part; and how far it runs in plan. The joint rules' shape conditions
(:mod:`.joints`, ``shared/joint_rules.toml``): pure, components and overlap vertices in the world frame.
"""

from __future__ import annotations

import numpy as np

from bimbot.shared.manifest import Component

from .placement import in_pose_frame

END_TOLERANCE_M = 0.01  # an overlap this much past a rule's depth from the member's end still lies at it
EMBED_SECTION_SHARE = 0.9  # an embedded member's section lies this much inside the part, on both axes
PAST_THE_PART_M = 0.05  # a member carried through a part runs on at least this far beyond it at both ends
ENCLOSED_M = 0.01  # …and the part goes on at least this far round it on every side across its thickness
# an end drawn in at a slant overlaps its part along the member for up to this many times its section's
# larger side (a 114 mm tube on a 20° slant to the chord: about 0.33 m), past its middle if it is short
SLANT_RUN_SECTIONS = 3.0
BAR_SECTIONS = 4.0  # …a member this many times longer than its section's larger side (a tube, not a wall)


def embedded_along(member: Component, part: Component, region_world_m: np.ndarray) -> bool:
    """Whether ``member`` is drawn inside ``part``'s thickness along its length where they overlap: the
    overlap (its vertices) takes in the member's whole section (within :data:`EMBED_SECTION_SHARE` of it
    on both short axes of its own frame) and runs along its length for more than twice the part's
    thickness (the least side of its own box): a lintel or bond beam in its wall, not a beam through it."""
    local = in_pose_frame(member.target_pose_world, region_world_m)
    low, high = np.asarray(member.bbox_local.min_m), np.asarray(member.bbox_local.max_m)
    size = high - low
    length_axis = int(np.argmax(size))
    covered = local.max(axis=0) - local.min(axis=0)
    section = [axis for axis in range(3) if axis != length_axis]
    if any(covered[axis] < EMBED_SECTION_SHARE * size[axis] for axis in section):
        return False
    thickness_m = float(np.min(np.asarray(part.bbox_local.max_m) - np.asarray(part.bbox_local.min_m)))
    return bool(covered[length_axis] > 2.0 * thickness_m)


def carried_through(member: Component, part: Component, region_world_m: np.ndarray) -> bool:
    """Whether ``member`` is carried through ``part`` where they overlap: the overlap (its vertices) takes
    in the member's whole section (within :data:`EMBED_SECTION_SHARE` of it on both short axes of its own
    frame) and the part's whole thickness (within that share of the least side of its own box), and the
    member runs on at least :data:`PAST_THE_PART_M` beyond the overlap at both of its ends along its length,
    and the part goes on round it (:data:`ENCLOSED_M`) on every side: a girder through the wall it bears on,
    not its end in a pocket nor a wall stopped at the beam over it."""
    local = in_pose_frame(member.target_pose_world, region_world_m)
    low, high = np.asarray(member.bbox_local.min_m), np.asarray(member.bbox_local.max_m)
    size = high - low
    length_axis = int(np.argmax(size))
    covered = local.max(axis=0) - local.min(axis=0)
    if any(covered[axis] < EMBED_SECTION_SHARE * size[axis] for axis in range(3) if axis != length_axis):
        return False
    first, last = local[:, length_axis].min(), local[:, length_axis].max()
    if first < low[length_axis] + PAST_THE_PART_M or last > high[length_axis] - PAST_THE_PART_M:
        return False
    in_part = in_pose_frame(part.target_pose_world, region_world_m)
    part_low, part_high = np.asarray(part.bbox_local.min_m), np.asarray(part.bbox_local.max_m)
    part_size = part_high - part_low
    thin_axis = int(np.argmin(part_size))
    spanned = float(in_part[:, thin_axis].max() - in_part[:, thin_axis].min())
    if spanned < EMBED_SECTION_SHARE * float(part_size[thin_axis]):
        return False
    # the part goes on round the member on every side across its thickness (a hole through it, not a
    # notch at its edge: a partition drawn up to the top of the beam over it stops there)
    return all(
        in_part[:, axis].min() > part_low[axis] + ENCLOSED_M
        and in_part[:, axis].max() < part_high[axis] - ENCLOSED_M
        for axis in range(3)
        if axis != thin_axis
    )


def plan_run_m(region_world_m: np.ndarray) -> float:
    """How far the overlap (its vertices, world frame) runs in plan: the largest distance between two of
    its vertices seen from above (a lining's overlap runs along the wall; a pier's is its width)."""
    xy = np.asarray(region_world_m, dtype=float)[:, :2]
    if len(xy) < 2:
        return 0.0
    return float(np.max(np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=-1)))


def at_an_end(
    member: Component, region_world_m: np.ndarray, band_m: float, *, length_only: bool = False
) -> bool:
    """Whether the overlap (its vertices, world frame) lies within ``band_m`` of one end or face of
    ``member``'s box, along an axis of its own frame on which it is longer than ``2 * band_m``; with
    ``length_only``, of one of its two ends along its longest axis (a framed end, not a side it touches).

    Not for a framed end: an overlap that takes in one end of the member itself and stops short of its
    middle lies at that end however far along it runs: an end drawn into its part at a slant (a tube's end
    cut to the saddle of the chord it meets, a short brace on a shallow slant) overlaps the part far past
    the depth it is drawn in (the Revit 2025 structural sample: HSS 114 braces 53-65 mm into the tube they
    meet, the overlap 120-150 mm along them). A short member's slanted end may run past its middle: it
    still lies at that end while the run is at most :data:`SLANT_RUN_SECTIONS` times the member's larger
    section side, for a bar (:data:`BAR_SECTIONS`; the same sample's 0.6 m HSS 114 stubs on its arched
    tube: 317 mm along them). The rule's depth still bounds how far in it is drawn; a member lying along
    its part (a tee under the canopy it carries) overlaps it far past that."""
    local = in_pose_frame(member.target_pose_world, region_world_m)
    low, high = np.asarray(member.bbox_local.min_m), np.asarray(member.bbox_local.max_m)
    size = high - low
    length_axis = int(np.argmax(size))
    axes = [length_axis] if length_only else range(3)
    for axis in axes:
        if size[axis] <= 2.0 * band_m:
            continue
        first, last = local[:, axis].min(), local[:, axis].max()
        if last <= low[axis] + band_m or first >= high[axis] - band_m:
            return True
        if length_only or axis != length_axis:
            continue
        half = low[axis] + size[axis] / 2.0
        section_m = max(size[other] for other in range(3) if other != axis)
        bar = size[axis] >= BAR_SECTIONS * section_m
        short = bar and last - first <= SLANT_RUN_SECTIONS * section_m
        if (first <= low[axis] + END_TOLERANCE_M and (last < half or short)) or (
            last >= high[axis] - END_TOLERANCE_M and (first > half or short)
        ):
            return True  # one of its ends lies in the part; the overlap stops short of its middle, or of
            # the run of an end on a slant
    return False
