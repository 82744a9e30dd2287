"""docs/architecture.md stays a map a newcomer reads in minutes, and its key table is the registry's.

The table is read from the doc (every line of a code block that starts with ``bimbot/<site>/``, split into
key, model and who on runs of two or more spaces) and compared with the rows of
:data:`bimbot.shared.messages.KEY_SPACE` both ways: a key in the registry missing from the doc fails, and
so does a row in the doc that the registry does not hold (a key, a model or a speaker that changed).
"""

from __future__ import annotations

import re
from pathlib import Path

from bimbot.shared.messages import KEY_SPACE

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
MAX_LINES = 400


def _doc_key_rows(text: str) -> list[tuple[str, str, str]]:
    rows = []
    in_block = False
    for line in text.splitlines():
        if line.startswith("```"):
            in_block = not in_block
        elif in_block and line.startswith("bimbot/<site>/"):
            key, model, who = re.split(r"\s{2,}", line.strip(), maxsplit=2)
            rows.append((key, model, who))
    return rows


def test_the_architecture_doc_is_at_most_400_lines() -> None:
    assert len(DOC.read_text(encoding="utf-8").splitlines()) <= MAX_LINES


def test_the_doc_key_table_holds_every_registry_entry_and_nothing_else() -> None:
    doc_rows = _doc_key_rows(DOC.read_text(encoding="utf-8"))
    registry_rows = [entry.row() for entry in KEY_SPACE]
    assert len(doc_rows) == len(set(doc_rows)), "a key is listed twice in the doc"
    assert sorted(set(registry_rows) - set(doc_rows)) == [], "registry entries missing from the doc"
    assert sorted(set(doc_rows) - set(registry_rows)) == [], "doc rows the registry does not hold"


def test_the_doc_points_nowhere_outside_the_repository() -> None:
    text = DOC.read_text(encoding="utf-8")
    assert "../" not in text
    assert not re.search(r"(?<![\w.])/(work|home|tmp|opt)/", text)
