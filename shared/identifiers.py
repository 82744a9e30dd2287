"""Reversible mappings from IFC GlobalIds to bus key chunks and to folder names, and site slugs.

IFC GlobalIds are 22 characters of the alphabet ``0-9A-Za-z_$``. Two places cannot take them raw:

* **Zenoh key chunks** forbid ``$`` (and ``* # ? /``). :func:`guid_to_key` keeps ``0-9A-Za-z_`` as is,
  writes ``$`` as ``-`` (not in the GUID alphabet, so the map stays reversible) and any other character
  (only found in non-conforming files) as ``.`` followed by its UTF-8 bytes in two-digit upper-case hex.
  Example: ``1ZYEEONkr85w1TbdaOn$Js`` → ``1ZYEEONkr85w1TbdaOn-Js``. :func:`key_to_guid` inverts it.
* **Folder names** must be safe in URIs and on every OS, including case-insensitive file systems where two
  GlobalIds that differ only by letter case would collide. :func:`guid_to_folder` writes the 128-bit UUID
  that the GlobalId encodes as 32 lower-case hex digits (``ifcopenshell.guid.expand``), which
  :func:`folder_to_guid` compresses back. A GlobalId that is not a valid 22-character IFC GUID gets
  ``x`` + the hex of its UTF-8 bytes instead, also reversible.
"""

from __future__ import annotations

import re
import string
import unicodedata

GUID_ALPHABET = frozenset(string.digits + string.ascii_letters + "_$")
_KEY_PLAIN = frozenset(string.digits + string.ascii_letters + "_")
_GUID_PATTERN = re.compile(r"^[0-3][0-9A-Za-z_$]{21}$")
_HEX_PAIR = re.compile(r"\.([0-9A-F]{2})")


def is_valid_guid(guid: str) -> bool:
    """True for a 22-character IFC GlobalId in the IFC base-64 alphabet."""
    return bool(_GUID_PATTERN.match(guid))


def guid_to_key(guid: str) -> str:
    """Map a GlobalId to a Zenoh key chunk (``$`` → ``-``; other unsafe characters → ``.XX`` hex)."""
    if not guid:
        raise ValueError("empty GlobalId has no bus key")
    out: list[str] = []
    for char in guid:
        if char in _KEY_PLAIN:
            out.append(char)
        elif char == "$":
            out.append("-")
        else:
            out.extend(f".{byte:02X}" for byte in char.encode("utf-8"))
    return "".join(out)


def key_to_guid(key: str) -> str:
    """Invert :func:`guid_to_key`."""
    raw = bytearray()
    index = 0
    while index < len(key):
        char = key[index]
        if char == "-":
            raw += b"$"
            index += 1
        elif char == ".":
            match = _HEX_PAIR.match(key, index)
            if match is None:
                raise ValueError(f"bus key {key!r} has a malformed escape at position {index}")
            raw.append(int(match.group(1), 16))
            index += 3
        elif char in _KEY_PLAIN:
            raw += char.encode("ascii")
            index += 1
        else:
            raise ValueError(f"bus key {key!r} holds {char!r}, which no GlobalId maps to")
    return raw.decode("utf-8")


def guid_to_folder(guid: str) -> str:
    """Map a GlobalId to a folder name safe in URIs and on case-insensitive file systems."""
    if is_valid_guid(guid):
        import ifcopenshell.guid  # lazy: ifcopenshell costs ~50 MB in services that only need keys

        return ifcopenshell.guid.expand(guid).lower()
    return "x" + guid.encode("utf-8").hex()


def folder_to_guid(folder: str) -> str:
    """Invert :func:`guid_to_folder`."""
    if folder.startswith("x"):
        return bytes.fromhex(folder[1:]).decode("utf-8")
    if re.fullmatch(r"[0-9a-f]{32}", folder):
        import ifcopenshell.guid

        return ifcopenshell.guid.compress(folder)
    raise ValueError(f"folder name {folder!r} was not made by guid_to_folder")


def slugify(name: str | None, default: str = "site") -> str:
    """A lower-case ``[a-z0-9_-]`` name for files and key chunks (site names); ``default`` when empty."""
    text = unicodedata.normalize("NFKD", name or "").encode("ascii", "ignore").decode("ascii").lower()
    text = re.sub(r"[^a-z0-9_-]+", "-", text).strip("-_")
    return text[:64] or default


def named_guid(guid: str, name: str | None) -> str:
    """How a user reads a component: ``Name (GUID)``, the whole GUID (a Revit model's share their first
    characters); the GUID alone without a name. The run's table, its stall report, the planner and
    ``--check-stability`` all name components so."""
    return f"{name} ({guid})" if name else guid
