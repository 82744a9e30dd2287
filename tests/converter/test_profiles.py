"""Profile definitions split into convex 2D pieces (services/converter/profiles.py)."""

from __future__ import annotations

import math

import ifcopenshell
import numpy as np
import pytest

from bimbot.services.converter.profiles import (
    is_convex_polygon,
    outline_tolerance_m,
    polygon_area,
    profile_polygons,
)

MM = 0.001  # unit_scale_m of a millimetre model


@pytest.fixture
def model() -> ifcopenshell.file:
    return ifcopenshell.file(schema="IFC4")


def _area_m2(polygons: list[np.ndarray]) -> float:
    return sum(polygon_area(polygon) for polygon in polygons)


def _bounds(polygons: list[np.ndarray]) -> np.ndarray:
    points = np.vstack(polygons)
    return np.array([points.min(axis=0), points.max(axis=0)])


def _profile(model: ifcopenshell.file, ifc_class: str, **attributes: object) -> ifcopenshell.entity_instance:
    return model.create_entity(ifc_class, ProfileType="AREA", **attributes)


def test_i_shape_is_three_boxes_with_the_analytic_area_ignoring_fillets(model: ifcopenshell.file) -> None:
    profile = _profile(
        model,
        "IfcIShapeProfileDef",
        OverallWidth=200.0,
        OverallDepth=400.0,
        WebThickness=10.0,
        FlangeThickness=20.0,
        FilletRadius=21.0,
    )
    pieces = profile_polygons(profile, MM)
    assert pieces is not None and len(pieces) == 3
    assert all(len(piece) == 4 for piece in pieces)
    analytic_m2 = (2 * 200.0 * 20.0 + (400.0 - 2 * 20.0) * 10.0) * MM**2
    assert _area_m2(pieces) == pytest.approx(analytic_m2, rel=1e-12)
    np.testing.assert_allclose(_bounds(pieces), [[-0.1, -0.2], [0.1, 0.2]])


def test_every_piece_is_convex_and_counter_clockwise(model: ifcopenshell.file) -> None:
    profiles = [
        _profile(
            model,
            "IfcIShapeProfileDef",
            OverallWidth=2.0,
            OverallDepth=4.0,
            WebThickness=0.2,
            FlangeThickness=0.3,
        ),
        _profile(model, "IfcRectangleHollowProfileDef", XDim=2.0, YDim=1.0, WallThickness=0.1),
        _profile(model, "IfcCircleHollowProfileDef", Radius=1.0, WallThickness=0.1),
        _profile(model, "IfcCShapeProfileDef", Depth=2.0, Width=1.0, WallThickness=0.1, Girth=0.3),
        _profile(
            model, "IfcZShapeProfileDef", Depth=2.0, FlangeWidth=1.0, WebThickness=0.1, FlangeThickness=0.1
        ),
        _profile(model, "IfcEllipseProfileDef", SemiAxis1=2.0, SemiAxis2=1.0),
    ]
    for profile in profiles:
        pieces = profile_polygons(profile, 1.0)
        assert pieces is not None, profile.is_a()
        for piece in pieces:
            assert piece.shape[1] == 2
            assert is_convex_polygon(piece), profile.is_a()
            assert polygon_area(piece) > 0.0, profile.is_a()


def test_asymmetric_i_shape_has_its_own_top_and_bottom_flanges(model: ifcopenshell.file) -> None:
    profile = _profile(
        model,
        "IfcAsymmetricIShapeProfileDef",
        BottomFlangeWidth=300.0,
        OverallDepth=500.0,
        WebThickness=12.0,
        BottomFlangeThickness=25.0,
        TopFlangeWidth=150.0,
        TopFlangeThickness=15.0,
    )
    pieces = profile_polygons(profile, MM)
    assert pieces is not None and len(pieces) == 3
    analytic_m2 = (300.0 * 25.0 + 150.0 * 15.0 + (500.0 - 40.0) * 12.0) * MM**2
    assert _area_m2(pieces) == pytest.approx(analytic_m2)
    np.testing.assert_allclose(_bounds(pieces), [[-0.15, -0.25], [0.15, 0.25]])


