"""Checks shared by conversion tests: the SDFormat reference parser and PyBullet loading.

``ign sdf -k`` (Debian's ignition-tools + libsdformat-dev, installed by ``scripts/setup.sh``) is the
reference parser; it prints ``Valid.`` for a valid file. Model URIs (``model://…``) resolve through
``SDF_PATH``/``GZ_SIM_RESOURCE_PATH``, set to the conversion's ``models/`` folder.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
from lxml import etree
from scipy.spatial.transform import Rotation

IGN = shutil.which("ign")


def ign_sdf_check(path: Path, models_dir: Path) -> str:
    """Run ``ign sdf -k`` on ``path``; return its combined output (``Valid.`` on success)."""
    assert IGN is not None, "ign (ignition-tools) is not installed: run scripts/setup.sh"
    env = dict(
        os.environ,
        SDF_PATH=str(models_dir),
        GZ_SIM_RESOURCE_PATH=str(models_dir),
        IGN_GAZEBO_RESOURCE_PATH=str(models_dir),
    )
    result = subprocess.run(
        [IGN, "sdf", "-k", str(path)], capture_output=True, text=True, env=env, timeout=120, check=False
    )
    lines = (result.stdout + result.stderr).splitlines()
    output = "\n".join(line for line in lines if "libignition-tools-backward" not in line).strip()
    return output if result.returncode == 0 else f"exit {result.returncode}: {output}"


def sdf_model_pose(path: Path) -> np.ndarray:
    """4×4 matrix of the first ``<model><pose>`` in an SDF file (SDF roll-pitch-yaw)."""
    root = etree.parse(str(path)).getroot()
    values = [float(v) for v in root.find(".//model/pose").text.split()]
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", values[3:]).as_matrix()
    matrix[:3, 3] = values[:3]
    return matrix
