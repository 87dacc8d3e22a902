"""The contract every line extractor keeps (incremental, line regression, RANSAC, Hough):
invalid beams, gaps, range segments, how lines are built, determinism and bad input. What
only one extractor does, and its scores against the simulator's ground truth, are tested in
its own file."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit import Scan, line_segment, range_segments, segment_labels, split_and_merge
from labkit.evaluation import ray_errors
from labkit.geometry import angle_difference
from labkit.lines import LINE_EXTRACTORS
from labkit.noise import FIXED_INCREMENTAL, scan_sigma
from labkit.sim import Lidar, Wall, World, scan_at, scenario, simulate
from tests.line_scans import ROOM, doorway_scan, key, noiseless, room_scan, rounded, wall_scan
from tests.test_split_merge import _past_own_rays

#: the extractors this contract holds for, read from the registry (the others -- split-and-merge,
#: angular segmentation, IAV lines -- have their own files: they keep part of it)
CONTRACT = ("incremental", "regression", "ransac", "hough")
EXTRACTORS = [LINE_EXTRACTORS[name].fn for name in CONTRACT]
incremental_lines, regression_lines, ransac_lines, hough_lines = EXTRACTORS
IDS = list(CONTRACT)
extractors = pytest.mark.parametrize("extract", EXTRACTORS, ids=IDS)


# ---------------------------------------------------------------------------- closed form cases
@extractors
@pytest.mark.parametrize("r, alpha, fov", [(3.0, a, (a - 0.6, a + 0.6))
                                           for a in (0.0, 0.7, 1.9, 3.0, math.pi, -0.6, -2.2, -3.0)]
                         + [(3.0, 0.4, (-0.3, 1.1))])
def test_one_wall_gives_one_exact_line(extract, r, alpha, fov):
    scan = wall_scan(r, alpha, fov=fov)
    lines = extract(scan)
    assert len(lines) == 1
    (line,) = lines
    assert line.r == pytest.approx(r, abs=1e-9)
    assert float(angle_difference(line.alpha, alpha)) == pytest.approx(0.0, abs=1e-9)
    assert -math.pi < line.alpha <= math.pi
    assert (line.first, line.last, line.n_points) == (0, scan.n_beams - 1, scan.n_beams)
    assert line.error < 1e-9


#: How far (m and degrees) a line of a noiseless room may be off its wall: incremental and
#: regression lines end exactly at the corners; a RANSAC or Hough line also takes the points of
#: the next wall within ``threshold_m`` (3 cm) of it. Measured: 8.3e-5 m off for both.
CORNER_TOLERANCE = [1e-5, 1e-5, 1e-4, 1e-4]


@pytest.mark.parametrize("extract, atol", list(zip(EXTRACTORS, CORNER_TOLERANCE, strict=True)), ids=IDS)
def test_a_full_circle_room_is_cut_at_the_seam(extract, atol):
    """The wall x = -3 crosses the seam of a full-circle scan: the documented behaviour is two
    lines, one ending on the last beam and one starting on the first."""
    lines = extract(room_scan(n=720))
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines],
                               [(3, 180), (2, -90), (3, 0), (2, 90), (3, 180)], atol=atol)
    assert lines[0].first == 0 and lines[-1].last == 719
    assert all(ln.first <= ln.last for ln in lines)


#: The extractors that end their lines exactly at corners (RANSAC and Hough lines take the next
#: wall's points near a corner; see CORNER_TOLERANCE).
exact_at_corners = pytest.mark.parametrize("extract", [incremental_lines, regression_lines],
                                           ids=["incremental", "regression"])


@exact_at_corners
def test_three_walls_of_a_room_are_split_exactly_at_the_corners(extract):
    """A 6 x 4 m room seen over 180 degrees: the walls y = -2, x = 3 and y = 2, each line
    holding exactly the beams the simulator says hit its wall. (Incremental: without handing
    the corner points back, the first two lines would keep a few beams of the next wall.
    Regression: the corner beams, which no cluster holds, are given to the line they lie on.)"""
    scan, truth = noiseless(World("room", walls=ROOM))
    lines = extract(scan)
    assert rounded(lines) == [(round(w.r, 5), round(math.degrees(w.alpha), 4) + 0.0, w.first, w.last)
                              for w in truth.walls]
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines], [(2, -90), (3, 0), (2, 90)],
                               atol=1e-5)


@exact_at_corners
def test_a_diamond_room_gives_one_line_per_quadrant(extract):
    """Walls joining (3, 0), (0, 3), (-3, 0), (0, -3): r = 3 / sqrt(2), normals at +-45 and
    +-135 degrees. Beam 0 points exactly at the vertex (-3, 0), which lies on two walls."""
    walls = (Wall((3, 0), (0, 3)), Wall((0, 3), (-3, 0)), Wall((-3, 0), (0, -3)), Wall((0, -3), (3, 0)))
    scan, truth = noiseless(World("diamond", walls=walls), 360.0, full_circle=True)
    lines = extract(scan)
    np.testing.assert_allclose([(ln.r, math.degrees(ln.alpha)) for ln in lines],
                               [(3 / math.sqrt(2), a) for a in (-135.0, -45.0, 45.0, 135.0)], atol=1e-5)
    for line in lines:
        beams = line.indices[line.indices != 0]
        assert len(set(truth.hits[beams].tolist())) == 1  # every line on one wall
    assert sum(ln.n_points for ln in lines) == scan.n_beams  # and every beam on a line


# ---------------------------------------------------------------------------- invalid beams, gaps, segments
@extractors
def test_invalid_beams_are_masked_and_a_dropout_does_not_cut_the_wall(extract):
    scan = wall_scan(2.0, 0.0)
    ranges = scan.ranges.copy()
    bad = [10, 11, 50, 90, 91]
    ranges[bad] = [np.nan, np.inf, 0.0, 30.0, 20.0]  # NaN, inf, zero, beyond and at range_max
    scan = scan.replace(ranges=ranges, range_max=20.0)
    lines = extract(scan)
    assert len(lines) == 1
    (line,) = lines
    assert line.r == pytest.approx(2.0, abs=1e-9) and line.alpha == pytest.approx(0.0, abs=1e-9)
    assert not set(bad) & set(line.indices.tolist())
    assert (line.first, line.last, line.n_points) == (0, scan.n_beams - 1, scan.n_beams - len(bad))


@extractors
def test_a_gap_wider_than_max_gap_m_cuts_the_line(extract):
    scan = wall_scan(2.0, 0.0)  # 0.5 deg steps at 2 m: points 17 mm apart
    ranges = scan.ranges.copy()
    ranges[70:90] = np.nan  # 20 beams lost: a gap of about 0.36 m
    scan = scan.replace(ranges=ranges)
    lines = extract(scan)
    assert [(ln.first, ln.last) for ln in lines] == [(0, 69), (90, scan.n_beams - 1)]
    assert len(extract(scan, max_gap_m=0.5)) == 1


@extractors
def test_a_doorway_wider_than_max_gap_m_cuts_a_wall(extract):
    """Both sides of a doorway are on one line (y = 2) but two segments when the doorway is
    wider than max_gap_m; a narrower one is spanned."""
    wide = extract(doorway_scan(1.0))
    assert len(wide) == 2
    for ln in wide:
        assert ln.r == pytest.approx(2.0, abs=1e-9) and ln.alpha == pytest.approx(math.pi / 2, abs=1e-9)
    assert np.hypot(*(wide[1].start - wide[0].end)) > 1.0
    (narrow,) = extract(doorway_scan(0.1))
    assert narrow.n_points == np.isfinite(doorway_scan(0.1).ranges).sum()
    assert len(extract(doorway_scan(0.1), max_gap_m=0.05)) == 2


#: Whether a valid beam labelled -1 (taken by another detector) ends a line, as a segment
#: boundary does (incremental, regression), or is only left out, like an invalid beam (RANSAC, Hough).
TAKEN_BEAMS_CUT = [True, True, False, False]


@pytest.mark.parametrize("extract, cuts", list(zip(EXTRACTORS, TAKEN_BEAMS_CUT, strict=True)), ids=IDS)
def test_segment_boundaries_are_never_crossed(extract, cuts):
    """Two labelled segments with no gap between them give two lines; beams labelled -1 take no part."""
    scan = wall_scan(2.0, 0.0)
    labels = segment_labels(scan)
    labels[40:45] = -1  # e.g. the beams of a leg in front of the wall
    labels[100:] = 1  # a second segment, with no gap between them
    lines = extract(scan, segments=labels)
    if cuts:
        assert [(ln.first, ln.last) for ln in lines] == [(0, 39), (45, 99), (100, scan.n_beams - 1)]
    else:
        assert [(ln.first, ln.last) for ln in lines] == [(0, 99), (100, scan.n_beams - 1)]
        assert lines[0].n_points == 95
    assert not set(range(40, 45)) & set(np.concatenate([ln.indices for ln in lines]).tolist())
    assert all(ln.r == pytest.approx(2.0, abs=1e-9) for ln in lines)


@pytest.mark.parametrize("extract, cuts", list(zip(EXTRACTORS, TAKEN_BEAMS_CUT, strict=True)), ids=IDS)
def test_beams_labelled_minus_one_take_no_part(extract, cuts):
    scan = wall_scan(2.0, 0.0)
    labels = np.where(np.arange(scan.n_beams) < 80, 0, 1)
    labels[40:46] = -1  # e.g. beams taken by a leg detector
    lines = extract(scan, segments=labels)
    if cuts:
        assert [(ln.first, ln.last) for ln in lines] == [(0, 39), (46, 79), (80, scan.n_beams - 1)]
    else:
        assert [(ln.first, ln.last) for ln in lines] == [(0, 79), (80, scan.n_beams - 1)]
        assert lines[0].n_points == 74
    assert not set(range(40, 46)) & set(np.concatenate([ln.indices for ln in lines]).tolist())
    assert all(ln.r == pytest.approx(2.0, abs=1e-9) for ln in lines)


@extractors
def test_range_segment_records_work_too(extract):
    room = room_scan(full=False)
    assert rounded(extract(room, segments=range_segments(room))) == rounded(extract(room))
    assert rounded(extract(room, segments=segment_labels(room))) == rounded(extract(room))


# ---------------------------------------------------------------------------- how lines are built
@extractors
def test_lines_are_built_by_line_segment_from_the_scan_points(extract):
    # the covariance of the scan's estimated range noise where the extractor's default is "auto"
    # (incremental, RANSAC, Hough), of each line's own residuals where it is none (regression)
    scan = next(iter(simulate("office", 3, n_scans=1)))[0]
    lines = extract(scan)
    auto = LINE_EXTRACTORS[CONTRACT[EXTRACTORS.index(extract)]].params_cls().range_sigma_m == "auto"
    sigma = scan_sigma(scan) if auto else None
    assert lines
    assert [ln.first for ln in lines] == sorted(ln.first for ln in lines)
    for line in lines:
        idx = line.indices
        assert np.all(np.diff(idx) > 0) and np.all(scan.valid[idx])
        ref = line_segment(scan.points[idx], idx, range_sigma=sigma)
        assert (line.r, line.alpha, line.error) == (ref.r, ref.alpha, ref.error)
        assert np.array_equal(line.covariance, ref.covariance)
        assert line.n_points >= 5 and line.length >= 0.15


@extractors
@pytest.mark.parametrize("world, seed", [("corridor", 7), ("hall", 3)])
def test_the_same_scan_gives_the_same_lines(extract, world, seed):
    scan = next(iter(simulate(world, seed, n_scans=1)))[0]
    a, b = extract(scan), extract(scan.replace())
    assert a and rounded(a) == rounded(b)
    assert key(a) == key(b) and key(extract(scan)) == key(a)


@pytest.mark.parametrize("extract, kwargs", [(incremental_lines, FIXED_INCREMENTAL),
                                             (regression_lines, {"range_sigma_m": 0.02})],
                         ids=["incremental", "regression"])
def test_a_segment_stops_at_the_ray_of_its_end_beam(extract, kwargs):
    """The wall x = 1 m from -30 to 45 deg, its last beam reading 6 cm long (4.2 cm off the
    wall); past it, from 45.5 deg, the beams see the wall x = 3 m. The last point's projection
    onto the line lies 4.2 cm along the wall from its ray, beyond the rays of the next two beams
    (1.75 cm apart there): that segment would claim the near wall where they saw the far one,
    2.85 m behind (incremental's fixed 5 cm takes the point in). The segment ends where the last
    beam's ray meets the line (as split-and-merge's, ``tests/test_split_merge.py``), and every far
    beam's ray meets the far wall first, at its measured range. (Line regression takes that point into the line only
    within three sigmas of it: it is told sigma = 2 cm.)"""
    theta = np.radians(np.arange(-30.0, 60.25, 0.5))
    near = theta <= math.radians(45.0) + 1e-9
    ranges = np.where(near, 1.0, 3.0) / np.cos(theta)
    last = int(np.flatnonzero(near)[-1])
    ranges[last] += 0.06
    scan = Scan(ranges=ranges, angles=theta)
    lines = extract(scan, **kwargs)
    (wall,) = [ln for ln in lines if ln.first <= last <= ln.last]
    assert wall.last == last and wall.r == pytest.approx(1.0, abs=0.01)
    u = np.array([math.cos(theta[last]), math.sin(theta[last])])
    assert np.allclose(wall.end, wall.r / math.cos(theta[last] - wall.alpha) * u, atol=1e-12)
    errors = ray_errors(scan, lines)
    far = errors.beams > last
    assert far.sum() >= 25 and np.abs(errors.errors[far]).max() < 1e-9


@pytest.mark.parametrize("extract", [split_and_merge, incremental_lines, regression_lines],
                         ids=["split_and_merge", "incremental", "regression"])
@pytest.mark.parametrize("noise", [0.01, 0.03])
def test_lines_never_reach_past_the_rays_of_their_own_end_beams(extract, noise):
    """A noisy end point seen at a grazing angle projects along the line, over the next beams'
    rays: the line would claim a surface where those beams saw farther (or nearer). On the
    simulated corridor seen from 12 places, no segment end lies outside the wedge between its
    end beams' rays."""
    rng = np.random.default_rng(7)
    world = scenario("corridor").world
    lidar = Lidar.from_fov("test", 270.0, 0.5, range_max=20.0, noise_std_m=noise)
    past = []
    for x in np.linspace(1.0, 20.0, 12):
        scan = scan_at(world, lidar, (x, 0.0, 0.0), 0.0, rng=rng)[0]
        past += [_past_own_rays(scan, ln) for ln in extract(scan)]
    assert len(past) > 40 and max(past) < 1e-9, max(past)