def test_ifc2x3_i_shapes_without_slope_attributes_and_asymmetric_subtype() -> None:
    model = ifcopenshell.file(schema="IFC2X3")
    position = model.createIfcAxis2Placement2D(model.createIfcCartesianPoint((0.0, 0.0)), None)
    i_shape = model.create_entity(
        "IfcIShapeProfileDef",
        ProfileType="AREA",
        Position=position,
        OverallWidth=25.0,
        OverallDepth=50.0,
        WebThickness=5.0,
        FlangeThickness=5.0,
    )
    asymmetric = model.create_entity(
        "IfcAsymmetricIShapeProfileDef",
        ProfileType="AREA",
        Position=position,
        OverallWidth=25.0,
        OverallDepth=50.0,
        WebThickness=5.0,
        FlangeThickness=5.0,
        TopFlangeWidth=20.0,
    )
    assert _area_m2(profile_polygons(i_shape, 1.0)) == pytest.approx(2 * 25 * 5 + 40 * 5)
    # TopFlangeThickness omitted: the top flange is as thick as the bottom one
    assert _area_m2(profile_polygons(asymmetric, 1.0)) == pytest.approx(25 * 5 + 20 * 5 + 40 * 5)


def test_rectangle_hollow_is_four_walls_with_the_right_area(model: ifcopenshell.file) -> None:
    profile = _profile(model, "IfcRectangleHollowProfileDef", XDim=200.0, YDim=100.0, WallThickness=8.0)
    pieces = profile_polygons(profile, MM)
    assert pieces is not None and len(pieces) == 4
    assert _area_m2(pieces) == pytest.approx((200 * 100 - 184 * 84) * MM**2)


def test_rectangle_and_rounded_rectangle_are_one_box(model: ifcopenshell.file) -> None:
    for ifc_class, extra in (
        ("IfcRectangleProfileDef", {}),
        ("IfcRoundedRectangleProfileDef", {"RoundingRadius": 5.0}),
    ):
        pieces = profile_polygons(_profile(model, ifc_class, XDim=300.0, YDim=200.0, **extra), MM)
        assert pieces is not None and len(pieces) == 1
        assert _area_m2(pieces) == pytest.approx(0.06)


def test_circle_hollow_is_convex_annular_sectors_close_to_the_annulus_area(model: ifcopenshell.file) -> None:
    profile = _profile(model, "IfcCircleHollowProfileDef", Radius=57.15, WallThickness=3.6)
    pieces = profile_polygons(profile, MM)
    assert pieces is not None and len(pieces) >= 16
    annulus_m2 = math.pi * (57.15**2 - 53.55**2) * MM**2
    assert _area_m2(pieces) == pytest.approx(annulus_m2, rel=0.02)
    for piece in pieces:  # no piece reaches into the hole
        assert np.linalg.norm(piece, axis=1).min() == pytest.approx(53.55 * MM)


def test_circle_and_ellipse_are_one_polygon_close_to_the_analytic_area(model: ifcopenshell.file) -> None:
    circle = profile_polygons(_profile(model, "IfcCircleProfileDef", Radius=100.0), MM)
    ellipse = profile_polygons(_profile(model, "IfcEllipseProfileDef", SemiAxis1=200.0, SemiAxis2=100.0), MM)
    assert circle is not None and len(circle) == 1
    assert ellipse is not None and len(ellipse) == 1
    assert _area_m2(circle) == pytest.approx(math.pi * 0.1**2, rel=0.02)
    assert _area_m2(ellipse) == pytest.approx(math.pi * 0.2 * 0.1, rel=0.02)
    np.testing.assert_allclose(_bounds(ellipse), [[-0.2, -0.1], [0.2, 0.1]], atol=1e-12)


OPEN_SECTIONS = {  # class: (attributes in mm, pieces, area in mm², bounds in mm)
    "IfcLShapeProfileDef": (
        {"Depth": 150.0, "Width": 100.0, "Thickness": 12.0},
        2,
        150 * 12 + 88 * 12,
        [[-50, -75], [50, 75]],
    ),
    "IfcTShapeProfileDef": (
        {"Depth": 150.0, "FlangeWidth": 150.0, "WebThickness": 7.1, "FlangeThickness": 10.7},
        2,
        150 * 10.7 + (150 - 10.7) * 7.1,
        [[-75, -75], [75, 75]],
    ),
    "IfcUShapeProfileDef": (
        {"Depth": 300.0, "FlangeWidth": 100.0, "WebThickness": 10.0, "FlangeThickness": 15.0},
        3,
        300 * 10 + 2 * 90 * 15,
        [[-50, -150], [50, 150]],
    ),
    "IfcCShapeProfileDef": (
        {"Depth": 200.0, "Width": 80.0, "WallThickness": 3.0, "Girth": 25.0},
        5,
        200 * 3 + 2 * 77 * 3 + 2 * 22 * 3,
        [[-40, -100], [40, 100]],
    ),
    # Z: flange tips at ±FlangeWidth from the web's centre line, as IfcOpenShell builds it
    "IfcZShapeProfileDef": (
        {"Depth": 200.0, "FlangeWidth": 80.0, "WebThickness": 8.0, "FlangeThickness": 12.0},
        3,
        200 * 8 + 2 * 76 * 12,
        [[-80, -100], [80, 100]],
    ),
}


