"""Components as plain boxes, without an IFC: for the site plan's tests, which only need where each one
stands, how big it is and how it is built."""

from __future__ import annotations

import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component


def box_component(
    guid: str,
    size_m: tuple[float, float, float],
    at_m: tuple[float, float, float],
    method: ConstructionMethod = ConstructionMethod.LIFTED,
    mass_kg: float = 100.0,
) -> Component:
    """A component with a box of ``size_m`` in its own frame, placed at ``at_m`` (no rotation)."""
    low, high = np.array(at_m), np.array(at_m) + np.array(size_m)
    box = {"min_m": (0.0, 0.0, 0.0), "max_m": tuple(size_m)}
    return Component.model_validate(
        {
            "guid": guid, "key": guid, "folder": guid, "ifc_class": "IfcBuildingElementProxy",
            "target_pose_world": {"position_m": at_m, "quat_xyzw": (0, 0, 0, 1), "rpy_rad": (0, 0, 0)},
            "bbox_world": {"min_m": tuple(low), "max_m": tuple(high)}, "bbox_local": box,
            "volume_m3": float(np.prod(size_m)), "watertight": True, "mass_kg": mass_kg,
            "mass_source": "IfcQuantityWeight", "com_local_m": tuple(np.array(size_m) / 2),
            "inertia_kg_m2": {"ixx": 1, "ixy": 0, "ixz": 0, "iyy": 1, "iyz": 0, "izz": 1},
            "inertia_source": "mesh", "collision_method": "convex_hull", "collision_parts": 1,
            "files": {"model_dir": "m", "sdf_file": "m/model.sdf", "config_file": "m/model.config",
                      "split_ifc": "m/x.ifc", "visual_dae": "v.dae", "visual_obj": "v.obj",
                      "visual_glb": "v.glb", "collision": []},
            "method": method,
        }
    )  # fmt: skip


def upper_floor_beams(length_m: float) -> list[Component]:
    """Beams 6 m up every 5 m along ``length_m`` in two rows 20 m apart, 600 kg each: only a crane sets
    them (above the carriers' 3.5 m), and a beam's hook radius is its distance from the crane."""
    return [
        box_component(f"b{row}-{index}", (4.0, 0.3, 0.4), (index * 5.0, row * 20.0, 6.0), mass_kg=600.0)
        for index in range(int(length_m // 5.0))
        for row in (0, 1)
    ]
