"""Lock-step puts block instead of dropping: over a real Zenoh link to a subscriber that falls behind (as a
service on a loaded machine does), Zenoh's default put loses messages once its queue stays full, and
:data:`bimbot.shared.bus.LOCK_STEP_PUT` delivers every one, in order. A message dropped in a lock-step run
and sent again later is taken at another step, and two runs of one seed part."""

from __future__ import annotations

import socket
import time
from collections.abc import Mapping
from typing import Any

import zenoh

from bimbot.shared.bus import LOCK_STEP_PUT

MESSAGES, PAD = 2000, b"x" * 20_000  # 40 MB: far more than the link's queues hold
SLOW_S = 0.0005  # the subscriber's work per message


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _config(**entries: str) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    for path, value in entries.items():
        config.insert_json5(path.replace("__", "/"), value)
    return config


def _delivered(options: Mapping[str, Any]) -> list[int]:
    """What a slow subscriber receives of ``MESSAGES`` puts made with ``options``."""
    endpoint = f'["tcp/127.0.0.1:{_free_port()}"]'
    sender = zenoh.open(_config(listen__endpoints=endpoint))
    receiver = zenoh.open(_config(connect__endpoints=endpoint, listen__endpoints="[]"))
    got: list[int] = []

    def on_sample(sample: zenoh.Sample) -> None:
        got.append(int(sample.payload.to_bytes()[:8]))
        time.sleep(SLOW_S)

    subscriber = receiver.declare_subscriber("bimbot/test/lock-step", on_sample)
    try:
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:  # the subscription has reached the sender
            matching = sender.declare_publisher("bimbot/test/lock-step")
            ready = matching.matching_status.matching  # type: ignore[attr-defined]
            matching.undeclare()
            if ready:
                break
            time.sleep(0.05)
        for index in range(MESSAGES):
            sender.put("bimbot/test/lock-step", b"%08d" % index + PAD, **options)
        deadline = time.monotonic() + 30.0
        last = -1
        while time.monotonic() < deadline:  # until nothing more comes
            time.sleep(0.5)
            if len(got) == last or len(got) == MESSAGES:
                break
            last = len(got)
        return list(got)
    finally:
        subscriber.undeclare()
        receiver.close()
        sender.close()


def test_a_lock_step_put_reaches_a_subscriber_that_falls_behind_where_the_default_put_drops() -> None:
    dropped = _delivered({})
    blocked = _delivered(LOCK_STEP_PUT)
    assert len(dropped) < MESSAGES, "the default put drops once the queue stays full"
    assert blocked == list(range(MESSAGES)), "every lock-step message arrives, in order"
