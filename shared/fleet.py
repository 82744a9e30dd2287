"""The fleet on site: robot types (their descriptions) and how many of each, from one TOML file.

Why one file: physics spawns from it, and serves the descriptions with its site info, so each robot reads
its own type and the planner all of them from there; nobody repeats a robot's limits. The embedded default
(``shared/robots/default_fleet.toml``: a Husky, a heavy carrier, a tower crane, a concrete pump and a
block-laying robot) is what ``bimbot demo`` and ``bimbot run`` build with when no ``--fleet`` is given.
``--robots N`` means N robots of the file's ``default_type`` plus every machine of the file that stands
fixed (its cranes, pumps, block layers): a site keeps its crane when one asks for more carriers. Robot ids
are ``r1``, ``r2``… in the order of the file's ``[[robots]]`` entries (with ``--robots``: the N first).

A URDF path is resolved by :func:`resolve_urdf`: absolute; else relative to the fleet file; else one of
bimbot's own models (``shared/robots/``); else relative to ``pybullet_data``.
"""

from __future__ import annotations

import difflib
import functools
import tomllib
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .errors import InputError
from .robot_description import Capability, RobotDescription

MODELS_DIR = Path(__file__).resolve().parent / "robots"
DEFAULT_FLEET_FILE = MODELS_DIR / "default_fleet.toml"
MAX_ROBOTS = 1000


