"""Notebook 01's figures (labkit.viz.segmentation_plots) draw what they are given, where it is."""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pytest

from labkit.viz import segmentation_plots as sp

STEP = math.radians(0.5)


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_wall_spacing_by_hand():
    # head-on at 10 m: the arc 10 m x 0.5 deg = 87.27 mm; at 60 deg incidence twice that (1 / cos 60 = 2)
    assert sp.wall_spacing(10.0, STEP, 0) == pytest.approx(0.0872665, rel=1e-6)
    assert sp.wall_spacing(10.0, STEP, 60) == pytest.approx(2 * 0.0872665, rel=1e-6)


def test_neighbour_gaps_puts_each_pair_at_its_range_and_gap():
    rho, gap, incidence = np.array([1.0, 5.0, 9.0]), np.array([0.01, 0.05, 0.2]), np.array([0.0, 30.0, 80.0])
    ax = sp.plot_neighbour_gaps(rho, gap, incidence, STEP, incidences=(0, 85))
    (dots,) = ax.collections
    np.testing.assert_allclose(dots.get_offsets(), [[1.0, 10.0], [5.0, 50.0], [9.0, 200.0]])
    np.testing.assert_allclose(dots.get_array(), [0.0, 30.0, 80.0])
    head_on, grazing, threshold = ax.lines
    assert head_on.get_ydata()[-1] == pytest.approx(1000 * 12 * STEP)  # 104.7 mm at the axis' end, 12 m
    assert grazing.get_ydata()[-1] == pytest.approx(1000 * 12 * STEP / math.cos(math.radians(85)))
    assert tuple(threshold.get_ydata()) == (80.0, 80.0)
    # a label at the right end (head-on never reaches 0.9 x 400 mm before 12 m), the other where its curve
    # reaches 360 mm: at 0.36 cos(85 deg) / dphi = 3.595 m
    (x0, y0), (x85, y85) = (t.xy for t in ax.texts)
    assert (x0, y0) == pytest.approx((12.0, 1000 * 12 * STEP))
    assert (x85, y85) == pytest.approx((3.5954, 360.0), abs=1e-3)
    assert [t.get_text() for t in ax.texts] == ["beta = 0 deg", "beta = 85 deg"]
    assert ax.get_ylim() == (0, 400) and ax.get_title() == "neighbouring points on the same wall, 0.5 degree step"


def test_threshold_curves_are_the_given_thresholds_in_mm():
    rho = np.array([1.0, 2.0, 4.0])
    ax = sp.plot_threshold_curves(rho, {0.5: [0.08, 0.1, 0.2], 1.0: [0.09, 0.2, 0.4]}, STEP, incidences=(60,),
                                  title="t")
    by_label = {ln.get_label(): ln for ln in ax.lines}
    np.testing.assert_allclose(by_label["adaptive, step 0.5 deg"].get_ydata(), [80, 100, 200])
    np.testing.assert_allclose(by_label["adaptive, step 1.0 deg"].get_ydata(), [90, 200, 400])
    assert by_label["adaptive, step 1.0 deg"].get_linestyle() == "--"
    # spacing at 60 deg incidence: 2 r dphi, i.e. 17.45, 34.91 and 69.81 mm
    np.testing.assert_allclose(by_label["wall spacing, step 0.5 deg, incidence 60 deg"].get_ydata(),
                               [17.453, 34.907, 69.813], atol=1e-3)
    assert tuple(by_label["fixed, 80 mm"].get_ydata()) == (80.0, 80.0)
    assert ax.get_title() == "t"


def test_first_split_dashes_the_first_line_between_the_runs_end_points_and_crosses_its_worst_point():
    from types import SimpleNamespace

    from labkit import Scan

    # beams at 45, 90, 135 and 150 deg: points (1, 1), (0, 1), (-1, 1) and one beam without a return
    scan = Scan(ranges=[math.sqrt(2), 1.0, math.sqrt(2), np.nan], angles=np.radians([45, 90, 135, 150]))
    truth = SimpleNamespace(walls=[], circles=[], arcs=[], legs=[])
    # the line y = 0.5 (r = 0.5, alpha = 90 deg), worst point beam 1, 0.5 m off
    first_fit = SimpleNamespace(first=0, last=3, r=0.5, alpha=math.pi / 2, at=1, value=0.5)
    final = [SimpleNamespace(start=(1.0, 1.0), end=(-1.0, 1.0))]
    ax = sp.plot_first_split(scan, truth, first_fit, final, title="t", xlim=(-2, 2), ylim=(0, 2))
    by_label = {ln.get_label(): ln.get_xydata() for ln in ax.lines}
    # the first and last finite points of beams 0..3, (1, 1) and (-1, 1), projected onto y = 0.5
    np.testing.assert_allclose(by_label["first line measured against"], [(1.0, 0.5), (-1.0, 0.5)], atol=1e-12)
    np.testing.assert_allclose(by_label["its worst point (0.50 m)"], [(0.0, 1.0)], atol=1e-12)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "first line measured against", "its worst point (0.50 m)", "final line segments"]
    assert ax.get_xlim() == (-2, 2) and ax.get_ylim() == (0, 2) and ax.get_title() == "t"
