"""What the converter's per-element work passes around: a shard's shared context, the work done once per
distinct geometry, and an element placed in the local frame. Data only, below the modules that fill and
read it (:mod:`.component_writer`, :mod:`.component_methods`, :mod:`.panel_writer`, :mod:`.shards`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import ifcopenshell
import numpy as np

from bimbot.shared.construction_methods import MethodDecision, MethodLimits
from bimbot.shared.methods_file import MethodsFile

from .collision import CollisionShape
from .mass_properties import MassProperties
from .mesh import TriMesh
from .mesh_files import VISUAL_FORMATS, GeometryFiles
from .prism_split import SectionCache
from .room_contents import RoomFloor
from .tessellation import ElementShape

if TYPE_CHECKING:
    from .crane_reach import LiftLimit


@dataclass
class ShardContext:
    """What every element of a shard shares, computed once per shard (not per element)."""

    out_dir: Path
    origin: np.ndarray  # local origin, IFC world frame, metres
    unit_scale_m: float
    mass_unit_kg: float = 1.0  # kilograms per project mass unit (mass.mass_unit_kg)
    formats: tuple[str, ...] = VISUAL_FORMATS  # visual mesh formats written (see mesh_files)
    split_ifc: bool = True  # write each component's standalone IFC
    sections: SectionCache = field(default_factory=SectionCache)  # section splits by section
    chains: dict[int, list[ifcopenshell.entity_instance]] = field(default_factory=dict)  # split_ifc
    decisions: dict[str, MethodDecision] = field(default_factory=dict)  # by GlobalId; absent: lifted/rule
    limits: MethodLimits | None = None  # what a lifted part may weigh and measure (None: the default fleet's)
    lift_limits: dict[str, LiftLimit] = field(default_factory=dict)  # by GlobalId: the crane's where it goes
    methods: MethodsFile | None = None  # the methods file in force: its cast-in-place rates
    storey_levels_m: tuple[float, ...] = ()  # storey elevations, IFC world z, metres (panels' rows)
    style_materials: dict[int, ifcopenshell.entity_instance] = field(default_factory=dict)  # face_materials
    room_floors: dict[int, RoomFloor] = field(default_factory=dict)  # by step id: a room's content's floor


@dataclass
class GeometryWork:
    """Per distinct geometry: computed once, shared by every element that uses it.

    The collision shape is computed when first read: a whole component needs it, an element cut into
    panels or poured in bays does not (each panel and bay has its own). On a Revit office of 258 panelised
    walls and slabs, the convex decomposition of the whole walls was half the converter's CPU."""

    mesh: TriMesh  # welded, outward: the visual mesh and the input of every computation
    props: MassProperties
    find_collision: Callable[[], CollisionShape]
    volumes_by_style: dict[int, float] = field(default_factory=dict)  # m³ by face style (face_materials)
    files: GeometryFiles | None = None
    files_dir: Path | None = None

    @cached_property
    def collision(self) -> CollisionShape:
        """The whole element's convex parts (:func:`.collision.collision_shape`), once."""
        return self.find_collision()


@dataclass
class PlacedElement:
    element: ifcopenshell.entity_instance
    shape: ElementShape
    geometry_key: str
    rotation: np.ndarray
    translation_m: np.ndarray
    vertices_local_m: np.ndarray
    bbox_ifc_world_m: np.ndarray  # (2, 3) in IFC world coordinates (before the local-origin shift)
    notes: tuple[str, ...] = ()  # what was done to its geometry (a room's content cut at its floor)