class FleetEntry(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    type: str = Field(min_length=1, max_length=64)
    count: int = Field(ge=0, le=MAX_ROBOTS)
    up_to: int | None = Field(
        default=None,
        ge=1,
        le=MAX_ROBOTS,
        description="a crane type: the site erects more, up to this many, where its cranes set up so far "
        "leave parts only a crane sets unhooked (bimbot.shared.crane_count)",
    )

    @model_validator(mode="after")
    def _up_to_at_least_count(self) -> FleetEntry:
        if self.up_to is not None and self.up_to < self.count:
            raise ValueError(f"up_to ({self.up_to}) is less than count ({self.count}) for {self.type!r}")
        return self


class Fleet(BaseModel):
    """Robot types by name, the robots on site (type and count, in id order) and the ``--robots`` type."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    types: dict[str, RobotDescription]
    robots: tuple[FleetEntry, ...] = ()
    default_type: str | None = None
    source: str = Field(default="", exclude=True, description="where it was read from (messages)")
    base_dir: str = Field(default="", exclude=True, description="the fleet file's folder (URDF paths)")

    @model_validator(mode="before")
    @classmethod
    def _named(cls, data: object) -> object:
        """Types take their name from their table's key (``[types.husky]``) unless they give one."""
        if isinstance(data, dict) and isinstance(data.get("types"), dict):
            types = {}
            for key, value in data["types"].items():
                types[key] = {"name": key, **value} if isinstance(value, dict) else value
            data = {**data, "types": types}
        return data

    @model_validator(mode="after")
    def _known_types(self) -> Fleet:
        for name, description in self.types.items():
            if description.name != name:
                raise ValueError(f"type {name!r} is named {description.name!r}: use one name")
        unknown = sorted({entry.type for entry in self.robots} - set(self.types))
        if unknown:
            raise ValueError(
                f"robots of unknown type(s) {unknown}; types: {sorted(self.types)}"
                + _did_you_mean(unknown[0], list(self.types))
            )
        if self.default_type is not None and self.default_type not in self.types:
            raise ValueError(
                f"default_type {self.default_type!r} is not among the types {sorted(self.types)}"
            )
        if sum(entry.count for entry in self.robots) > MAX_ROBOTS:
            raise ValueError(f"at most {MAX_ROBOTS} robots")
        return self

    def robot_types(self) -> list[RobotDescription]:
        """One description per robot, in robot id order (r1 first)."""
        return [self.types[entry.type] for entry in self.robots for _ in range(entry.count)]

    def type_of(self) -> dict[str, str]:
        """Robot id → type name."""
        return {f"r{index + 1}": robot.name for index, robot in enumerate(self.robot_types())}

    def on_site(self) -> dict[str, RobotDescription]:
        """The types that have at least one robot on site."""
        return {entry.type: self.types[entry.type] for entry in self.robots if entry.count > 0}

    def with_robots(self, count: int, type_name: str | None = None) -> Fleet:
        """This fleet's types with ``count`` robots of ``type_name`` (default: the file's default type) first,
        then every machine of the fleet that stands fixed (cranes, pumps, block layers: their entries as the
        file has them, except ``type_name``'s own, which ``count`` replaces)."""
        name = type_name or self.default_type or next(iter(self.types))
        if name not in self.types:
            raise InputError(
                f"{self.source or 'fleet'}: no robot type {name!r} (types: {sorted(self.types)})"
            )
        machines = tuple(
            entry
            for entry in self.robots
            if entry.type != name and self.types[entry.type].can(Capability.STAND_FIXED)
        )
        return self.model_copy(update={"robots": (FleetEntry(type=name, count=count), *machines)})

    def with_counts(self, counts: dict[str, int]) -> Fleet:
        """This fleet with the robot count of each type named in ``counts`` replaced (a crane count the site
        plan sized, :mod:`.crane_count`); the same fleet when nothing changes."""
        if not counts:
            return self
        robots = tuple(
            entry.model_copy(update={"count": counts[entry.type]}) if entry.type in counts else entry
            for entry in self.robots
        )
        return self if robots == self.robots else self.model_copy(update={"robots": robots})

    def summary(self) -> str:
        """``1 husky, 1 carrier, 1 tower_crane, 1 concrete_pump, 1 block_layer``."""
        return ", ".join(f"{entry.count} {entry.type}" for entry in self.robots if entry.count) or "no robots"

    def resolve_urdf(self, urdf: str) -> Path:
        """A type's URDF path as a file (see the module docstring)."""
        return resolve_urdf(urdf, Path(self.base_dir) if self.base_dir else None)


def resolve_urdf(urdf: str, base_dir: Path | None = None) -> Path:
    """``urdf`` as a file: absolute, relative to ``base_dir``, bimbot's models, or pybullet_data's."""
    path = Path(urdf)
    if path.is_absolute():
        return path
    candidates = [base_dir / path] if base_dir is not None else []
    candidates.append(MODELS_DIR / path)
    import pybullet_data

    candidates.append(Path(pybullet_data.getDataPath()) / path)
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise InputError(f"robot URDF {urdf!r} not found (looked in: {', '.join(str(c) for c in candidates)})")


def load_fleet(path: Path | str | None = None) -> Fleet:
    """The fleet in ``path`` (TOML), or the embedded default; one clear line when it is wrong."""
    file = Path(path) if path is not None else DEFAULT_FLEET_FILE
    try:
        data = tomllib.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"fleet file {file} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"fleet file {file}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"fleet file {file}: not valid TOML: {exc}") from None
    if path is not None:
        data = _over_builtin(data)
    try:
        fleet = Fleet.model_validate({**data, "source": str(file), "base_dir": str(file.resolve().parent)})
    except ValidationError as exc:
        raise InputError(f"fleet file {file}: {_problems(exc)}{_new_type_hint(data)}") from None
    return fleet


def _new_type_hint(data: dict[str, object]) -> str:
    """For a ``[types.NAME]`` table that is not one of bimbot's types but is spelt like one (so it is taken
    for a new type, which must give every field): the type it may mean."""
    given = data.get("types")
    if not isinstance(given, dict):
        return ""
    builtin = list(_default_fleet_data()["types"])
    for name, table in given.items():
        if name not in builtin and isinstance(table, dict) and "urdf" not in table:
            hint = _did_you_mean(name, builtin)
            if hint:
                return (
                    f"; [types.{name}] is no type of bimbot's{hint}: a table of one of bimbot's types "
                    "changes only what it gives, a new type gives every field"
                )
    return ""


