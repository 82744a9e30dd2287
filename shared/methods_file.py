"""The methods file: how each component of a model is built, as rules a builder can read and change (TOML).

Like the fleet file (:mod:`.fleet`), one file holds everything: the user's own word by GlobalId, class and
material; whether what the IFC says is followed; the rules used where it says nothing; which classes are
split into panels when too heavy or too large; a road truck's load size; and the rates of cast-in-place
work. Two presets are embedded (``shared/methods/``): ``prefab`` (the default: what can be lifted is lifted,
what is too heavy is panelised, foundations and ground slabs are cast) and ``conventional`` (concrete cast,
masonry laid; steel, timber, precast, windows and doors lifted), and the paper's ``lifted`` (everything
lifted whole, what the IFC says ignored: a run shows what the fleet cannot lift). ``bimbot methods show``
prints one.

A user's file names the preset it starts from (``preset = "conventional"``, default ``prefab``) and gives
only what it changes: its tables are laid over the preset's, key by key, and a list (``rules``) replaces
the preset's. How the converter applies a file is in ``services/converter/method_decisions.py``.
"""

from __future__ import annotations

import re
import tomllib
from enum import StrEnum
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from .connection_kinds import ConnectionTimes, TemporarySupportRules
from .construction_methods import ConstructionMethod
from .errors import InputError

PRESETS_DIR = Path(__file__).resolve().parent / "methods"
PRESETS = ("prefab", "conventional", "lifted")
COMMON_FILE = PRESETS_DIR / "common.toml"  # what the presets share: transport, cast-in-place rates
DEFAULT_PRESET = "prefab"
_CLASS_NAME = re.compile(r"^Ifc[A-Za-z0-9]+$")
_CLASS_AND_TYPE = re.compile(r"^Ifc[A-Za-z0-9]+(\.[A-Z0-9_]+)?$")  # IfcSlab, or IfcSlab.BASESLAB


class MaterialKind(StrEnum):
    """What an element is made of, as the rules see it (read from its material names and categories)."""

    CONCRETE = "concrete"
    MASONRY = "masonry"
    STEEL = "steel"
    ALUMINIUM = "aluminium"
    TIMBER = "timber"
    GLASS = "glass"
    GYPSUM = "gypsum"
    UNKNOWN = "unknown"  # no material, or a name that says nothing of what it is


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


def _check_classes(names: tuple[str, ...]) -> tuple[str, ...]:
    for name in names:
        if not _CLASS_NAME.match(name):
            raise ValueError(f"{name!r} is not an IFC class name (IfcWall, IfcSlab, …)")
    return names


class MethodRule(_Frozen):
    """One rule: when an element matches every condition given, it is built by ``method``. Classes take
    subclasses (``IfcWall`` takes ``IfcWallStandardCase``); predefined types are the element's (or its
    type's; a user-defined one is its object type); ``in_ground``: its target lies in the ground (true) or
    not (false)."""

    method: ConstructionMethod
    note: str = Field(default="", description="why: written to the component's method_note")
    classes: tuple[str, ...] = ()
    predefined_types: tuple[str, ...] = ()
    except_predefined_types: tuple[str, ...] = ()
    materials: tuple[MaterialKind, ...] = ()
    in_ground: bool | None = None

    _classes = field_validator("classes")(_check_classes)


class PanelRule(_Frozen):
    """What is split into precast panels when a lifted element is too heavy or too large."""

    classes: tuple[str, ...] = Field(description="IFC classes (with subclasses) that are panelised")
    cast_when_too_heavy: tuple[MaterialKind, ...] = Field(
        default=(), description="the others, of these materials, are cast in place instead"
    )
    cast_unknown_classes: tuple[str, ...] = Field(
        default=(),
        description=(
            "elements of these classes whose material is unknown are cast in place when no machine lifts "
            "them whole and no panel cut fits (a solid floor slab of that size is concrete on a site)"
        ),
    )
    lay_when_not_panelised: tuple[MaterialKind, ...] = Field(
        default=(),
        description=(
            "elements of these materials that no panel cut fits are laid where they stand (a brick or "
            "block wall too heavy to lift whole is laid course by course on a site)"
        ),
    )
    cast_unknown_when_too_heavy: bool = Field(
        default=False,
        description=(
            "cast those elements in place as soon as no machine lifts them whole or no truck carries them, "
            "before any panel cut: taken for concrete, as the file casts its concrete (conventional)"
        ),
    )

    _classes = field_validator("classes", "cast_unknown_classes")(_check_classes)