# ---------------------------------------------------------------------------- bad input
#: Per extractor, how many beams 2 m away (or 1 m) are too few for a line: fewer than
#: ``min_points`` (incremental), a single window (regression), fewer than ``min_inliers`` or
#: ``min_votes`` (RANSAC, Hough).
TOO_FEW = [(4, 2.0), (7, 2.0), (5, 1.0), (5, 1.0)]


@pytest.mark.parametrize("extract, too_few", list(zip(EXTRACTORS, TOO_FEW, strict=True)), ids=IDS)
def test_empty_and_all_invalid_scans_give_no_lines(extract, too_few):
    n, r = too_few
    assert extract(Scan(ranges=[], angles=[])) == []
    assert extract(Scan(ranges=[np.nan] * 50, angles=np.arange(50) * 0.01)) == []
    assert extract(Scan(ranges=[r] * n, angles=np.arange(n) * 0.01)) == []


#: The arguments every extractor has, with bad values.
COMMON_BAD = [
    ({"min_points": 1}, "min_points"), ({"min_points": 5.0}, "min_points"), ({"min_points": True}, "min_points"),
    ({"min_length_m": -0.1}, "min_length_m"), ({"max_gap_m": 0}, "max_gap_m"), ({"max_gap_m": 0.0}, "max_gap_m"),
    ({"max_gap_m": np.inf}, "max_gap_m"), ({"max_gap_m": np.nan}, "max_gap_m"),
    ({"segments": np.zeros(3, dtype=int)}, "segments"), ({"segments": [1, 2]}, "segments"),
]

