"""Wall-clock bounds in tests, scaled by how fast this machine runs at the moment.

A wall-clock bound in a test (a subprocess or queue timeout, a ``time.monotonic()`` deadline, a "returned
within" check) is there to stop a hang, not to measure speed: speed figures belong in bench/. Where the code
under test takes a bound in sim seconds (``--stall-after-s``, the planner's and agents' timeouts), a test
uses that. Every other bound is written ``bound_s(base_s)``: ``base_s`` is the bound on the reference
machine (2 cores, nothing else running), and :func:`speed_factor` scales it to this machine now.

The factor is measured, not configured: a fixed CPU-bound pure-Python workload (:func:`reference_work`)
is timed three times and the median's ratio to :data:`REFERENCE_WORK_S` (its time on the reference machine)
is taken. A process measures again when its last measurement is over :data:`REMEASURE_S` old and keeps the
largest factor it saw, so that a build started beside the suite halfway through still widens the later
bounds. The measured factor is at least 1 and at most :data:`MAX_FACTOR` (a hang must still end); the
environment variable ``BIMBOT_TEST_SLOWDOWN`` sets a floor (e.g. 3 for a run under a tracer). pytest's
header prints the factor.
"""

from __future__ import annotations

import os
import statistics
import threading
import time

# The workload's wall time on the reference machine: its CPU time (time.thread_time), which is what its
# wall time is when it has a core to itself, measured on the 2-core machine CI runs on.
REFERENCE_WORK_S = 0.10
REFERENCE_ITERATIONS = 1_500_000
REMEASURE_S = 30.0
MAX_FACTOR = 10.0
SLOWDOWN_ENV = "BIMBOT_TEST_SLOWDOWN"


def reference_work(iterations: int = REFERENCE_ITERATIONS) -> int:
    """The fixed workload: integer arithmetic in the interpreter, no allocation, no I/O."""
    total = 0
    for i in range(iterations):
        total = (total * 31 + i) % 1_000_003
    return total


def measure_factor() -> float:
    """This machine's slowness now: the median of three timed workloads over the reference time."""
    times_s = []
    for _ in range(3):
        started = time.perf_counter()
        reference_work()
        times_s.append(time.perf_counter() - started)
    return statistics.median(times_s) / REFERENCE_WORK_S


def _floor() -> float:
    value = os.environ.get(SLOWDOWN_ENV, "1")
    try:
        return max(1.0, float(value))
    except ValueError:
        raise ValueError(f"{SLOWDOWN_ENV}={value!r} is not a number (a factor, e.g. 3)") from None


class _Measured:
    """The largest factor this process measured, and when it last measured."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.factor = 0.0
        self.at = float("-inf")


_MEASURED = _Measured()


def speed_factor() -> float:
    """How many times longer than on the reference machine a wall-clock bound should be (1 to MAX_FACTOR,
    or the floor ``BIMBOT_TEST_SLOWDOWN`` sets)."""
    with _MEASURED.lock:
        if time.monotonic() - _MEASURED.at >= REMEASURE_S:
            _MEASURED.factor = max(_MEASURED.factor, measure_factor())
            _MEASURED.at = time.monotonic()
        return max(_floor(), min(MAX_FACTOR, _MEASURED.factor))


def bound_s(base_s: float) -> float:
    """A wall-clock bound of ``base_s`` on the reference machine, scaled to this machine now."""
    return base_s * speed_factor()
