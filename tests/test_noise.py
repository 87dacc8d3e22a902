"""labkit.noise against independent truth: the simulator's known range noise, closed-form walls,
bad inputs, and the real recordings in ../shared/datasets (skipped when absent).

Where the bounds come from (measured with the seeds below, numpy 2, 361-722 beams):

* On a straight wall with Gaussian noise the residuals are exactly N(0, sigma^2) but neighbours are
  correlated (each range error enters three residuals: lag-1 correlation -2/3, lag-2 +1/6 for equal
  steps and ranges). The variance of their mean square is then 2 (1 + 2 (4/9 + 1/36)) / n = 3.9 / n,
  so one scan's estimate has a relative spread of about sqrt(3.9 / n) / 2 = 1 / sqrt(n): 5.3 % for
  361 beams, 3.7 % for 722. Measured on 2000 synthetic 361-beam walls: mean 0.997-1.000 of the
  truth, spread 5.0-5.3 %, at 2 mm, 1 cm and 5 cm.
* In the simulated worlds (1440 scans) the mean over 20 scans is 0.96-1.04 of the truth except in
  the hall (see ``HALL_ROUND_OBJECT_BIAS``). One scan's deviation in units of 1 / sqrt(n), n its
  number of residuals, has mean +0.28 (corners and jump edges: about +1.5 %), spread 1.06 and
  extremes -2.5 / +4.1 outside the hall. Bounds: 10 % for the mean of 20 scans (the module's claim;
  SE about 1.2 %); for one scan 5.5 / sqrt(n): 29 % for the LMS200's 361 beams, 24 % for the
  LMS111's 541, 37-43 % for the XV-11, whose 6 m range and 2 % dropouts leave 160-230 residuals
  (a flat 25 % would be 3.4 of its standard deviations, and is exceeded: 1.27 and 1.40 measured).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import zlib

import numpy as np
import pytest

from labkit import Scan, read_scans
from labkit.app.experiments import world_scans
from labkit.noise import MIN_RESIDUALS, estimate_range_noise, range_noise_residuals
from labkit.sim import LIDARS, Column, World, make_world, random_polygons, scan_at, scenario, simulate

SIGMAS_M = (0.002, 0.005, 0.01, 0.02, 0.03, 0.05)
WORLD_NAMES = ("hall", "corridor", "office", "random_polygons")
N_SCANS = 20
MEAN_TOL = 0.10  # the mean of N_SCANS estimates, relative to the true sigma
SCAN_TOL_SD = 5.5  # one scan's estimate, in units of 1 / sqrt(its number of residuals)

# The hall (LMS presets seen from near its bottom wall) holds four columns, a rolling cylinder, a
# walking student's legs and a rounded corner: a fifth of the residuals of a scan fall on curved
# surfaces. Noise-free, a column of radius 0.25 m at 4.6 m gives |z| of 3-5 mm per beam at 0.5 deg
# steps (the curvature between three beams), 5-16 mm at 1 deg: inliers of the 3.5-sigma cut when
# sigma is of the same size, which inflate the estimate. Measured mean / true over 20 scans:
# lms200 2 mm 1.22 (one scan up to 1.46), 5 mm 1.10, 1 cm 1.07; lms111 2 mm 1.12, 5 mm 1.10; xv11
# 5 mm 1.08 (one scan 1.40), 1 cm 1.06 (its 1 deg steps make the columns outliers at 2 mm: 1.01).
# The cases over 10 % are expected failures below: strict at 2 mm, not strict at 5 mm, where the
# mean sits on the bound (1.09-1.10 by seed). With the round objects' beams masked by the simulator's
# truth the same scans give 0.98-1.01 (test_hall_bias_comes_from_its_round_objects). The module
# docstring's "within 10 % ... in every simulated world and sensor preset" does not hold there.
HALL_ROUND_OBJECT_BIAS = {  # (preset, sigma): strict
    ("lms200", 0.002): True, ("lms111", 0.002): True, ("lms200", 0.005): False, ("lms111", 0.005): False,
}


def _seed(*key) -> int:
    """A seed per test case, the same in every run (``hash`` of a str is salted per process)."""
    return zlib.crc32(repr(key).encode())


def _rng(*key) -> np.random.Generator:
    return np.random.default_rng(_seed(*key))


def _wall_scan(theta, *, d=2.5, alpha=0.7, sigma=0.0, rng=None, **kw) -> Scan:
    """A straight wall ``x cos(alpha) + y sin(alpha) = d`` seen at the beam angles ``theta``
    (float64, exact), plus Gaussian range noise."""
    theta = np.asarray(theta, dtype=np.float64)
    r = d / np.cos(theta - alpha)
    if sigma:
        r = r + rng.normal(0.0, sigma, theta.size)
    return Scan(ranges=r, angles=theta, **kw)


def _room_scan(theta, corners) -> Scan:
    """A noise-free scan (float64, exact) from the origin inside a convex polygon ``corners``
    (counter-clockwise): each beam's range is the nearest edge line in front of it."""
    c = np.asarray(corners, dtype=np.float64)
    a, b = c, np.roll(c, -1, axis=0)
    normal = np.stack([b[:, 1] - a[:, 1], a[:, 0] - b[:, 0]], axis=1)  # outward for a ccw polygon
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    d = np.sum(normal * a, axis=1)  # > 0: the origin is inside
    alpha = np.arctan2(normal[:, 1], normal[:, 0])
    cos = np.cos(np.asarray(theta)[:, None] - alpha[None, :])
    with np.errstate(divide="ignore"):
        r = np.where(cos > 1e-12, d[None, :] / cos, np.inf).min(axis=1)
    return Scan(ranges=r, angles=theta)


