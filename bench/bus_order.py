"""Does Zenoh deliver one session's messages in the order they were put? The ground of lock-step runs'
"every put through the session" (docs/architecture.md, "Same seed, same outcome").

Run: ``.venv/bin/python bench/bus_order.py [--messages 20000]``. A router on a free loopback port, a
client (each with the config a bimbot service uses) that puts numbered messages on three keys, a
client subscribed to all three; for each way of putting (one declared publisher; session puts on several
keys; two declared publishers; a publisher and session puts mixed) and each way of calling the subscribers
back (zenoh-python's default, a Python thread per subscriber; or on the receiving thread, as
:func:`bimbot.shared.bus.in_arrival_order` does) it prints how many messages came after a later-numbered
one (inversions) and how many never came. The inversions come from the receiver's threads, not the
sender: on two loaded cores, 51-355 of 20,000 with a thread per subscriber for the ways that put on two
subscribers' keys, 0 for every way on the receiving thread (and none lost).
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import queue
import time

import zenoh

from bimbot.shared.bus import BusOptions, zenoh_config
from bimbot.supervisor import free_port

QUIET_S = 3.0  # a message that has not come this long after the one before never comes


def _config(mode: str, *, connect: str = "", listen: str = "") -> zenoh.Config:
    """The Zenoh config a bimbot service of ``mode`` uses (its drop wait, its retries)."""
    return zenoh_config(
        BusOptions(mode=mode, connect=(connect,) if connect else (), listen=(listen,) if listen else ())
    )


def measure(way: str, count: int, *, in_arrival: bool) -> tuple[int, int]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with zenoh.open(_config("router", listen=endpoint)):
        time.sleep(0.3)
        with (
            zenoh.open(_config("client", connect=endpoint)) as sender,
            zenoh.open(_config("client", connect=endpoint)) as receiver,
        ):
            got: queue.Queue[int] = queue.Queue()
            subscribers = [
                receiver.declare_subscriber(
                    key,
                    zenoh.handlers.Callback(
                        lambda s: got.put(int(s.payload.to_string())), indirect=not in_arrival
                    ),
                )
                for key in ("order/a", "order/b", "order/c/*")
            ]
            time.sleep(0.3)
            first, second = sender.declare_publisher("order/a"), sender.declare_publisher("order/b")
            puts = {
                "one publisher": lambda i: first.put(str(i)),
                "session puts": lambda i: sender.put(f"order/c/{i % 7}", str(i)),
                "two publishers": lambda i: (first if i % 2 else second).put(str(i)),
                "publisher and session": lambda i: (
                    first.put(str(i)) if i % 2 else sender.put("order/b", str(i))
                ),
            }
            for index in range(count):
                puts[way](index)
            numbers = []
            with contextlib.suppress(queue.Empty):  # until nothing more comes for QUIET_S
                while len(numbers) < count:
                    numbers.append(got.get(timeout=QUIET_S))
            del subscribers
    inversions = sum(1 for x, y in itertools.pairwise(numbers) if y < x)
    return inversions, count - len(set(numbers))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=20_000)
    args = parser.parse_args()
    for in_arrival in (False, True):
        callbacks = "on the receiving thread" if in_arrival else "a thread per subscriber"
        for way in ("one publisher", "session puts", "two publishers", "publisher and session"):
            inversions, missing = measure(way, args.messages, in_arrival=in_arrival)
            print(
                f"{callbacks}, {way}: {inversions} of {args.messages} came after a later one, "
                f"{missing} never came"
            )


if __name__ == "__main__":
    main()
