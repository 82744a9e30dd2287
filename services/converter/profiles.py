"""IFC profile definitions split exactly into convex 2D polygons, for collision shapes of extruded members.

A moving rigid body collides as a set of convex parts. An element whose body is a straight extrusion of a
parametric profile decomposes exactly and almost for free: an I-section is three boxes, a hollow rectangle
four, a channel three. This module does the 2D half of that: one IFC profile entity in, a list of convex
polygons out (numpy arrays of shape (k, 2), counter-clockwise, metres), or ``None`` when the profile is not
supported so that the caller falls back to a general mesh decomposition.

Coordinates are the profile's own 2D coordinate system *including* its ``Position`` placement (when present),
i.e. the XY plane of the extrusion's position frame; IFC length units are multiplied by ``unit_scale_m``.
Every parametric profile is centred on its bounding box, as IFC 2x3 and IFC 4 define them; where the
standard leaves a dimension open the pieces follow IfcOpenShell's meshes (which they are validated
against): a Z-section's flange tips lie at ±FlangeWidth from the web's centre line.

Approximations (collision is an approximation; the caller validates the pieces against the tessellated
mesh and falls back when they disagree):

* fillet radii, edge radii and flange or leg slopes are ignored (sharp-cornered, parallel-flange shapes);
  IfcOpenShell 0.9 thins a sloped flange towards the web, so a steep taper (IPN, 14 %) fails the caller's
  volume check and falls back, while a filleted UPN still passes;
* circles, circular tubes and ellipses are polygons inscribed in the curve (``segments`` vertices);
* a rounded rectangle is its plain rectangle.

Unsupported (``None``): open or curve profiles, profiles with voids, composite, derived and mirrored
profiles, arbitrary profiles whose outer curve is not a straight-segment polygon (polyline, indexed poly
curve without arcs, composite curve of polylines) or is not convex, and any profile with missing or
non-positive dimensions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import ifcopenshell
import numpy as np

from .placement import axis2placement_matrix

logger = logging.getLogger(__name__)

DEFAULT_SEGMENTS = 24  # vertices of a full circle or ellipse; a multiple of 4 keeps the axis extremes exact
_COLLINEAR_TOL = 1e-9  # relative cross-product below which three polygon vertices count as collinear

CURVE_REL_TOL = 0.02  # outline error allowed for polygonised circles and ellipses, × their largest radius
ROUNDING_REL_TOL = 0.42  # outline error of an ignored outer rounding, × its radius (√2 − 1, rounded up)

_CURVE_RADII = {
    "IfcCircleProfileDef": ("Radius",),
    "IfcCircleHollowProfileDef": ("Radius",),
    "IfcEllipseProfileDef": ("SemiAxis1", "SemiAxis2"),
}
_ROUNDING_RADII = (  # attributes that round the outer outline (absent ones read as None)
    "RoundingRadius",
    "OuterFilletRadius",
    "EdgeRadius",
    "FlangeEdgeRadius",
    "WebEdgeRadius",
    "BottomFlangeEdgeRadius",
    "TopFlangeEdgeRadius",
)

Polygon = np.ndarray  # (k, 2) float64, counter-clockwise
_PieceBuilder = Callable[[ifcopenshell.entity_instance, int], list[Polygon] | None]


def profile_polygons(
    profile: ifcopenshell.entity_instance, unit_scale_m: float, *, segments: int = DEFAULT_SEGMENTS
) -> list[Polygon] | None:
    """Split ``profile`` into convex counter-clockwise polygons in metres, or ``None`` if unsupported."""
    if getattr(profile, "ProfileType", "AREA") != "AREA":
        return None
    builder = _BUILDERS.get(profile.is_a())
    if builder is None:
        return None
    try:
        pieces = builder(profile, segments)
    except (TypeError, ValueError) as exc:  # missing (None) or invalid attribute values
        logger.debug("profile #%s (%s) not decomposed: %s", profile.id(), profile.is_a(), exc)
        return None
    if not pieces:
        return None
    placement = _position_matrix(profile)
    return [_ccw(_transform(piece, placement) * unit_scale_m) for piece in pieces]


def outline_tolerance_m(profile: ifcopenshell.entity_instance, unit_scale_m: float) -> float:
    """How far the polygons' outline may stray from the true profile's outer outline, metres.

    Zero for exact shapes. Polygonised curves get ``CURVE_REL_TOL`` of their largest radius (both this
    module and the mesher inscribe polygons); ignored outer roundings (edge radii, rounded corners) get
    ``ROUNDING_REL_TOL`` of the largest radius, the gap between a sharp corner and its arc along any
    direction. Internal fillets do not move the outline and are not counted.
    """
    curved = [getattr(profile, name, None) for name in _CURVE_RADII.get(profile.is_a(), ())]
    rounded = [getattr(profile, name, None) for name in _ROUNDING_RADII]
    if profile.is_a("IfcCShapeProfileDef") and profile.InternalFilletRadius and profile.WallThickness:
        rounded.append(profile.InternalFilletRadius + profile.WallThickness)  # bent corners are round outside
    largest_curve = max((float(r) for r in curved if r), default=0.0)
    largest_rounding = max((float(r) for r in rounded if r), default=0.0)
    return unit_scale_m * max(CURVE_REL_TOL * largest_curve, ROUNDING_REL_TOL * largest_rounding)


def polygon_area(polygon: Polygon) -> float:
    """Signed area (shoelace): positive for counter-clockwise polygons."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def is_convex_polygon(polygon: Polygon) -> bool:
    """True when the (simple) polygon has no reflex vertex; collinear vertices are allowed."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    cross = edges[:, 0] * np.roll(edges[:, 1], -1) - edges[:, 1] * np.roll(edges[:, 0], -1)
    tol = _COLLINEAR_TOL * float(np.max(np.abs(edges)) ** 2)
    return bool(np.all(cross >= -tol) or np.all(cross <= tol))


# --- helpers ---------------------------------------------------------------------------------------------


def _positive(*values: float | None) -> tuple[float, ...]:
    """The values as floats; raises ValueError when one is missing or not positive."""
    present = [v for v in values if v is not None]
    if len(present) < len(values) or any(v <= 0.0 for v in present):
        raise ValueError(f"missing or non-positive dimension in {values}")
    return tuple(float(v) for v in present)


def _rect(x0: float, y0: float, x1: float, y1: float) -> Polygon | None:
    """Axis-aligned rectangle, counter-clockwise; None when it has no area."""
    if x1 <= x0 or y1 <= y0:
        return None
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def _rects(*rects: Polygon | None) -> list[Polygon]:
    return [r for r in rects if r is not None]


def _ccw(polygon: Polygon) -> Polygon:
    return polygon if polygon_area(polygon) >= 0.0 else polygon[::-1].copy()


def _position_matrix(profile: ifcopenshell.entity_instance) -> np.ndarray:
    """4×4 matrix of the profile's Position (IFC length units), identity when absent."""
    position = getattr(profile, "Position", None)
    if position is None:
        return np.eye(4)
    return axis2placement_matrix(position)


