"""``bimbot watch [--build OUT/ | --site S]``: a live table of component states in the terminal.

Subscribes to ``bimbot/<site>/components/*/state`` and, once at start, asks every agent for its twin
(``get bimbot/<site>/components/*/twin``) so components that changed before the watch started are
shown too. On a terminal the table (GUID, name, class, construction method, state, robot) is redrawn in
place with ANSI escapes at most ``REFRESH_S`` apart, problems and work in progress first, trimmed to the
terminal's height under a count per state; when stdout is not a terminal (a pipe, a log file) it prints
one line per state change instead. With ``--build`` names, classes and methods (``lifted``, ``cast in
place``, ``laid``, …) come from the manifest; with only ``--site`` names and classes from the twins (a
twin does not carry the method: the column stays empty). Ctrl-C (or SIGTERM) ends it with exit code 0.

Writing the table to stdout is this command's job; everything else goes through logging.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import zenoh

from bimbot.shared.bus import Answer, BusOptions, Inbox, Received, add_bus_arguments, open_session
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    COMPONENT_STATE,
    COMPONENT_TWIN,
    ComponentState,
    ComponentStateMsg,
    TwinMsg,
)
from bimbot.shared.report.methods import method_word
from bimbot.shared.service_runner import resolve_build, run_service, service_bus

REFRESH_S = 0.25
# display order: what needs attention first, then work in progress, waiting, not started, done
STATE_ORDER = [
    ComponentState.FAILED,
    ComponentState.MISPLACED,
    ComponentState.VERIFYING,
    ComponentState.ASSEMBLING,
    ComponentState.POURING,
    ComponentState.FORMING,
    ComponentState.LAYING,
    ComponentState.DRIVING,
    ComponentState.TRANSPORTING,
    ComponentState.PICKING,
    ComponentState.RELEASED,
    ComponentState.PLANNED,
    ComponentState.CONSTRUCTED,
]
ANSI_COLORS = {  # SGR codes, in the spirit of the observer's state colours
    ComponentState.PLANNED: "37",
    ComponentState.RELEASED: "34",
    ComponentState.PICKING: "36",
    ComponentState.TRANSPORTING: "33",
    ComponentState.ASSEMBLING: "35",
    ComponentState.FORMING: "33",
    ComponentState.POURING: "36",
    ComponentState.LAYING: "35",
    ComponentState.DRIVING: "33",
    ComponentState.VERIFYING: "93",
    ComponentState.CONSTRUCTED: "32",
    ComponentState.MISPLACED: "31",
    ComponentState.FAILED: "1;31",
}
COLUMNS = (("GUID", 22), ("NAME", 24), ("CLASS", 16), ("METHOD", 13), ("STATE", 12), ("ROBOT", 8))
STATE_COLUMN = 4


@dataclass
class Row:
    guid: str
    name: str = ""
    ifc_class: str = ""
    method: str = ""  # as a person writes it (``cast in place``); empty without a manifest
    state: ComponentState | None = None
    robot_id: str | None = None
    sim_time_s: float = -1.0
    seen_state_msg: bool = False


class WatchTable:
    """Component rows, updated from state messages and twins; renders itself as text. No I/O."""

    def __init__(self, manifest: Manifest | None = None) -> None:
        self.rows: dict[str, Row] = {}
        for component in manifest.components if manifest else ():
            method = method_word(component.method)
            self.rows[component.guid] = Row(component.guid, component.name or "", component.ifc_class, method)

    def apply_state(self, msg: ComponentStateMsg) -> bool:
        """Take a state change; True when the row changed."""
        # An agent publishes a component's changes in order over one session, and Zenoh keeps that order;
        # sim times are no guide (senders stamp them from different clocks).
        row = self.rows.setdefault(msg.guid, Row(msg.guid))
        row.seen_state_msg = True
        changed = (row.state, row.robot_id) != (msg.state, msg.robot_id)
        row.state, row.robot_id, row.sim_time_s = msg.state, msg.robot_id, msg.sim_time_s
        return changed

    def apply_twin(self, twin: TwinMsg) -> bool:
        """Take a twin (names and classes; the state unless a state message was seen already)."""
        row = self.rows.setdefault(twin.guid, Row(twin.guid))
        row.name = row.name or twin.name or ""
        row.ifc_class = row.ifc_class or twin.ifc_class
        twin_time_s = twin.history[-1].sim_time_s if twin.history else 0.0
        if row.seen_state_msg:
            return False  # a state message already said what is newer
        changed = (row.state, row.robot_id) != (twin.state, twin.robot_id)
        row.state, row.robot_id, row.sim_time_s = twin.state, twin.robot_id, twin_time_s
        return changed

    def counts(self) -> dict[ComponentState, int]:
        result = dict.fromkeys(ComponentState, 0)
        for row in self.rows.values():
            if row.state is not None:
                result[row.state] += 1
        return result

    def render(self, height: int = 40, color: bool = True) -> list[str]:
        """The table as lines, at most ``height`` of them (a summary line, a header, then rows)."""
        counts = self.counts()
        known = sum(counts.values())
        summary = f"{len(self.rows)} components, {known} reporting: " + ", ".join(
            f"{_paint(state.value, state, color)} {counts[state]}" for state in STATE_ORDER if counts[state]
        )
        header = "  ".join(title.ljust(width) for title, width in COLUMNS).rstrip()
        rank = {state: index for index, state in enumerate(STATE_ORDER)}
        rows = sorted(
            self.rows.values(),
            key=lambda r: (rank.get(r.state, len(rank)) if r.state else len(rank), r.name, r.guid),
        )
        room = max(height - 2, 1)
        lines = [summary, header]
        shown = rows if len(rows) <= room else rows[: room - 1]
        lines += [_row_line(row, color) for row in shown]
        if len(shown) < len(rows):
            lines.append(f"… {len(rows) - len(shown)} more")
        return lines


def change_line(msg: ComponentStateMsg, row: Row | None) -> str:
    """One line per state change, for a non-terminal stdout."""
    previous = msg.previous.value if msg.previous else "-"
    name = row.name if row and row.name else "-"
    ifc_class = row.ifc_class if row and row.ifc_class else "-"
    method = f"  ({row.method})" if row and row.method else ""
    return (
        f"t={msg.sim_time_s:9.2f}s  {msg.guid}  {name}  {ifc_class}{method}  {previous} -> {msg.state.value}"
        f"  robot={msg.robot_id or '-'}"
    )


def twin_line(twin: TwinMsg) -> str:
    """The line of a component's state as its twin reported it (at start, for a non-terminal stdout)."""
    at_s = twin.history[-1].sim_time_s if twin.history else 0.0
    return (
        f"t={at_s:9.2f}s  {twin.guid}  {twin.name or '-'}  {twin.ifc_class}  (twin) {twin.state.value}"
        f"  robot={twin.robot_id or '-'}"
    )


