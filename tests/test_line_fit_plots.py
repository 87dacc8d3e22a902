"""Notebook 02's figures (labkit.viz.line_fit_plots) draw what they are given, where it is."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from labkit.viz import line_fit_plots as lp


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_draw_line_by_hand():
    fig, ax = plt.subplots()
    (ahead,) = lp.draw_line(ax, 2.0, 0.0, half_length=1.0)             # the line x = 2
    (above,) = lp.draw_line(ax, 1.0, math.pi / 2, half_length=1.0, alpha=0.5)  # y = 1; alpha is the opacity
    np.testing.assert_allclose(ahead.get_xydata(), [(2.0, -1.0), (2.0, 1.0)], atol=1e-12)
    np.testing.assert_allclose(above.get_xydata(), [(1.0, 1.0), (-1.0, 1.0)], atol=1e-12)
    assert above.get_alpha() == 0.5


def test_normal_form_puts_the_example_point_beyond_the_wall():
    # wall x = 1 (r = 1, alpha = 0): foot of the example 1.2 m along it, the point 0.3 m beyond: (1.3, 1.2)
    ax = lp.plot_normal_form([1.0, 1.0], [0.0, 0.5], 1.0, 0.0, along=1.2, beyond=0.3)
    by_label = {ln.get_label(): ln.get_xydata() for ln in ax.lines}
    np.testing.assert_allclose(by_label["distance d_i"], [(1.3, 1.2), (1.0, 1.2)])
    np.testing.assert_allclose(by_label["point (rho_i, theta_i)"], [(1.3, 1.2)])
    np.testing.assert_allclose(by_label["true wall"], [(1.0, -0.3), (1.0, 3.0)])
    (arrow,) = [t for t in ax.texts if t.get_text() == ""]
    assert tuple(arrow.xy) == pytest.approx((1.0, 0.0))


def test_objective_marks_the_closed_form_alpha_in_degrees():
    grid = np.radians([-90.0, 0.0, 90.0])
    ax = lp.plot_objective(grid, [3.0, 1.0, 3.0], math.radians(30))
    curve, mark = ax.lines
    np.testing.assert_allclose(curve.get_xydata(), [(-90, 3), (0, 1), (90, 3)])
    assert mark.get_xdata()[0] == pytest.approx(30.0)


def test_sum_timings_in_ms_with_a_slope_two_line_through_the_last_time():
    ax = lp.plot_sum_timings([10, 100, 1000, 10000], [1e-4, 1e-3, 0.02, 2.0], [1e-5, 1e-5, 1e-5, 2e-5])
    double, product, slope = ax.lines
    np.testing.assert_allclose(double.get_ydata(), [0.1, 1.0, 20.0, 2000.0])
    np.testing.assert_allclose(product.get_ydata(), [0.01, 0.01, 0.01, 0.02])
    # from n = 1000 to 10000 through 2000 ms at 10000: 2000 (n / 10000)^2 = 20 and 2000 ms
    np.testing.assert_allclose(slope.get_xydata(), [(1000, 20.0), (10000, 2000.0)])


def test_fits_label_each_error_and_frame_points_and_sensor():
    pts = np.array([(2.0, -1.0), (2.0, 1.0)])
    fits = {"TLS": SimpleNamespace(r=2.0, alpha=math.radians(1.0)),
            "OLS": ValueError("all x are equal: no line y = a x + b fits these points at all")}
    ax = lp.plot_fits(2.0, 0.0, pts, fits, title="t")
    labels = [ln.get_label() for ln in ax.lines]
    assert "TLS: alpha off by +1.00 deg" in labels
    # the error's text cut to 60 characters: "OLS: " (5) and the first 55 of the message, then "..."
    assert "OLS: all x are equal: no line y = a x + b fits these points ..." in labels
    # the points and the sensor span x 0..2, y -1..1: a square of half-width 1 + 0.4 around (1, 0)
    assert ax.get_xlim() == pytest.approx((-0.4, 2.4)) and ax.get_ylim() == pytest.approx((-1.4, 1.4))
    assert ax.get_title() == "t"


def test_error_ellipse_of_a_diagonal_covariance_has_its_semi_axes():
    # C = diag(4, 1): the 95% ellipse has semi-axes sqrt(5.99 * 4) along x and sqrt(5.99) along y
    ex, ey = lp.error_ellipse(np.diag([4.0, 1.0]), n=5)          # angles 0, 90, 180, 270, 360 deg
    a, b = math.sqrt(5.99 * 4), math.sqrt(5.99)
    np.testing.assert_allclose(ex, [a, 0, -a, 0, a], atol=1e-12)
    np.testing.assert_allclose(ey, [0, b, 0, -b, 0], atol=1e-12)


def test_error_ellipse_plot_in_mm_and_degrees():
    errors = [(0.001, math.radians(2.0)), (-0.003, 0.0)]
    C = np.diag([1e-6, math.radians(1.0) ** 2])                    # sigma_r 1 mm, sigma_alpha 1 deg
    ax = lp.plot_error_ellipse(errors, C, title="x" * 61, label="refits", size=4)
    (cloud,) = ax.collections
    np.testing.assert_allclose(cloud.get_offsets(), [(1.0, 2.0), (-3.0, 0.0)])
    assert cloud.get_sizes()[0] == 4 and cloud.get_label() == "refits"
    (ellipse,) = ax.lines
    # in mm and degrees the ellipse is a circle of radius sqrt(5.99)
    np.testing.assert_allclose(np.hypot(*ellipse.get_xydata().T), math.sqrt(5.99), rtol=1e-9)
    assert ax.title.get_fontsize() == 9 and ax.get_xlabel() == "r error (mm)"


def test_uncertainty_band_draws_the_first_fits_the_band_and_the_points_span():
    s = np.array([0.0, 1.0, 2.0])
    offsets = np.array([[0.001, 0.0, -0.001], [0.0, 0.0, 0.0], [0.002, 0.002, 0.002]])
    ax = lp.plot_uncertainty_band(s, [0.003, 0.001, 0.003], offsets, [0.5, 1.5, 1.0], 0.9, n_lines=2)
    fit0, fit1, upper, lower, star = ax.lines                       # only the first 2 fits drawn
    np.testing.assert_allclose(fit0.get_xydata(), [(0, 1), (1, 0), (2, -1)])
    np.testing.assert_allclose(upper.get_ydata(), [3, 1, 3])
    np.testing.assert_allclose(lower.get_ydata(), [-3, -1, -3])
    assert star.get_xdata()[0] == pytest.approx(0.9)
    (span,) = ax.patches
    assert (span.get_x(), span.get_x() + span.get_width()) == pytest.approx((0.5, 1.5))    # a Rectangle