#: The arguments of one extractor only, with bad values.
OWN_BAD = {
    incremental_lines: [({"max_error_m": 0.0}, "max_error_m"), ({"max_error_m": np.nan}, "max_error_m"),
                        ({"max_error_m": "5 cm"}, "max_error_m")],
    regression_lines: [({"window": 2}, "window"), ({"window": 7.0}, "window"),
                       ({"fidelity_threshold": 0.0}, "fidelity_threshold"),
                       ({"fidelity_threshold": np.nan}, "fidelity_threshold"),
                       ({"range_sigma_m": 0.0}, "range_sigma_m"), ({"range_sigma_m": "auto"}, "range_sigma_m")],
    ransac_lines: [({"threshold_m": -0.01}, "threshold_m"), ({"threshold_m": np.nan}, "threshold_m"),
                   ({"min_inliers": 1}, "min_inliers"), ({"min_inliers": 8.0}, "min_inliers"),
                   ({"max_trials": 0}, "max_trials"), ({"draw_window": 0}, "draw_window"), ({"rng": 42}, "rng"),
                   ({"rng": np.random.RandomState(0)}, "rng")],
    hough_lines: [({"r_step_m": 0.0}, "r_step_m"), ({"r_step_m": np.inf}, "r_step_m"),
                  ({"alpha_step_deg": -0.1}, "alpha_step_deg"), ({"alpha_step_deg": 91.0}, "alpha_step_deg"),
                  ({"alpha_step_deg": 1e-3}, "alpha_step_deg"), ({"threshold_m": 0}, "threshold_m"),
                  ({"min_votes": 1}, "min_votes"), ({"min_votes": True}, "min_votes")],
}