def _paint(text: str, state: ComponentState | None, color: bool) -> str:
    return f"\x1b[{ANSI_COLORS[state]}m{text}\x1b[0m" if color and state is not None else text


def _fit(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


def _row_line(row: Row, color: bool) -> str:
    state = row.state.value if row.state else "?"
    cells = [row.guid, row.name, row.ifc_class, row.method, state, row.robot_id or ""]
    padded = [_fit(cell, width).ljust(width) for cell, (_, width) in zip(cells, COLUMNS, strict=True)]
    padded[STATE_COLUMN] = _paint(padded[STATE_COLUMN], row.state, color)
    return "  ".join(padded).rstrip()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--build", type=Path, default=None, metavar="OUT/", help="converted build (names, classes)"
    )
    parser.add_argument("--site", default=None, help="site slug (default: the build's; env BIMBOT_SITE)")
    add_bus_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Check the options (and the build, when given), then show the table until SIGINT/SIGTERM."""
    options = service_bus(args)
    build = resolve_build(args.build) if args.build else None
    manifest = build.manifest if build else None
    site = args.site or os.environ.get("BIMBOT_SITE") or (manifest.site if manifest else None)
    if not site:
        raise UserError("watch: give --build OUT/ or --site SITE")
    return run_service(main, options, site, WatchTable(manifest), sys.stdout)


def main(options: BusOptions, site: str, table: WatchTable, out: TextIO, stop: threading.Event) -> int:
    """Open the session and :func:`watch` until ``stop``; 0."""
    with open_session(options) as session:
        watch(session, site, table, stop, out)
    return 0


def watch(session: zenoh.Session, site: str, table: WatchTable, stop: threading.Event, out: TextIO) -> None:
    """Subscribe, ask for the twins once, and show changes on ``out`` until ``stop`` is set."""
    inbox = Inbox()
    subscriber = inbox.subscribe(session, COMPONENT_STATE, site=site, key="*")
    inbox.ask(session, COMPONENT_TWIN, timeout_s=5.0, site=site, key="*")
    terminal = out.isatty()
    dirty, last_draw = terminal, 0.0
    while not stop.is_set():
        for item in inbox.drain(first_timeout_s=0.1):
            match item:
                case Received(message=ComponentStateMsg() as message):
                    if table.apply_state(message) and not terminal:
                        _write(out, [change_line(message, table.rows.get(message.guid))])
                    dirty = True
                case Answer(message=TwinMsg() as twin) if table.apply_twin(twin):
                    dirty = True
                    if not terminal:
                        _write(out, [twin_line(twin)])
        if terminal and dirty and time.monotonic() - last_draw >= REFRESH_S:
            size = shutil.get_terminal_size()
            lines = table.render(size.lines - 1)
            _write(out, ["\x1b[H\x1b[2J" + lines[0], *lines[1:]])  # cursor home, clear, redraw
            dirty, last_draw = False, time.monotonic()
    del subscriber


def _write(out: TextIO, lines: Iterable[str]) -> None:
    out.write("\n".join(lines) + "\n")
    out.flush()