class TransportLimits(_Frozen):
    """The largest part a road truck carries without a permit: its longest side on the deck, the other two
    across it and standing up."""

    length_m: float = Field(gt=0, le=100)
    width_m: float = Field(gt=0, le=20)
    height_m: float = Field(gt=0, le=20, description="of the load, above the deck")


class CastRates(_Frozen):
    """Rates of one concrete crew (and pump), for a class; a field left out takes the general value."""

    formwork_m2_per_h: float | None = Field(default=None, gt=0, description="set, strike (and rebar)")
    pour_m3_per_h: float | None = Field(default=None, gt=0)
    pour_setup_h: float | None = Field(default=None, ge=0, description="a pour's fixed time")
    cure_h: float | None = Field(default=None, ge=0, description="until what rests on it may be placed")


class CastInPlace(_Frozen):
    """The general rates and, by IFC class (with subclasses) or class and predefined type
    (``IfcSlab.BASESLAB``, which goes before its class), others."""

    formwork_m2_per_h: float = Field(gt=0)
    pour_m3_per_h: float = Field(gt=0)
    pour_setup_h: float = Field(ge=0)
    cure_h: float = Field(ge=0)
    pour_day_h: float = Field(
        default=8.0, gt=0, le=24, description="one day's pour: a larger element is poured in bays"
    )
    by_class: dict[str, CastRates] = {}

    @field_validator("by_class")
    @classmethod
    def _class_keys(cls, value: dict[str, CastRates]) -> dict[str, CastRates]:
        for name in value:
            if not _CLASS_AND_TYPE.match(name):
                raise ValueError(f"{name!r} is not an IFC class name, or a class and a predefined type")
        return value

    @model_validator(mode="after")
    def _day_longer_than_setup(self) -> CastInPlace:
        setups = [self.pour_setup_h, *(r.pour_setup_h for r in self.by_class.values() if r.pour_setup_h)]
        if max(setups) >= self.pour_day_h:
            raise ValueError(f"pour_day_h ({self.pour_day_h:g} h) must be longer than every pour_setup_h")
        return self

    def day_pour_m3(self, class_key: str | None) -> float:
        """What one day's pour places for the ``by_class`` key an element matched: the day less the pour's
        setup, at the pour rate (a larger element is poured in bays)."""
        _, pour_m3_per_h, setup_h, _ = self.rates(class_key)
        return (self.pour_day_h - setup_h) * pour_m3_per_h

    def rates(self, class_key: str | None) -> tuple[float, float, float, float]:
        """(formwork m²/h, pour m³/h, pour setup h, cure h) for the ``by_class`` key an element matched."""
        own = self.by_class.get(class_key, CastRates()) if class_key else CastRates()
        return (
            own.formwork_m2_per_h or self.formwork_m2_per_h,
            own.pour_m3_per_h or self.pour_m3_per_h,
            self.pour_setup_h if own.pour_setup_h is None else own.pour_setup_h,
            self.cure_h if own.cure_h is None else own.cure_h,
        )


