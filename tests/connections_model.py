"""A small site for connections and temporary supports (ifcopenshell.api): two steel columns on base
plates and anchor bolts over pad footings, a beam framed between their tops, a precast wall panel on a
strip footing, and a slab bearing on the beam and the panel."""

from __future__ import annotations

from pathlib import Path

from converter.ifc_builders import add_box, add_material, new_model

COLUMN_H_M = 3.0
PLATE_M = 0.02
BEAM_TOP_M = PLATE_M + COLUMN_H_M + 0.3  # the beam's top, the panel's top: where the slab bears


def write_connections_model(path: Path) -> Path:
    small = new_model()
    steel, concrete = [], []
    for index, x in enumerate((0.0, 4.0)):
        concrete.append(
            add_box(
                small, "IfcFooting", f"Pad {index}", size_m=(1.0, 1.0, 0.5), corner_m=(x - 0.5, -0.5, -0.5)
            )
        )
        steel.append(
            add_box(
                small,
                "IfcPlate",
                f"Base plate {index}",
                size_m=(0.4, 0.4, PLATE_M),
                corner_m=(x - 0.2, -0.2, 0.0),
            )
        )
        for dx in (-0.15, 0.13):
            steel.append(
                add_box(
                    small,
                    "IfcMechanicalFastener",
                    f"Anchor bolt {index}",
                    size_m=(0.02, 0.02, 0.3),
                    corner_m=(x + dx, -0.01, -0.28),
                )
            )
        steel.append(
            add_box(
                small,
                "IfcColumn",
                f"Column {index}",
                size_m=(0.2, 0.2, COLUMN_H_M),
                corner_m=(x - 0.1, -0.1, PLATE_M),
            )
        )
    steel.append(
        add_box(small, "IfcBeam", "Beam", size_m=(3.8, 0.2, 0.3), corner_m=(0.1, -0.1, PLATE_M + COLUMN_H_M))
    )
    concrete.append(add_box(small, "IfcFooting", "Strip", size_m=(4.4, 0.6, 0.5), corner_m=(-0.2, 2.7, -0.5)))
    concrete.append(
        add_box(small, "IfcWall", "Panel", size_m=(4.0, 0.2, BEAM_TOP_M), corner_m=(0.0, 2.9, 0.0))
    )
    concrete.append(
        add_box(small, "IfcSlab", "Plank", size_m=(3.6, 3.0, 0.15), corner_m=(0.2, 0.0, BEAM_TOP_M))
    )
    add_material(small, steel, "Steel S355", "steel")
    add_material(small, concrete, "Concrete C30/37", "concrete")
    small.file.write(str(path))
    return path