@pytest.mark.parametrize("extract, kwargs, name", [
    pytest.param(extract, kwargs, name, id=f"{ident}-{next(iter(kwargs))}-{k}")
    for extract, ident in zip(EXTRACTORS, IDS, strict=True)
    for k, (kwargs, name) in enumerate(COMMON_BAD + OWN_BAD[extract])
])
def test_bad_parameters_are_named(extract, kwargs, name):
    with pytest.raises(ValueError, match=name):
        extract(wall_scan(), **kwargs)


@extractors
@pytest.mark.parametrize("not_a_scan", [np.ones(10), [1.0, 2.0]], ids=["array", "list"])
def test_a_scan_must_be_a_scan(extract, not_a_scan):
    with pytest.raises(ValueError, match="scan"):
        extract(not_a_scan)


#: Per extractor, the arguments the property test draws besides the scan.
DRAWN_KWARGS = [
    st.fixed_dictionaries({"max_error_m": st.sampled_from([0.01, 0.05, 0.2])}),
    st.fixed_dictionaries({"window": st.sampled_from([3, 7, 9]), "range_sigma_m": st.sampled_from([None, 0.01])}),
    st.just({}),
    st.just({}),
]


@pytest.mark.parametrize("extract, drawn", list(zip(EXTRACTORS, DRAWN_KWARGS, strict=True)), ids=IDS)
@settings(max_examples=60)
@given(values=st.lists(st.one_of(st.floats(0.01, 40.0), st.sampled_from([0.0, np.nan, np.inf, 30.0])),
                       max_size=200),
       full=st.booleans(), data=st.data())
