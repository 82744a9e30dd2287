"""Does Zenoh deliver one session's messages in the order they were put? The ground of lock-step runs'
"every put through the session" (docs/architecture.md, "Same seed, same outcome").

Run: ``.venv/bin/python bench/bus_order.py [--messages 20000]``. A router on a free loopback port, a
client that puts numbered messages on three keys, a client subscribed to all three; for each way of
putting (one declared publisher; session puts on several keys; two declared publishers; a publisher and
session puts mixed) it prints how many messages came after a later-numbered one (inversions) and how many
never came. Measured on two loaded cores (load 8–30): 0 inversions for one publisher and for session puts,
51–244 of 20,000 for two publishers or a mix.
"""

from __future__ import annotations

import argparse
import itertools
import json
import queue
import time

import zenoh

from bimbot.supervisor import free_port


def _config(mode: str, **endpoints: str) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("scouting/multicast/enabled", "false")
    for option, endpoint in endpoints.items():
        config.insert_json5(f"{option}/endpoints", json.dumps([endpoint]))
    return config


def measure(way: str, count: int) -> tuple[int, int]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with zenoh.open(_config("router", listen=endpoint)):
        time.sleep(0.3)
        with (
            zenoh.open(_config("client", connect=endpoint)) as sender,
            zenoh.open(_config("client", connect=endpoint)) as receiver,
        ):
            got: queue.Queue[int] = queue.Queue()
            subscribers = [
                receiver.declare_subscriber(key, lambda sample: got.put(int(sample.payload.to_string())))
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
            time.sleep(2.0)
            numbers = []
            while not got.empty():
                numbers.append(got.get())
            del subscribers
    inversions = sum(1 for x, y in itertools.pairwise(numbers) if y < x)
    return inversions, count - len(set(numbers))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=20_000)
    args = parser.parse_args()
    for way in ("one publisher", "session puts", "two publishers", "publisher and session"):
        inversions, missing = measure(way, args.messages)
        print(f"{way}: {inversions} of {args.messages} came after a later one, {missing} never came")


if __name__ == "__main__":
    main()
