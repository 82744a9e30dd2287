"""Physics' site info for a made-up site, shared by the observer's report tests (a module of its own:
`conftest` is no importable name once several test folders each have one)."""

from __future__ import annotations

from bimbot.shared.fleet import default_fleet
from bimbot.shared.messages import SiteInfoMsg
from bimbot.shared.site_plan import Rect, SiteLayout


def site_info(robot_type_of: dict[str, str]) -> SiteInfoMsg:
    """Physics' site info for robots of the default fleet's types (``{"r1": "husky", …}``) on a small
    made-up site: what the report takes robot types from."""
    fleet = default_fleet()
    layout = SiteLayout(
        building=Rect((0.0, 0.0), (10.0, 10.0)),
        yard=Rect((12.0, 0.0), (18.0, 10.0)),
        depot=Rect((12.0, 12.0), (18.0, 14.0)),
        fence=Rect((-5.0, -5.0), (30.0, 20.0)),
        slots={},
        robot_starts=tuple((12.5 + i, 13.0, 0.0) for i in range(len(robot_type_of))),
    )
    return SiteInfoMsg(
        robot_ids=list(robot_type_of),
        robot_starts_xy_yaw=list(layout.robot_starts),
        robot_type_of=robot_type_of,
        robot_types={name: fleet.types[name] for name in set(robot_type_of.values())},
        step_s=0.01,
        control_period_s=0.1,
        lock_step=True,
        layout=layout,
    )
