"""The converter's manifest: every component and every skipped element of one conversion (``manifest.json``).

Every other service reads this file, so it is a versioned, frozen pydantic model. Frames and units:

* ``*_world`` values are in the simulation world frame: metres, Z up, right-handed, equal to the IFC
  project's world coordinates minus ``Manifest.local_origin_m`` (the shift that keeps single-precision
  physics exact for models far from the origin).
* ``*_local`` values are in the component's own frame (its IFC object placement), metres.
* Quaternions are ``quat_xyzw``; Euler angles are SDF's fixed-axis roll-pitch-yaw in radians.
* Paths are POSIX paths relative to the conversion's output folder.
"""

from __future__ import annotations

import json
from enum import StrEnum
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from bimbot.shared.connection_kinds import ConnectionLink, TemporarySupportNeed
from bimbot.shared.construction_methods import (
    CastWork,
    ConstructionMethod,
    GuestElement,
    MethodSource,
    PanelisedElement,
)
from bimbot.shared.errors import UserError
from bimbot.shared.geometry import Quat, Vec3
from bimbot.shared.run_folder import ENDED_NAME, RUNS_DIR_NAME

MANIFEST_SCHEMA_VERSION = 1
MANIFEST_FILE_NAME = "manifest.json"


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Pose(_Frozen):
    """A rigid pose: position in metres, unit quaternion (x, y, z, w) and SDF roll-pitch-yaw in radians."""

    position_m: Vec3
    quat_xyzw: Quat
    rpy_rad: Vec3


class BoundingBox(_Frozen):
    """Axis-aligned box, metres."""

    min_m: Vec3
    max_m: Vec3


class Inertia(_Frozen):
    """Inertia tensor about the centre of mass, axes of the component frame, kg·m² (SDF sign convention)."""

    ixx: float
    ixy: float
    ixz: float
    iyy: float
    iyz: float
    izz: float


class MassSource(StrEnum):
    """Where a component's mass came from, in the order the converter tries them."""

    QUANTITY_WEIGHT = "IfcQuantityWeight"
    VENDOR_PROPERTY = "vendor_weight_property"
    MATERIAL_DENSITY_PROPERTY = "mesh_volume_x_Pset_MaterialCommon.MassDensity"
    MATERIAL_DENSITY_TABLE = "mesh_volume_x_material_table"
    DEFAULT_DENSITY = "mesh_volume_x_default_density"


class InertiaSource(StrEnum):
    MESH = "mesh"
    BOUNDING_BOX_FALLBACK = "bounding_box_fallback"


MAX_COLLISION_PARTS = 16
"""Convex collision parts per component at most: pybullet builds a compound shape of the first 16 parts
it is given and silently drops the rest (its MAX_COMPOUND_COLLISION_SHAPES; measured with 40 boxes: 16 are
hit by rays), so a 22-part window would collide with 16 of its parts."""


class CollisionMethod(StrEnum):
    """How the collision shape of a moving body was made."""

    CONVEX_HULL = "convex_hull"  # the element is convex: one hull
    PROFILE_DECOMPOSITION = "profile_decomposition"  # extruded parametric profile split exactly into prisms
    MESH_SPLIT = "mesh_split"  # separate solids of the mesh, cut along their own face planes where concave
    VHACD = "vhacd"  # what is left (concave and not a closed manifold): pybullet's V-HACD


class Connection(_Frozen):
    """A relationship from this component to another element."""

    relation: str  # IFC class of the relationship, e.g. IfcRelConnectsElements
    role: str  # this component's role: relating/related/realizing/aggregate_parent/aggregate_child
    other_guid: str
    other_class: str


class JointSource(StrEnum):
    """Why an overlap the model draws is a joint."""

    RELATION = "relation"  # the IFC relates the two components (``Joint.rule`` names the relationship)
    RULE = "rule"  # the usual drawing of a joint: a member's end in what it bears on (``Joint.rule``)
    CAST = "cast"  # one of the two is cast in place: its concrete is poured around the other (a pocket)
    # a member's end drawn butting the part it frames into, or just short of it: fabricated short of the
    # butt and bolted through clearance holes, it is erected with a gap (``Joint.clearance_m``)
    FRAMED = "framed"
    # a new component drawn into existing work (in place before the robots come) no deeper than a site cuts a
    # notch or scribes the new part to fit it: fitted to it, not a clash
    FITTED = "fitted"
    # a deck drawn through an upright that passes through it (a post through a roof plank): cut round it
    NOTCHED = "notched"


