"""Every traced algorithm's steps replay to its result, on scenes whose answer is known in closed form.

One keyword, ``trace=True``, one record, :class:`labkit.Step`. The replays below rebuild the
result from the steps alone and compare it with what the function returned and with the
simulator's ground truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import labkit
from labkit import Step, sim

LIDAR = sim.Lidar.from_fov("t", 270.0, 0.5, range_max=20.0, noise_std_m=0.0)


def _square_room():
    """A 4 m square room around the sensor, seen over 270 deg: the corners at +-45 and +-135 deg."""
    c = [(2.0, -2.0), (2.0, 2.0), (-2.0, 2.0), (-2.0, -2.0)]
    walls = tuple(sim.Wall(c[k], c[(k + 1) % 4]) for k in range(4))
    scan, truth = sim.scan_at(sim.World("square", walls=walls), LIDAR, (0.0, 0.0, 0.3))
    return scan, truth


def _replay_split_merge(steps: list[Step]) -> list[tuple[int, int]]:
    """The lines' beam ranges from the steps alone: the accepted runs, merged where a merge step
    joined two, less the lines a reject step dropped after merging (no absorb in these scenes)."""
    runs: list[tuple[int, int]] = []
    for s in steps:
        if s.kind == "accept":
            runs.append((s.first, s.last))
        elif s.kind == "merge":
            inside = [k for k, (a, b) in enumerate(runs) if a in (s.first,) or b in (s.last,)]
            runs[min(inside):max(inside) + 1] = [(s.first, s.last)]
        elif s.kind == "reject" and s.test == "min_length_m":
            runs.remove((s.first, s.last))
    return runs


@pytest.mark.parametrize("method, algorithm", [("endpoints", "iepf"), ("fit", "split_and_merge")])
def test_split_and_merge_splits_a_square_room_at_its_corners(method, algorithm):
    scan, truth = _square_room()
    lines, steps = labkit.split_and_merge(scan, method=method, trace=True)
    assert {s.algorithm for s in steps} == {algorithm} and all(isinstance(s, Step) for s in steps)
    assert _replay_split_merge(steps) == [(ln.first, ln.last) for ln in lines]
    if method == "endpoints":  # (fit-split loses short walls: see split_and_merge's docstring)
        # four lines, one per wall, give or take the corner beam that both walls touch
        assert len(lines) == len(truth.walls) == 4
        for ln, w in zip(lines, truth.walls, strict=True):
            assert abs(ln.first - w.first) <= 1 and abs(ln.last - w.last) <= 1
        # the chord splits at the corner beams: each split's worst point is the corner
        splits = sorted(s.at for s in steps if s.kind == "split")
        assert len(splits) == 3
        for at, w in zip(splits, truth.walls[:-1], strict=True):
            assert at in (w.last, w.last + 1)
        for s in steps:
            if s.kind in ("split", "accept", "fit"):
                assert s.threshold == 0.05 and (s.value > s.threshold) == (s.kind == "split" or (
                    s.kind == "fit" and steps[steps.index(s) + 1].kind == "split"))


def test_split_and_merge_replay_with_a_merge():
    """A wall cut in two by a dropped beam: two range segments, two accepted runs, one merge step,
    one line over both (the wall at x = 2 m)."""
    world = sim.World("wall", walls=(sim.Wall((2.0, -2.0), (2.0, 2.0)),))
    scan, truth = sim.scan_at(world, LIDAR, (0.0, 0.0, 0.0))
    (w,) = truth.walls
    ranges = scan.ranges.copy()
    ranges[(w.first + w.last) // 2] = np.nan
    lines, steps = labkit.split_and_merge(scan.replace(ranges=ranges), trace=True)
    assert [s.kind for s in steps].count("accept") == 2 and [s.kind for s in steps].count("merge") == 1
    assert _replay_split_merge(steps) == [(ln.first, ln.last) for ln in lines] == [(w.first, w.last)]
    (merge,) = [s for s in steps if s.kind == "merge"]
    assert merge.r == pytest.approx(2.0, abs=1e-6) and merge.value < merge.threshold == 1.0


def test_iav_circles_accepted_steps_are_the_circles():
    world = sim.World("columns", walls=(sim.Wall((5.0, -4.0), (5.0, 4.0)),),
                      circles=(sim.Column((2.0, 1.0), 0.3), sim.Column((3.0, -1.5), 0.25)))
    scan, truth = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    circles, steps = labkit.detect_circles(scan, trace=True)
    accepted = [s for s in steps if s.kind == "accept"]
    assert [(s.first, s.last, s.center, s.radius) for s in accepted] == [
        (c.first, c.last, tuple(c.center), c.radius) for c in circles]
    assert len(circles) == 2
    for s, c in zip(accepted, sorted(truth.circles, key=lambda c: c.first), strict=True):
        assert math.dist(s.center, c.center) < 0.02 and s.radius == pytest.approx(c.radius, abs=0.02)
    walls = [s for s in steps if s.kind == "reject"]  # the wall, cut by the columns' shadows
    assert walls and all(s.algorithm == "iav_circles" for s in steps)
    for s in walls:
        assert s.test in ("prerequisite", "iav mean", "too few points", "chord too short")
        if s.test == "prerequisite":  # a straight wall: the middle point lies on the chord
            assert abs(s.value) < s.threshold == 0.1


def test_iav_lines_accepted_steps_are_the_lines():
    world = sim.World("walls", walls=(sim.Wall((2.0, -1.0), (2.0, 1.0)), sim.Wall((-1.0, 3.0), (1.0, 3.0))),
                      circles=(sim.Column((1.5, -2.0), 0.3),))
    scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    lines, steps = labkit.detect_lines_iav(scan, trace=True)
    accepted = [s for s in steps if s.kind == "accept"]
    assert [(s.first, s.last, s.r, s.alpha) for s in accepted] == [(ln.first, ln.last, ln.r, ln.alpha) for ln in lines]
    assert sorted(round(s.r, 6) for s in accepted) == [2.0, 3.0]
    (column,) = [s for s in steps if s.kind == "reject"]
    assert column.test == "iav mean" and column.value > column.threshold == pytest.approx(math.radians(5))


def test_legs_accepted_steps_are_the_legs():
    world = sim.World("legs", circles=(sim.Column((2.0, 0.5), 0.07), sim.Column((2.5, -0.6), 0.06)))
    scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    legs, steps = labkit.detect_legs(scan, trace=True)
    assert len(legs) == 2
    assert [(s.first, s.last, s.center, s.radius) for s in steps if s.kind == "accept"] == [
        (g.first, g.last, tuple(g.center), g.diameter / 2) for g in legs]


def test_angular_accepted_steps_are_the_segments():
    scan, truth = _square_room()
    segments, steps = labkit.angular_segmentation(scan, trace=True)
    accepted = [s for s in steps if s.kind == "accept"]
    assert [(s.first, s.last, s.r, s.alpha, len(s.beams)) for s in accepted] == [
        (g.first, g.last, g.r, g.alpha, g.n_points) for g in segments]
    assert [s.beams for s in accepted] == [tuple(g.indices.tolist()) for g in segments]
    # the square's walls come in two parallel pairs: two directions, two offsets each, 2 m from the sensor
    directions = [s for s in steps if s.kind == "direction"]
    offsets = [s for s in steps if s.kind == "offset"]
    assert len(directions) == 2 and len(offsets) == 4
    assert sorted(abs(s.value) for s in offsets) == pytest.approx([2.0] * 4, abs=1e-3)
    assert len(segments) == 4


def test_steps_view_in_the_widget_for_every_algorithm():
    """The one viewer draws every algorithm's steps (headless)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from labkit.viz.steps import step_viewer

    scan, _ = _square_room()
    traces = {
        "iepf": labkit.split_and_merge(scan, trace=True)[1],
        "angular": labkit.angular_segmentation(scan, trace=True)[1],
        "iav_circles": labkit.detect_circles(scan, trace=True)[1],
        "iav_lines": labkit.detect_lines_iav(scan, trace=True)[1],
    }
    box = step_viewer(scan, traces)
    for name, steps in traces.items():
        box.choice.value = name
        for k in (0, len(steps) - 1):
            box.slider.value = k
            assert box.figure.axes[0].get_title().startswith(f"step {k + 1} of {len(steps)}: {name}")
            assert box.figure.axes[1].get_title() == steps[k].reason
    plt.close("all")


def test_the_notebook_04_viewer_cell():
    """The code notebook 04's step viewer cell becomes (see the report of issue 14, item 4)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    room_scan, _ = _square_room()
    # --- the cell ---
    from labkit.viz.steps import step_viewer

    room_traces = {method: labkit.split_and_merge(room_scan, method=method, trace=True)[1]
                   for method in ["endpoints", "fit"]}
    viewer = step_viewer(room_scan, room_traces, description="method")
    # --- end of the cell ---
    assert viewer.choice.options == ("endpoints", "fit")
    viewer.choice.value = "fit"
    assert viewer.slider.max == len(room_traces["fit"]) - 1
    plt.close("all")
