"""labkit.viz.angular_plots (notebook 07) draws what it is given, where it is: checked against values worked
out by hand."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import labkit
from labkit.viz import angular_plots as ap


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _three_beams():
    # beams at 0, 90 and 180 degrees, ranges 1, 2, 3: the points (1, 0), (0, 2), (-3, 0)
    return labkit.Scan(ranges=np.array([1.0, 2.0, 3.0]), angles=np.radians([0.0, 90.0, 180.0]), range_max=10.0)


def test_local_directions_ticks_along_each_direction():
    scan = _three_beams()
    ax = ap.plot_local_directions(scan, [0.0, np.pi / 2, np.nan], length=0.2, title="t", xlim=(-4, 2))
    ticks = ax.collections[0]
    # direction 0 at (1, 0): from (0.9, 0) to (1.1, 0); direction 90 deg at (0, 2): from (0, 1.9) to (0, 2.1)
    np.testing.assert_allclose(ticks.get_segments(), [[(0.9, 0.0), (1.1, 0.0)], [(0.0, 1.9), (0.0, 2.1)]], atol=1e-12)
    np.testing.assert_allclose(ticks.get_array(), [0.0, 90.0])
    assert ticks.get_clim() == (0, 180) and ticks.get_cmap().name == "twilight"
    assert ax.get_title() == "t" and ax.get_xlim() == (-4, 2)
    assert len(ax.figure.axes) == 2                                       # the colour bar


def test_segments_limits_title_and_truth(monkeypatch):
    drawn = []
    monkeypatch.setattr(ap.lkplot, "plot_truth", lambda truth, ax: drawn.append(truth))
    truth = object()
    ax = ap.plot_segments(_three_beams(), [0, 0, -1], truth=truth, title="3 segments")
    assert drawn == [truth] and ax.get_title() == "3 segments"
    assert ax.get_xlim() == (-1.5, 19.0) and ax.get_ylim() == (-2.0, 2.5)
    np.testing.assert_allclose(ax.collections[0].get_offsets(), [(1.0, 0.0), (0.0, 2.0), (-3.0, 0.0)], atol=1e-12)


def test_offsets_histogram_and_marks():
    offsets = [-0.79, -0.795, -0.785, 1.61, 1.615]       # three points in the 2 cm bin from -0.8, two in that from 1.6
    fig = ap.plot_offsets_and_segments(offsets, [-0.8, 1.6], _three_beams(), [0, 1, -1], offsets_title="two peaks",
                                       segments_title="final")
    ax_h, ax_s = fig.axes
    heights = sorted(p.get_height() for p in ax_h.patches if p.get_height() > 0)
    assert heights == [2.0, 3.0]
    assert sorted(line.get_xdata()[0] for line in ax_h.get_lines()) == [-0.8, 1.6]
    assert (ax_h.get_title(), ax_s.get_title()) == ("two peaks", "final")


def test_side_by_side_one_panel_per_extractor():
    scan = _three_beams()
    a = labkit.line_segment(np.array([(1.0, 0.0), (0.0, 2.0)]), np.arange(2))
    b = labkit.line_segment(np.array([(0.0, 2.0), (-3.0, 0.0)]), np.arange(1, 3))
    fig = ap.plot_side_by_side(scan, {"left": ([a], "tab:blue"), "right": ([a, b], "tab:orange")},
                               xlim=(-4, 2), ylim=(-1, 3))
    left, right = fig.axes
    assert (left.get_title(), right.get_title()) == ("left", "right")
    (lines_left,) = [c for c in left.collections if c.get_label().startswith("lines")]
    (lines_right,) = [c for c in right.collections if c.get_label().startswith("lines")]
    assert len(lines_left.get_segments()) == 1 and len(lines_right.get_segments()) == 2
    np.testing.assert_allclose(lines_left.get_segments()[0], [a.start, a.end])
    np.testing.assert_allclose(lines_right.get_colors()[0][:3], plt.matplotlib.colors.to_rgb("tab:orange"))
    assert right.get_xlim() == (-4, 2) and right.get_ylim() == (-1, 3)


def test_eps_sliders_call_redraw_with_the_values():
    calls = []
    box = ap.eps_sliders(lambda eps_theta_deg, eps_dist_m: calls.append((eps_theta_deg, eps_dist_m)))
    theta, dist = box.children[:2]
    assert (theta.description, theta.value, theta.min, theta.max) == ("eps_theta (deg)", 3.0, 0.5, 20.0)
    assert (dist.description, dist.value, dist.min, dist.max) == ("eps_dist (m)", 0.03, 0.005, 0.5)
    dist.value = 0.35
    assert calls[-1] == (3.0, 0.35)


def test_column_up_close_two_panels_at_the_columns_limits(monkeypatch):
    drawn = []
    monkeypatch.setattr(ap.lkplot, "plot_truth", lambda truth, ax: drawn.append(truth))
    scan = _three_beams()
    a = labkit.line_segment(np.array([(1.0, 0.0), (0.0, 2.0)]), np.arange(2))
    truth = object()
    fig = ap.plot_column_up_close(scan, [a], [], truth=truth)
    left, right = fig.axes[:2]
    assert left.get_title() == "a column seen up close: angular segmentation"
    assert right.get_title() == "a column seen up close: split-and-merge"
    assert left.get_xlim() == (0.0, 1.4) and left.get_ylim() == (-0.45, 0.45) and drawn == [truth, truth]
