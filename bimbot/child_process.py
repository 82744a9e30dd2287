"""What a service process and the process that starts it agree on: the environment that ties the service's
life to its starter's, the hash seed every service of a run shares, and the service's half of the tie.

A module of its own, below both sides: the starters (:mod:`bimbot.supervisor`, the fork servers) set the
environment, and the command line (:mod:`bimbot.cli`) and the forked services read it.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

STOP_WITH_PARENT_ENV = "BIMBOT_STOP_WITH_PARENT"  # the pid of the process that started the service
# Every service of a run hashes strings alike, run after run: Python salts ``hash`` per process, so a set
# iterated where it decides (which of two equal choices comes first) would differ between two runs of one
# seed. A value the user set wins.
HASH_SEED = {"PYTHONHASHSEED": "0"}
PR_SET_PDEATHSIG = 1  # prctl(2): the signal the kernel sends when the parent dies


def stop_with_parent() -> None:
    """A service started by :mod:`bimbot.supervisor` gets SIGTERM when the process that started it dies,
    even by SIGKILL (a killed ``bimbot run`` or test), so no service runs on alone forever. Linux's
    ``prctl(PR_SET_PDEATHSIG)``, set here rather than between fork and exec because the starting process
    has Zenoh's threads; a parent that died before this line is caught by the pid check."""
    parent = os.environ.pop(STOP_WITH_PARENT_ENV, None)
    if parent is None or not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        return
    if os.getppid() != int(parent):
        raise SystemExit(f"the process that started this service ({parent}) is gone")