def test_any_ranges_give_valid_lines(extract, drawn, values, full, data):
    n = len(values)
    step = (2 * math.pi / max(n, 1)) if full else math.radians(0.5)
    scan = Scan(ranges=np.array(values, dtype=float), angles=np.arange(n) * step, range_max=30.0)
    lines = extract(scan, **data.draw(drawn))
    used = np.concatenate([ln.indices for ln in lines]) if lines else np.zeros(0, int)
    assert len(np.unique(used)) == len(used)  # no beam on two lines
    assert [ln.first for ln in lines] == sorted(ln.first for ln in lines)
    for line in lines:
        assert line.r >= 0 and -math.pi < line.alpha <= math.pi
        assert line.n_points >= 5 and line.length >= 0.15
        assert np.all(np.diff(line.indices) > 0) and np.all(scan.valid[line.indices])
        p = scan.points[line.indices]
        assert np.all(np.hypot(*np.diff(p, axis=0).T) <= 0.3)  # never across a gap


# ---------------------------------------------------------------------------- every registered extractor
#: The part of the contract that every registered method keeps, read from the registry at
#: collection time (the eight of labkit, and whatever a user registers): LineSegments on valid
#: beams, no beam on two lines, the same lines twice, the same lines with ``trace=True`` (and a
#: list of labkit.Step records beside them), nothing from an empty scan, a clear error for a non-scan.
ALL = tuple(LINE_EXTRACTORS)


def _contract_scans():
    scans = [next(iter(simulate(world, seed, n_scans=1)))[0] for world, seed in (("corridor", 1), ("hall", 2))]
    rng = np.random.default_rng(5)
    values = rng.choice([0.5, 2.0, 2.01, 2.02, 7.0, np.nan, np.inf, 0.0], size=181)
    scans.append(Scan(ranges=values, angles=np.radians(np.arange(-90.0, 90.5, 1.0)), range_max=30.0))
    return scans


