"""The table ``bimbot run`` prints at the end: every component not built, and why.

Read from the report (``report.json``'s components and their ``reason``), so the terminal and the file
say the same. Plain aligned text, no colours and no wrapping: the whole GUID (Revit exports share long
prefixes: the first characters tell nothing apart), the state and the reason code stay on one line that
a user can grep, and the message is never cut. The run's ending (how it stopped) is printed once above
the table, so a row whose reason is that ending shows only what is particular to it (its state, its last
robot).
"""

from __future__ import annotations

from typing import Any

MAX_NAME_CHARS = 32
HEADER = ("component", "guid", "state", "reason", "why")


def not_built_rows(report: dict[str, Any]) -> list[tuple[str, str, str, str, str]]:
    """(name, GUID, state, reason code, message) per component not constructed, in planned order."""
    rows = []
    ending_prefix = f"{(report.get('ending') or {}).get('message', '')}; "
    components = sorted(
        report.get("components", []),
        key=lambda c: (c.get("sequence_index") is None, c.get("sequence_index") or 0, c["guid"]),
    )
    for component in components:
        if component["state"] == "constructed":
            continue
        reason = component.get("reason") or {}
        name = component.get("name") or component.get("ifc_class") or ""
        if len(name) > MAX_NAME_CHARS:
            name = name[: MAX_NAME_CHARS - 1] + "…"
        message = reason.get("message", "no reason was given")
        if len(ending_prefix) > 2 and message.startswith(ending_prefix):
            message = message[len(ending_prefix) :]
        rows.append((name, component["guid"], component["state"], reason.get("code", "?"), message))
    return rows


def not_built_table(report: dict[str, Any]) -> str:
    """The table as text (empty when every component is constructed)."""
    rows = not_built_rows(report)
    if not rows:
        return ""
    widths = [max(len(row[i]) for row in [HEADER, *rows]) for i in range(4)]
    lines = [f"not built: {len(rows)} component(s)"]
    for row in [HEADER, *rows]:
        lines.append(
            "  "
            + "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=False))
            + "  "
            + row[4]
        )
    return "\n".join(lines) + "\n"
