"""labkit.viz.iav_plots (notebooks 08 and 08b) draws what it is given, where it is: checked against values
worked out by hand."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

from labkit.viz import iav_plots as ip


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _lines_of(ax):
    return [np.asarray(line.get_xydata()) for line in ax.get_lines()]


def test_inscribed_angles_half_circle():
    # a half circle from (0, -1) counter-clockwise to (0, 1), its interior point at (1, 0): the theorem says 90 deg
    points = [(0.0, -1.0), (1.0, 0.0), (0.0, 1.0)]
    ax = ip.plot_inscribed_angles(points, [90.0], 180.0)
    assert ax.get_title() == "inscribed angles: theory 90.0°"
    assert [t.get_text() for t in ax.texts] == ["90.0°"] and tuple(ax.texts[0].xy) == (1.0, 0.0)
    lines = _lines_of(ax)
    chord = next(d for d in lines if len(d) == 2)
    np.testing.assert_allclose(chord, [(0.0, -1.0), (0.0, 1.0)], atol=1e-12)
    arc = next(d for d in lines if len(d) == 200)
    np.testing.assert_allclose(arc[[0, -1]], [(0.0, -1.0), (0.0, 1.0)], atol=1e-12)
    np.testing.assert_allclose(np.hypot(*arc.T), 1.0)
    assert np.all(arc[:, 0] >= -1e-12)                                  # the right half, through (1, 0)
    np.testing.assert_allclose(next(d for d in lines if len(d) == 3), points)   # P_1, the interior point, P_n


def test_inscribed_angles_arc_starts_at_the_first_point():
    # a quarter circle from (1, 0) to (0, 1): theory 180 - 45 = 135 deg; two interior points, two colours
    s = np.sqrt(0.5)
    ax = ip.plot_inscribed_angles([(1.0, 0.0), (np.cos(0.3), np.sin(0.3)), (s, s), (0.0, 1.0)], [135.0, 135.04], 90.0)
    assert ax.get_title() == "inscribed angles: theory 135.0°"
    assert [t.get_text() for t in ax.texts] == ["135.0°", "135.0°"]
    assert [t.get_color() for t in ax.texts] == ["C0", "C1"]
    arc = next(d for d in _lines_of(ax) if len(d) == 200)
    np.testing.assert_allclose(arc[[0, -1]], [(1.0, 0.0), (0.0, 1.0)], atol=1e-12)


def test_arc_sliders_call_redraw_with_the_values():
    calls = []
    box = ip.arc_sliders(lambda span_deg, s1, s2, s3: calls.append((span_deg, s1, s2, s3)))
    sliders = {w.description: w for w in box.children[:4]}
    assert sorted(sliders) == ["arc (deg)", "point 1", "point 2", "point 3"]
    assert (sliders["arc (deg)"].min, sliders["arc (deg)"].max, sliders["arc (deg)"].value) == (20.0, 340.0, 200.0)
    assert [sliders[f"point {k}"].value for k in (1, 2, 3)] == [0.2, 0.5, 0.8]
    assert not any(w.continuous_update for w in sliders.values())      # redrawn on release
    sliders["arc (deg)"].value = 100.0
    assert calls[-1] == (100.0, 0.2, 0.5, 0.8)


def test_iav_shapes_titles_and_angles():
    shapes = {"arc": [(2.9, -0.1), (2.8, 0.0), (2.9, 0.1)], "line": [(3.0, -0.2), (3.0, 0.0), (3.0, 0.2)]}
    angles = {"arc": np.radians([120.0]), "line": np.radians([180.0])}
    stats = {"arc": (np.radians(120.0), np.radians(1.54)), "line": (np.radians(180.0), 0.0)}
    fig = ip.plot_iav_shapes(shapes, angles, stats)
    ax_arc, ax_line, ax_angles = fig.axes
    assert ax_arc.get_title() == "arc: mean 120°, std 1.5°" and ax_line.get_title() == "line: mean 180°, std 0.0°"
    np.testing.assert_allclose(ax_arc.get_lines()[0].get_xydata(), shapes["arc"])         # the points
    np.testing.assert_allclose(ax_arc.get_lines()[1].get_xydata(), [(2.9, -0.1), (2.9, 0.1)])  # the chord
    assert ax_arc.get_xlim() == (2.4, 3.4) and ax_arc.get_ylim() == (-0.5, 0.5)
    np.testing.assert_allclose([line.get_ydata()[0] for line in ax_angles.get_lines()], [120.0, 180.0])
    (band,) = ax_angles.patches
    np.testing.assert_allclose([band.get_y(), band.get_y() + band.get_height()], [90.0, 135.0])


def test_fit_errors_in_centimetres_on_a_log_scale():
    fig = ip.plot_fit_errors([30, 60], {"iav": [0.01, 0.002], "geometric": [0.005, 0.001]},
                             {"iav": [0.02, 0.004], "geometric": [0.01, 0.002]}, title="t")
    ax_c, ax_r = fig.axes
    assert ax_c.get_yscale() == "log" and fig._suptitle.get_text() == "t"
    np.testing.assert_allclose([line.get_ydata() for line in ax_c.get_lines()], [[1.0, 0.2], [0.5, 0.1]])
    np.testing.assert_allclose([line.get_ydata() for line in ax_r.get_lines()], [[2.0, 0.4], [1.0, 0.2]])
    assert [line.get_label() for line in ax_c.get_lines()] == ["iav", "geometric"]


def test_leg_tracks_first_walk_and_distances():
    # true legs at 1 s (3, 4) and 7 s (6, 8): 5 m and 10 m from the sensor, their mean (4.5, 6)
    # detections: (3.1, 4) at 2 s, (6, 8.1) at 8 s, and (30, 40) at 9 s, 42 m from that mean (left out, right)
    fig = ip.plot_leg_tracks([1.0, 7.0], [(3.0, 4.0), (6.0, 8.0)], [2.0, 8.0, 9.0],
                             [(3.1, 4.0), (6.0, 8.1), (30.0, 40.0)], first_walk_s=6.0, title="recall 50%")
    ax_xy, ax_t, _colorbar = fig.axes
    np.testing.assert_allclose(ax_xy.get_lines()[0].get_xydata(), [(3.0, 4.0)])          # true legs before 6 s
    np.testing.assert_allclose(ax_xy.collections[0].get_offsets(), [(3.1, 4.0)])         # detections before 6 s
    assert ax_xy.get_title() == "first walk, 0 to 6 s (sensor frame)"
    true_line, det_line = ax_t.get_lines()
    np.testing.assert_allclose(true_line.get_xydata(), [(1.0, 5.0), (7.0, 10.0)])
    np.testing.assert_allclose(det_line.get_xydata(), [(2.0, np.hypot(3.1, 4.0)), (8.0, np.hypot(6.0, 8.1))])
    assert ax_t.get_title() == "recall 50%"