@pytest.mark.parametrize("ifc_class", sorted(OPEN_SECTIONS))
def test_open_sections_have_their_piece_count_area_and_bounding_box(
    model: ifcopenshell.file, ifc_class: str
) -> None:
    attributes, count, area_mm2, bounds_mm = OPEN_SECTIONS[ifc_class]
    pieces = profile_polygons(_profile(model, ifc_class, **attributes), MM)
    assert pieces is not None and len(pieces) == count
    assert _area_m2(pieces) == pytest.approx(area_mm2 * MM**2)
    np.testing.assert_allclose(_bounds(pieces), np.array(bounds_mm) * MM, atol=1e-12)


def test_equal_leg_angle_may_omit_its_width(model: ifcopenshell.file) -> None:
    pieces = profile_polygons(_profile(model, "IfcLShapeProfileDef", Depth=100.0, Thickness=10.0), MM)
    assert pieces is not None and len(pieces) == 2
    assert _area_m2(pieces) == pytest.approx((100 * 10 + 90 * 10) * MM**2)
    np.testing.assert_allclose(_bounds(pieces), [[-0.05, -0.05], [0.05, 0.05]], atol=1e-12)


def test_open_sections_face_the_ifc_directions(model: ifcopenshell.file) -> None:
    """U and C open to +x, L's legs run up the left and along the bottom, T's flange is on top."""
    u = profile_polygons(
        _profile(
            model, "IfcUShapeProfileDef", Depth=3.0, FlangeWidth=1.0, WebThickness=0.1, FlangeThickness=0.1
        ),
        1.0,
    )
    web = max(u, key=lambda piece: np.ptp(piece[:, 1]))
    assert web[:, 0].max() == pytest.approx(-0.4)
    angle = profile_polygons(_profile(model, "IfcLShapeProfileDef", Depth=2.0, Width=1.0, Thickness=0.1), 1.0)
    assert {tuple(np.round(piece.min(axis=0), 6)) for piece in angle} == {(-0.5, -1.0), (-0.4, -1.0)}
    tee = profile_polygons(
        _profile(
            model, "IfcTShapeProfileDef", Depth=2.0, FlangeWidth=1.0, WebThickness=0.1, FlangeThickness=0.2
        ),
        1.0,
    )
    flange = max(tee, key=lambda piece: np.ptp(piece[:, 0]))
    assert flange[:, 1].max() == pytest.approx(1.0)


def test_position_offset_and_rotation_are_applied(model: ifcopenshell.file) -> None:
    position = model.createIfcAxis2Placement2D(
        model.createIfcCartesianPoint((100.0, 50.0)), model.createIfcDirection((0.0, 1.0))
    )
    profile = _profile(model, "IfcRectangleProfileDef", Position=position, XDim=200.0, YDim=20.0)
    (piece,) = profile_polygons(profile, MM)
    # rotated by 90°: the 200 mm side now runs along y, centred on (100, 50) mm
    np.testing.assert_allclose(_bounds([piece]), [[0.09, -0.05], [0.11, 0.15]], atol=1e-12)
    assert polygon_area(piece) == pytest.approx(0.004)


def test_unit_scale_turns_ifc_units_into_metres(model: ifcopenshell.file) -> None:
    profile = _profile(model, "IfcRectangleProfileDef", XDim=10.0, YDim=4.0)  # feet, say
    (piece,) = profile_polygons(profile, 0.3048)
    assert polygon_area(piece) == pytest.approx(40 * 0.3048**2)


def test_convex_arbitrary_closed_profile_is_one_piece(model: ifcopenshell.file) -> None:
    points = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]  # collinear point kept
    polyline = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in points])
    indexed = model.createIfcIndexedPolyCurve(
        model.createIfcCartesianPointList2D([(0.0, 0.0), (3.0, 0.0), (0.0, 3.0)]),
        [model.createIfcLineIndex((1, 2)), model.createIfcLineIndex((2, 3, 1))],
        False,
    )
    for curve, area in ((polyline, 2.0), (indexed, 4.5)):
        pieces = profile_polygons(model.createIfcArbitraryClosedProfileDef("AREA", None, curve), 1.0)
        assert pieces is not None and len(pieces) == 1
        assert polygon_area(pieces[0]) == pytest.approx(area)


