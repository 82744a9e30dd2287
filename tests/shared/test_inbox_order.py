"""One sender's messages on several keys reach a lock-step participant's inbox in the order they were put.

Lock-step runs take a participant's outputs once its answer to the step is heard; an answer that
overtook the messages before it (each subscriber on a Python thread of its own) let them be taken a
step late, and two runs of one seed drove apart.
"""

from __future__ import annotations

import time

from wall_clock import bound_s

from bimbot.shared.bus import BusOptions, Inbox, RawSample, open_session
from bimbot.supervisor import free_port

MESSAGES = 10_000


def test_messages_put_on_two_keys_are_drained_in_the_order_they_were_put() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        open_session(BusOptions(mode="peer", connect=(), listen=(endpoint,))) as receiver,
        open_session(BusOptions(mode="peer", connect=(endpoint,), listen=())) as sender,
    ):
        inbox = Inbox(in_order=True)
        subscribers = [inbox.subscribe_raw(receiver, key) for key in ("order/state", "order/answer")]
        publishers = [sender.declare_publisher(key) for key in ("order/state", "order/answer")]
        time.sleep(0.3)  # the subscriptions have reached the sender
        for number in range(MESSAGES):
            publishers[number % 2].put(str(number))
        heard: list[int] = []
        deadline = time.monotonic() + bound_s(10.0)
        while len(heard) < MESSAGES and time.monotonic() < deadline:
            for item in inbox.drain(first_timeout_s=0.1):
                assert isinstance(item, RawSample)
                heard.append(int(item.payload.decode()))
        assert len(subscribers) == 2
        assert len(heard) == MESSAGES
        assert heard == sorted(heard)
