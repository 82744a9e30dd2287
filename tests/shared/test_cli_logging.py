"""The services' logs: the transitions library's INFO line for every state entry and exit (most of a
robot's log, thousands of lines a second in the agents) is left out unless ``-v`` asks for debug."""

from __future__ import annotations

import logging

import pytest

from bimbot.cli import configure_logging


@pytest.mark.parametrize(("verbosity", "shown"), [(-1, False), (0, False), (1, True)])
def test_state_machine_chatter_is_left_out_of_the_logs_unless_debugging(verbosity: int, shown: bool) -> None:
    chatter = logging.getLogger("transitions.core")
    logging.getLogger("transitions").setLevel(logging.NOTSET)
    root = logging.getLogger()
    level = root.level
    try:
        configure_logging(verbosity)
        root.setLevel(logging.DEBUG if verbosity > 0 else logging.INFO)  # basicConfig acts only once
        assert chatter.isEnabledFor(logging.INFO) is shown
        assert chatter.isEnabledFor(logging.WARNING)
    finally:
        root.setLevel(level)
        logging.getLogger("transitions").setLevel(logging.NOTSET)