# ============================================================== known sigma in the simulator
def _sweep_params():
    for world_name, preset, sigma in itertools.product(WORLD_NAMES, sorted(LIDARS), SIGMAS_M):
        marks = []
        if world_name == "hall" and (preset, sigma) in HALL_ROUND_OBJECT_BIAS:
            marks.append(pytest.mark.xfail(strict=HALL_ROUND_OBJECT_BIAS[preset, sigma],
                                           reason="round objects bias the estimate up at low noise "
                                           "(see HALL_ROUND_OBJECT_BIAS)"))
        yield pytest.param(world_name, preset, sigma, marks=marks, id=f"{world_name}-{preset}-{sigma * 1000:g}mm")


@pytest.mark.parametrize(("world_name", "preset", "sigma"), list(_sweep_params()))
def test_estimate_recovers_the_simulated_noise(world_name, preset, sigma):
    lidar = dataclasses.replace(LIDARS[preset], noise_std_m=sigma)
    scans = [s for s, _ in world_scans(world_name, lidar, N_SCANS, _rng(world_name, preset, sigma))]
    ratio = np.array([estimate_range_noise(s) for s in scans]) / sigma
    n_residuals = np.array([len(range_noise_residuals(s)) for s in scans])
    assert np.all(np.isfinite(ratio))
    assert abs(ratio.mean() - 1.0) <= MEAN_TOL, f"mean estimate / true = {ratio.mean():.3f}"
    deviation = np.abs(ratio - 1.0) * np.sqrt(n_residuals)
    assert deviation.max() <= SCAN_TOL_SD, (f"single scans {ratio.min():.3f} .. {ratio.max():.3f}, "
                                            f"{deviation.max():.1f} / sqrt(n) from the truth")


@pytest.mark.parametrize("preset", sorted(LIDARS))
@pytest.mark.parametrize("sigma", [0.002, 0.005, 0.01])
def test_hall_bias_comes_from_its_round_objects(preset, sigma):
    """The same hall scans as above with the beams on columns, bench feet, the rolling cylinder,
    the legs and the rounded corner made invalid (from the simulator's truth): unbiased again.
    Measured mean / true 0.98-1.01."""
    world = make_world("hall")
    lidar = dataclasses.replace(LIDARS[preset], noise_std_m=sigma)
    ratios = []
    for scan, truth in world_scans("hall", lidar, N_SCANS, _rng("hall", preset, sigma)):
        walls_only = np.where(truth.hits < len(world.walls), scan.ranges, np.nan)
        ratios.append(estimate_range_noise(scan.replace(ranges=walls_only)) / sigma)
    assert abs(np.mean(ratios) - 1.0) <= 0.05, f"mean estimate / true = {np.mean(ratios):.3f}"