@pytest.mark.parametrize("name", ALL)
def test_every_registered_extractor_keeps_the_common_contract(name):
    from labkit import LineSegment, Step

    extract = LINE_EXTRACTORS[name].fn
    for scan in _contract_scans():
        lines = extract(scan)
        assert isinstance(lines, list) and all(isinstance(ln, LineSegment) for ln in lines), name
        used = np.concatenate([ln.indices for ln in lines]) if lines else np.zeros(0, int)
        assert len(np.unique(used)) == len(used), f"{name}: a beam on two lines"
        assert np.all(scan.valid[used]), f"{name}: a line on an invalid beam"
        for line in lines:
            assert line.r >= 0 and -math.pi < line.alpha <= math.pi
        assert key(extract(scan.replace())) == key(lines), f"{name}: not deterministic"
        traced, steps = extract(scan, trace=True)
        assert key(traced) == key(lines), f"{name}: trace=True changed the lines"
        assert isinstance(steps, list) and all(isinstance(s, Step) for s in steps)
    assert extract(Scan(ranges=[], angles=[])) == []
    assert extract(Scan(ranges=[np.nan] * 50, angles=np.arange(50) * 0.01)) == []
    with pytest.raises(ValueError, match="scan"):
        extract(np.ones(10))


# ---------------------------------------------------------------------------- global extractors' segments
GLOBAL = ("ransac", "hough")  # an infinite line's inliers, cut into the segments the beams saw


@pytest.mark.parametrize("name", GLOBAL)
def test_the_line_survives_clutter_in_front_of_the_wall(name):
    """Every third beam of the middle third sees clutter 0.5-2.5 m away in front of the wall at
    3 m: the consensus (RANSAC) or the accumulator (Hough: the clutter's votes scatter, the
    wall's pile up in one cell) ignores it, and the wall's line is exact (its points are
    noiseless). No segment claims the wall behind the clutter (no beam saw it there): the wall is
    the two stretches either side, and the pieces of two beams between clutter are too short to
    be segments."""
    scan = wall_scan(3.0, 0.2, fov=(-0.6, 1.0))
    ranges = scan.ranges.copy()
    n = scan.n_beams
    clutter = np.arange(n // 3, 2 * n // 3, 3)
    ranges[clutter] = np.random.default_rng(5).uniform(0.5, 2.5, clutter.size)
    lines = [ln for ln in LINE_EXTRACTORS[name].fn(scan.replace(ranges=ranges)) if ln.n_points > 10]
    assert len(lines) == 2
    for wall in lines:
        assert wall.r == pytest.approx(3.0, abs=1e-9) and wall.alpha == pytest.approx(0.2, abs=1e-9)
        assert not np.any((clutter >= wall.first) & (clutter <= wall.last))
    assert sum(wall.n_points for wall in lines) >= n - (2 * n // 3 - n // 3)


@pytest.mark.parametrize("name", GLOBAL)
@pytest.mark.parametrize("post_x", [2.0, 2.6])
def test_no_segment_claims_the_wall_behind_a_post(name, post_x):
    # a wall at x = 3 m and a post 5 cm in radius in front of it: the post's shadow on the
    # wall is 8-15 cm wide, narrower than max_gap_m, so the inliers either side of it are close
    # neighbours; but the beams between them end at the post, in front of the wall. A segment
    # across the shadow would claim a stretch no beam saw (ray-axis errors of 0.4-1 m on those
    # beams); the wall is cut into the two parts the beams saw.
    from labkit.evaluation import ray_errors

    theta = np.radians(np.arange(-40.0, 40.25, 0.25))
    ranges = 3.0 / np.cos(theta)
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    along = u @ np.array([post_x, 0.0])  # the ray's closest approach to the post's centre
    miss = np.sqrt(np.maximum(post_x ** 2 - along ** 2, 0.0))
    on_post = miss < 0.05
    ranges[on_post] = along[on_post] - np.sqrt(0.05 ** 2 - miss[on_post] ** 2)
    scan = Scan(ranges=ranges + np.random.default_rng(1).normal(0.0, 0.003, theta.size), angles=theta)
    lines = [ln for ln in LINE_EXTRACTORS[name].fn(scan) if abs(ln.r - 3.0) < 0.05]
    shadow = np.flatnonzero(on_post)
    assert len(lines) == 2
    assert not any(ln.first < shadow[0] and ln.last > shadow[-1] for ln in lines)
    errors = ray_errors(scan, lines)
    assert np.abs(errors.errors).max() < 0.05 and errors.coverage > 0.9
