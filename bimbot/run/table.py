"""The table ``bimbot run`` prints at the end: every component not built, and why.

Read from the report (``report.json``'s components and their ``reason``), so the terminal and the file
say the same. Plain aligned text, no colours and no wrapping: the whole GUID (Revit exports share long
prefixes: the first characters tell nothing apart), the state and the reason code stay on one line that
a user can grep, and the message is never cut. The run's ending (how it stopped) is printed once above
the table, so a row whose reason is that ending shows only what is particular to it (its state, its last
robot). Four or more components blocked by one failed component take one row (how many, the first
names); every one of them is in ``report.json``. The first line counts them by reason code, most first
(``not built: 72 component(s): 69 out_of_reach, 2 blocked_by, 1 unstable``): on a real building the
table runs to dozens of rows, and the tally says at once which kind of problem to look at first.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable
from typing import Any

from bimbot.shared.identifiers import named_guid

MAX_NAME_CHARS = 48
NAME_TAIL_CHARS = 16  # a long name keeps its end: Revit names end in the element id that tells them apart
HEADER = ("component", "guid", "state", "reason", "why")
GROUP_FROM = 4  # this many components blocked by one failed component take one row (all are in report.json)
NAMES_SHOWN = 3
OPTION_BEFORE = re.compile(r"(?<![\w-])--[a-z][\w-]*[ =]$")  # ``--exclude `` just before a GUID
GUID = re.compile(r"(?<![0-9A-Za-z_$])[0-9A-Za-z_$]{22}(?![0-9A-Za-z_$])")  # an IFC GlobalId in a sentence


# a figure in a message (4.46, 1,200, 85): not a digit inside a word, a GUID or a name such as 300x300
FIGURE = re.compile(r"(?<![\w$.,])\d{1,3}(?:,\d{3})+(?:\.\d+)?(?![\w$])|(?<![\w$.,])\d+(?:\.\d+)?(?![\w$])")

Row = tuple[str, str, str, str, str]  # name, GUID, state, reason code, message


def not_built_rows(report: dict[str, Any]) -> list[Row]:
    """(name, GUID, state, reason code, message) per component not constructed: grouped by reason code,
    most frequent first, planned order within a code; alike rows taken together."""
    rows: list[Row] = []
    ending_prefix = f"{(report.get('ending') or {}).get('message', '')}; "
    components = sorted(
        report.get("components", []),
        key=lambda c: (c.get("sequence_index") is None, c.get("sequence_index") or 0, c["guid"]),
    )
    groups: dict[str, list[dict[str, Any]]] = {}
    for component in components:
        reason = component.get("reason") or {}
        if component["state"] == "blocked" and reason.get("code") == "blocked_by" and reason.get("guid"):
            groups.setdefault(reason["guid"], []).append(component)
    grouped = {guid for guid, members in groups.items() if len(members) >= GROUP_FROM}
    names = {c["guid"]: c["name"] for c in components if c.get("name")}
    codes = {c["guid"]: (c.get("reason") or {}).get("code") for c in components}
    for component in components:
        if component["state"] == "constructed":
            continue
        reason = component.get("reason") or {}
        root = reason.get("guid")
        if component["state"] == "blocked" and reason.get("code") == "blocked_by" and root in grouped:
            if groups[root][0] is component:
                rows.append(_group_row(root, groups[root], names, codes.get(root)))
            continue
        name = shortened(component.get("name") or component.get("ifc_class") or "")
        message = reason.get("message", "no reason was given")
        if len(ending_prefix) > 2 and message.startswith(ending_prefix):
            message = message[len(ending_prefix) :]
        message = with_names(message, names, own=component["guid"])
        rows.append((name, component["guid"], component["state"], reason.get("code") or "?", message))
    counts = reason_counts([c for c in components if c["state"] != "constructed"])
    return by_reason(same_reason_together(rows), counts)


def same_reason_together(rows: list[Row]) -> list[Row]:
    """Rows that say the same (state, code and message: ``planned  interrupted  it was planned``), or the
    same but for their figures (``target top at 4.46 m`` and ``at 3.92 m``: 16 rows of the Revit hub),
    take one row from ``GROUP_FROM`` of them on: how many, the message with each differing figure as its
    range (``3.92–4.46 m``) and the first names (every one is in report.json)."""
    alike: dict[tuple[str, str, str], list[Row]] = {}
    for row in rows:
        alike.setdefault(_shape(row), []).append(row)
    out: list[Row] = []
    for row in rows:
        members = alike[_shape(row)]
        if len(members) < GROUP_FROM or row[1] == "(report.json)":
            out.append(row)
        elif members[0] is row:
            shown = first_names([member[0] for member in members])
            message = with_ranges([member[4] for member in members])
            out.append((f"{len(members)} components", "(report.json)", *row[2:4], f"{message}: {shown}"))
    return out


def _shape(row: Row) -> tuple[str, str, str]:
    """(state, code, message with every figure as ``#``): what alike rows share."""
    return (row[2], row[3], FIGURE.sub("#", row[4]))


def with_ranges(messages: list[str]) -> str:
    """Messages of one shape (:data:`FIGURE` apart) as one: each figure that differs between them becomes
    ``lowest–highest`` (as written in the messages), one that does not stays as it is; a range in each
    (``127.5–144.2 m``, ``136.1–148.5 m``) becomes one range, ``127.5–148.5 m`` (it read
    ``127.5–136.1–144.2–148.5 m``)."""
    texts = FIGURE.split(messages[0])  # the text around the figures: the same in every message
    figures = [FIGURE.findall(message) for message in messages]
    parts = [texts[0]]
    index = 0
    while index < len(texts) - 1:
        spanned = texts[index + 1] == "–" and index + 2 < len(texts)  # a range in each: ``127.5–144.2 m``
        last = index + 1 if spanned else index
        low = _extreme([row[index] for row in figures], min)
        high = _extreme([row[last] for row in figures], max)
        parts.append(low if low == high else f"{low}–{high}")  # ranges joined: ``127.5–148.5 m``
        parts.append(texts[last + 1])
        index = last + 1
    return "".join(parts)


def _extreme(column: list[str], pick: Callable[[list[float]], float]) -> str:
    """The figure of ``column`` (as written) whose value ``pick`` (min or max) chooses."""
    values = [float(figure.replace(",", "")) for figure in column]
    return column[values.index(pick(values))]


def by_reason(rows: list[Row], counts: Counter[str]) -> list[Row]:
    """The rows grouped by reason code in the tally's order (``counts``: components per code, most first,
    then by code), planned order within a code."""
    return sorted(rows, key=lambda row: (-counts[row[3]], row[3]))  # stable: planned order within a code


def shortened(name: str) -> str:
    """``name`` within MAX_NAME_CHARS: a longer one loses its middle, not its end
    (``M_W-Wide Flange-Column:W10X49:Structural Column:W10X49:412345`` →
    ``M_W-Wide Flange-Column:W10X49:S…mn:W10X49:412345``)."""
    if len(name) <= MAX_NAME_CHARS:
        return name
    return name[: MAX_NAME_CHARS - 1 - NAME_TAIL_CHARS] + "…" + name[-NAME_TAIL_CHARS:]


def with_names(message: str, names: dict[str, str], own: str = "") -> str:
    """``message`` with every other component's GUID it mentions preceded by that component's name
    (``came to rest on 2mLB0dQuXv1Ub0xTLNyjS4`` → ``came to rest on Beam A1-A2 (2mLB0dQuXv1Ub0xTLNyjS4)``),
    unless the name is there already (before it or after it): a GUID alone tells a user nothing. A GUID
    given to an option of a command the message advises (``--exclude 21TEK1_hD0xO7FHM1D4Y0W``) stays
    bare: named, the command no longer ran as pasted."""

    def named(match: re.Match[str]) -> str:
        guid = match.group(0)
        name = names.get(guid)
        before, after = message[: match.start()].rstrip(" ("), message[match.end() :].lstrip(" (")
        if name is None or guid == own or before.endswith(name) or after.startswith(name):
            return guid
        if OPTION_BEFORE.search(message[: match.start()]):
            return guid
        return named_guid(guid, name)

    return GUID.sub(named, message)


def _group_row(
    root: str, members: list[dict[str, Any]], names_by_guid: dict[str, str], root_code: str | None
) -> tuple[str, str, str, str, str]:
    """One row for every component blocked by ``root``: how many, why ``root`` was not built (as a single
    row says it), and the first few names."""
    names = [member.get("name") or member.get("ifc_class") or member["guid"] for member in members]
    failed = with_names(root, names_by_guid)
    shown = first_names(names)
    return (
        f"{len(members)} components",
        "(report.json)",
        "blocked",
        "blocked_by",
        f"they rest, directly or through others, on {failed}, which was not built"
        + (f" ({root_code})" if root_code else "")
        + f": {shown}",
    )


def first_names(names: list[str]) -> str:
    """``Beam 0, Beam 1, Beam 2 and 3 more``: the first names of a row that stands for many."""
    more = f" and {len(names) - NAMES_SHOWN} more" if len(names) > NAMES_SHOWN else ""
    return ", ".join(names[:NAMES_SHOWN]) + more


def reason_counts(components: list[dict[str, Any]]) -> Counter[str]:
    """Components per reason code (``?`` for a component without one)."""
    return Counter((component.get("reason") or {}).get("code") or "?" for component in components)


def reason_tally(components: list[dict[str, Any]]) -> str:
    """``69 out_of_reach, 2 blocked_by, 1 unstable``: the components by reason code, most first (then by
    code), the order :func:`by_reason` puts the rows in."""
    counts = reason_counts(components)
    return ", ".join(
        f"{counts[code]} {code}" for code in sorted(counts, key=lambda code: (-counts[code], code))
    )


def not_built_table(report: dict[str, Any]) -> str:
    """The table as text (empty when every component is constructed)."""
    rows = not_built_rows(report)
    if not rows:
        return ""
    widths = [max(len(row[i]) for row in [HEADER, *rows]) for i in range(4)]
    missing = [component for component in report.get("components", []) if component["state"] != "constructed"]
    lines = [f"not built: {len(missing)} component(s): {reason_tally(missing)}"]
    for row in [HEADER, *rows]:
        lines.append(
            "  "
            + "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=False))
            + "  "
            + row[4]
        )
    return "\n".join(lines) + "\n"