class Joint(_Frozen):
    """Two components the model draws into each other where they are joined: not a clash.

    Physics lets the pair overlap (no contact between them) and connects the one set second to the first;
    the support graph orders the pair (``shared/support_graph.py``). ``guids`` is (part, member): the part
    the other is drawn into (a filling's host, the part a rule's member bears on or frames into), or for a
    relation without a direction the relating element first.
    """

    guids: tuple[str, str]
    depth_m: float = Field(ge=0.0, description="how deep they overlap: the shortest move that parts them")
    source: JointSource
    rule: str = Field(
        description="the IFC relationship, or the rule: 'IfcColumn into IfcFooting, up to 100 mm'"
    )
    directed: bool = Field(default=True, description="guids[0] is the part the other is set into")
    clearance_m: float = Field(
        default=0.0,
        ge=0.0,
        description="a framed end's erection gap: how far the part may stand off without moving the member",
    )
    part_first: bool = Field(
        default=False,
        description="guids[0] goes first whatever the heights: the member is fitted to it (rule part_first)",
    )
    bottoms_at_joint_m: tuple[float, float] | None = Field(
        default=None,
        description=(
            "how low each of ``guids`` reaches right under where they overlap (world z): the lower one bears "
            "(a rafter's box reaches below its purlin at the eaves, its section over the purlin does not)"
        ),
    )


class Clash(_Frozen):
    """Two components the model puts into each other deeper than a contact, with no joint between them."""

    guids: tuple[str, str]
    depth_m: float = Field(ge=0.0)


class ComponentFiles(_Frozen):
    model_dir: str
    sdf_file: str
    config_file: str
    split_ifc: str  # empty: not written (``bimbot convert --no-split-ifc``)
    visual_dae: str
    visual_obj: str
    visual_glb: str
    collision: list[str]


class Component(_Frozen):
    guid: str
    key: str = Field(description="bus key chunk for this GUID (bimbot.shared.identifiers.guid_to_key)")
    folder: str = Field(description="model folder name (bimbot.shared.identifiers.guid_to_folder)")
    ifc_class: str
    predefined_type: str | None = None
    name: str | None = None
    storey: str | None = None
    material: str | None = None
    target_pose_world: Pose
    bbox_world: BoundingBox
    bbox_local: BoundingBox
    volume_m3: float
    watertight: bool
    mass_kg: float = Field(gt=0)
    mass_source: MassSource
    com_local_m: Vec3
    inertia_kg_m2: Inertia
    inertia_source: InertiaSource
    collision_method: CollisionMethod
    collision_parts: int
    part_boxes_local: list[BoundingBox] = Field(
        default=[],
        description=(
            "the box of each collision part, component frame, when it has more than one: the gaps between "
            "them (a door's opening under its lintel) are driven through"
        ),
    )
    face_slope_deg: float = Field(
        default=0.0,
        ge=0.0,
        le=90.0,
        description=(
            "the area-weighted slope of its faces within 60° of horizontal, world (0: flat; a pitched roof "
            "panel's pitch): what bears on a slope is fastened down, not left on friction"
        ),
    )
    files: ComponentFiles
    connections: list[Connection] = []
    warnings: list[str] = []
    # how it is built (shared/construction_methods.py): decided at conversion from the IFC, rules, the user
    method: ConstructionMethod = ConstructionMethod.LIFTED
    method_source: MethodSource = MethodSource.RULE
    method_note: str = Field(default="", description="why this method: what the IFC or the rule said")
    parent_guid: str | None = Field(default=None, description="a panel: the element it was cut from")
    cast: CastWork | None = Field(default=None, description="cast_in_place: its formwork, pour and cure")
    guests: list[GuestElement] = Field(default=[], description="elements built into it (with_host)")
    # how it is connected to each supporting neighbour, and the temporary supports it needs until those
    # hold it (shared/connection_kinds.py): decided at conversion, used by physics
    connection_links: list[ConnectionLink] = []
    temporary_support: TemporarySupportNeed | None = None


class SkippedElement(_Frozen):
    guid: str
    ifc_class: str
    name: str | None = None
    reason: str


class SourceModel(_Frozen):
    path: str
    schema_name: str
    sha256: str
    length_unit_m: float = Field(description="metres per IFC length unit")


