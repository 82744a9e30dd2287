"""Set a :class:`threading.Event` from a signal handler without ever blocking the process.

Python runs a signal handler in the main thread, between two bytecodes of whatever it was doing. A handler
that calls ``event.set()`` takes the event's lock; when the main thread already holds that lock (it is
inside ``event.wait()`` reacquiring it, or inside the first handler's ``event.set()`` when a second signal
lands), the lock is not reentrant and the main thread waits for itself forever. Seen: a bus router left
running for 35 minutes after its run was killed, its main thread five handlers deep in ``Event.set``; and
two Ctrl-C in a row could do the same to ``bimbot run`` waiting on its viewer.

So the handler only writes a byte to a pipe (one system call, no lock), and a small daemon thread that
reads the pipe sets the event; if the main thread holds the lock, that thread waits until it lets go.
That thread blocks the stop signals itself: the kernel hands a process's signal to any thread that does not
block it, and Python runs the handler only when the main thread next runs Python code, so a signal taken by
a thread that then sleeps in ``read`` would wait there; for the same reason a main thread must not wait
without a bound (:func:`wait_stop`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager

STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)
WAKE_S = 0.25  # a main thread waiting for a stop looks at its pending signal handlers this often


class SignalEvent:
    """``event``, set by :meth:`request` — safe to call from a signal handler, any number of times. Its
    thread blocks ``signums``, the signals whose handlers call :meth:`request`."""

    def __init__(self, event: threading.Event, signums: Collection[int] = STOP_SIGNALS) -> None:
        self.event = event
        self._signums = set(signums)
        self._read_fd, self._write_fd = os.pipe()
        os.set_blocking(self._write_fd, False)  # a full pipe already holds a request: drop this one
        self._watcher = threading.Thread(target=self._watch, name="signal-event", daemon=True)
        self._watcher.start()

    def request(self) -> None:
        """Ask for the event to be set (from a handler: no lock taken, returns at once)."""
        with contextlib.suppress(OSError):  # full (a request is pending) or closed (shutting down)
            os.write(self._write_fd, b"\0")

    def close(self) -> None:
        """Stop the watcher (requests made before are still applied)."""
        with contextlib.suppress(OSError):
            os.close(self._write_fd)
        self._watcher.join(timeout=5.0)
        with contextlib.suppress(OSError):
            os.close(self._read_fd)

    def _watch(self) -> None:
        signal.pthread_sigmask(signal.SIG_BLOCK, self._signums)  # delivered to a thread that runs handlers
        while True:
            try:
                data = os.read(self._read_fd, 64)
            except OSError:
                return
            if not data:  # the write end closed: no more requests
                return
            self.event.set()


@contextmanager
def stop_handlers(
    event: threading.Event,
    signums: Collection[int] = STOP_SIGNALS,
    on_signal: Callable[[int], None] | None = None,
) -> Iterator[None]:
    """For the ``with`` block, ``signums`` set ``event`` through a :class:`SignalEvent`, after
    ``on_signal(signum)`` if given (it must take no lock); the previous handlers come back after. Outside
    the main thread (Python allows no handlers there) nothing is installed: the event's holder sets it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    setter = SignalEvent(event, signums)

    def handle(signum: int, _frame: object) -> None:
        if on_signal is not None:
            on_signal(signum)
        setter.request()

    previous = {signum: signal.signal(signum, handle) for signum in signums}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        setter.close()


def wait_stop(stop: threading.Event, seconds: float | None = None) -> bool:
    """``stop.wait(seconds)`` in slices of :data:`WAKE_S`, so the main thread runs a signal handler that is
    due (a signal another thread received sets no event until then); whether ``stop`` is set."""
    deadline = None if seconds is None else time.monotonic() + seconds
    while True:
        left = WAKE_S if deadline is None else min(WAKE_S, deadline - time.monotonic())
        if left <= 0.0:
            return stop.is_set()
        if stop.wait(left):
            return True
