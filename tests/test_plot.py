"""The matplotlib helpers draw what they are given, where it is."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

from labkit import detect_circles, find_corners, split_and_merge
from labkit.sim import Lidar, Wall, World, scan_at
from labkit.viz.plot import plot_features, plot_lines


@pytest.fixture
def room():
    walls = (Wall((3.0, -2.0), (3.0, 2.0)), Wall((3.0, 2.0), (-1.0, 2.0)), Wall((-1.0, -2.0), (3.0, -2.0)))
    scan = scan_at(World("room", walls=walls), Lidar.from_fov("t", 180.0, 0.5, range_max=10.0, noise_std_m=0.0),
                   (0.0, 0.0, 0.0), 0.0)[0]
    yield scan
    plt.close("all")


def test_lines_are_drawn_between_their_ends(room):
    lines = split_and_merge(room)
    ax = plot_lines(lines)
    (collection,) = ax.collections
    drawn = np.array(collection.get_segments())
    np.testing.assert_allclose(drawn, [[ln.start, ln.end] for ln in lines])
    assert collection.get_label() == f"lines ({len(lines)})"
    assert plot_lines(lines, label="mine").collections[0].get_label() == "mine"


def test_features_figure_has_one_legend_entry_per_layer(room):
    lines = split_and_merge(room)
    corners = find_corners(lines)
    ax = plot_features(room, lines=lines, corners=corners, circles=detect_circles(room))
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert f"lines ({len(lines)})" in labels
    assert f"concave corners ({len(corners)})" in labels and len(corners) == 2
    assert not any(label.startswith("circles") for label in labels)  # none found, none drawn
