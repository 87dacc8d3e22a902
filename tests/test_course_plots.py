"""labkit.viz.course_plots draws what it is given, where it is."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import labkit
from labkit.viz import course_plots as cp


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _wall_scan():
    # a wall x = 2 seen from -30 to 30 degrees, one beam per degree: points (2, 2 tan theta)
    angles = np.radians(np.arange(-30.0, 30.5, 1.0))
    return labkit.Scan(ranges=2.0 / np.cos(angles), angles=angles, range_min=0.05, range_max=10.0)


def test_lines_and_corners_draws_the_given_layers(monkeypatch):
    scan = _wall_scan()
    line = labkit.line_segment(scan.points[:31], np.arange(31))          # the lower half of the wall
    drawn = {}
    monkeypatch.setattr(cp.lkplot, "plot_truth", lambda truth, ax: drawn.setdefault("truth", truth))
    monkeypatch.setattr(cp.lkplot, "plot_corners", lambda corners, ax: drawn.setdefault("corners", corners))
    truth, corners = object(), ["a corner"]
    ax = cp.plot_lines_and_corners(scan, [line], corners, truth=truth, title="t", point_size=3)
    assert drawn == {"truth": truth, "corners": corners}
    # the scan's 61 points, and the line from (2, -2 tan 30 deg) = (2, -1.155) to (2, 0)
    np.testing.assert_allclose(ax.collections[0].get_offsets(), scan.xy)
    (segment,) = [c for c in ax.collections if c.get_label().startswith("lines")]
    np.testing.assert_allclose(segment.get_segments()[0], [(2.0, -2 * np.tan(np.radians(30))), (2.0, 0.0)],
                               atol=1e-9)
    assert ax.get_title() == "t" and ax.get_legend().get_texts()[0].get_fontsize() == 7


def test_lines_and_corners_without_truth_or_legend():
    scan = _wall_scan()
    fig, ax = plt.subplots()
    assert cp.plot_lines_and_corners(scan, [], [], legend_fontsize=None, ax=ax) is ax
    assert ax.get_legend() is None


def test_lines_and_corners_grid_one_panel_per_scan():
    scan = _wall_scan()
    line = labkit.line_segment(scan.points[:31], np.arange(31))          # (2, -1.155) to (2, 0), as above
    fig = cp.plot_lines_and_corners_grid([(scan, [line], [], "first"), (scan, [], [], "second")], ncols=3)
    first, second, spare = fig.axes
    assert (first.get_title(), second.get_title()) == ("first", "second") and not spare.get_visible()
    np.testing.assert_allclose(second.collections[0].get_offsets(), scan.xy)
    (segment,) = [c for c in first.collections if c.get_label().startswith("lines")]
    np.testing.assert_allclose(segment.get_segments()[0], [(2.0, -2 * np.tan(np.radians(30))), (2.0, 0.0)], atol=1e-9)
    assert first.get_legend() is not None and second.get_legend() is None
    fig = cp.plot_lines_and_corners_grid([(scan, [], [], "a")] * 4, ncols=3, legend=False)
    assert len(fig.axes) == 6 and sum(ax.get_visible() for ax in fig.axes) == 4 and fig.axes[0].get_legend() is None


def test_extraction_controls_call_show_with_the_values():
    calls = []
    box = cp.extraction_controls(lambda **values: calls.append(values), ["hall", "corridor"], n_scans=7)
    (scene, k), method, (split, min_points, merge), _out = [getattr(w, "children", w) for w in box.children]
    assert scene.value == "corridor" and list(scene.options) == ["hall", "corridor"] and (k.min, k.max) == (0, 6)
    assert (split.value, min_points.value, merge.value, method.value) == (0.05, 5, "thresholds", "endpoints")
    split.value = 0.2
    assert calls[-1] == {"scene": "corridor", "k": 0, "method": "endpoints", "split_threshold_m": 0.2,
                         "min_points": 5, "merge": "thresholds"}
    merge.value = "none"
    assert calls[-1]["merge"] == "none"


def test_counts_and_timings_one_panel_per_kind_and_the_stages_but_the_skipped():
    counts = {"lines": np.array([2, 4, 3]), "legs": np.array([0, 1, 0]), "segments": np.array([9, 9, 9])}
    times_ms = {"lines": np.array([1.0, 3.0, 2.0]), "arcs": np.array([0.1, 0.1, 0.1]),
                "total": np.array([2.0, 4.0, 3.0])}
    fig = cp.plot_counts_and_timings(counts, times_ms, ["lines", "legs"], skip=["arcs"], title="t")
    lines_ax, legs_ax, time_ax = fig.axes
    np.testing.assert_allclose(lines_ax.lines[0].get_xydata(), [(0, 2), (1, 4), (2, 3)])
    assert lines_ax.get_title(loc="right") == "mean 3.00 per scan" and lines_ax.get_ylim() == (-0.5, 4.5)
    assert legs_ax.get_title(loc="right") == "mean 0.33 per scan" and legs_ax.get_ylim() == (-0.5, 1.5)
    assert [ln.get_label() for ln in time_ax.lines] == ["lines (median 2.00 ms)", "total (median 3.00 ms)"]
    # the 99.5th percentile of the totals 2, 3, 4 is 3 + 0.99 * 1 = 3.99 ms; the axis reaches 1.2 times it
    assert time_ax.get_ylim() == pytest.approx((0.0, 1.2 * 3.99))
    assert fig.get_suptitle() == "t"


def test_map_draws_points_segments_and_path_where_they_are():
    points = [(0.0, 0.0), (1.0, 2.0), (3.0, -1.0)]
    segments = [[(0.0, 0.0), (1.0, 0.0)], [(1.0, 0.0), (1.0, 1.0)]]
    path = [(0.5, 0.5), (0.6, 0.7), (0.8, 0.9)]
    ax = cp.plot_map(points, segments, path, points_label="p", lines_label="lines (every scan)", title="t")
    (cloud, drawn) = ax.collections
    np.testing.assert_allclose(cloud.get_offsets(), points)
    np.testing.assert_allclose(np.array(drawn.get_segments()), segments)
    (sensor_path,) = ax.lines
    np.testing.assert_allclose(sensor_path.get_xydata(), path)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["p", "2 lines (every scan)", "sensor path"]
    assert ax.get_title() == "t" and ax.get_aspect() == 1.0


def test_seam_merges_draw_the_lines_at_the_seam_wide(monkeypatch):
    from types import SimpleNamespace

    def line(first, last, alpha_deg):
        return SimpleNamespace(first=first, last=last, alpha=np.radians(alpha_deg), start=np.zeros(2), end=np.ones(2))

    naive = [line(0, 9, -179.0), line(10, 50, 90.0), line(340, 359, 178.0)]     # both ends face backwards
    wrapped = [line(340, 9, 179.5), line(10, 50, 90.0)]                          # the first crosses the seam
    titles, wide = [], []
    monkeypatch.setattr(cp.lkplot, "plot_scan", lambda scan, ax, **kw: titles.append(kw["title"]))
    plot_lines = cp.lkplot.plot_lines

    def recording(lines, ax, **kw):
        if "lw" in kw:
            wide.append((kw["label"], kw["lw"]))
        return plot_lines(lines, ax, **kw)

    monkeypatch.setattr(cp.lkplot, "plot_lines", recording)
    fig = cp.plot_seam_merges(object(), {"naive": naive, "wrapped": wrapped})
    assert len(fig.axes) == 2
    assert titles == ["office, scan 0, merged with the naive angle difference",
                      "office, scan 0, merged with the wrapped angle difference"]
    # the wrapped merge's last line (alpha 90) is neither across the seam nor backwards: not drawn wide
    assert wide == [("beams 0..9, alpha -179.0 deg", 4), ("beams 340..359, alpha 178.0 deg", 4),
                    ("beams 340..9, alpha 179.5 deg", 4)]
