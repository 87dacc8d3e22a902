"""Angles and normal-form lines against closed-form geometry."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from labkit.geometry import (
    angle_difference,
    arc_points,
    circular_mean,
    intersect_lines,
    inverse_transform_points,
    line_through_points,
    normalize_line,
    project_onto_line,
    signed_distance_to_line,
    transform_points,
    wrap_angle,
)

finite = st.floats(-1e3, 1e3, allow_nan=False)


@given(st.floats(-100, 100))
def test_wrap_angle_interval_and_equivalence(a):
    w = wrap_angle(a)
    assert -np.pi < w <= np.pi
    assert np.isclose(np.cos(w), np.cos(a), atol=1e-9) and np.isclose(np.sin(w), np.sin(a), atol=1e-9)


def test_wrap_angle_edges():
    assert wrap_angle(np.pi) == np.pi
    assert wrap_angle(-np.pi) == np.pi
    np.testing.assert_allclose(wrap_angle(np.array([0.0, 2 * np.pi, 3 * np.pi])), [0.0, 0.0, np.pi], atol=1e-12)


def test_angle_difference_across_the_wrap():
    # 170 deg vs -170 deg are 20 deg apart, not 340
    assert np.isclose(np.degrees(angle_difference(np.radians(170), np.radians(-170))), -20.0)
    assert np.isclose(np.degrees(angle_difference(np.radians(-170), np.radians(170))), 20.0)


def test_circular_mean_periods():
    assert np.isclose(np.degrees(circular_mean(np.radians([350.0, 20.0]))), 5.0)
    # line directions live modulo 180 degrees: 179 and 1 degree average to 0, not 90
    m = np.degrees(circular_mean(np.radians([179.0, 1.0]), period=np.pi))
    assert np.isclose(min(m, 180 - m), 0.0, atol=1e-9)
    with pytest.raises(ValueError, match="empty"):
        circular_mean([])
    with pytest.raises(ValueError, match="undefined"):
        circular_mean([0.0, np.pi])


@settings(max_examples=200)
@given(px=finite, py=finite, qx=finite, qy=finite)
def test_line_through_points_contains_both(px, py, qx, qy):
    if (px, py) == (qx, qy):
        with pytest.raises(ValueError, match="distinct"):
            line_through_points((px, py), (qx, qy))
        return
    assume(np.hypot(qx - px, qy - py) > 1e-6)  # nearly coincident points give an ill-posed line
    r, a = line_through_points((px, py), (qx, qy))
    assert r >= 0 and -np.pi < a <= np.pi
    d = signed_distance_to_line(np.array([[px, py], [qx, qy]]), r, a)
    np.testing.assert_allclose(d, 0.0, atol=1e-6 * max(1.0, abs(px), abs(py), abs(qx), abs(qy)))


def test_normalize_line_conventions():
    assert normalize_line(-2.0, 0.0) == (2.0, np.pi)
    r, a = normalize_line(0.0, -np.pi / 2)
    assert r == 0.0 and np.isclose(a, np.pi / 2)
    r, a = normalize_line(0.0, np.pi)
    assert np.isclose(a, 0.0)


def test_projection_and_intersection():
    # the line x = 2 (r = 2, alpha = 0) and the line y = 1 (r = 1, alpha = pi/2)
    np.testing.assert_allclose(project_onto_line([[5.0, 3.0]], 2.0, 0.0), [[2.0, 3.0]])
    np.testing.assert_allclose(intersect_lines(2.0, 0.0, 1.0, np.pi / 2), [2.0, 1.0])
    assert intersect_lines(1.0, 0.3, 2.0, 0.3) is None


@given(x=finite, y=finite, th=st.floats(-4, 4), px=finite, py=finite)
def test_transforms_are_inverse(x, y, th, px, py):
    p = np.array([[px, py]])
    back = inverse_transform_points(transform_points(p, (x, y, th)), (x, y, th))
    np.testing.assert_allclose(back, p, atol=1e-8)


def test_arc_points_lie_on_circle_and_take_the_short_way():
    pts = arc_points((1.0, 1.0), 2.0, (3.0, 1.0), (1.0, 3.0), n=9)
    np.testing.assert_allclose(np.hypot(pts[:, 0] - 1, pts[:, 1] - 1), 2.0)
    assert np.all(pts[:, 0] >= 1 - 1e-12) and np.all(pts[:, 1] >= 1 - 1e-12)  # the 90-degree quarter
