"""The compact binary layout of the high-rate bus messages (a topic marked ``binary`` in the registry).

Why: physics sends every robot its clock step, odometry and laser scan each control period. As JSON a
180-beam scan is 2.4 kB of decimal text; here the whole :class:`~bimbot.shared.messages.SensorsMsg` is
about 0.9 kB (ranges as float32, rounded back to 10 µm on decoding, which gives physics' millimetre
ranges back exactly). The
pydantic models stay the schema: :func:`decode` unpacks the bytes into the model's fields and validates
them like any JSON payload (bounds included, :mod:`bimbot.shared.message_bounds`), so a binary topic is
checked exactly as strictly as a JSON one. No numpy here: every service loads this module with the bus,
and the agents' processes stay free of numpy.

Layout of a ``SensorsMsg`` (little-endian): ``b"BS"``, layout version (u8), schema version (u8), robot id
(u8 length + UTF-8); clock: sim time (f64), step (i64), real-time factor (f64), lock-step (u8), epoch
(i64), a flag (u8) and the time its inputs are vouched for up to (f64), a flag (u8) and the latest wake
step (i64); odometry: x, y, yaw, v, w, sim time (6 × f64); a scan flag (u8), and with a scan: angle min,
angle increment, range max, sim time (4 × f64), beam count (u32), ranges (f32 each; +inf is "no return");
a fix flag (u8), and with a position fix: x, y, standard deviation, yaw, its standard deviation, sim time
(6 × f64). Layout 2 added the fix, layout 3 the clock's inputs time and wake step; both ends are this
codebase, so a payload of an older layout is refused like any other foreign bytes.
"""

from __future__ import annotations

import struct
from typing import Any, Final

from pydantic import BaseModel

from .messages import SensorsMsg

MAGIC: Final = b"BS"
LAYOUT_VERSION: Final = 3
_HEAD = struct.Struct("<2sBBB")  # magic, layout, schema version, robot id length
_CLOCK = struct.Struct("<dqdBqBdBq")
_ODOM = struct.Struct("<6d")
_SCAN = struct.Struct("<4dI")
_FLAG = struct.Struct("<B")
_FIX = struct.Struct("<6d")


class WireError(ValueError):
    """Bytes that are not a message of the expected layout (the bus counts them as invalid)."""


def is_binary(model: type[BaseModel]) -> bool:
    return model is SensorsMsg


def encode_sensors(message: SensorsMsg) -> bytes:
    robot = message.robot_id.encode("utf-8")
    if len(robot) > 255:
        raise WireError(f"robot id of {len(robot)} bytes does not fit the layout (255 at most)")
    clock, odom, scan = message.clock, message.odom, message.scan
    parts = [
        _HEAD.pack(MAGIC, LAYOUT_VERSION, message.schema_version, len(robot)),
        robot,
        _CLOCK.pack(
            clock.sim_time_s,
            clock.step,
            clock.real_time_factor,
            clock.lock_step,
            clock.epoch,
            clock.inputs_to_s is not None,
            clock.inputs_to_s or 0.0,
            clock.last_wake_step is not None,
            clock.last_wake_step or 0,
        ),
        _ODOM.pack(*odom.pose_xy_yaw, odom.v_mps, odom.w_radps, odom.sim_time_s),
        _FLAG.pack(scan is not None),
    ]
    if scan is not None:
        ranges = scan.ranges_m
        parts.append(
            _SCAN.pack(
                scan.angle_min_rad, scan.angle_increment_rad, scan.range_max_m, scan.sim_time_s, len(ranges)
            )
        )
        parts.append(struct.pack(f"<{len(ranges)}f", *ranges))
    fix = message.fix
    parts.append(_FLAG.pack(fix is not None))
    if fix is not None:
        parts.append(_FIX.pack(*fix.position_xy_m, fix.std_m, fix.yaw_rad, fix.yaw_std_rad, fix.sim_time_s))
    return b"".join(parts)


def decode_sensors(payload: bytes) -> SensorsMsg:
    """The validated message (pydantic's ``ValidationError`` for bad values, :class:`WireError` for bytes
    that do not fit the layout)."""
    return SensorsMsg.model_validate(sensors_fields(payload))


def sensors_fields(payload: bytes) -> dict[str, Any]:
    """The message's fields as plain data, not validated yet."""
    try:
        magic, layout, schema, robot_length = _HEAD.unpack_from(payload, 0)
        if magic != MAGIC or layout != LAYOUT_VERSION:
            raise WireError(f"not a binary SensorsMsg (starts {bytes(payload[:3])!r})")
        at = _HEAD.size
        robot_id = bytes(payload[at : at + robot_length]).decode("utf-8")
        at += robot_length
        sim_s, step, rtf, lock_step, epoch, has_inputs_to, inputs_to, has_wake, wake = _CLOCK.unpack_from(
            payload, at
        )
        at += _CLOCK.size
        x, y, yaw, v, w, odom_s = _ODOM.unpack_from(payload, at)
        at += _ODOM.size
        (has_scan,) = _FLAG.unpack_from(payload, at)
        at += _FLAG.size
        scan = None
        if has_scan:
            angle_min, increment, range_max, scan_s, count = _SCAN.unpack_from(payload, at)
            at += _SCAN.size
            end = at + 4 * count
            if len(payload) < end:
                raise WireError(f"scan of {count} beams cut short at byte {len(payload)}")
            # float32 keeps ~7 digits: rounding to 10 µm gives back physics' millimetre ranges exactly
            ranges = [round(r, 5) for r in struct.unpack_from(f"<{count}f", payload, at)]
            at = end
            scan = {
                "schema_version": schema,
                "robot_id": robot_id,
                "angle_min_rad": angle_min,
                "angle_increment_rad": increment,
                "range_max_m": range_max,
                "ranges_m": ranges,
                "sim_time_s": scan_s,
            }
        (has_fix,) = _FLAG.unpack_from(payload, at)
        at += _FLAG.size
        fix = None
        if has_fix:
            fix_x, fix_y, fix_std, fix_yaw, fix_yaw_std, fix_s = _FIX.unpack_from(payload, at)
            at += _FIX.size
            fix = {
                "schema_version": schema,
                "robot_id": robot_id,
                "position_xy_m": (fix_x, fix_y),
                "std_m": fix_std,
                "yaw_rad": fix_yaw,
                "yaw_std_rad": fix_yaw_std,
                "sim_time_s": fix_s,
            }
        if at != len(payload):
            raise WireError(f"{len(payload) - at} byte(s) after the message")
    except (struct.error, UnicodeDecodeError) as error:
        raise WireError(f"not a binary SensorsMsg ({error})") from error
    return {
        "schema_version": schema,
        "robot_id": robot_id,
        "clock": {
            "schema_version": schema,
            "sim_time_s": sim_s,
            "step": step,
            "real_time_factor": rtf,
            "lock_step": bool(lock_step),
            "epoch": epoch,
            "inputs_to_s": inputs_to if has_inputs_to else None,
            "last_wake_step": wake if has_wake else None,
        },
        "odom": {
            "schema_version": schema,
            "robot_id": robot_id,
            "pose_xy_yaw": (x, y, yaw),
            "v_mps": v,
            "w_radps": w,
            "sim_time_s": odom_s,
        },
        "scan": scan,
        "fix": fix,
    }