@pytest.mark.parametrize("sigma", [0.002, 0.005])
def test_quantised_ranges_add_q_over_sqrt12(sigma):
    """Ranges rounded to whole centimetres, as in the Radish CARMEN logs: the estimate is the
    noise and the rounding together, sqrt(sigma^2 + q^2 / 12) (1 cm alone: 2.9 mm).
    Measured over 20 random rooms (LMS200 preset, 361 beams): 1.00 of that at 2 and 5 mm."""
    q = 0.01
    lidar = dataclasses.replace(LIDARS["lms200"], noise_std_m=sigma)
    est = [estimate_range_noise(s.replace(ranges=np.round(s.ranges / q) * q))
           for s, _ in world_scans("random_polygons", lidar, N_SCANS, _rng("quantised", sigma))]
    assert np.mean(est) == pytest.approx(math.hypot(sigma, q / math.sqrt(12)), rel=0.05)


@pytest.mark.xfail(strict=True, reason="quantisation alone, fine steps: rounding errors of slowly varying "
                   "ranges are correlated, most residuals are ~0 and the robust estimate collapses")
def test_quantisation_alone_at_fine_steps_gives_q_over_sqrt12():
    """Noise-free ranges rounded to 1 cm seen by 722 beams over 180 deg (0.25 deg): runs of equal
    readings make more than half the residuals ~0, so the median -- and the estimate -- fall far
    below 1 cm / sqrt(12) = 2.9 mm. Measured over 20 random rooms: mean 1.8 mm, one scan 0.06 mm.
    (At 0.5 deg steps, or with >= 2 mm of noise on top, it is 2.9 mm, as the test above shows.)"""
    q = 0.01
    lidar = dataclasses.replace(LIDARS["lms200"], angle_increment=math.pi / 721, n_beams=722, noise_std_m=0.0)
    est = [estimate_range_noise(s.replace(ranges=np.round(s.ranges / q) * q))
           for s, _ in world_scans("random_polygons", lidar, N_SCANS, np.random.default_rng(0))]
    assert min(est) >= 0.5 * q / math.sqrt(12)


# ============================================================== closed form
@pytest.mark.parametrize("incidence_deg", [0.0, 30.0, 60.0, 80.0, -80.0])
def test_residuals_vanish_on_a_noise_free_wall_at_any_incidence(incidence_deg):
    alpha = 0.7
    theta = alpha + np.radians(incidence_deg + np.arange(-4.0, 4.01, 0.25))
    z = range_noise_residuals(_wall_scan(theta, alpha=alpha))
    assert len(z) == theta.size - 2
    assert np.abs(z).max() < 1e-9


@pytest.mark.parametrize("incidence_deg", [0.0, 45.0, 70.0, 80.0])
def test_residuals_have_unit_spread_at_any_incidence(incidence_deg):
    """The normalisation k_i (neighbours at other ranges weigh differently) keeps the residuals at
    sigma also where ranges change fast along the wall: 50 scans of 81 beams at 1 cm pooled,
    relative spread about 1 / sqrt(4000) = 1.6 %."""
    rng = np.random.default_rng(_seed("incidence", incidence_deg))
    theta = np.radians(incidence_deg + np.arange(-4.0, 4.01, 0.1))
    scans = [_wall_scan(theta, alpha=0.0, sigma=0.01, rng=rng) for _ in range(50)]
    assert estimate_range_noise(scans) == pytest.approx(0.01, rel=0.06)


def test_noise_free_polygon_room_gives_zero():
    """Exact (float64) ranges in a convex room: every residual off the corners is 0 to rounding,
    and the corners are outliers."""
    theta = np.radians(np.arange(-180.0, 180.0, 0.5))
    scan = _room_scan(theta, [(4.0, -3.0), (5.0, 2.0), (-1.0, 4.0), (-6.0, 1.0), (-3.0, -5.0)])
    assert scan.is_full_circle and scan.valid.all()
    assert estimate_range_noise(scan) < 1e-9