class MethodsFile(_Frozen):
    """A methods file, its preset's values filled in (see the module docstring and the presets)."""

    preset: str = DEFAULT_PRESET
    name: str = ""
    description: str = ""
    ifc: bool = Field(default=True, description="follow what the IFC says where it says it")
    existing_in_place: bool = Field(default=True, description="existing work in the IFC is in place")
    default: ConstructionMethod = ConstructionMethod.LIFTED
    by_guid: dict[str, ConstructionMethod] = {}
    by_class: dict[str, ConstructionMethod] = {}
    by_material: dict[str, ConstructionMethod] = {}
    rules: tuple[MethodRule, ...] = ()
    panels: PanelRule
    transport: TransportLimits
    cast_in_place: CastInPlace
    connections: ConnectionTimes
    temporary_supports: TemporarySupportRules
    source: str = Field(default="", exclude=True, description="where it was read from (messages)")

    @field_validator("by_class")
    @classmethod
    def _class_keys(cls, value: dict[str, ConstructionMethod]) -> dict[str, ConstructionMethod]:
        _check_classes(tuple(value))
        return value

    @field_validator("by_material")
    @classmethod
    def _patterns(cls, value: dict[str, ConstructionMethod]) -> dict[str, ConstructionMethod]:
        for pattern in value:
            try:
                re.compile(pattern)
            except re.error as error:
                raise ValueError(f"{pattern!r} is not a regular expression ({error})") from None
        return value

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, value: str) -> str:
        if value not in PRESETS:
            raise ValueError(f"unknown preset {value!r} (presets: {', '.join(PRESETS)})")
        return value


def preset_text(name: str = DEFAULT_PRESET) -> str:
    """The preset as one complete TOML file (its rules, then what the presets share), as ``bimbot methods
    show`` prints it; :class:`InputError` for an unknown name."""
    if name not in PRESETS:
        raise InputError(f"unknown methods preset {name!r} (presets: {', '.join(PRESETS)})")
    own = (PRESETS_DIR / f"{name}.toml").read_text(encoding="utf-8")
    return own.rstrip("\n") + "\n\n" + COMMON_FILE.read_text(encoding="utf-8")


def load_methods(spec: str | Path | None = None) -> MethodsFile:
    """The methods in force: ``None`` → the default preset; a preset's name; else a TOML file laid over the
    preset it names. One :class:`InputError` line naming the file and the field when it is wrong."""
    if spec is None or str(spec) in PRESETS:
        name = DEFAULT_PRESET if spec is None else str(spec)
        return _validated({**_preset_data(name), "source": name}, f"methods preset {name}")
    path = Path(spec)
    if not path.is_file():
        raise InputError(
            f"methods file {path} does not exist (presets: {', '.join(PRESETS)})"
            if not path.exists()
            else f"methods file {path} is not a file"
        )
    data = _read(path, "methods file")
    base_name = data.get("preset", DEFAULT_PRESET)
    base = _preset_data(base_name) if base_name in PRESETS else {}  # an unknown preset: the model says so
    return _validated({**_laid_over(base, data), "source": str(path)}, f"methods file {path}")


def _preset_data(name: str) -> dict[str, Any]:
    return tomllib.loads(preset_text(name))


def _read(path: Path, what: str) -> dict[str, Any]:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{what} {path}: {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"{what} {path}: not valid TOML: {error}") from None


def _laid_over(base: dict[str, Any], top: dict[str, Any]) -> dict[str, Any]:
    """``top`` over ``base``: tables merged key by key (at any depth), everything else replaced."""
    merged = dict(base)
    for key, value in top.items():
        below = merged.get(key)
        if isinstance(value, dict) and isinstance(below, dict):
            merged[key] = _laid_over(below, value)
        else:
            merged[key] = value
    return merged


def _validated(data: dict[str, Any], what: str) -> MethodsFile:
    try:
        return MethodsFile.model_validate(data)
    except ValidationError as error:
        raise InputError(f"{what}: {_problems(error)}") from None


def _problems(error: ValidationError, shown: int = 3) -> str:
    """Pydantic's errors as one line: ``by_class.IfcWall: Input should be 'lifted', …; …``."""
    parts = []
    for item in error.errors()[:shown]:
        where = ".".join(str(part) for part in item["loc"])
        message = str(item["msg"]).removeprefix("Value error, ")
        parts.append(f"{where}: {message}" if where else message)
    more = error.error_count() - shown
    return "; ".join(parts) + (f" (and {more} more)" if more > 0 else "")
