"""Notebook 06's figures (labkit.viz.dbscan_plots) draw what they are given, where it is."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgba

from labkit.viz import dbscan_plots as dp


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_roles_put_each_point_in_its_role_with_its_interval():
    x = np.array([0.0, 0.4, 0.7, 3.0])
    role = np.array(["core", "core", "border", "noise"])
    ax = dp.plot_roles(x, role, 0.5, title="t")
    points = {c.get_label(): c.get_offsets()[:, 0].tolist() for c in ax.collections}
    assert points == {"core": [0.0, 0.4], "border": [0.7], "noise": [3.0]}
    bars = [ln for ln in ax.lines if ln.get_linewidth() == 2]
    # point i's bar: from x - eps to x + eps at height -0.15 - 0.07 i, in its role's colour
    np.testing.assert_allclose([b.get_xdata() for b in bars], [(-0.5, 0.5), (-0.1, 0.9), (0.2, 1.2), (2.5, 3.5)])
    assert [b.get_ydata()[0] for b in bars] == pytest.approx([-0.15, -0.22, -0.29, -0.36])
    assert [b.get_color() for b in bars] == ["tab:blue", "tab:blue", "tab:orange", "tab:gray"]
    assert ax.get_title() == "t"


def test_policy_rings_the_shared_point_and_counts_by_hand():
    # two clusters (0: the first three points, 1: the last two), the point at 2.0 reached by both
    x = np.array([0.0, 0.5, 1.0, 2.0, 3.0, 3.5, 9.0])
    core = np.array([True, True, True, False, True, True, False])
    border = np.array([False, False, False, True, False, False, False])
    labels = np.array([[0, -1], [0, -1], [0, -1], [0, 1], [1, -1], [1, -1], [-1, -1]])
    ax = dp.plot_policy(x, 1.0, core, border, labels, title="eps = 1")
    assert ax.get_title() == "eps = 1: 2 cluster(s), 5 core, 1 border, 1 unclustered"
    by_label = {c.get_label(): c for c in ax.collections}
    ring = by_label["in two clusters: 2 (clusters 0 and 1)"]
    assert ring.get_offsets()[:, 0].tolist() == [2.0]
    assert by_label["noise"].get_offsets()[:, 0].tolist() == [9.0]
    # core points coloured by their (first) cluster, noise grey
    np.testing.assert_allclose(by_label["core"].get_facecolors(),
                               [to_rgba(c) for c in ["C0", "C0", "C0", "C1", "C1"]])
    np.testing.assert_allclose(by_label["noise"].get_facecolors(), [to_rgba("gray")], atol=1e-6)


def test_policy_with_one_label_column_rings_nothing():
    x = np.array([0.0, 0.5, 5.0])
    ax = dp.plot_policy(x, 1.0, np.array([True, True, False]), np.zeros(3, bool), np.array([0, 0, -1]))
    assert ax.get_title() == "1 cluster(s), 2 core, 0 border, 1 unclustered"
    ring = next(c for c in ax.collections if c.get_label().startswith("in two clusters"))
    assert ring.get_label() == "in two clusters: none" and len(ring.get_offsets()) == 0


def test_reference_clusters_shade_the_index_ranges():
    x = np.array([0.0, 0.4, 0.8, 3.0, 5.0, 5.2])
    clusters = [SimpleNamespace(id=0, lower=0, upper=2), SimpleNamespace(id=1, lower=4, upper=5)]
    ax = dp.plot_reference_clusters(x, [0, 0, 0, -1, 1, 1], clusters)
    extents = {p.get_label(): (p.get_x(), p.get_x() + p.get_width()) for p in ax.patches}
    assert set(extents) == {"cluster 0: indices 0..2", "cluster 1: indices 4..5"}
    assert extents["cluster 0: indices 0..2"] == pytest.approx((-0.1, 0.9))
    assert extents["cluster 1: indices 4..5"] == pytest.approx((4.9, 5.3))


def test_timings_draw_the_given_times_and_a_line_proportional_to_n():
    sizes = np.array([10, 100, 1000])
    fig = dp.plot_timings(sizes, {"a": [1.0, 2.0, 4.0], "b": [3.0, 5.0, np.nan]},
                          [0.5, 5.0], {"a": [1.0, 1.0], "c": [2.0, 8.0]}, 1234)
    ax_n, ax_e = fig.axes
    lines = {ln.get_label(): ln.get_ydata() for ln in ax_n.lines}
    np.testing.assert_array_equal(lines["b"], [3.0, 5.0, np.nan])
    # through a's last time (4 s at N = 1000): 0.04, 0.4, 4
    np.testing.assert_allclose(lines[r"$\propto N$"], [0.04, 0.4, 4.0])
    assert {ln.get_label(): list(ln.get_ydata()) for ln in ax_e.lines} == {"a": [1.0, 1.0], "c": [2.0, 8.0]}
    assert ax_e.get_title() == "time against eps, N = 1,234 (cf. paper Fig. 8)"
    assert ax_n.get_xscale() == ax_n.get_yscale() == "log"
