"""Joint rules: when an overlap the model draws between two components is a joint, not a clash.

Real models draw joints as overlaps: a column into its footing and its base plate, a beam's end into a
column's face or a wall, channels lapped, a window into its wall. The converter lists every pair that
overlaps deeper than a contact (``contact_m``) as a joint when the IFC relates the two or a rule here fits
(:mod:`bimbot.services.converter.joints`), and as a clash otherwise when it is deeper than
:data:`CLASH_DEPTH_M`. The rules live in a small TOML file (``joint_rules.toml`` beside this module is the
default and says why each depth; ``bimbot convert --joints FILE`` reads another), loaded into the frozen
models below; a bad file is one clear line (:class:`~bimbot.shared.errors.InputError`).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator

from bimbot.shared.errors import InputError

DEFAULT_JOINT_RULES_FILE = Path(__file__).resolve().parent / "joint_rules.toml"

FITTING_THIN_M = 0.05
"""A member whose least side is at most this is a board or sheet a site scribes or cuts to fit it."""
FITTING_OPEN_FILL = 0.25
"""A member whose volume fills at most this share of its own box is an open frame (a railing, a screen)."""

CLASH_DEPTH_M = 0.015
"""An overlap deeper than this that is no joint is a clash: physics cannot take it for a contact to stop at
(a robot setting a member against its neighbour stops there; shallower overlaps are cleared at release)."""


def _as_tuple(value: object) -> object:
    return (value,) if isinstance(value, str) else value


ClassNames = Annotated[tuple[str, ...], BeforeValidator(_as_tuple), Field(min_length=1)]


class JointRule(BaseModel):
    """A ``member``'s end drawn inside a ``part`` it bears on or frames into, at most ``max_depth_m`` deep."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    member: ClassNames  # IFC classes (with subclasses)
    part: ClassNames
    max_depth_m: float = Field(gt=0.0, le=2.0)
    # the overlap must lie within max_depth_m of one end or face of the member (not through its middle)
    at_end: bool = True
    # erection clearance at a framed end: a member's end drawn butting the part (no deeper than a contact) or
    # up to this far short of it is a framed joint too. The member is fabricated short of the drawn butt by
    # the clearance (a bolted end's gap to the web it frames into), so the part's erection error is taken in
    # the gap instead of pushing the member out of place. 0: contacts are not joints under this rule.
    clearance_m: float = Field(default=0.0, ge=0.0, le=0.05)
    # the part goes first whatever the heights: what the rule's member is fitted to stands before it (a
    # storefront is fitted under the ledger over it, not the ledger set on the storefront)
    part_first: bool = False
    # only a member shaped as a bar (a rod, strut or hanger: its oriented box at least ten times longer than
    # wide), whatever class it was exported as; not a cabinet or a fitting of the same class
    slender: bool = False
    # only a member drawn inside the part's thickness along its length (a lintel or bond beam in its
    # wall): the overlap takes in the member's whole section and runs along it for more than twice the
    # part's thickness, so a member crossing the part is not one
    embedded: bool = False
    # only a member carried through the part: the overlap takes in the member's whole section and the
    # part's whole thickness, and the member runs on past both of the part's faces (a purlin through a
    # gable, a girder through the wall it bears on), not an end drawn into it
    through: bool = False
    # only an overlap that runs at least this far in plan (a lining along the wall it lines, not a wall's
    # edge against a pier); 0: any
    min_run_m: float = Field(default=0.0, ge=0.0, le=100.0)
    # only a member a site makes to fit the part as built: a board or sheet (its least side at most
    # FITTING_THIN_M) or an open frame (its volume at most FITTING_OPEN_FILL of its own box: a railing, a
    # screen, a rod on the slant), not a solid block
    fitting: bool = False
    # only a member that weighs at most this; 0: any
    max_member_kg: float = Field(default=0.0, ge=0.0)
    # …and at most this share of the part's mass (the lighter is made to fit the heavier); 0: any
    max_member_share: float = Field(default=0.0, ge=0.0, le=1.0)
    why: str = ""

    @field_validator("member", "part")
    @classmethod
    def _ifc_classes(cls, names: tuple[str, ...]) -> tuple[str, ...]:
        for name in names:
            if not (name.startswith("Ifc") and name[3:].isalnum()):
                raise ValueError(f"{name!r} is not an IFC class name (IfcColumn, IfcWall, …)")
        return names

    def takes_masses(self, member_kg: float, part_kg: float) -> bool:
        """Whether a member of ``member_kg`` drawn into a part of ``part_kg`` is light enough for the rule."""
        if self.max_member_kg > 0.0 and member_kg > self.max_member_kg:
            return False
        return not (self.max_member_share > 0.0 and member_kg > self.max_member_share * part_kg)

    def takes_shape(self, least_side_m: float, box_fill: float) -> bool:
        """Whether a member whose own box's least side is ``least_side_m`` and whose volume fills
        ``box_fill`` of that box is shaped as the rule asks: any, or a ``fitting`` (a board, a sheet or an
        open frame)."""
        return not self.fitting or least_side_m <= FITTING_THIN_M or box_fill <= FITTING_OPEN_FILL

    def describe(self, member: str, part: str) -> str:
        """``"IfcColumn into IfcFooting, up to 100 mm"`` (a fitting rule: ``"IfcRailing made to fit IfcWall,
        up to 350 mm"``; a through rule: ``"IfcBeam carried through IfcWall"``): the rule as the manifest and
        the log name it."""
        if self.through:  # its depth bound is no measure of anything (the shape decides)
            return f"{member} carried through {part}"
        how = "made to fit" if self.fitting else "into"
        return f"{member} {how} {part}, up to {1000.0 * self.max_depth_m:.0f} mm"

    def describe_framed(self, member: str, part: str) -> str:
        """``"IfcBeam framed to IfcBeam, 10 mm erection clearance"``: a butt or gap taken by this rule."""
        return f"{member} framed to {part}, {1000.0 * self.clearance_m:.0f} mm erection clearance"


class JointSettings(BaseModel):
    """What the converter takes for a joint (see ``joint_rules.toml``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    contact_m: float = Field(default=0.003, ge=0.0, lt=CLASH_DEPTH_M)
    rule: tuple[JointRule, ...] = ()
    source: str = ""  # the file it was read from

    @property
    def framed_reach_m(self) -> float:
        """The widest erection clearance of any rule: how far apart a framed end may be drawn (0: none)."""
        return max((rule.clearance_m for rule in self.rule), default=0.0)


def load_joint_settings(path: Path | str | None = None) -> JointSettings:
    """The joint rules in ``path`` (TOML), or the embedded default; one clear line when the file is wrong."""
    file = Path(path) if path is not None else DEFAULT_JOINT_RULES_FILE
    try:
        data = tomllib.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"joint rules {file}: no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"joint rules {file}: {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise InputError(f"joint rules {file}: not valid TOML: {error}") from None
    try:
        return JointSettings.model_validate({**data, "source": str(file)})
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first["loc"])
        message = str(first["msg"]).removeprefix("Value error, ")
        more = f" (and {error.error_count() - 1} more)" if error.error_count() > 1 else ""
        raise InputError(f"joint rules {file}: {where}: {message}{more}") from None


def default_joint_settings() -> JointSettings:
    return load_joint_settings(None)
