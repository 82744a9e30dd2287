"""A crane's URDF with its mast made taller: the crane erected higher than its file draws it (pure).

Why: the site erects a tower crane as high as the building needs (:mod:`.crane_erection`), so physics must
load, and the dashboard draw, a crane whose hook hangs that much higher. The mast is the link the ``slew``
joint turns on: its boxes and cylinders are stretched upwards by the raise (their bottom stays where it
is), the ``slew`` joint moves up by as much, and the ``hoist`` joint's travel grows by as much, so the
hook still reaches the ground. Everything above the slewing ring is unchanged. A mesh named by a relative
path is made absolute against the original file's folder, so the result can be loaded from anywhere.

Input and output are URDF bytes; nothing is read or written on disk here.
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from .errors import InputError

SLEW_JOINT = "slew"
HOIST_JOINT = "hoist"


def raised_mast_urdf(urdf: bytes, raise_m: float, *, source: Path) -> bytes:
    """``urdf`` (the file at ``source``) with its mast ``raise_m`` metres taller (see the module docstring);
    an InputError names what the URDF lacks."""
    parser = etree.XMLParser(remove_comments=False, resolve_entities=False, no_network=True)
    try:
        robot = etree.fromstring(urdf, parser)
    except etree.XMLSyntaxError as exc:
        raise InputError(f"robot URDF {source}: {exc}") from None
    slew = _joint(robot, SLEW_JOINT, source)
    parent = slew.find("parent")
    mast_name = parent.get("link") if parent is not None else None
    mast = next((link for link in robot.findall("link") if link.get("name") == mast_name), None)
    if mast is None:
        raise InputError(f"robot URDF {source}: the {SLEW_JOINT!r} joint's parent link is missing")
    _shift_z(_origin(slew), raise_m)
    for element in (*mast.findall("visual"), *mast.findall("collision")):
        _stretch(element, raise_m)
    inertial = mast.find("inertial")
    if inertial is not None:
        _shift_z(_origin(inertial), raise_m / 2.0)
    limit = _joint(robot, HOIST_JOINT, source).find("limit")
    if limit is not None and limit.get("upper") is not None:
        limit.set("upper", _number(float(limit.get("upper", "0")) + raise_m))
    for mesh in robot.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename and "://" not in filename and not Path(filename).is_absolute():
            mesh.set("filename", str((source.parent / filename).resolve()))
    return bytes(etree.tostring(robot, xml_declaration=True, encoding="utf-8"))


def _joint(robot: etree._Element, name: str, source: Path) -> etree._Element:
    joint = next((item for item in robot.findall("joint") if item.get("name") == name), None)
    if joint is None:
        raise InputError(f"robot URDF {source}: no joint {name!r} (a crane needs slew, trolley and hoist)")
    return joint


def _origin(element: etree._Element) -> etree._Element:
    origin = element.find("origin")
    if origin is None:
        origin = etree.SubElement(element, "origin")
    return origin


def _xyz(origin: etree._Element) -> list[float]:
    return [float(value) for value in (origin.get("xyz") or "0 0 0").split()]


def _shift_z(origin: etree._Element, by_m: float) -> None:
    x, y, z = _xyz(origin)
    origin.set("xyz", " ".join(_number(value) for value in (x, y, z + by_m)))


def _stretch(element: etree._Element, by_m: float) -> None:
    """A visual or collision box or cylinder of the mast ``by_m`` longer upwards (its bottom kept): its
    length grows by ``by_m`` and its centre rises by half of it. Other shapes (a mesh) stay as drawn."""
    geometry = element.find("geometry")
    box = geometry.find("box") if geometry is not None else None
    cylinder = geometry.find("cylinder") if geometry is not None else None
    if box is not None:
        size = [float(value) for value in (box.get("size") or "0 0 0").split()]
        size[2] += by_m
        box.set("size", " ".join(_number(value) for value in size))
    elif cylinder is not None:
        cylinder.set("length", _number(float(cylinder.get("length", "0")) + by_m))
    else:
        return
    _shift_z(_origin(element), by_m / 2.0)


def _number(value: float) -> str:
    return f"{value:.6g}"
