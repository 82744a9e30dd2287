"""Open an IFC model for conversion, turning every unreadable-input case into one clear :class:`UserError`.

ifcopenshell opens a truncated STEP file without complaint and reports other problems with several
exception types; the converter wants one line that says what is wrong with which file: missing, empty, not
IFC, truncated, an unsupported schema. IFC2X3, IFC4 and IFC4X3 (any addendum) are supported. What the
parser could not read inside an otherwise readable file (a damaged line) comes back with the model
(:func:`read_model`, :mod:`.parse_damage`): the converter leaves out the elements it leaves incomplete.
"""

from __future__ import annotations

import hashlib
import logging
import re
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell

from bimbot.shared.errors import UserError

from .ifc_parse_damage import ParseDamage, read_parse_log
from .step_brackets import first_unclosed_line

_log = logging.getLogger(__name__)

SUPPORTED_SCHEMA_PREFIXES = ("IFC2X3", "IFC4")
SUPPORTED_SCHEMAS = "IFC2X3, IFC4 and IFC4X3"
_STEP_MAGIC = b"ISO-10303-21;"
_STEP_END = b"END-ISO-10303-21;"


@dataclass(frozen=True)
class ReadModel:
    model: ifcopenshell.file
    damage: ParseDamage  # what the parser could not read (empty for a sound file)


def open_model(path: Path) -> ifcopenshell.file:
    """Open ``path`` as an IFC-SPF model or raise :class:`UserError` with one line naming the problem."""
    return read_model(path).model


TOKEN_AT_OFFSET = re.compile(r"token (?P<token>.*?) at offset (?P<offset>\d+) invalid")


def parse_failure(path: Path, error: str, log: str) -> str:
    """The line for a file the parser gave up on: where and what, from the parser's log when it says
    (ifcopenshell's own message is "Syntax error during parse, check logs")."""
    found = TOKEN_AT_OFFSET.search(log or "")
    if found is None:
        return f"{path}: not a readable IFC file ({error})"
    offset = int(found["offset"])
    with open(path, "rb") as source:
        line = source.read(offset).count(b"\n") + 1
    token = found["token"].strip()
    shown = token if len(token) <= 40 else token[:40] + "…"
    return (
        f"{path} line {line}: not a readable IFC file: {shown!r} is no valid STEP token there "
        "(the file is cut off or damaged at that point)"
    )


def read_model(path: Path) -> ReadModel:
    """:func:`open_model`, and what the parser could not read in the file."""
    path = Path(path)
    if not path.exists():
        raise UserError(f"{path}: no such file")
    if path.is_dir():
        raise UserError(f"{path}: is a folder, not an IFC file")
    size = path.stat().st_size
    if size == 0:
        raise UserError(f"{path}: empty file, not an IFC model")
    _check_step_frame(path, size)
    ifcopenshell.get_log()  # what earlier opens logged: the log is read (and emptied) after this one
    try:
        model = ifcopenshell.open(str(path))
    except ifcopenshell.SchemaError as error:
        schema = str(error).removeprefix("Unsupported schema:").strip()
        message = f"{path}: unsupported IFC schema {schema} (bimbot reads {SUPPORTED_SCHEMAS})"
        raise UserError(message) from None
    except (ifcopenshell.Error, OSError, RuntimeError) as error:
        raise UserError(parse_failure(path, str(error), ifcopenshell.get_log())) from None
    schema = model.schema_identifier if hasattr(model, "schema_identifier") else model.schema
    if not str(schema).upper().startswith(SUPPORTED_SCHEMA_PREFIXES):
        raise UserError(f"{path}: unsupported IFC schema {schema} (bimbot reads {SUPPORTED_SCHEMAS})")
    damage = read_parse_log(ifcopenshell.get_log(), path)
    if any(_END_MARKER.search(what) for _, what in damage.unreadable):
        raise UserError(_lost_its_place(path, damage))
    if not model.by_type("IfcProject"):
        if damage.unreadable:
            line, what = damage.unreadable[0]
            raise UserError(
                f"{path} line {line}: could not be read ({what.rstrip()}), and no IfcProject was read after "
                "it: a damaged IFC file"
            )
        raise UserError(f"{path}: no IfcProject, not a complete IFC model")
    return ReadModel(model, damage)


_END_MARKER = re.compile(r"'(ENDSEC|END-ISO-10303-21)'")


def _lost_its_place(path: Path, damage: ParseDamage) -> str:
    """The line for a file whose end markers the parser read as instances: it lost its place at an
    instance whose brackets do not close, and what followed was swallowed (:mod:`.step_brackets`)."""
    line = first_unclosed_line(path)
    if line is not None:
        return (
            f"{path} line {line}: not a readable IFC file: the brackets of this instance do not close "
            "before its ';', so the parser reads the rest of the file as part of it (the file is damaged "
            "at that point)"
        )
    first = next((number for number, _ in damage.unreadable if number is not None), None)
    where = f" line {first}" if first is not None else ""
    return (
        f"{path}{where}: not a readable IFC file: the parser lost its place before the file's end (it read "
        "the end markers as instances): the file is damaged"
    )


def _check_step_frame(path: Path, size: int) -> None:
    """Reject files that are not STEP physical files or that were cut off before ``END-ISO-10303-21;``."""
    with path.open("rb") as stream:
        head = stream.read(256)
        stream.seek(max(0, size - 256))
        tail = stream.read()
    if head.startswith(b"PK\x03\x04"):
        raise UserError(f"{path}: a zip archive, not an IFC file: unzip it and convert the .ifc inside")
    if _STEP_MAGIC not in head.lstrip()[: len(_STEP_MAGIC) + 8]:
        raise UserError(f"{path}: not an IFC file (no ISO-10303-21 header; only IFC-SPF .ifc files are read)")
    if _STEP_END not in tail:
        raise UserError(f"{path}: truncated IFC file (it does not end with END-ISO-10303-21;)")


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with Path(path).open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
