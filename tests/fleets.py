"""Fleet files for tests that need ground robots only."""

from __future__ import annotations

from pathlib import Path

from bimbot.shared.fleet import DEFAULT_FLEET_FILE


def ground_fleet_file(folder: Path, count: int = 1, type_name: str = "carrier") -> Path:
    """A fleet file with the default fleet's types and only ``count`` robots of ``type_name`` on site (no
    crane, pump or block layer: ``--robots N`` keeps those). Written as ``folder/ground_fleet.toml``."""
    text = DEFAULT_FLEET_FILE.read_text(encoding="utf-8")
    types = text[: text.index("[[robots]]")]
    path = Path(folder) / "ground_fleet.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'{types}[[robots]]\ntype = "{type_name}"\ncount = {count}\n', encoding="utf-8")
    return path
