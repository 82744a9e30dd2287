"""Checks that a command can write where it was told to, made before it starts its work: one clear line.

A command that writes (``bimbot convert -o``, ``bimbot sample -o``, a run folder) checks its output first
and raises a :class:`~bimbot.shared.errors.UserError` naming the option, the path and the reason: a parent
that is a regular file, a folder that cannot be written. Permission bits do not stop root, so the checks
do not ask :func:`os.access`; they make (and at once remove) an empty folder where the output goes, which
fails for root too on a read-only mount, in ``/proc`` or ``/sys``. Nothing is left behind.

Light on purpose (standard library only): ``bimbot sample`` checks its output before ifcopenshell loads.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from bimbot.shared.errors import UserError

PROBE_PREFIX = ".bimbot-write-check-"


def nearest_existing(path: Path) -> Path:
    """``path`` itself when it exists, else its closest ancestor that does (``.`` or ``/`` at the worst)."""
    existing = Path(path)
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    return existing


def _why_not_writable(folder: Path) -> str | None:
    """None when an entry can be made in ``folder`` (tried: an empty folder made and removed), else why."""
    try:
        probe = tempfile.mkdtemp(prefix=PROBE_PREFIX, dir=folder)
    except OSError as error:
        return error.strerror or str(error)
    os.rmdir(probe)
    return None


def _tail(hint: str) -> str:
    return f"; {hint}" if hint else ""


def check_writable_dir(path: Path, what: str, hint: str = "") -> Path:
    """``path`` is a folder that can be written, or one that can be made; a UserError otherwise, naming
    ``what`` (the option), the path, the reason and ``hint`` (what to do instead). Makes nothing."""
    path = Path(path)
    existing = nearest_existing(path)
    if not existing.is_dir():
        raise UserError(f"{what} {path}: {existing} is a file, not a folder{_tail(hint)}")
    reason = _why_not_writable(existing)
    if reason is not None:
        where = "the folder is not writable" if existing == path else f"cannot create anything in {existing}"
        raise UserError(f"{what} {path}: {where} ({reason}){_tail(hint)}")
    return path


def check_writable_file(path: Path, what: str) -> Path:
    """``path`` can be written as a file in a folder that exists (an existing file is overwritten); a
    UserError otherwise. Makes nothing and changes no existing file."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{what} {path} is a folder; give a file name such as {path / 'model.ifc'}")
    folder = path.parent
    existing = nearest_existing(folder)
    if not existing.is_dir():
        raise UserError(f"{what} {path}: {existing} is a file, not a folder")
    if existing != folder:
        raise UserError(f"{what} {path}: the folder {folder} does not exist")
    reason = _why_not_writable(folder)
    if reason is not None:
        raise UserError(f"{what} {path}: cannot create a file in {folder} ({reason})")
    if path.exists():
        try:
            with open(path, "ab"):  # appends nothing: the file stays as it is
                pass
        except OSError as error:
            raise UserError(f"{what} {path}: the file cannot be overwritten ({error.strerror})") from None
    return path
