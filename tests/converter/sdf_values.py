"""A pure Python check of the values in the converter's SDF files, and the structure key that groups them.

The reference parser (``sdf_checks.py``) costs about 0.13 s a file, and a build has a ``model.sdf`` per
component (115 for the Revit hub). The files come from one deterministic writer
(``services/converter/sdf_writer.py``): files with the same tag tree and the same attribute names differ only
in their values. ``structure_key`` is that tree without the values; ``sdf_check_files`` gives the reference
parser one file per key and every file the checks here.

``sdf_value_problems`` checks each value the writer varies from file to file, at least as strictly as the
reference parser does (libsdformat 12 calls a file with a mass of ``inf`` or 0, an empty ``<mass>``, a colour
of three numbers or an empty ``ifc_name`` valid; these are refused here):

* every leaf element has a rule: numbers are finite floats, as many as the element takes; colours are four
  of them in [0, 1]; booleans are ``true`` or ``false``; a mesh ``<uri>`` names a file that exists;
* every ``<inertial>`` has a positive mass and an inertia tensor whose principal moments are positive and
  meet the triangle inequality (ignition-math's ``MassMatrix3::IsValid``, the parser's test);
* every attribute has a value; a ``name`` is not reserved (``world``, ``__…__``) and holds no ``::``;
  named siblings have different names.

A leaf the table below does not know is a problem too: a new element in the writer needs its rule here.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from lxml import etree

#: leaf tag → how many finite floats it holds
FLOAT_COUNTS = {
    "pose": 6,
    "gravity": 3,
    "magnetic_field": 3,
    "direction": 3,
    "normal": 3,
    "size": 2,
    "mass": 1,
    **{tag: 1 for tag in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    **{tag: 1 for tag in ("max_step_size", "real_time_factor", "real_time_update_rate")},
    **{tag: 1 for tag in ("range", "constant", "linear", "quadratic", "mu", "mu2")},
}
COLOUR_TAGS = frozenset({"ambient", "diffuse", "specular", "background"})  # RGBA in [0, 1]
BOOLEAN_TAGS = frozenset({"static", "shadows", "cast_shadows"})
URI_TAG = "uri"
MODEL_URI = "model://"
INERTIA_TOLERANCE = 10.0  # ignition-math's IGN_MASSMATRIX3_DEFAULT_TOLERANCE


def structure_key(root: etree._Element) -> str:
    """The tag tree of ``root`` with each element's attribute names, without any text or attribute value."""
    children = ",".join(structure_key(child) for child in root if isinstance(child.tag, str))
    return f"{root.tag}[{','.join(sorted(root.attrib))}]({children})"


def sdf_value_problems(path: Path, models_dir: Path) -> list[str]:
    """What is wrong with the values of the SDF file ``path`` (see the module); empty when nothing is."""
    try:
        root = etree.parse(str(path)).getroot()
    except etree.XMLSyntaxError as error:
        return [f"not XML: {error}"]
    problems = (
        [] if root.tag == "sdf" and root.get("version") == "1.9" else ["root is not <sdf version='1.9'>"]
    )
    for element in root.iter():
        if not isinstance(element.tag, str):
            continue
        where = root.getroottree().getpath(element)
        problems += [f"{where}: {problem}" for problem in _attribute_problems(element)]
        if len([child for child in element if isinstance(child.tag, str)]) == 0 and element.tag != "sdf":
            problems += [f"{where}: {problem}" for problem in _leaf_problems(element, path, models_dir)]
        if element.tag == "inertial":
            problems += [f"{where}: {problem}" for problem in _inertial_problems(element)]
    return problems


def _attribute_problems(element: etree._Element) -> list[str]:
    problems = [f"empty attribute {name}" for name, value in element.attrib.items() if not value.strip()]
    name = element.get("name")
    if name is not None and (
        name == "world" or "::" in name or (name.startswith("__") and name.endswith("__"))
    ):
        problems.append(f"reserved or invalid name {name!r}")
    names = [child.get("name") for child in element if isinstance(child.tag, str) and child.get("name")]
    problems += [f"two children named {name!r}" for name in sorted({n for n in names if names.count(n) > 1})]
    return problems


def _leaf_problems(element: etree._Element, path: Path, models_dir: Path) -> list[str]:
    tag, text = element.tag, (element.text or "").strip()
    if tag.startswith("{"):  # a custom element (bimbot:ifc): its attributes are checked
        return []
    if tag in FLOAT_COUNTS:
        return _float_problems(text, FLOAT_COUNTS[tag])
    if tag in COLOUR_TAGS:
        problems = _float_problems(text, 4)
        if not problems and not all(0.0 <= float(v) <= 1.0 for v in text.split()):
            problems.append(f"colour {text!r} outside [0, 1]")
        return problems
    if tag in BOOLEAN_TAGS:
        return [] if text in ("true", "false") else [f"not a boolean: {text!r}"]
    if tag == URI_TAG:
        return _uri_problems(text, path, models_dir)
    if not text:  # no value, attributes only: <atmosphere type="adiabatic"/>, a link without children
        return []
    return [f"no value rule for <{tag}>: add one to {Path(__file__).name}"]


def _float_problems(text: str, count: int) -> list[str]:
    words = text.split()
    if len(words) != count:
        return [f"{count} number(s) expected, got {text!r}"]
    try:
        values = [float(word) for word in words]
    except ValueError:
        return [f"not a number: {text!r}"]
    return [] if all(math.isfinite(v) for v in values) else [f"not finite: {text!r}"]


def _uri_problems(uri: str, path: Path, models_dir: Path) -> list[str]:
    if not uri:
        return ["empty <uri>"]
    target = models_dir / uri[len(MODEL_URI) :] if uri.startswith(MODEL_URI) else path.parent / uri
    return [] if target.is_file() else [f"<uri> {uri} names no file ({target})"]


def _inertial_problems(inertial: etree._Element) -> list[str]:
    """A positive mass and a valid inertia tensor (positive principal moments, triangle inequality)."""
    try:
        mass = float(inertial.findtext("mass") or "nan")
        inertia = inertial.find("inertia")
        values = {
            tag: float(inertia.findtext(tag) or "nan") for tag in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
    except (ValueError, AttributeError):
        return ["no mass or inertia of numbers"]
    problems = [] if math.isfinite(mass) and mass > 0.0 else [f"mass {mass!r} is not positive"]
    tensor = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    if not np.isfinite(tensor).all():
        return [*problems, f"inertia {values} is not finite"]
    moments = np.linalg.eigvalsh(tensor)
    epsilon = INERTIA_TOLERANCE * sys.float_info.epsilon * 0.5 * abs(float(np.trace(tensor)))
    largest = moments.max()
    if moments.min() <= 0.0 or moments.sum() - largest + epsilon < largest:
        problems.append(f"inertia {values}: principal moments {moments.tolist()} are not valid")
    return problems
