"""Checks shared by conversion tests: the SDFormat reference parser and PyBullet loading.

``ign sdf -k`` (Debian's ignition-tools + libsdformat-dev, installed by ``scripts/setup.sh --tests``) is the
reference parser; it prints ``Valid.`` for a valid file. Model URIs (``model://…``) resolve through
``SDF_PATH``/``GZ_SIM_RESOURCE_PATH``, set to the conversion's ``models/`` folder.

``ign sdf -k`` is a Ruby script that loads libsdformat and calls its ``cmdCheck`` on one file: 0.3 s a
file, most of it starting Ruby and loading the library. ``sdf_check_all`` calls the very same function of
the very same library (the one the Ruby script names) on every file in one process (``sdf_batch_check.py``)
and asks ``ign sdf -k`` itself only about a file that fails, for its message.

``sdf_check_files`` is what a test of a whole build uses: the reference parser on one file per structure
(the tag tree with attribute names, ``sdf_values.structure_key``; the world file has one of its own) and the
pure Python value check (``sdf_values.sdf_value_problems``) on every file. The files come from one
deterministic writer; files of one structure differ only in their values, which the value check reads in
each of them.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from lxml import etree
from scipy.spatial.transform import Rotation
from sdf_values import sdf_value_problems, structure_key
from wall_clock import bound_s

IGN = shutil.which("ign")
BATCH_SCRIPT = Path(__file__).with_name("sdf_batch_check.py")
RUBY_COMMANDS = Path("/usr/lib/ruby/ignition")


def _resource_env(models_dir: Path) -> dict[str, str]:
    return dict(
        os.environ,
        SDF_PATH=str(models_dir),
        GZ_SIM_RESOURCE_PATH=str(models_dir),
        IGN_GAZEBO_RESOURCE_PATH=str(models_dir),
    )


def sdformat_library() -> Path:
    """The libsdformat that ``ign sdf`` loads: the ``LIBRARY_NAME`` of its Ruby command file, newest first."""
    for commands in sorted(RUBY_COMMANDS.glob("cmdsdformat*.rb"), reverse=True):
        found = re.search(r"^LIBRARY_NAME = '([^']+)'", commands.read_text(), re.MULTILINE)
        if found:
            return (commands.parent / found.group(1)).resolve()
    raise AssertionError(f"no cmdsdformat*.rb in {RUBY_COMMANDS}: run scripts/setup.sh --tests")


def sdf_check_all(paths: list[Path], models_dir: Path) -> dict[Path, str]:
    """``Valid.`` or the reference parser's message for each of ``paths``, checked in one process."""
    with tempfile.TemporaryDirectory(prefix="sdf-check-") as scratch:  # the build may be shared: not there
        results = Path(scratch) / "sdf-check.json"
        command = [sys.executable, str(BATCH_SCRIPT), str(sdformat_library()), str(results), *map(str, paths)]
        subprocess.run(
            command, capture_output=True, env=_resource_env(models_dir), timeout=bound_s(300), check=True
        )
        codes = json.loads(results.read_text())
    assert len(codes) == len(paths), "the batch checker answered for every file"
    return {
        path: "Valid." if code == 0 else ign_sdf_check(path, models_dir)
        for path, code in zip(paths, codes, strict=True)
    }


def one_file_per_structure(paths: list[Path]) -> list[Path]:
    """The first of ``paths`` with each structure key; a file lxml cannot parse is a structure of its own."""
    first: dict[str, Path] = {}
    for path in paths:
        try:
            key = structure_key(etree.parse(str(path)).getroot())
        except etree.XMLSyntaxError:
            key = f"unparsed {path}"
        first.setdefault(key, path)
    return list(first.values())


def sdf_check_files(paths: list[Path], models_dir: Path) -> dict[Path, str]:
    """``Valid.`` or what is wrong, for each of ``paths``: the value check of every file and the reference
    parser's answer for one file per structure (``one_file_per_structure``), see the module."""
    referenced = sdf_check_all(one_file_per_structure(paths), models_dir)
    answers: dict[Path, str] = {}
    for path in paths:
        problems = [f"value check: {problem}" for problem in sdf_value_problems(path, models_dir)]
        if referenced.get(path, "Valid.") != "Valid.":
            problems.append(f"reference parser: {referenced[path]}")
        answers[path] = "\n".join(problems) or "Valid."
    return answers


def ign_sdf_check(path: Path, models_dir: Path) -> str:
    """Run ``ign sdf -k`` on ``path``; return its combined output (``Valid.`` on success)."""
    assert IGN is not None, "ign (ignition-tools) is not installed: run scripts/setup.sh --tests"
    result = subprocess.run(
        [IGN, "sdf", "-k", str(path)],
        capture_output=True,
        text=True,
        env=_resource_env(models_dir),
        timeout=bound_s(120),
        check=False,
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