def test_composite_curve_of_polylines_is_read_in_each_segments_sense(model: ifcopenshell.file) -> None:
    """A wall footprint as some exporters write it: four two-point polylines, one of them reversed."""
    corners = [(0.0, 120.0), (0.0, -120.0), (7837.4, -120.0), (7172.8, 120.0)]
    segments = []
    for index, start in enumerate(corners):
        end = corners[(index + 1) % 4]
        reverse = index == 2
        ends = (end, start) if reverse else (start, end)
        polyline = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in ends])
        segments.append(model.createIfcCompositeCurveSegment("CONTINUOUS", not reverse, polyline))
    curve = model.createIfcCompositeCurve(segments, False)
    pieces = profile_polygons(model.createIfcArbitraryClosedProfileDef("AREA", None, curve), MM)
    assert pieces is not None and len(pieces) == 1
    assert polygon_area(pieces[0]) == pytest.approx((7837.4 + 7172.8) / 2 * 240 * MM**2)


def test_concave_or_curved_arbitrary_profiles_return_none(model: ifcopenshell.file) -> None:
    l_points = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0), (0.0, 0.0)]
    concave = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in l_points])
    with_arc = model.createIfcIndexedPolyCurve(
        model.createIfcCartesianPointList2D([(0.0, 0.0), (2.0, 0.0), (1.0, 1.0)]),
        [model.createIfcLineIndex((1, 2)), model.createIfcArcIndex((2, 3, 1))],
        False,
    )
    for curve in (concave, with_arc):
        assert profile_polygons(model.createIfcArbitraryClosedProfileDef("AREA", None, curve), 1.0) is None


def test_unsupported_profiles_return_none(model: ifcopenshell.file) -> None:
    square = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0), (0.0, 0.0)]
    hole = [(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 1.0)]
    outer = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in square])
    inner = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in hole])
    rectangle = _profile(model, "IfcRectangleProfileDef", XDim=1.0, YDim=1.0)
    operator = model.createIfcCartesianTransformationOperator2D(
        None, None, model.createIfcCartesianPoint((0.0, 0.0))
    )
    unsupported = [
        model.createIfcArbitraryProfileDefWithVoids("AREA", None, outer, [inner]),
        model.createIfcDerivedProfileDef("AREA", None, rectangle, operator, None),
        model.createIfcCompositeProfileDef("AREA", None, [rectangle, rectangle], None),
        model.create_entity("IfcRectangleProfileDef", ProfileType="CURVE", XDim=1.0, YDim=1.0),
        model.createIfcArbitraryOpenProfileDef("CURVE", None, outer),
    ]
    for profile in unsupported:
        assert profile_polygons(profile, 1.0) is None, profile.is_a()


def test_missing_or_non_positive_dimensions_return_none(model: ifcopenshell.file) -> None:
    assert profile_polygons(_profile(model, "IfcCircleHollowProfileDef", Radius=1.0), 1.0) is None
    assert profile_polygons(_profile(model, "IfcRectangleProfileDef", XDim=0.0, YDim=1.0), 1.0) is None


def test_outline_tolerance_is_zero_for_exact_shapes_and_covers_curves_and_roundings(
    model: ifcopenshell.file,
) -> None:
    exact = _profile(
        model,
        "IfcIShapeProfileDef",
        OverallWidth=200.0,
        OverallDepth=400.0,
        WebThickness=10.0,
        FlangeThickness=20.0,
        FilletRadius=20.0,
    )
    circle = _profile(model, "IfcCircleProfileDef", Radius=100.0)
    rounded = _profile(model, "IfcRoundedRectangleProfileDef", XDim=300.0, YDim=200.0, RoundingRadius=10.0)
    assert outline_tolerance_m(exact, MM) == 0.0  # an internal fillet does not move the outline
    # a 24-gon inscribed in r deviates by r(1 - cos 7.5°) ≈ 0.0086 r; the mesher does about as much
    assert 0.0086 * 0.1 < outline_tolerance_m(circle, MM) <= 0.02 * 0.1
    assert outline_tolerance_m(rounded, MM) >= (math.sqrt(2) - 1) * 0.01