class Manifest(_Frozen):
    schema_version: int = MANIFEST_SCHEMA_VERSION
    generator: str
    site: str = Field(description="site slug: world file name and bus key root bimbot/<site>/")
    site_name: str | None = None
    source: SourceModel
    local_origin_m: Vec3 = Field(description="IFC world coordinates (m) of the simulation world origin")
    world_file: str
    sequence_file: str
    sequence_source: str
    components: list[Component]
    # in place before the robots come (cast in situ, built by others: ``convert --in-place``): physics puts
    # them at their BIM pose, static; nothing plans, carries or counts them
    in_place: list[Component] = []
    # elements split into precast panels: each panel is a component with ``parent_guid`` set
    panelised: list[PanelisedElement] = []
    # pairs of components (or in place) the model draws into each other: joints, and clashes (deepest first)
    joints: list[Joint] = []
    clashes: list[Clash] = []
    skipped: list[SkippedElement] = []
    warnings: list[str] = []

    def component(self, guid: str) -> Component:
        """The component with this GlobalId (KeyError when absent)."""
        for item in self.components:
            if item.guid == guid:
                return item
        raise KeyError(guid)


def write_manifest(manifest: Manifest, out_dir: Path) -> Path:
    path = Path(out_dir) / MANIFEST_FILE_NAME
    path.write_text(manifest.model_dump_json(indent=2), encoding="utf-8")
    return path


def read_manifest(build_dir: Path) -> Manifest:
    """Read ``<build_dir>/manifest.json`` (or the file itself when given one)."""
    path = Path(build_dir)
    if path.is_dir():
        path = path / MANIFEST_FILE_NAME
    data = json.loads(path.read_text(encoding="utf-8"))
    version = data.get("schema_version")
    if version != MANIFEST_SCHEMA_VERSION:
        raise ValueError(
            f"{path}: manifest schema_version {version!r}, this bimbot reads {MANIFEST_SCHEMA_VERSION}"
        )
    return Manifest.model_validate(data)


def require_components(build: Path, manifest: Manifest) -> None:
    """A :class:`UserError` when the build has nothing to construct (a conversion that converted nothing,
    exit 2, still writes its folder): what ``bimbot run`` and ``bimbot fleet check`` say of it."""
    if not manifest.components:
        raise UserError(f"{build}: the build has no components to construct")


def _run_folder(folder: Path) -> bool:
    """Whether ``folder`` is a run folder: its run ended (``ENDED``) or left a report (a trial user gave
    ``bimbot run`` the run folder and read "no manifest")."""
    return folder.is_dir() and (
        (folder / ENDED_NAME).is_file() or (folder / "report" / "report.json").is_file()
    )


def load_manifest(build: Path) -> Manifest:
    """:func:`read_manifest` for a command: a missing or broken manifest is one clear :class:`UserError`
    line naming the file (what every service and ``bimbot run`` report), never a traceback."""
    build = Path(build)
    path = build / MANIFEST_FILE_NAME if build.is_dir() else build
    if not build.exists():
        raise UserError(f"{build}: no such folder (convert a model first: bimbot convert MODEL.ifc -o OUT/)")
    if not path.is_file() and _run_folder(build):
        ran = build.parent.parent if build.parent.name == RUNS_DIR_NAME else None
        raise UserError(
            f"{build}: a run folder (what bimbot run wrote), not a build; give the build it ran"
            + (f": {ran}" if ran is not None else " (the folder bimbot convert -o wrote)")
        )
    if not path.is_file():
        raise UserError(f"{path}: no manifest (convert a model first: bimbot convert MODEL.ifc -o OUT/)")
    if path.suffix.lower() in (".ifc", ".ifczip", ".ifcxml"):
        raise UserError(
            f"{path}: an IFC model, not a converted build (convert it first: bimbot convert {path} -o OUT/, "
            "then use OUT/)"
        )
    try:
        return read_manifest(path)
    except json.JSONDecodeError as error:
        raise UserError(f"{path}: not a JSON manifest ({error.msg} at line {error.lineno})") from None
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first.get("loc", ())) or "manifest"
        raise UserError(f"{path}: invalid manifest ({where}: {first.get('msg', 'invalid')})") from None
    except (ValueError, OSError) as error:
        first_line = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise UserError(f"{path}: unreadable manifest ({first_line})") from None
