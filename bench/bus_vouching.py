"""Does physics' clock come after every input it vouches for? The ground of lock-step runs' "nobody hears
anyone else's answer" (:mod:`bimbot.shared.step_gate`, docs/architecture.md "Same seed, same outcome").

Run: ``.venv/bin/python bench/bus_vouching.py [--steps 5000] [--load 4]``. Routers on free loopback ports
(one, or two linked as ``bimbot run --routers 2`` links them), clients with the config a bimbot service
uses: four participants, each putting three outputs (on three keys, through declared publishers) and then
its answer for every step; a "physics" client that puts clock step ``i`` once it has heard every answer to
``i``; a consumer subscribed to the outputs and the clock, called back on the receiving thread as the
services are. On each clock the consumer counts the outputs of steps up to ``i`` that have not reached it
yet: a clock that overtook an input it vouches for. With ``--load N``, N busy processes share the cores.
Measured on two cores with a load of 4 (``--steps 4000 --load 4``): in each of the five layouts, all
4,000 clocks and 48,000 outputs heard, and no output missing when a clock that vouches for it came.
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing
import threading
import time

import zenoh

from bimbot.shared.bus import BusOptions, in_arrival_order, zenoh_config
from bimbot.supervisor import free_port

PARTICIPANTS = 4
OUTPUTS = 3  # outputs per participant and step, each on its own key
# which router each client joins (0 or 1): the participants, physics, the consumer
LAYOUTS = {
    "one router": ((0, 0, 0, 0), 0, 0),
    "two routers, the consumer apart": ((0, 0, 0, 0), 0, 1),
    "two routers, physics apart": ((0, 0, 0, 0), 1, 0),
    "two routers, participants split": ((0, 1, 0, 1), 0, 1),
    "two routers, physics with half": ((0, 1, 1, 1), 0, 1),
}


def _config(mode: str, *, connect: str = "", listen: str = "") -> zenoh.Config:
    return zenoh_config(
        BusOptions(mode=mode, connect=(connect,) if connect else (), listen=(listen,) if listen else ())
    )


def measure(layout: str, steps: int) -> tuple[int, int, int]:
    """(clocks heard, outputs heard, outputs missing when a clock that vouches for them came)."""
    where, physics_at, consumer_at = LAYOUTS[layout]
    endpoints = [f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"]
    with contextlib.ExitStack() as stack:
        stack.enter_context(zenoh.open(_config("router", listen=endpoints[0])))
        stack.enter_context(zenoh.open(_config("router", listen=endpoints[1], connect=endpoints[0])))
        time.sleep(0.5)

        def client(router: int) -> zenoh.Session:
            return stack.enter_context(zenoh.open(_config("client", connect=endpoints[router])))

        participants = [client(router) for router in where]
        physics, consumer = client(physics_at), client(consumer_at)
        heard: set[tuple[int, int, int]] = set()
        counts = {"clocks": 0, "missing": 0}

        def on_output(sample: zenoh.Sample) -> None:
            heard.add(tuple(int(part) for part in sample.payload.to_string().split(":")))  # type: ignore[arg-type]

        def on_clock(sample: zenoh.Sample) -> None:
            step = int(sample.payload.to_string())
            counts["clocks"] += 1
            counts["missing"] += sum(
                (p, step, o) not in heard for p in range(PARTICIPANTS) for o in range(OUTPUTS)
            )

        stack.callback(consumer.declare_subscriber("vouch/out/**", in_arrival_order(on_output)).undeclare)
        stack.callback(consumer.declare_subscriber("vouch/clock", in_arrival_order(on_clock)).undeclare)
        answered: dict[int, int] = {}
        changed = threading.Condition()

        def on_answer(sample: zenoh.Sample) -> None:
            participant, step = (int(part) for part in sample.payload.to_string().split(":"))
            with changed:
                answered[participant] = step
                changed.notify_all()

        stack.callback(physics.declare_subscriber("vouch/answer/*", in_arrival_order(on_answer)).undeclare)
        clock = physics.declare_publisher("vouch/clock")
        time.sleep(0.5)

        def participate(index: int) -> None:
            session = participants[index]
            outputs = [session.declare_publisher(f"vouch/out/{index}/{o}") for o in range(OUTPUTS)]
            answer = session.declare_publisher(f"vouch/answer/{index}")
            for step in range(steps):
                for o, publisher in enumerate(outputs):
                    publisher.put(f"{index}:{step}:{o}")
                answer.put(f"{index}:{step}")
                time.sleep(0.0001)

        def tick() -> None:
            for step in range(steps):
                with changed:
                    changed.wait_for(lambda at=step: _all_answered(answered, at), timeout=10)
                clock.put(str(step))

        threads = [threading.Thread(target=participate, args=(i,)) for i in range(PARTICIPANTS)]
        threads.append(threading.Thread(target=tick))
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        time.sleep(2.0)  # the last clocks
        return counts["clocks"], len(heard), counts["missing"]


def _all_answered(answered: dict[int, int], step: int) -> bool:
    return len(answered) == PARTICIPANTS and min(answered.values()) >= step


def _busy() -> None:
    while True:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--load", type=int, default=0, help="busy processes beside it")
    args = parser.parse_args()
    load = [multiprocessing.Process(target=_busy, daemon=True) for _ in range(args.load)]
    for process in load:
        process.start()
    try:
        for layout in LAYOUTS:
            clocks, outputs, missing = measure(layout, args.steps)
            print(
                f"{layout}: {clocks} of {args.steps} clocks heard, {outputs} of "
                f"{args.steps * PARTICIPANTS * OUTPUTS} outputs; "
                f"{missing} output(s) not there yet when a clock that vouches for them came"
            )
    finally:
        for process in load:
            process.terminate()


if __name__ == "__main__":
    main()
