"""How one period's messages travel: each robot's clock step, odometry and scan as one message.

The core (:mod:`.simulation`) gives the clock, each robot's :class:`~bimbot.shared.messages.OdomMsg` and
:class:`~bimbot.shared.messages.ScanMsg` (both keyed on the robot's ``sensors`` key), its ground-truth pose
and the component poses. A robot needs the first three every period, so they go to it as one
:class:`~bimbot.shared.messages.SensorsMsg` (binary, :mod:`bimbot.shared.wire`): one delivery wakes it once
instead of three times. The clock also goes out on its own for everyone else (planner, agents, observer);
everything else goes out as it is, in order.
"""

from __future__ import annotations

from collections.abc import Iterable

from bimbot.shared.messages import ClockMsg, OdomMsg, PositionFixMsg, ScanMsg, SensorsMsg

from .simulation import Outgoing


def bundle(messages: Iterable[Outgoing]) -> list[Outgoing]:
    """The period's messages with each robot's odometry, scan and fix folded into one ``SensorsMsg`` (placed
    where its odometry was), stamped with the period's clock."""
    items = list(messages)
    clock = next((item.message for item in items if isinstance(item.message, ClockMsg)), None)
    if clock is None:
        return items
    scans = {item.message.robot_id: item.message for item in items if isinstance(item.message, ScanMsg)}
    fixes = {
        item.message.robot_id: item.message for item in items if isinstance(item.message, PositionFixMsg)
    }
    out: list[Outgoing] = []
    for item in items:
        message = item.message
        if isinstance(message, OdomMsg):
            robot_id = message.robot_id
            sensors = SensorsMsg(
                robot_id=robot_id,
                clock=clock,
                odom=message,
                scan=scans.get(robot_id),
                fix=fixes.get(robot_id),
            )
            out.append(Outgoing(item.key_expr, sensors))
        elif not isinstance(message, ScanMsg | PositionFixMsg):
            out.append(item)
    return out
