"""The vocabulary of the message registry (:mod:`bimbot.shared.messages`): topics, queryables, tokens.

A registry entry ties a key template (``bimbot/{site}/components/{key}/state``) to what travels there and
who speaks: a :class:`Topic` to its message model and publisher, a :class:`Queryable` to its request and
reply models and the service that answers, a :class:`Liveliness` entry to its token owners. Services name
the entry, never a model, so a subscriber cannot validate a key against the wrong model
(:class:`bimbot.shared.bus.Inbox`), and the module docstring's key table is rendered from the same
entries (:func:`key_table`), so the documentation cannot drift from the code. Every payload is the model's
JSON, except on a topic marked ``binary`` (a high-rate one), whose layout is :mod:`bimbot.shared.wire`'s.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Generic, TypeVar

from pydantic import BaseModel

M = TypeVar("M", bound=BaseModel)
R = TypeVar("R", bound=BaseModel)

_PART = re.compile(r"\{(\w+)\}")


def fill(template: str, **parts: str) -> str:
    """The key of ``template`` with its ``{part}``s filled (``*`` is a wildcard chunk)."""
    return template.format(**parts)


def template_matches(template: str, site: str, key_expr: str) -> bool:
    """Whether the concrete ``key_expr`` is an instance of ``template`` on ``site`` (one chunk per part)."""
    pattern = template.split("/")
    chunks = key_expr.split("/")
    if len(pattern) != len(chunks):
        return False
    for want, got in zip(pattern, chunks, strict=True):
        if want == "{site}":
            if got != site:
                return False
        elif not _PART.fullmatch(want) and want != got:
            return False
    return True


def shown(template: str) -> str:
    """``bimbot/{site}/clock`` → ``bimbot/<site>/clock``, as the docs write keys."""
    return _PART.sub(r"<\1>", template)


@dataclass(frozen=True)
class Topic(Generic[M]):
    """A published key: ``model`` travels on ``template``, put by ``publisher`` for ``readers``."""

    template: str
    model: type[M]
    publisher: str
    readers: str
    note: str = ""
    binary: bool = False  # the compact binary layout of :mod:`bimbot.shared.wire`, not JSON

    def key(self, **parts: str) -> str:
        return fill(self.template, **parts)

    def matches(self, site: str, key_expr: str) -> bool:
        return template_matches(self.template, site, key_expr)

    def row(self) -> tuple[str, str, str]:
        note = " ".join(part for part in ("binary" if self.binary else "", self.note) if part)
        return shown(self.template), self.model.__name__, _who(f"{self.publisher} → {self.readers}", note)


@dataclass(frozen=True)
class Queryable(Generic[R]):
    """A key ``answerer`` serves: a ``request`` payload (None: an empty query) answered with ``reply``."""

    template: str
    request: type[BaseModel] | None
    reply: type[R]
    answerer: str
    note: str = ""

    def key(self, **parts: str) -> str:
        return fill(self.template, **parts)

    def matches(self, site: str, key_expr: str) -> bool:
        return template_matches(self.template, site, key_expr)

    def row(self) -> tuple[str, str, str]:
        asked = f"{self.request.__name__} → " if self.request is not None else ""
        return (
            shown(self.template),
            "(queryable)",
            _who(f"{self.answerer} answers {asked}{self.reply.__name__}", self.note),
        )


@dataclass(frozen=True)
class Liveliness:
    """Liveliness tokens on ``template``: declared by ``owners`` while they run."""

    template: str
    owners: str
    note: str = ""

    def key(self, **parts: str) -> str:
        return fill(self.template, **parts)

    def row(self) -> tuple[str, str, str]:
        return shown(self.template), "(liveliness)", _who(f"token of {self.owners}", self.note)


Entry = Topic | Queryable | Liveliness


def _who(text: str, note: str) -> str:
    return f"{text} ({note})" if note else text


def key_table(entries: Iterable[Entry], indent: str = "    ") -> str:
    """The key table of the docs, one line per entry, columns aligned."""
    rows = [entry.row() for entry in entries]
    width_key = max(len(row[0]) for row in rows) + 3
    width_model = max(len(row[1]) for row in rows) + 3
    return "\n".join(f"{indent}{k:<{width_key}}{m:<{width_model}}{w}".rstrip() for k, m, w in rows)
