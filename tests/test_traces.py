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
from labkit.noise import FIXED_INCREMENTAL

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
    lines, steps = labkit.split_and_merge(scan, method=method, trace=True, split_threshold_m=0.05)
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
    circles, steps = labkit.detect_circles(scan, trace=True, range_sigma_m=0)  # the paper's fixed tests
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

    from labkit.viz.step_plots import step_viewer

    scan, _ = _square_room()
    traces = {
        "iepf": labkit.split_and_merge(scan, trace=True)[1],
        "angular": labkit.angular_segmentation(scan, trace=True)[1],
        "iav_circles": labkit.detect_circles(scan, trace=True)[1],
        "iav_lines": labkit.detect_lines_iav(scan, trace=True)[1],
        "incremental": labkit.lines.incremental_lines(scan, trace=True)[1],
        "regression": labkit.lines.regression_lines(scan, trace=True)[1],
        "ransac": labkit.lines.ransac_lines(scan, trace=True)[1],
        "hough": labkit.lines.hough_lines(scan, trace=True)[1],
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
    from labkit.viz.step_plots import step_viewer

    room_traces = {method: labkit.split_and_merge(room_scan, method=method, trace=True)[1]
                   for method in ["endpoints", "fit"]}
    viewer = step_viewer(room_scan, room_traces, description="method")
    # --- end of the cell ---
    assert viewer.choice.options == ("endpoints", "fit")
    viewer.choice.value = "fit"
    assert viewer.slider.max == len(room_traces["fit"]) - 1
    plt.close("all")


# ------------------------------------------------------------ the reference line extractors
#: The square room's walls in the sensor frame (heading 0.3 rad): r = 2 m, normals 0, 90, 180,
#: -90 deg in the world, turned by -0.3 rad.
_ROOM_ALPHAS = [math.remainder(a - 0.3, 2 * math.pi) for a in (0.0, math.pi / 2, math.pi, -math.pi / 2)]


def _line_key(lines):
    return [(ln.first, ln.last, ln.r, ln.alpha, tuple(ln.indices.tolist())) for ln in lines]


def _accepted_key(steps):
    """The accepted lines, from the steps alone, in scan order: less those the placing dropped
    after (a ``"reject"`` step with ``test="place_confidence"`` on the same line)."""
    dropped = {(s.first, s.last, s.r, s.alpha) for s in steps if s.kind == "reject" and s.test == "place_confidence"}
    return [(s.first, s.last, s.r, s.alpha, s.beams) for s in sorted(
        (s for s in steps if s.kind == "accept" and (s.first, s.last, s.r, s.alpha) not in dropped),
        key=lambda s: s.first)]


def _on_a_room_wall(r, alpha, atol_r=1e-6, atol_alpha=1e-6):
    """Whether the line (r, alpha) is one of the room's walls, within the tolerances."""
    off = min(abs(math.remainder(alpha - a, 2 * math.pi)) for a in _ROOM_ALPHAS)
    return abs(r - 2.0) <= atol_r and off <= atol_alpha


def test_incremental_replays_to_the_room_walls():
    """Grow each line until a point misses it, hand the corner points back, accept: replayed from
    the steps alone, the lines are the simulator's walls, beam for beam."""
    scan, truth = _square_room()
    lines, steps = labkit.incremental_lines(scan, trace=True, **FIXED_INCREMENTAL)  # a fixed 5 cm
    assert {s.algorithm for s in steps} == {"incremental"}
    assert _accepted_key(steps) == _line_key(lines)
    spans = [[s.first, s.last] for s in steps if s.kind == "grow"]
    for s in steps:
        if s.kind == "hand_back":  # beam `at` leaves the line ending there for the next one
            (left,) = [sp for sp in spans if sp[1] == s.at]
            (right,) = [sp for sp in spans if sp[0] == s.at + 1]
            left[1], right[0] = s.at - 1, s.at
            assert s.value < s.threshold  # nearer the next line than its own
    walls = [(w.first, w.last) for w in truth.walls]
    assert [tuple(sp) for sp in spans] == [(s.first, s.last) for s in steps if s.kind == "accept"] == walls
    for s in steps:
        if s.kind == "grow" and s.at >= 0:  # a line stops on a point of the next wall, too far off
            assert s.value > s.threshold == 0.05 and any(w.last < s.at <= w.last + 5 for w in truth.walls)
    assert all(_on_a_room_wall(s.r, s.alpha) for s in steps if s.kind == "accept")


def test_regression_replays_to_the_room_walls():
    """Every window across a corner disagrees with its neighbours; the clusters lie inside the
    walls; absorbing the free points gives the walls, beam for beam."""
    scan, truth = _square_room()
    lines, steps = labkit.lines.regression_lines(scan, trace=True)
    assert {s.algorithm for s in steps} == {"regression"}
    assert _accepted_key(steps) == _line_key(lines)
    rejected = {(s.first, s.last) for s in steps if s.kind == "reject" and s.test == "fidelity_threshold"}
    for w in truth.walls[:-1]:  # the windows of 7 beams holding both sides of a corner
        across = {(a, a + 6) for a in range(w.last - 5, w.last + 1)}
        assert across <= rejected
    clusters = [(s.first, s.last) for s in steps if s.kind == "cluster"]
    assert len(clusters) == 4
    for (a, b), w in zip(clusters, truth.walls, strict=True):
        assert w.first <= a <= b <= w.last
    spans = dict(enumerate(clusters))
    for s in steps:
        if s.kind == "absorb":
            (k,) = [k for k, (a, b) in spans.items() if s.first <= a and b <= s.last]
            spans[k] = (s.first, s.last)
    walls = [(w.first, w.last) for w in truth.walls]
    assert list(spans.values()) == [(s.first, s.last) for s in steps if s.kind == "accept"] == walls


@pytest.mark.parametrize("extract, algorithm", [(labkit.lines.ransac_lines, "ransac"),
                                                (labkit.lines.hough_lines, "hough")])
def test_global_extractors_replay_to_the_room_walls(extract, algorithm):
    """Each round's candidate (RANSAC's best hypothesis, Hough's peak cell) is a room wall, its
    consensus set the beams of that wall (give or take a corner beam), and the accepted runs are
    the returned lines, one per wall."""
    scan, truth = _square_room()
    lines, steps = extract(scan, trace=True)
    assert {s.algorithm for s in steps} == {algorithm}
    assert _accepted_key(steps) == _line_key(lines)
    candidate = "hypothesis" if algorithm == "ransac" else "peak"
    rounds = [s for s in steps if s.kind == candidate]
    consensus = [s for s in steps if s.kind == "consensus"]
    assert len(consensus) == 4
    for s in rounds[:4]:
        assert s.value >= s.threshold == 8
        # the candidate's beams (RANSAC: the two drawn, Hough: the voters) lie on one wall, give
        # or take the corner beam next to it (as near to the line as the wall's own, in a Hough cell)
        assert any(w.first - 1 <= min(s.beams) and max(s.beams) <= w.last + 1 for w in truth.walls)
        if algorithm == "ransac":  # the line through two wall points (float32 ranges) is the wall
            assert _on_a_room_wall(s.r, s.alpha, 1e-5, 1e-4)
        else:  # every voter lies within half a cell of the peak cell's line, which is as near as the
            # cells get to the wall: 2 m away, within a few cells of its direction
            p = scan.points[list(s.beams)]
            assert s.value == len(s.beams)
            assert np.abs(p @ [math.cos(s.alpha), math.sin(s.alpha)] - s.r).max() <= 0.05 / 2 + 1e-9
            assert _on_a_room_wall(s.r, s.alpha, 0.05 + 1e-9, math.radians(3.0))
    for c in consensus:
        (w,) = [w for w in truth.walls if w.first - 1 <= c.first and c.last <= w.last + 1]
        assert len(c.beams) == c.value and set(range(w.first + 1, w.last)) <= set(c.beams)
    if algorithm == "hough":  # the search ends on a peak with too few votes
        assert steps[-1].kind == "reject" and steps[-1].test == "min_votes" and steps[-1].value < 8
    accepted = [s for s in steps if s.kind == "accept"]
    assert len(accepted) == 4 and all(_on_a_room_wall(s.r, s.alpha, 1e-3, 1e-3) for s in accepted)
    for s, w in zip(sorted(accepted, key=lambda s: s.first), truth.walls, strict=True):
        assert abs(s.first - w.first) <= 1 and abs(s.last - w.last) <= 1


def test_ransac_trace_takes_the_same_draws():
    scan, _ = _square_room()
    noisy = scan.replace(ranges=scan.ranges + np.random.default_rng(3).normal(0.0, 0.01, scan.n_beams))
    for seed in (1, 2):
        plain = labkit.lines.ransac_lines(noisy, draw_window=None, rng=np.random.default_rng(seed))
        traced, _ = labkit.lines.ransac_lines(noisy, draw_window=None, rng=np.random.default_rng(seed), trace=True)
        assert _line_key(traced) == _line_key(plain)


def _scenes():
    """A few scans of every simulated scenario and of every bundled recording."""
    import itertools

    from labkit import bundled_data, read_scans
    from labkit.app.data import BUNDLED

    for name in ("hall", "corridor", "office", "random_polygons_2"):
        for k, (scan, _) in enumerate(sim.simulate(name, seed=1, n_scans=3)):
            yield f"sim {name} {k}", scan
    for name in sorted(BUNDLED):
        for k, scan in enumerate(itertools.islice(read_scans(bundled_data(name)), 0, 60, 20)):
            yield f"{name} {k}", scan


@pytest.mark.parametrize("name", ["incremental", "regression", "ransac", "hough"])
def test_reference_extractors_give_the_same_lines_with_trace(name):
    """Tracing changes nothing: the same lines with and without ``trace`` (with and without a
    shared range segmentation), on simulated scenes and the bundled recordings; and the
    accepted steps are those lines."""
    from labkit.lines import LINE_EXTRACTORS

    extract = LINE_EXTRACTORS[name].fn
    n = 0
    for where, scan in _scenes():
        for segments in (None, labkit.segment_labels(scan, threshold_m=0.3)):
            lines, steps = extract(scan, segments=segments, trace=True)
            assert _line_key(lines) == _line_key(extract(scan, segments=segments)), where
            assert _accepted_key(steps) == _line_key(lines), where
            assert all(s.algorithm == name for s in steps)
            n += len(lines)
    assert n > 100  # the scenes have lines to compare
