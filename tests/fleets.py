"""Fleet files for tests: the default fleet's robot types with only the robots a test needs on site."""

from __future__ import annotations

from pathlib import Path

from bimbot.shared.fleet import DEFAULT_FLEET_FILE


def fleet_file(folder: Path, robots: dict[str, int], name: str = "fleet.toml") -> Path:
    """A fleet file with the default fleet's types and, on site, ``robots`` (type name → count), in that
    order (robot ids r1, r2, … follow it). Written as ``folder/name``."""
    text = DEFAULT_FLEET_FILE.read_text(encoding="utf-8")
    types = text[: text.index("[[robots]]")]
    on_site = "".join(
        f'[[robots]]\ntype = "{type_name}"\ncount = {count}\n' for type_name, count in robots.items()
    )
    path = Path(folder) / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"{types}{on_site}", encoding="utf-8")
    return path


def ground_fleet_file(folder: Path, count: int = 1, type_name: str = "carrier") -> Path:
    """A fleet file with the default fleet's types and only ``count`` robots of ``type_name`` on site (no
    crane, pump or block layer: ``--robots N`` keeps those). Written as ``folder/ground_fleet.toml``."""
    return fleet_file(folder, {type_name: count}, name="ground_fleet.toml")
