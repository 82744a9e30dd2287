"""A context-managed pybullet client, so no code relies on pybullet's global default client.

Every pybullet call in bimbot passes ``physicsClientId=client.id``. ``DIRECT`` needs no display and runs
as fast as the CPU allows; ``GUI`` is for looking at a scene by hand. pybullet's C++ side prints its
banner and URDF importer warnings straight to file descriptors 1 and 2, past Python's logging;
:func:`quiet_stdout` silences them around the few calls that print (import, connect, loadURDF).
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
from collections.abc import Callable, Iterator
from types import ModuleType, TracebackType

_log = logging.getLogger(__name__)


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Send file descriptors 1 and 2 to /dev/null for the duration: pybullet's C++ prints (its banner,
    URDF importer warnings) bypass Python. Keep the block small: Python errors raised inside still
    propagate, but nothing printed inside is seen."""
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
    except (OSError, ValueError, AttributeError):  # no real descriptors (embedded, captured): just run
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        for descriptor, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, descriptor)
            os.close(copy)


CLIENT_FORGETTERS: list[Callable[[int], None]] = []
"""What keeps state per pybullet client id registers here how to drop it (:mod:`.ray_scene`'s records): a
client that connects or closes forgets what an earlier client of its id left."""


def import_pybullet() -> ModuleType:
    """``import pybullet`` without its build-time banner on standard output."""
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    with quiet_stdout():
        import pybullet
    return pybullet


p = import_pybullet()


class BulletClient:
    """``with BulletClient() as client:`` connects a physics server (DIRECT by default) and disconnects it.

    ``client.id`` is the ``physicsClientId`` to pass to every pybullet call.
    """

    def __init__(self, mode: int | None = None) -> None:
        self.mode = p.DIRECT if mode is None else mode
        self._id: int | None = None

    @property
    def id(self) -> int:
        if self._id is None:
            raise RuntimeError("pybullet client is not connected (use it in a with block)")
        return self._id

    @property
    def connected(self) -> bool:
        return self._id is not None and bool(p.isConnected(physicsClientId=self._id))

    def __enter__(self) -> BulletClient:
        with quiet_stdout():
            client_id = p.connect(self.mode)
        if client_id < 0:
            raise RuntimeError("could not connect a pybullet physics server")
        for forget in CLIENT_FORGETTERS:  # what an earlier client of this id left (one not closed)
            forget(client_id)
        self._id = client_id
        _log.debug("pybullet client %d connected", client_id)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        if self._id is not None:
            for forget in CLIENT_FORGETTERS:  # pybullet gives the next client this id again
                forget(self._id)
            if p.isConnected(physicsClientId=self._id):
                p.disconnect(physicsClientId=self._id)
            _log.debug("pybullet client %d disconnected", self._id)
            self._id = None
