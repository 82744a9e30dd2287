"""A signal never deadlocks a service: its handler takes no lock, however many signals land and wherever.

A bus router was found alive 35 minutes after its run had been killed, its main thread five signal
handlers deep in ``Event.set``: a handler that takes the stop event's lock while the main thread already
holds it (inside ``Event.wait``, or inside the first handler when a second signal lands) waits for itself.
And a main thread that waits without a bound never runs a handler for a signal another thread received:
the router hung on the first burst of signals once a thread of its own (the pipe's reader) could take them.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.supervisor import ServiceProcess, free_port

# A signal landing while the main thread holds the stop event's lock, made deterministic: the handler is
# called with the lock held, as Python calls it between two bytecodes of Event.wait or of a first handler.
HELD_LOCK = textwrap.dedent(
    """
    import signal, sys
    from bimbot.run.loop import StopSignals
    from bimbot.shared.service_runner import stop_on_signals

    with stop_on_signals() as stop:
        handler = signal.getsignal(signal.SIGTERM)
        with stop._cond:
            handler(signal.SIGTERM, None)
            handler(signal.SIGINT, None)
        assert stop.wait(5.0), "the service's stop event was never set"
    signals = StopSignals()
    with signals.installed():
        handler = signal.getsignal(signal.SIGINT)
        with signals.event._cond:
            handler(signal.SIGINT, None)
            handler(signal.SIGINT, None)
        assert signals.event.wait(5.0), "bimbot run's stop event was never set"
        assert signals.signum == signal.SIGINT
    print("stopped")
    """
)


def test_a_signal_landing_while_the_stop_event_is_locked_still_stops() -> None:
    result = subprocess.run(
        [sys.executable, "-c", HELD_LOCK], capture_output=True, text=True, timeout=bound_s(30), check=False
    )
    assert result.returncode == 0 and result.stdout.strip() == "stopped", result.stderr[-2000:]


def test_a_burst_of_signals_stops_a_service_cleanly(tmp_path: Path) -> None:
    bus = ServiceProcess("bus", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path)
    try:
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
        for number in range(300):  # SIGTERM and SIGINT as fast as they go, as a dying parent and a user might
            try:
                os.kill(bus.process.pid, signal.SIGTERM if number % 2 else signal.SIGINT)
            except ProcessLookupError:
                break
        code = bus.wait(timeout_s=bound_s(20.0))  # raises TimeoutExpired when it hangs
        assert "bus router stopped" in bus.log(), bus.log()  # it stopped itself, session closed
        # 0; or a signal of the burst that landed after the service had finished, while the interpreter
        # exits with its default handlers back
        assert code in {0, -signal.SIGINT, -signal.SIGTERM}, bus.log()
    finally:
        if bus.alive():
            bus.kill()
