"""The incremental (line-tracking) extractor against closed-form geometry and the simulator's
ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit import Scan, line_segment, range_segments, segment_labels
from labkit.geometry import angle_difference
from labkit.incremental import incremental_lines
from labkit.sim import Lidar, Wall, World, scan_at, scenario, simulate
from tests.test_split_merge import room_scan, score, wall_scan


def rounded(lines) -> list[tuple[float, float, int, int]]:
    """(r, alpha in degrees, first, last) of every line, rounded (r to 1e-5 m: the simulator
    stores ranges as float32)."""
    return [(round(ln.r, 5), round(math.degrees(ln.alpha), 4) + 0.0, ln.first, ln.last) for ln in lines]


def noiseless(world: World, fov_deg: float = 180.0, step_deg: float = 0.5, full_circle: bool = False):
    lidar = Lidar.from_fov("test", fov_deg, step_deg, full_circle=full_circle, range_max=20.0, noise_std_m=0.0)
    return scan_at(world, lidar, (0.0, 0.0, 0.0), 0.0)


# ---------------------------------------------------------------------------- closed form cases
@pytest.mark.parametrize("alpha", [0.0, 0.7, 1.9, 3.0, math.pi, -0.6, -2.2, -3.0])
def test_one_wall_in_every_quadrant_gives_one_exact_line(alpha):
    scan = wall_scan(3.0, alpha, fov=(alpha - 0.6, alpha + 0.6))
    lines = incremental_lines(scan)
    assert len(lines) == 1
    (line,) = lines
    assert line.r == pytest.approx(3.0, abs=1e-9)
    assert float(angle_difference(line.alpha, alpha)) == pytest.approx(0.0, abs=1e-9)
    assert -math.pi < line.alpha <= math.pi
    assert (line.first, line.last, line.n_points) == (0, scan.n_beams - 1, scan.n_beams)
    assert line.error < 1e-9


def test_three_walls_of_a_room_are_split_exactly_at_the_corners():
    """A 6 x 4 m room seen over 180 degrees: the walls y = -2, x = 3 and y = 2, each line
    holding exactly the beams the simulator says hit its wall. Without handing the corner
    points back, the first two lines would keep a few beams of the next wall."""
    walls = (Wall((-3, -2), (3, -2)), Wall((3, -2), (3, 2)), Wall((3, 2), (-3, 2)), Wall((-3, 2), (-3, -2)))
    scan, truth = noiseless(World("room", walls=walls))
    lines = incremental_lines(scan)
    assert rounded(lines) == [(round(w.r, 5), round(math.degrees(w.alpha), 4) + 0.0, w.first, w.last)
                              for w in truth.walls]
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines], [(2, -90), (3, 0), (2, 90)],
                               atol=1e-5)


def test_a_diamond_room_gives_one_line_per_quadrant():
    """Walls joining (3, 0), (0, 3), (-3, 0), (0, -3): r = 3 / sqrt(2), normals at +-45 and
    +-135 degrees. Beam 0 points exactly at the vertex (-3, 0), which lies on two walls."""
    walls = (Wall((3, 0), (0, 3)), Wall((0, 3), (-3, 0)), Wall((-3, 0), (0, -3)), Wall((0, -3), (3, 0)))
    scan, truth = noiseless(World("diamond", walls=walls), 360.0, full_circle=True)
    lines = incremental_lines(scan)
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines],
                               [(3 / math.sqrt(2), a) for a in (-135.0, -45.0, 45.0, 135.0)], atol=1e-5)
    for line in lines:
        beams = line.indices[line.indices != 0]
        assert len(set(truth.hits[beams].tolist())) == 1  # every line on one wall
    assert sum(ln.n_points for ln in lines) == scan.n_beams  # and every beam on a line


def test_a_full_circle_room_is_cut_at_the_seam():
    """The wall x = -3 crosses the seam of a full-circle scan: the documented behaviour is two
    lines, one ending on the last beam and one starting on the first."""
    lines = incremental_lines(room_scan(n=720))
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines],
                               [(3, 180), (2, -90), (3, 0), (2, 90), (3, 180)], atol=1e-5)
    assert lines[0].first == 0 and lines[-1].last == 719
    assert all(ln.first <= ln.last for ln in lines)


@pytest.mark.parametrize("step_m, n_lines", [(0.02, 1), (0.04, 1), (0.08, 2), (0.15, 2)])
def test_the_line_condition_is_max_error_m(step_m, n_lines):
    """Two parallel walls x = 2 and x = 2 + step, met at the beam straight ahead: a step
    smaller than max_error_m (0.05 m) keeps one line, a larger one starts a new line there."""
    theta = np.radians(np.arange(-30.0, 30.25, 0.5))
    ranges = np.where(theta < 0, 2.0, 2.0 + step_m) / np.cos(theta)
    lines = incremental_lines(Scan(ranges=ranges, angles=theta))
    assert len(lines) == n_lines
    if n_lines == 2:
        assert [ln.r for ln in lines] == pytest.approx([2.0, 2.0 + step_m], abs=1e-9)
        assert (lines[0].last, lines[1].first) == (59, 60)


def test_a_smaller_max_error_splits_a_noisy_wall():
    """On a wall with 2 cm noise (points up to 6 cm off the line) the default keeps few lines;
    a 1 cm tolerance, below the noise, shatters the wall."""
    scan = wall_scan(2.0, 0.3, fov=(-0.5, 1.1))
    rng = np.random.default_rng(5)
    scan = scan.replace(ranges=scan.ranges + rng.normal(0.0, 0.02, scan.n_beams))
    assert len(incremental_lines(scan, max_error_m=0.01, min_length_m=0.0)) > 3 * len(incremental_lines(scan))


# ---------------------------------------------------------------------------- ground truth
@pytest.mark.parametrize("world, min_tp, max_fp", [
    ("office", 0.95, 0.08),
    ("corridor", 0.88, 0.25),
    ("random_polygons_1", 0.97, 0.08),
])
def test_walls_of_simulated_worlds_are_found(world, min_tp, max_fp):
    """Scored as split-and-merge is (``tests/test_split_merge.py::score``), 20 scans each.
    Measured, seeds 0 / 1 / 2 / 3: office (XV-11, 15 mm noise, 2 % dropouts) true positives
    0.993 / 0.993 / 0.986 / 1.000, false positives 0.017 / 0.017 / 0.029 / 0.028; corridor
    (LMS111) 0.926 / 0.916 / 0.926 / 0.947 and 0.162 / 0.174 / 0.167 / 0.143 -- the short
    sides of door recesses, seen end-on, lose or keep a beam of the next wall, which no
    line after them can take back; random_polygons_1 (LMS200) 1.000 every time, false
    positives 0.031 / 0.000 / 0.006 / 0.031. The bounds leave room for other seeds."""
    n_walls = len(scenario(world).world.walls)
    tp = eligible = fp = on_walls = 0
    for scan, truth in simulate(world, 0, n_scans=20):
        a, b, c, d = score(incremental_lines(scan), truth, n_walls)
        tp, eligible, fp, on_walls = tp + a, eligible + b, fp + c, on_walls + d
    assert eligible > 90
    assert tp / eligible >= min_tp
    assert fp / on_walls <= max_fp


# ---------------------------------------------------------------------------- invalid beams, gaps, segments
def test_invalid_beams_are_masked_and_a_dropout_does_not_cut_the_wall():
    scan = wall_scan(2.0, 0.0)
    ranges = scan.ranges.copy()
    ranges[[10, 11, 50]] = [np.nan, np.inf, 0.0]
    ranges[90] = 30.0  # the "no return" reading of a sensor with range_max 20
    lines = incremental_lines(scan.replace(ranges=ranges, range_max=20.0))
    assert len(lines) == 1
    (line,) = lines
    assert line.r == pytest.approx(2.0, abs=1e-9) and line.alpha == pytest.approx(0.0, abs=1e-9)
    assert not {10, 11, 50, 90} & set(line.indices.tolist())
    assert (line.first, line.last, line.n_points) == (0, scan.n_beams - 1, scan.n_beams - 4)


def test_a_gap_wider_than_max_gap_m_cuts_the_line():
    scan = wall_scan(2.0, 0.0)  # 0.5 deg steps at 2 m: points 17 mm apart
    ranges = scan.ranges.copy()
    ranges[70:90] = np.nan  # 20 beams lost: a gap of about 0.36 m
    scan = scan.replace(ranges=ranges)
    lines = incremental_lines(scan)
    assert [(ln.first, ln.last) for ln in lines] == [(0, 69), (90, scan.n_beams - 1)]
    assert len(incremental_lines(scan, max_gap_m=0.5)) == 1


def test_segments_are_never_crossed():
    scan = wall_scan(2.0, 0.0)
    labels = np.where(np.arange(scan.n_beams) < 80, 0, 1)
    labels[40:46] = -1  # e.g. beams taken by a leg detector
    lines = incremental_lines(scan, segments=labels)
    assert [(ln.first, ln.last) for ln in lines] == [(0, 39), (46, 79), (80, scan.n_beams - 1)]
    assert all(ln.r == pytest.approx(2.0, abs=1e-9) for ln in lines)
    # RangeSegment records work too
    room = room_scan(full=False)
    assert rounded(incremental_lines(room, segments=range_segments(room))) == rounded(incremental_lines(room))
    assert rounded(incremental_lines(room, segments=segment_labels(room))) == rounded(incremental_lines(room))


def test_lines_are_built_by_line_segment_from_the_scan_points():
    scan = next(iter(simulate("office", 3, n_scans=1)))[0]
    lines = incremental_lines(scan)
    assert lines
    assert [ln.first for ln in lines] == sorted(ln.first for ln in lines)
    for line in lines:
        idx = line.indices
        assert np.all(np.diff(idx) > 0) and np.all(scan.valid[idx])
        ref = line_segment(scan.points[idx], idx)
        assert (line.r, line.alpha, line.error) == (ref.r, ref.alpha, ref.error)
        assert np.array_equal(line.covariance, ref.covariance)
        assert line.n_points >= 5 and line.length >= 0.15


def test_the_same_scan_gives_the_same_lines():
    scan = next(iter(simulate("corridor", 7, n_scans=1)))[0]
    a, b = incremental_lines(scan), incremental_lines(scan.replace())
    assert rounded(a) == rounded(b)
    assert all(np.array_equal(x.indices, y.indices) and x.r == y.r for x, y in zip(a, b, strict=True))


def test_empty_and_all_invalid_scans_give_no_lines():
    assert incremental_lines(Scan(ranges=[], angles=[])) == []
    assert incremental_lines(Scan(ranges=[np.nan] * 50, angles=np.arange(50) * 0.01)) == []
    assert incremental_lines(Scan(ranges=[2.0] * 4, angles=np.arange(4) * 0.01)) == []  # fewer than min_points


@pytest.mark.parametrize("kwargs, name", [
    ({"max_error_m": 0.0}, "max_error_m"), ({"max_error_m": np.nan}, "max_error_m"),
    ({"max_error_m": "5 cm"}, "max_error_m"), ({"min_points": 1}, "min_points"), ({"min_points": 5.0}, "min_points"),
    ({"min_points": True}, "min_points"), ({"min_length_m": -0.1}, "min_length_m"), ({"max_gap_m": 0}, "max_gap_m"),
    ({"max_gap_m": np.inf}, "max_gap_m"), ({"segments": np.zeros(3, dtype=int)}, "segments"),
])
def test_bad_parameters_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        incremental_lines(wall_scan(), **kwargs)


def test_a_scan_must_be_a_scan():
    with pytest.raises(ValueError, match="scan"):
        incremental_lines(np.ones(10))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.floats(0.01, 40.0), st.sampled_from([0.0, np.nan, np.inf, 30.0])), max_size=200),
       st.booleans(), st.sampled_from([0.01, 0.05, 0.2]))
def test_any_ranges_give_valid_lines(values, full, max_error_m):
    n = len(values)
    step = (2 * math.pi / max(n, 1)) if full else math.radians(0.5)
    scan = Scan(ranges=np.array(values, dtype=float), angles=np.arange(n) * step, range_max=30.0)
    lines = incremental_lines(scan, max_error_m=max_error_m)
    used = np.concatenate([ln.indices for ln in lines]) if lines else np.zeros(0, int)
    assert len(np.unique(used)) == len(used)  # no beam on two lines
    assert [ln.first for ln in lines] == sorted(ln.first for ln in lines)
    for line in lines:
        assert line.r >= 0 and -math.pi < line.alpha <= math.pi
        assert line.n_points >= 5 and line.length >= 0.15
        assert np.all(np.diff(line.indices) > 0) and np.all(scan.valid[line.indices])
        p = scan.points[line.indices]
        assert np.all(np.hypot(*np.diff(p, axis=0).T) <= 0.3)  # never across a gap
