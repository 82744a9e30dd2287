"""The binary layout of the high-rate sensors message: it round-trips what physics sends, is checked as
strictly as JSON (bounds, NaN), and bytes that do not fit are one counted invalid payload, not a crash."""

from __future__ import annotations

import math
import struct

import pytest

from bimbot.shared.bus import InvalidPayloads, decode, encode
from bimbot.shared.messages import ROBOT_SENSORS, ClockMsg, OdomMsg, PositionFixMsg, ScanMsg, SensorsMsg
from bimbot.shared.wire import decode_sensors


def _sensors(ranges: list[float] | None) -> SensorsMsg:
    clock = ClockMsg(sim_time_s=12.2, step=61, real_time_factor=23.5, lock_step=True, epoch=2)
    odom = OdomMsg(robot_id="r1", pose_xy_yaw=(-10.25, 3.5, 1.25), v_mps=0.8, w_radps=-0.3, sim_time_s=12.2)
    scan = (
        None
        if ranges is None
        else ScanMsg(
            robot_id="r1",
            angle_min_rad=-math.pi,
            angle_increment_rad=2 * math.pi / 179,
            range_max_m=15.0,
            ranges_m=ranges,
            sim_time_s=12.2,
        )
    )
    return SensorsMsg(robot_id="r1", clock=clock, odom=odom, scan=scan)


def test_a_scan_of_millimetre_ranges_comes_back_exactly_and_smaller_than_json() -> None:
    ranges = [round(0.3 + 0.0731 * i, 3) for i in range(179)] + [math.inf]
    message = _sensors(ranges)
    payload = encode(message)
    assert decode(SensorsMsg, "k", payload, InvalidPayloads()) == message
    assert len(payload) < 0.6 * len(message.model_dump_json())
    assert ROBOT_SENSORS.binary


def test_a_robot_without_a_laser_sends_its_clock_and_odometry_only() -> None:
    message = _sensors(None)
    assert decode_sensors(encode(message)) == message


def test_the_clock_s_lock_step_times_come_back_and_their_absence_too() -> None:
    """A sleeping robot knows its wake and what to take only from these two (shared/step_gate.py)."""
    message = _sensors(None)
    for inputs_to_s, wake in ((11.8, 40), (0.0, 0), (None, None)):
        clock = message.clock.model_copy(update={"inputs_to_s": inputs_to_s, "last_wake_step": wake})
        sent = message.model_copy(update={"clock": clock})
        assert decode_sensors(encode(sent)).clock == clock


@pytest.mark.parametrize(
    ("change", "why"),
    [
        (lambda b: b[:-5], "cut short"),
        (lambda b: b + b"\x00", "after the message"),
        (lambda b: b"XX" + b[2:], "not a binary SensorsMsg"),
        (lambda b: b"{}", "not a binary SensorsMsg"),
    ],
)
def test_bytes_that_do_not_fit_the_layout_are_one_invalid_payload(change, why: str) -> None:  # type: ignore[no-untyped-def]
    invalid = InvalidPayloads()
    assert (
        decode(SensorsMsg, "bimbot/s/robots/r1/sensors", change(encode(_sensors([1.0] * 180))), invalid)
        is None
    )
    assert invalid.total == 1


def test_values_out_of_bounds_are_rejected_as_in_json() -> None:
    payload = bytearray(encode(_sensors([1.0] * 180)))
    nan = struct.pack("<f", math.nan)
    payload[-5:-1] = nan  # the last range (before the fix flag): NaN is never a range
    invalid = InvalidPayloads()
    assert decode(SensorsMsg, "k", bytes(payload), invalid) is None and invalid.total == 1


def test_a_position_fix_travels_with_the_scan_and_is_checked_like_the_rest() -> None:
    fix = PositionFixMsg(
        robot_id="r1",
        position_xy_m=(25.125, -3.5),
        std_m=0.003,
        yaw_rad=-2.5,
        yaw_std_rad=0.004,
        sim_time_s=12.2,
    )
    message = _sensors([2.0] * 180).model_copy(update={"fix": fix})
    payload = encode(message)
    assert decode_sensors(payload) == message
    assert len(payload) == len(encode(_sensors([2.0] * 180))) + 48  # six doubles
    broken = bytearray(payload)
    broken[-16:-8] = struct.pack("<d", -0.001)  # a negative standard deviation (of the heading)
    invalid = InvalidPayloads()
    assert decode(SensorsMsg, "k", bytes(broken), invalid) is None and invalid.total == 1