def test_noise_free_simulated_rooms_give_zero():
    """The simulator stores ranges as float32 (as a LaserScan does): rounding of 0.5 um at 8 m is
    all that is left. Measured: 1.3e-7 m."""
    for k in range(3):
        scan, _ = scan_at(random_polygons(k), LIDARS["lms200"], (6.0, 4.5, k), 0.0)
        assert estimate_range_noise(scan) < 1e-6


ROOM = World("room", tuple(random_polygons(0, n_obstacles=0).walls))
ROUND_OBJECTS = (Column((3.0, 6.5), 0.25), Column((9.0, 2.5), 0.2), Column((8.5, 6.8), 0.15),
                 Column((2.5, 2.0), 0.06, "leg"), Column((2.8, 2.1), 0.06, "leg"),
                 Column((10.0, 4.5), 0.06, "leg"), Column((10.1, 4.2), 0.06, "leg"))


@pytest.mark.parametrize("preset", sorted(LIDARS))
@pytest.mark.parametrize("sigma", [0.002, 0.01, 0.05])
def test_corners_jump_edges_and_round_objects_barely_move_the_estimate(preset, sigma):
    """The same noise (seed per pose) in the empty 12 x 9 m room, in it with three columns and two
    pairs of legs, and in random-polygon rooms (six obstacles: corners, jump edges), over 20
    headings from the centre. Measured mean ratio to the empty room: round objects 1.05 at 2 mm
    for the LMS presets (one scan up to 1.09), <= 1.01 from 1 cm; XV-11 (1 deg steps, 6 m range,
    so fewer wall beams) 1.08 at 2 mm, 1.04 at 1 cm (one scan up to 1.16); polygons 1.00-1.01 for
    the LMS presets, XV-11 up to 1.04 (one scan 1.19). Bounds: 10 % and 6 % on the mean."""
    lidar = dataclasses.replace(LIDARS[preset], noise_std_m=sigma, dropout_prob=0.0)
    with_round = World("room+round", ROOM.walls, circles=ROUND_OBJECTS)
    empty, rounds, polygons = [], [], []
    for k, heading in enumerate(np.linspace(-np.pi, np.pi, N_SCANS, endpoint=False)):
        pose, seed = (6.0, 4.5, float(heading)), _seed("features", preset, sigma, k)
        for out, world in ((empty, ROOM), (rounds, with_round), (polygons, random_polygons(k))):
            out.append(estimate_range_noise(scan_at(world, lidar, pose, rng=np.random.default_rng(seed))[0]))
    empty = np.array(empty)
    assert abs(empty.mean() / sigma - 1.0) <= MEAN_TOL
    assert np.mean(np.array(rounds) / empty) <= 1.10
    assert np.mean(np.array(polygons) / empty) <= 1.06


# ============================================================== inputs
def test_all_invalid_scan_gives_nan():
    theta = np.radians(np.arange(-90.0, 90.5, 0.5))
    for bad in (np.nan, np.inf, 0.0, -1.0, 30.0):
        scan = Scan(ranges=np.full(theta.size, bad), angles=theta, range_max=30.0)
        assert len(range_noise_residuals(scan)) == 0
        assert math.isnan(estimate_range_noise(scan))
    assert math.isnan(estimate_range_noise(Scan(ranges=[], angles=[])))
    assert math.isnan(estimate_range_noise([]))


