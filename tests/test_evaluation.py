"""labkit.evaluation against hand-built truth, brute force and the simulator's ground truth."""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit import Scan, line_segment, sim, split_and_merge
from labkit.evaluation import (
    is_occluded_in_truth,
    match_circles,
    match_legs,
    match_lines,
    ray_errors,
    score_detections,
    score_lines,
)


def wall(x0, y0, x1, y1, n_beams=50, wall_id=0):
    """A visible wall from (x0, y0) to (x1, y1), its normal form worked out by hand."""
    dx, dy = x1 - x0, y1 - y0
    alpha = math.atan2(dx, -dy)  # a normal of the direction (dx, dy)
    r = x0 * math.cos(alpha) + y0 * math.sin(alpha)
    if r < 0:
        r, alpha = -r, math.atan2(-math.sin(alpha), -math.cos(alpha))
    return NS(r=r, alpha=alpha, start=(x0, y0), end=(x1, y1), n_beams=n_beams, wall_id=wall_id)


def seg(x0, y0, x1, y1, first=0, n=20):
    """A line segment fitted to ``n`` exact points from (x0, y0) to (x1, y1)."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    p = np.array([x0, y0]) + t * np.array([x1 - x0, y1 - y0])
    return line_segment(p, range(first, first + n))


# ---------------------------------------------------------------------------- lines
def test_wall_helper_is_the_normal_form():
    w = wall(-2.0, 1.0, -2.0, -1.0)  # x = -2: normal points to -x
    assert w.r == pytest.approx(2.0) and abs(w.alpha) == pytest.approx(math.pi)


@pytest.mark.parametrize(("offset", "matched"), [(0.0, True), (0.049, True), (0.051, False), (-0.049, True)])
def test_distance_tolerance(offset, matched):
    m = match_lines([seg(2.0 + offset, -0.8, 2.0 + offset, 0.8)], [wall(2.0, -1.0, 2.0, 1.0)])
    assert (m.n_matched == 1) is matched
    assert len(m.scored) == 1
    if matched:
        assert m.dr[0] == pytest.approx(offset, abs=1e-9)


@pytest.mark.parametrize(("deg", "matched"), [(2.9, True), (3.1, False)])
def test_angle_tolerance(deg, matched):
    # a line through (2, 0) turned by ``deg``: r stays within a millimetre of 2 m
    a = math.radians(deg)
    d = np.array([-math.sin(a), math.cos(a)]) * 0.8
    line = seg(2.0 - d[0], -d[1], 2.0 + d[0], d[1])
    m = match_lines([line], [wall(2.0, -1.0, 2.0, 1.0)], max_dr_m=0.1)
    assert (m.n_matched == 1) is matched


def test_angle_difference_is_taken_across_the_wrap():
    """A wall at x = -2 has alpha = pi; a line tilted a little has alpha near -pi."""
    w = wall(-2.0, 1.0, -2.0, -1.0)
    line = seg(-2.0, 0.8, -2.02, -0.8)
    assert abs(line.alpha - w.alpha) > math.pi  # the raw difference wraps
    m = match_lines([line], [w])
    assert m.n_matched == 1 and abs(m.dalpha[0]) < math.radians(1)


def test_a_collinear_line_beyond_the_wall_does_not_match():
    w = wall(2.0, -1.0, 2.0, 1.0)
    assert match_lines([seg(2.0, 1.2, 2.0, 2.5)], [w]).n_matched == 0
    assert match_lines([seg(2.0, 0.6, 2.0, 1.6)], [w]).n_matched == 0  # 0.4 of 1.0 m on the wall
    assert match_lines([seg(2.0, 0.4, 2.0, 1.4)], [w]).n_matched == 1  # 0.6 on the wall


def test_one_to_one_keeps_the_closer_line_and_counts_the_other_false():
    w = wall(2.0, -1.0, 2.0, 1.0)
    near, far = seg(2.01, -0.9, 2.01, 0.9), seg(2.03, -0.9, 2.03, 0.9)
    m = match_lines([far, near], [w])
    assert m.pairs == ((1, 0),) and m.false_positives == (0,) and m.missed == ()


def test_walls_too_short_or_thin_are_not_truth_and_lines_on_them_not_scored():
    short = wall(2.0, -0.1, 2.0, 0.1, wall_id=0)  # 0.2 m
    few = wall(-2.0, 1.0, -2.0, -1.0, n_beams=5, wall_id=1)
    good = wall(0.5, 3.0, -0.5, 3.0, wall_id=2)
    lines = [seg(2.0, -0.1, 2.0, 0.1), seg(-2.0, 0.9, -2.0, -0.9), seg(0.4, 3.0, -0.4, 3.0), seg(1, 5, 2, 6)]
    m = match_lines(lines, [short, few, good])
    assert m.truth == (2,)
    assert m.pairs == ((2, 2),)
    assert m.scored == (2, 3) and m.false_positives == (3,)


def test_lines_on_round_objects_are_not_scored():
    """The truth's ``hits`` say which object each beam hit: a line whose beams mostly hit a
    column is left to the circle detector."""
    w = wall(2.0, -1.0, 2.0, 1.0)
    hits = np.full(100, -1)
    hits[0:20] = 0  # the wall
    hits[40:60] = 7  # a column
    truth = NS(walls=(w,), hits=hits, circles=(NS(object_id=7),), legs=(), arcs=())
    on_column = seg(1.0, 0.5, 1.1, 0.6, first=40)
    on_nothing = seg(3.0, 3.0, 4.0, 3.5, first=70)
    m = match_lines([seg(2.0, -0.9, 2.0, 0.9, first=0), on_column, on_nothing], truth)
    assert m.n_matched == 1 and m.scored == (0, 2) and m.false_positives == (2,)


def test_score_lines_pools_counts_and_spreads():
    w = wall(2.0, -1.0, 2.0, 1.0)
    offsets = [0.01, -0.02, 0.03, 0.0]
    results = [([seg(2.0 + o, -0.9, 2.0 + o, 0.9)], [w]) for o in offsets]
    results.append(([seg(2.0, -0.9, 2.0, 0.9), seg(5, 5, 6, 6)], [w, wall(0, 3, 1, 3)]))
    s = score_lines(results)
    assert (s.n_scans, s.n_truth, s.n_lines, s.n_scored, s.n_matched) == (5, 6, 6, 6, 5)
    assert s.tp_rate == pytest.approx(5 / 6) and s.fp_rate == pytest.approx(1 / 6)
    assert s.sigma_dr == pytest.approx(np.std(offsets + [0.0], ddof=1), abs=1e-9)
    assert s.as_dict()["sigma_dalpha_deg"] == pytest.approx(0.0, abs=1e-6)


def test_no_lines_and_no_truth():
    s = score_lines([([], [])])
    assert s.n_truth == 0 and math.isnan(s.tp_rate) and math.isnan(s.fp_rate) and math.isnan(s.sigma_dr)


segments = st.tuples(*[st.floats(-5, 5, allow_nan=False)] * 4).filter(
    lambda t: math.hypot(t[2] - t[0], t[3] - t[1]) > 0.3)


@settings(max_examples=60)
@given(st.lists(segments, max_size=6), st.lists(segments, max_size=6), st.floats(0, 0.06))
def test_matching_is_one_to_one_within_the_rule_and_maximal(walls_xy, lines_xy, jitter):
    """Brute force over every (line, wall) pair: matched pairs obey the rule, nothing is
    used twice, and no line-wall pair that obeys the rule is left with both sides free."""
    walls = [wall(*w, wall_id=k) for k, w in enumerate(walls_xy)]
    lines = [seg(x0 + jitter, y0, x1 + jitter, y1) for x0, y0, x1, y1 in lines_xy]
    lines += [seg(w.start[0], w.start[1] + jitter, w.end[0], w.end[1]) for w in walls[:3]]
    m = match_lines(lines, walls)

    def obeys(line, w):
        da = abs((line.alpha - w.alpha + math.pi) % (2 * math.pi) - math.pi)
        u = np.subtract(w.end, w.start) / math.hypot(*np.subtract(w.end, w.start))
        a, b = sorted([float(np.dot(line.start - w.start, u)), float(np.dot(line.end - w.start, u))])
        wl = math.hypot(*np.subtract(w.end, w.start))
        on = max(0.0, min(b, wl) - max(a, 0.0)) / (b - a) if b > a else float(0 <= a <= wl)
        return abs(line.r - w.r) <= 0.05 and da <= math.radians(3) + 1e-12 and on >= 0.5

    used_l = [i for i, _ in m.pairs]
    used_w = [j for _, j in m.pairs]
    assert len(set(used_l)) == len(used_l) and len(set(used_w)) == len(used_w)
    for i, j in m.pairs:
        assert obeys(lines[i], walls[j])
    for i, line in enumerate(lines):
        for j, w in enumerate(walls):  # every wall is in the truth: 50 beams, longer than 0.3 m
            if i not in used_l and j not in used_w:
                assert not obeys(line, w)


def test_noiseless_room_from_the_simulator_is_found_exactly():
    """Four walls of a room, no noise: every wall found once, nothing false, dr below a
    millimetre (float32 ranges, and a corner beam that may join either wall)."""
    room = sim.World("room", walls=tuple(sim.Wall(a, b) for a, b in [((-3, -2), (4, -2)), ((4, -2), (4, 3)),
                                                                      ((4, 3), (-3, 3)), ((-3, 3), (-3, -2))]))
    lidar = sim.Lidar("l", -math.pi, 2 * math.pi / 720, 720, noise_std_m=0.0)
    scan, truth = sim.scan_at(room, lidar, (0.3, 0.2, 0.4))
    s = score_lines([(split_and_merge(scan), truth)])
    assert (s.n_truth, s.n_matched, s.n_scored) == (4, 4, 4)
    assert np.abs(s.dr).max() < 1e-3


# ---------------------------------------------------------------------------- circles and legs
def _scan_and_truth(objects, n=50, ranges=None, hits=None):
    angles = np.linspace(-0.5, 0.5, n)
    scan = Scan(np.full(n, 5.0) if ranges is None else ranges, angles)
    hits = np.full(n, -1) if hits is None else hits
    return scan, NS(circles=tuple(objects), legs=tuple(objects), hits=hits, walls=())


def _obj(x, y, radius=0.2, first=10, last=15, object_id=3):
    return NS(center=(x, y), radius=radius, diameter=2 * radius, first=first, last=last,
              n_beams=last - first + 1, object_id=object_id)


def test_circle_match_by_centre_distance_one_to_one():
    scan, truth = _scan_and_truth([_obj(2.0, 0.0), _obj(3.0, 1.0, first=30, last=35, object_id=4)])
    dets = [NS(center=np.array([2.05, 0.0]), radius=0.22), NS(center=np.array([2.02, 0.0]), radius=0.2),
            NS(center=np.array([3.0, 1.15]), radius=0.2)]
    m = match_circles(dets, scan, truth)
    assert m.pairs == ((1, 0),)  # the nearer of the two; the other and the one 15 cm off are false
    assert m.scored == (0, 1, 2) and m.truth == (0, 1)
    assert m.center_errors[0] == pytest.approx(0.02) and m.radius_errors[0] == pytest.approx(0.0, abs=1e-12)
    s = score_detections([m])
    assert s.precision == pytest.approx(1 / 3) and s.recall == pytest.approx(1 / 2)


def test_occluded_or_thin_truth_is_not_counted_and_detections_on_it_not_scored():
    ranges = np.full(50, 5.0)
    ranges[9] = 1.0  # something nearer beside the object's first beam
    hits = np.full(50, -1)
    hits[9], hits[10:16] = 9, 3
    scan, truth = _scan_and_truth([_obj(2.0, 0.0), _obj(3.0, 1.0, first=30, last=32, object_id=4)], ranges=ranges,
                                  hits=hits)
    assert is_occluded_in_truth(scan, truth, truth.circles[0])
    assert not is_occluded_in_truth(scan, truth, truth.circles[1])
    dets = [NS(center=np.array([2.0, 0.0]), radius=0.2), NS(center=np.array([3.0, 1.0]), radius=0.2)]
    m = match_circles(dets, scan, truth)  # circles need 4 beams: the second has 3
    assert m.truth == () and m.scored == () and m.pairs == ()
    legs = [NS(center=np.array([3.0, 1.0]), diameter=0.4)]
    m = match_legs(legs, scan, truth)  # legs need 3
    assert m.truth == (1,) and m.pairs == ((0, 1),)


def test_edge_of_the_field_of_view_occludes():
    scan, truth = _scan_and_truth([_obj(2.0, 0.0, first=0, last=4)])
    assert is_occluded_in_truth(scan, truth, truth.circles[0])


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="max_dr_m"):
        match_lines([], [], max_dr_m=0)
    with pytest.raises(ValueError, match="min_overlap"):
        match_lines([], [], min_overlap=1.5)
    with pytest.raises(ValueError, match="max_center_m"):
        match_circles([], *_scan_and_truth([]), max_center_m=-1)
    with pytest.raises(ValueError, match="scan"):
        ray_errors(np.zeros(3), [])


# ---------------------------------------------------------------------------- ray-axis error
def test_ray_errors_against_a_per_beam_solve():
    rng = np.random.default_rng(5)
    angles = np.linspace(-math.pi, math.pi, 361, endpoint=False)
    ranges = rng.uniform(0.5, 6.0, 361)
    ranges[::17] = np.nan
    scan = Scan(ranges, angles)
    segs = [NS(start=rng.uniform(-5, 5, 2), end=rng.uniform(-5, 5, 2)) for _ in range(8)]
    e = ray_errors(scan, segs)
    expected = []
    for rho, th in zip(ranges, angles, strict=False):
        if not np.isfinite(rho):
            continue
        u = np.array([math.cos(th), math.sin(th)])
        best = math.inf
        for sg in segs:
            a = np.column_stack([u, -(np.asarray(sg.end) - sg.start)])
            if abs(np.linalg.det(a)) < 1e-12:
                continue
            s, t = np.linalg.solve(a, sg.start)
            if s > 0 and 0 <= t <= 1:
                best = min(best, s)
        if math.isfinite(best):
            expected.append(rho - best)
    assert e.n_valid == int(np.isfinite(ranges).sum())
    np.testing.assert_allclose(e.errors, expected, atol=1e-9)
    assert e.coverage == pytest.approx(len(expected) / e.n_valid)


def test_a_ray_through_a_segments_end_meets_it():
    # a line extractor ends its segments where its first and last beams' rays meet the line; in
    # floating point such an end can land a hair outside [0, 1] of the segment: still a hit
    rng = np.random.default_rng(11)
    angles = np.radians(np.arange(-60.0, 60.01, 0.5))
    missed = 0
    for _ in range(200):
        r, alpha = rng.uniform(0.5, 8.0), rng.uniform(-0.5, 0.5)
        i, j = sorted(rng.choice(len(angles), 2, replace=False))
        ends = [r / math.cos(angles[k] - alpha) * np.array([math.cos(angles[k]), math.sin(angles[k])]) for k in (i, j)]
        scan = Scan(r / np.cos(angles - alpha), angles)
        e = ray_errors(scan, [NS(start=ends[0], end=ends[1])])
        missed += len({i, j} - set(e.beams.tolist()))
        assert set(e.beams.tolist()) <= set(range(i, j + 1))
        np.testing.assert_allclose(e.errors, 0.0, atol=1e-9)
    assert missed == 0


def test_ray_rmse_of_the_true_walls_is_the_range_noise():
    """The simulator's walls as segments: the ray-axis errors are exactly its range noise."""
    sc = sim.scenario("hall")
    lidar = sim.Lidar("l", -math.pi / 2, math.pi / 720, 721, noise_std_m=0.01)
    world = sim.World("walls", walls=sc.world.walls)
    rng = np.random.default_rng(0)
    total = None
    for k in range(5):
        scan, truth = sim.scan_at(world, lidar, (6.0, 0.4 + 0.3 * k, math.pi / 2), rng=rng)
        e = ray_errors(scan, truth.walls)
        total = e if total is None else total + e
    assert total.coverage > 0.99
    assert total.rmse == pytest.approx(0.01, rel=0.1)


def test_no_segments_cover_nothing():
    scan = Scan(np.ones(5), np.linspace(0, 1, 5))
    e = ray_errors(scan, [])
    assert e.coverage == 0 and math.isnan(e.rmse)


def test_ray_error_summaries():
    angles = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    scan = Scan(2.0 / np.cos(angles) + [0.0, 0.01, -0.02, 0.5, np.nan], angles)
    e = ray_errors(scan, [NS(start=(2.0, -1.0), end=(2.0, 0.15))])  # misses the last two rays
    assert e.beams.tolist() == [0, 1, 2] and e.n_valid == 4 and e.coverage == 0.75
    assert e.median_abs == pytest.approx(0.01) and e.share_over(0.015) == pytest.approx(1 / 3)
    both = e + e
    assert both.beams.tolist() == [0, 1, 2, 0, 1, 2] and both.rmse == pytest.approx(e.rmse)
