"""What the viewer shows where: the layout (blueprint) and the static scene around the twin.

* :func:`observer_blueprint` — the 3D twin on the left; "% constructed", "components by state" and the
  text log on the right; the ``sim_time`` timeline selected. Sent as the recording's default blueprint
  (``set_sinks(..., default_blueprint=…)``), so a viewer that connects live, or opens the ``.rrd`` later,
  starts with this layout; users can rearrange it ("reset blueprint" brings it back).
* :func:`site_items` / :func:`series_items` — static log items, logged once per run: Z-up view
  coordinates, the site physics planned and serves with its site info (building footprint, yard, depot
  and each tower crane's staging area — where ground robots put loads down for it — as outlines, and the
  fence; logged once physics answered), the BIM bounding box of every component as a
  faint wireframe ("what is left to build"), and the style of every progress series (one colour per
  state, from :data:`.twin_log.STATE_COLORS`).
"""

from __future__ import annotations

from collections.abc import Iterable

import rerun as rr
import rerun.blueprint as rrb

from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentState, SiteInfoMsg
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_plan import FENCE_HEIGHT_M, FENCE_THICKNESS_M, Rect, SiteLayout
from bimbot.shared.state_colors import STATE_COLORS

from .twin_items import SITE_LINE_Z_M, TIMELINE, LogItem


def site_eye(components: Iterable[Component]) -> rrb.EyeControls3D | None:
    """Where the 3D view's camera starts: south-west of the building, above it, looking at its centre
    from far enough to see the yard south of it. Without it the viewer fits its camera to every entity,
    a tower crane's 32 m mast included, and opens on a close-up of the mast."""
    boxes = [component.bbox_world for component in components]
    if not boxes:
        return None
    low = [min(box.min_m[axis] for box in boxes) for axis in range(3)]
    high = [max(box.max_m[axis] for box in boxes) for axis in range(3)]
    centre = [(low[axis] + high[axis]) / 2.0 for axis in range(2)]
    span = max(high[0] - low[0], high[1] - low[1], EYE_MIN_SPAN_M)
    target = (centre[0], centre[1] - 0.35 * span, 0.0)  # between the building and the yard
    position = (target[0] - 0.9 * span, target[1] - 1.6 * span, 1.2 * span)
    return rrb.EyeControls3D(position=position, look_target=target, eye_up=(0.0, 0.0, 1.0))


EYE_MIN_SPAN_M = 15.0  # a small model's site (yard, depot, crane) is still this wide


def observer_blueprint(site: str, components: Iterable[Component] = ()) -> rrb.Blueprint:
    """3D view of ``world`` (its camera from :func:`site_eye`), "% constructed" and "components by state"
    plots, and the log."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name=f"site {site}", eye_controls=site_eye(components)),
            rrb.Vertical(
                rrb.TimeSeriesView(
                    origin="progress/percent_constructed",
                    name="% constructed",
                    axis_y=rrb.ScalarAxis(range=(0.0, 100.0)),
                ),
                rrb.TimeSeriesView(origin="progress/components", name="components by state"),
                rrb.TextLogView(origin="log", name="log"),
                row_shares=[1.0, 1.0, 2.0],
            ),
            column_shares=[2.0, 1.0],
        ),
        rrb.TimePanel(timeline=TIMELINE, expanded=True),
        rrb.BlueprintPanel(expanded=False),
        rrb.SelectionPanel(expanded=False),
        collapse_panels=False,
    )


def rect_strip(rect: Rect, z_m: float = SITE_LINE_Z_M) -> list[tuple[float, float, float]]:
    (x0, y0), (x1, y1) = rect.min_xy, rect.max_xy
    return [(x0, y0, z_m), (x1, y0, z_m), (x1, y1, z_m), (x0, y1, z_m), (x0, y0, z_m)]


STAGING_COLOR = (233, 30, 99, 255)  # pink: not a colour of any state


def cranes_of(info: SiteInfoMsg) -> list[str]:
    """The tower cranes' robot ids in robot id order (the order of ``SiteLayout.staging``)."""
    types = info.robot_types
    return [
        robot_id
        for robot_id in info.robot_ids
        if (name := info.robot_type_of.get(robot_id)) in types and types[name].can(Capability.HOOK_LIFT)
    ]


def site_items(
    layout: SiteLayout, components: Iterable[Component], cranes: list[str] | None = None
) -> list[LogItem]:
    """The static scene: coordinates, site outlines (staging areas labelled with their crane, from
    ``cranes``, robot ids in the order of ``layout.staging``), fence walls and the BIM target boxes."""
    areas = {"building": layout.building, "yard": layout.yard, "depot": layout.depot}
    colors = {"building": (46, 160, 67, 255), "yard": (255, 193, 7, 255), "depot": (33, 150, 243, 255)}
    items = [LogItem("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)]
    for name, rect in areas.items():
        items.append(
            LogItem(
                f"world/site/{name}",
                rr.LineStrips3D([rect_strip(rect)], colors=[colors[name]], radii=0.03, labels=[name]),
                static=True,
            )
        )
    if layout.staging:
        crane_ids = list(cranes or [])
        labels = [
            f"staging {crane_ids[index]}" if index < len(crane_ids) else f"staging {index + 1}"
            for index in range(len(layout.staging))
        ]
        items.append(
            LogItem(
                "world/site/staging",
                rr.LineStrips3D(
                    [rect_strip(rect) for rect in layout.staging],
                    colors=[STAGING_COLOR],
                    radii=0.05,
                    labels=labels,
                ),
                static=True,
            )
        )
    inner = layout.fence
    t = FENCE_THICKNESS_M
    (x0, y0), (x1, y1) = inner.min_xy, inner.max_xy
    walls = [  # min corner, size: south, north, west, east
        ((x0 - t, y0 - t, 0.0), (x1 - x0 + 2 * t, t, FENCE_HEIGHT_M)),
        ((x0 - t, y1, 0.0), (x1 - x0 + 2 * t, t, FENCE_HEIGHT_M)),
        ((x0 - t, y0, 0.0), (t, y1 - y0, FENCE_HEIGHT_M)),
        ((x1, y0, 0.0), (t, y1 - y0, FENCE_HEIGHT_M)),
    ]
    items.append(
        LogItem(
            "world/site/fence",
            rr.Boxes3D(
                mins=[w[0] for w in walls],
                sizes=[w[1] for w in walls],
                colors=[(140, 110, 80, 160)],
                fill_mode="solid",
            ),
            static=True,
        )
    )
    boxes = list(components)
    if boxes:
        items.append(
            LogItem(
                "world/targets",
                rr.Boxes3D(
                    mins=[c.bbox_world.min_m for c in boxes],
                    sizes=[
                        [hi - lo for lo, hi in zip(c.bbox_world.min_m, c.bbox_world.max_m, strict=True)]
                        for c in boxes
                    ],
                    colors=[(200, 200, 200, 60)],
                    radii=0.005,
                ),
                static=True,
            )
        )
    return items


def series_items() -> list[LogItem]:
    """Static styles of the progress plots: one line per state, in the state's colour."""
    items = [
        LogItem(
            "progress/percent_constructed",
            rr.SeriesLines(
                colors=[STATE_COLORS[ComponentState.CONSTRUCTED]],
                names=["% constructed"],
                widths=2.0,
                interpolation_mode="StepAfter",
            ),
            static=True,
        )
    ]
    items += [
        LogItem(
            f"progress/components/{state.value}",
            rr.SeriesLines(colors=[color], names=[state.value], interpolation_mode="StepAfter"),
            static=True,
        )
        for state, color in STATE_COLORS.items()
    ]
    return items