def test_fewer_than_min_residuals_gives_nan():
    rng = np.random.default_rng(1)
    theta = np.radians(np.arange(MIN_RESIDUALS + 2) * 0.5)
    enough = _wall_scan(theta, sigma=0.01, rng=rng)
    assert len(range_noise_residuals(enough)) == MIN_RESIDUALS
    assert math.isfinite(estimate_range_noise(enough))
    short = _wall_scan(theta[:-1], sigma=0.01, rng=rng)
    assert len(range_noise_residuals(short)) == MIN_RESIDUALS - 1
    assert math.isnan(estimate_range_noise(short))
    # many valid beams, but every third one invalid: no beam has two valid neighbours
    theta = np.radians(np.arange(-90.0, 90.5, 0.5))
    r = 2.0 / np.cos(theta - 0.3)
    r[::3] = np.nan
    assert math.isnan(estimate_range_noise(Scan(ranges=r, angles=theta)))


def test_invalid_ranges_are_skipped_not_bridged():
    """NaN, inf, 0, negative, below range_min and at range_max: each removes exactly the residuals
    of the triples it is part of; every other residual is unchanged."""
    rng = np.random.default_rng(2)
    theta = np.radians(np.arange(-60.0, 60.5, 0.5))
    clean = _wall_scan(theta, alpha=0.2, sigma=0.01, rng=rng, range_min=0.1, range_max=20.0)
    holes = {10: np.nan, 40: np.inf, 41: -np.inf, 80: 0.0, 120: -2.0, 150: 0.05, 200: 20.0}
    r = clean.ranges.copy()
    for i, v in holes.items():
        r[i] = v
    holed = clean.replace(ranges=r)
    keep = np.ones(theta.size - 2, dtype=bool)  # residual j belongs to beam j + 1
    for i in holes:
        keep[max(i - 2, 0):i + 1] = False
    np.testing.assert_array_equal(range_noise_residuals(holed), range_noise_residuals(clean)[keep])
    assert estimate_range_noise(holed) == pytest.approx(estimate_range_noise(clean), rel=0.05)


def test_full_circle_scan_uses_the_wrap_neighbour():
    """360 beams round a convex room: every beam has two neighbours, the first and last beams
    (on the wall behind the sensor, at -180 and +179 deg) each other's; noise-free, their
    residuals are 0."""
    theta = np.radians(np.arange(-180.0, 180.0, 1.0))
    scan = _room_scan(theta, [(3.0, -3.0), (3.0, 3.0), (-2.0, 3.0), (-2.0, -3.0)])
    assert scan.is_full_circle
    z = range_noise_residuals(scan)
    assert len(z) == scan.n_beams
    assert abs(z[0]) < 1e-9 and abs(z[-1]) < 1e-9
    # a 270 deg scan does not wrap
    part = Scan(ranges=scan.ranges[45:316], angles=theta[45:316])
    assert not part.is_full_circle and len(range_noise_residuals(part)) == part.n_beams - 2
    # one invalid beam at the seam removes the three residuals it is part of, wrap included
    r = scan.ranges.copy()
    r[0] = np.nan
    assert len(range_noise_residuals(scan.replace(ranges=r))) == scan.n_beams - 3


def test_simulated_full_circle_scans_wrap():
    lidar = dataclasses.replace(LIDARS["xv11"], dropout_prob=0.0, range_max=30.0)
    scan, _ = scan_at(ROOM, lidar, (6.0, 4.5, 0.3), rng=np.random.default_rng(3))
    assert scan.is_full_circle and scan.valid.all()
    assert len(range_noise_residuals(scan)) == scan.n_beams


def test_non_uniform_angle_steps():
    rng = np.random.default_rng(4)
    steps = np.radians(rng.uniform(0.1, 1.0, 200))  # 0.1-1 deg, about 110 deg in all
    theta = np.radians(-60.0) + np.concatenate([[0.0], np.cumsum(steps)])
    assert theta[-1] < np.radians(70.0)
    assert np.abs(range_noise_residuals(_wall_scan(theta, alpha=0.1))).max() < 1e-9
    # with noise: the weights of unequal steps keep the residuals at sigma (50 scans pooled)
    scans = [_wall_scan(theta, alpha=0.1, sigma=0.01, rng=rng) for _ in range(50)]
    assert estimate_range_noise(scans) == pytest.approx(0.01, rel=0.05)


def _office_at_1cm(seed: int, n: int):
    sc = scenario("office")
    sc = dataclasses.replace(sc, lidar=dataclasses.replace(sc.lidar, noise_std_m=0.01))
    return (scan for scan, _ in simulate(sc, seed, n_scans=n))