def _over_builtin(data: dict[str, object]) -> dict[str, object]:
    """A user's fleet file laid over bimbot's own: a ``[types.NAME]`` table of a built-in type changes only
    the values it gives (``[types.carrier]`` with ``payload_kg = 5000`` is the carrier with a 5 t payload);
    a robot of a built-in type the file does not define is of bimbot's own; a file of types alone, every one
    built in, is the default fleet with those changes (its robots and default type)."""
    default = _default_fleet_data()
    builtin: dict[str, object] = default["types"]
    given = data.get("types")
    if not isinstance(given, dict):  # only [[robots]] (or nothing valid: the model says what is wrong)
        return data if given is not None else {**data, "types": builtin}
    types = {name: _laid_over(builtin.get(name), table) for name, table in given.items()}
    robots = data.get("robots", default["robots"] if set(given) <= set(builtin) else None)
    for entry in robots if isinstance(robots, list) else ():
        name = entry.get("type") if isinstance(entry, dict) else None
        if isinstance(name, str) and name in builtin and name not in types:
            types[name] = builtin[name]
    if "robots" not in data and robots is not None:  # the default fleet, changed
        return {
            "default_type": default.get("default_type"),
            **data,
            "types": {**builtin, **types},
            "robots": robots,
        }
    return {**data, "types": types}


@functools.cache
def _default_fleet_data() -> dict[str, Any]:
    """The embedded default fleet file as TOML data, read once (not changed by its readers)."""
    return tomllib.loads(DEFAULT_FLEET_FILE.read_text(encoding="utf-8"))


def _laid_over(base: object, table: object) -> object:
    """``table`` over ``base`` (TOML tables: its keys replace, its sub-tables are laid over theirs)."""
    if not isinstance(base, dict) or not isinstance(table, dict):
        return table
    return {**base, **{key: _laid_over(base.get(key), value) for key, value in table.items()}}


def _problems(error: ValidationError, shown: int = 3) -> str:
    """Pydantic's errors as one line, in the file's words: ``[[robots]] #2: cont: not a known key (did
    you mean count?); …``."""
    parts = []
    for item in error.errors()[:shown]:
        where = _where(item["loc"])
        message = str(item["msg"]).removeprefix("Value error, ")
        if item["type"] == "extra_forbidden":
            key = str(item["loc"][-1])
            message = "not a known key" + _did_you_mean(key, _keys_at(item["loc"]))
            if item["loc"][:1] == ("robots",) and difflib.get_close_matches(
                key, RobotDescription.model_fields
            ):
                message += " (a robot type's limits go in its [types.NAME] table)"
        elif item["type"] == "missing":
            message = "missing"
        parts.append(f"{where}: {message}" if where else message)
    more = error.error_count() - shown
    return "; ".join(parts) + (f" (and {more} more)" if more > 0 else "")


def _keys_at(loc: tuple[int | str, ...]) -> list[str]:
    """The keys the table at ``loc`` (an extra key's place) may have."""
    if loc[:1] == ("robots",):
        return list(FleetEntry.model_fields)
    if loc[:1] == ("types",) and len(loc) == 3:
        return list(RobotDescription.model_fields)
    return [name for name in Fleet.model_fields if name not in ("source", "base_dir")]


def _did_you_mean(word: str, choices: list[str]) -> str:
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean {close[0]}?)" if close else ""


def _where(loc: tuple[int | str, ...]) -> str:
    """A place in the fleet file as its reader counts: pydantic's ``robots.1.count`` (from 0) is the second
    ``[[robots]]`` entry's ``count``, said ``[[robots]] #2: count``."""
    if len(loc) >= 2 and loc[0] == "robots" and isinstance(loc[1], int):
        rest = ".".join(str(part) for part in loc[2:])
        return f"[[robots]] #{loc[1] + 1}" + (f": {rest}" if rest else "")
    return ".".join(str(part) for part in loc)


def check_urdfs(fleet: Fleet) -> None:
    """Every robot type's URDF can be found (an :class:`InputError` naming the first that cannot)."""
    for description in fleet.types.values():
        fleet.resolve_urdf(description.urdf)


def default_fleet() -> Fleet:
    return load_fleet(None)