def _transform(polygon: Polygon, matrix: np.ndarray) -> Polygon:
    return polygon @ matrix[:2, :2].T + matrix[:2, 3]


def _ellipse(a: float, b: float, segments: int) -> Polygon:
    t = np.linspace(0.0, 2.0 * np.pi, max(segments, 8), endpoint=False)
    return np.column_stack([a * np.cos(t), b * np.sin(t)])


# --- one builder per profile class (IFC length units, before Position) -----------------------------------


def _rectangle(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    x, y = _positive(p.XDim, p.YDim)
    return _rects(_rect(-x / 2, -y / 2, x / 2, y / 2))


def _rectangle_hollow(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    x, y, t = _positive(p.XDim, p.YDim, p.WallThickness)
    if 2 * t >= min(x, y):
        return _rectangle(p, _segments)  # solid: the walls meet
    return _rects(
        _rect(-x / 2, -y / 2, x / 2, -y / 2 + t),  # bottom
        _rect(-x / 2, y / 2 - t, x / 2, y / 2),  # top
        _rect(-x / 2, -y / 2 + t, -x / 2 + t, y / 2 - t),  # left
        _rect(x / 2 - t, -y / 2 + t, x / 2, y / 2 - t),  # right
    )


def _circle(p: ifcopenshell.entity_instance, segments: int) -> list[Polygon]:
    (r,) = _positive(p.Radius)
    return [_ellipse(r, r, segments)]


def _circle_hollow(p: ifcopenshell.entity_instance, segments: int) -> list[Polygon]:
    r, t = _positive(p.Radius, p.WallThickness)
    if t >= r:
        return [_ellipse(r, r, segments)]
    outer, inner = _ellipse(r, r, segments), _ellipse(r - t, r - t, segments)
    nxt = np.roll(np.arange(len(outer)), -1)
    return [
        np.array([inner[i], outer[i], outer[j], inner[j]])
        for i, j in zip(range(len(outer)), nxt, strict=True)
    ]


def _ellipse_profile(p: ifcopenshell.entity_instance, segments: int) -> list[Polygon]:
    a, b = _positive(p.SemiAxis1, p.SemiAxis2)
    return [_ellipse(a, b, segments)]


def _i_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    b, h, tw, tf = _positive(p.OverallWidth, p.OverallDepth, p.WebThickness, p.FlangeThickness)
    return _i_pieces(bottom_width=b, top_width=b, depth=h, web=tw, bottom_flange=tf, top_flange=tf)


def _asymmetric_i_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    if p.is_a("IfcIShapeProfileDef"):  # IFC2X3: a subtype of the I-shape, bottom flange in the I attributes
        bottom_width, bottom_flange = p.OverallWidth, p.FlangeThickness
    else:  # IFC4
        bottom_width, bottom_flange = p.BottomFlangeWidth, p.BottomFlangeThickness
    top_flange = p.TopFlangeThickness if p.TopFlangeThickness is not None else bottom_flange
    bb, bt, h, tw, tfb, tft = _positive(
        bottom_width, p.TopFlangeWidth, p.OverallDepth, p.WebThickness, bottom_flange, top_flange
    )
    return _i_pieces(bottom_width=bb, top_width=bt, depth=h, web=tw, bottom_flange=tfb, top_flange=tft)


def _i_pieces(
    *,
    bottom_width: float,
    top_width: float,
    depth: float,
    web: float,
    bottom_flange: float,
    top_flange: float,
) -> list[Polygon]:
    h2 = depth / 2
    return _rects(
        _rect(-bottom_width / 2, -h2, bottom_width / 2, -h2 + bottom_flange),
        _rect(-web / 2, -h2 + bottom_flange, web / 2, h2 - top_flange),
        _rect(-top_width / 2, h2 - top_flange, top_width / 2, h2),
    )


def _u_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    h, b, tw, tf = _positive(p.Depth, p.FlangeWidth, p.WebThickness, p.FlangeThickness)
    x0, y0 = -b / 2, -h / 2  # web on the left, flanges pointing to +x
    return _rects(
        _rect(x0, y0, x0 + tw, h / 2),
        _rect(x0 + tw, y0, b / 2, y0 + tf),
        _rect(x0 + tw, h / 2 - tf, b / 2, h / 2),
    )


def _c_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    h, b, t, g = _positive(p.Depth, p.Width, p.WallThickness, p.Girth)
    x0, y0 = -b / 2, -h / 2  # web on the left, lips at +x turned towards the centre
    return _rects(
        _rect(x0, y0, x0 + t, h / 2),
        _rect(x0 + t, y0, b / 2, y0 + t),
        _rect(x0 + t, h / 2 - t, b / 2, h / 2),
        _rect(b / 2 - t, y0 + t, b / 2, y0 + g),
        _rect(b / 2 - t, h / 2 - g, b / 2, h / 2 - t),
    )


def _l_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    width = p.Width if p.Width is not None else p.Depth  # an equal-leg angle may omit Width
    h, b, t = _positive(p.Depth, width, p.Thickness)
    x0, y0 = -b / 2, -h / 2  # vertical leg on the left, horizontal leg at the bottom
    return _rects(_rect(x0, y0, x0 + t, h / 2), _rect(x0 + t, y0, b / 2, y0 + t))


def _t_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    h, b, tw, tf = _positive(p.Depth, p.FlangeWidth, p.WebThickness, p.FlangeThickness)
    return _rects(_rect(-b / 2, h / 2 - tf, b / 2, h / 2), _rect(-tw / 2, -h / 2, tw / 2, h / 2 - tf))


def _z_shape(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon]:
    h, b, tw, tf = _positive(p.Depth, p.FlangeWidth, p.WebThickness, p.FlangeThickness)
    # web centred on the origin, top flange to -x, bottom flange to +x, tips at ±FlangeWidth (as IfcOpenShell
    # builds it: the flange width is measured from the web's centre line)
    return _rects(
        _rect(-tw / 2, -h / 2, tw / 2, h / 2),
        _rect(-b, h / 2 - tf, -tw / 2, h / 2),
        _rect(tw / 2, -h / 2, b, -h / 2 + tf),
    )


def _arbitrary_closed(p: ifcopenshell.entity_instance, _segments: int) -> list[Polygon] | None:
    points = _outer_curve_points(p.OuterCurve)
    if points is None:
        return None
    polygon = _clean_polygon(points)
    if polygon is None or not is_convex_polygon(polygon):
        return None
    return [polygon]


def _outer_curve_points(curve: ifcopenshell.entity_instance) -> np.ndarray | None:
    """Vertices of a straight-segment 2D curve: IfcPolyline, IfcIndexedPolyCurve without arcs, or an
    IfcCompositeCurve of polylines."""
    if curve.is_a("IfcPolyline"):
        return np.array([pt.Coordinates[:2] for pt in curve.Points], dtype=float)
    if curve.is_a("IfcCompositeCurve"):
        segments = []
        for segment in curve.Segments:
            if not segment.is_a("IfcCompositeCurveSegment") or not segment.ParentCurve.is_a("IfcPolyline"):
                return None
            points = np.array([pt.Coordinates[:2] for pt in segment.ParentCurve.Points], dtype=float)
            segments.append(points if segment.SameSense else points[::-1])
        return np.vstack(segments) if segments else None
    if curve.is_a("IfcIndexedPolyCurve"):
        coords = np.array(curve.Points.CoordList, dtype=float)[:, :2]
        if curve.Segments is None:
            return coords
        if any(seg.is_a("IfcArcIndex") for seg in curve.Segments):
            return None
        indices = [i - 1 for seg in curve.Segments for i in seg.wrappedValue]
        return coords[indices]
    return None


def _clean_polygon(points: np.ndarray) -> Polygon | None:
    """Drop repeated and collinear vertices (including the closing point); None if fewer than 3 remain."""
    scale = float(np.max(np.abs(points))) or 1.0
    keep = np.linalg.norm(points - np.roll(points, 1, axis=0), axis=1) > 1e-9 * scale
    pts = points[keep]
    changed = True
    while changed and len(pts) >= 3:
        prev, nxt = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
        a, b = pts - prev, nxt - pts
        cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        straight = np.abs(cross) <= _COLLINEAR_TOL * scale**2
        changed = bool(straight.any())
        if changed:
            pts = np.delete(pts, int(np.argmax(straight)), axis=0)
    return pts if len(pts) >= 3 else None


_BUILDERS: dict[str, _PieceBuilder] = {
    "IfcRectangleProfileDef": _rectangle,
    "IfcRoundedRectangleProfileDef": _rectangle,
    "IfcRectangleHollowProfileDef": _rectangle_hollow,
    "IfcCircleProfileDef": _circle,
    "IfcCircleHollowProfileDef": _circle_hollow,
    "IfcEllipseProfileDef": _ellipse_profile,
    "IfcIShapeProfileDef": _i_shape,
    "IfcAsymmetricIShapeProfileDef": _asymmetric_i_shape,
    "IfcUShapeProfileDef": _u_shape,
    "IfcCShapeProfileDef": _c_shape,
    "IfcLShapeProfileDef": _l_shape,
    "IfcTShapeProfileDef": _t_shape,
    "IfcZShapeProfileDef": _z_shape,
    "IfcArbitraryClosedProfileDef": _arbitrary_closed,
}