def test_an_iterable_of_scans_pools_residuals():
    """Six recordings of 50 office scans (XV-11, 1 cm): the pooled estimate of 50 scans varies
    about 1 / sqrt(50) as much as one scan's. Measured: single-scan spread ~5 %, pooled < 1 %."""
    singles, pooled = [], []
    for seed in range(6):
        scans = list(_office_at_1cm(seed, 50))
        singles += [estimate_range_noise(s) for s in scans]
        pooled.append(estimate_range_noise(scans))
    assert np.std(pooled) < 0.4 * np.std(singles)
    assert np.mean(pooled) == pytest.approx(0.01, rel=0.05)
    # pooling is not averaging the per-scan estimates, but close to it
    assert np.mean(pooled) == pytest.approx(np.mean(singles), rel=0.03)


def test_a_generator_and_a_tuple_work_like_a_list():
    scans = list(_office_at_1cm(7, 10))
    expected = estimate_range_noise(scans)
    assert estimate_range_noise(_office_at_1cm(7, 10)) == expected
    assert estimate_range_noise(tuple(scans)) == expected
    assert estimate_range_noise(iter(scans)) == expected
    assert estimate_range_noise([scans[0]]) == estimate_range_noise(scans[0])


@pytest.mark.parametrize("bad", ["scan.json", b"bytes", 3.5, None, np.arange(5.0), [1.0, 2.0], {"ranges": [1.0]}])
def test_not_a_scan_raises_value_error(bad):
    with pytest.raises(ValueError, match=r"labkit\.Scan"):
        estimate_range_noise(bad)


def test_a_non_scan_among_scans_raises_value_error():
    scan = _wall_scan(np.radians(np.arange(0.0, 20.0, 0.5)))
    with pytest.raises(ValueError, match=r"must be a labkit\.Scan, got str"):
        estimate_range_noise([scan, "scan.json"])
    with pytest.raises(ValueError, match=r"must be a labkit\.Scan, got ndarray"):
        range_noise_residuals(np.ones(10))


# ============================================================== real recordings
CARMEN_LOGS = ("aces", "csail", "freiburg-079", "infinite-corridor", "intel", "orebro")
REAL_MIN_M, REAL_MAX_M = 0.001, 0.10


def _real(path):
    if not path.exists():
        pytest.skip(f"{path} not found")
    return read_scans(path)


@pytest.mark.shared
@pytest.mark.parametrize("log", CARMEN_LOGS)
def test_radish_logs_give_a_plausible_noise(shared_datasets, log):
    """First 50 scans of each log, pooled. Measured (m): aces 0.028, csail 0.021, freiburg-079
    0.0072, infinite-corridor 0.030, intel 0.0061, orebro 0.0055; 1 deg logs of large, cluttered
    buildings read more than the sensor's noise (see benchmarks/noise.py)."""
    stream = _real(shared_datasets / "carmen" / f"{log}-corrected.log.gz")
    sigma = estimate_range_noise(itertools.islice(stream, 50))
    assert REAL_MIN_M < sigma < REAL_MAX_M


@pytest.mark.shared
@pytest.mark.parametrize("k", range(1, 7))
def test_json_single_scans_give_a_plausible_noise(shared_datasets, k):
    """Measured: 1.1-2.8 cm (541 beams, 0.5 deg, cluttered indoor scans)."""
    (scan,) = _real(shared_datasets / "single_scans" / f"laser_scan_{k}.json")
    assert REAL_MIN_M < estimate_range_noise(scan) < REAL_MAX_M


@pytest.mark.shared
def test_ros1_bag_gives_a_plausible_noise(shared_datasets):
    """Measured: 1.0 cm pooled over the first 50 scans (90 beams at 3 deg, recorded from a simulator)."""
    stream = _real(shared_datasets / "bags" / "Mapping1.bag")
    assert REAL_MIN_M < estimate_range_noise(itertools.islice(stream, 50)) < REAL_MAX_M
