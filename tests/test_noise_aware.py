"""Thresholds that follow the range noise ("auto") and the placing of lines (issue 16).

Truth here is independent of the code under test: Monte Carlo for the placing probability,
the simulator's known noise for the thresholds, closed-form geometry for the lines.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from labkit import Config, Scan, extract_features, split_and_merge
from labkit.fitting import placement_probability
from labkit.lines.split_merge import SplitMergeParams
from labkit.noise import (
    AUTO_CONFIG,
    AUTO_LINES,
    FIXED_CONFIG,
    FIXED_HOUGH,
    FIXED_INCREMENTAL,
    FIXED_LINES,
    FIXED_RANSAC,
    MIN_SPLIT_M,
    auto_split_threshold,
    noise_config,
    scan_sigma,
)
from labkit.segmentation import SegmentationParams, segment_labels


def _wall_scan(sigma: float, seed: int = 0, d: float = 3.0, half_deg: float = 60.0, step_deg: float = 0.25) -> Scan:
    theta = np.radians(np.arange(-half_deg, half_deg + step_deg / 2, step_deg))
    rng = np.random.default_rng(seed)
    return Scan(ranges=d / np.cos(theta) + rng.normal(0.0, sigma, theta.size), angles=theta)


# ----------------------------------------------------------------------------- placement_probability
@pytest.mark.parametrize("seed", range(8))
def test_placement_probability_matches_monte_carlo(seed):
    rng = np.random.default_rng(seed)
    sr, sa = 10 ** rng.uniform(-2.7, -1.3), math.radians(10 ** rng.uniform(-0.7, 0.6))
    rho = rng.uniform(-0.95, 0.95)
    cov = np.array([[sr * sr, rho * sr * sa], [rho * sr * sa, sa * sa]])
    z = rng.multivariate_normal([0.0, 0.0], cov, 200_000)
    mc = np.mean((np.abs(z[:, 0]) <= 0.05) & (np.abs(z[:, 1]) <= math.radians(3.0)))
    # binomial standard error of 200k samples is <= 0.0012
    assert placement_probability(cov, 0.05, math.radians(3.0)) == pytest.approx(mc, abs=0.005)


@pytest.mark.parametrize("seed", range(8))
def test_placement_probability_of_strongly_correlated_lines_matches_monte_carlo(seed):
    # a short wall far away: its r and alpha correlate to 0.99-0.9999 (a turn about the wall's
    # centroid moves r by the distance to it). The probability that r is within 5 cm given alpha
    # then falls from 1 to 0 at a step narrower than the integral's nodes were apart: it said
    # 0.72 for a line Monte Carlo places with 0.85, and such lines were dropped at 0.8.
    rng = np.random.default_rng(100 + seed)
    sr, sa = 10 ** rng.uniform(-1.8, -1.3), math.radians(10 ** rng.uniform(-0.3, 0.5))
    rho = rng.choice([-1.0, 1.0]) * (1.0 - 10 ** rng.uniform(-4.0, -2.0))
    cov = np.array([[sr * sr, rho * sr * sa], [rho * sr * sa, sa * sa]])
    z = rng.multivariate_normal([0.0, 0.0], cov, 400_000)
    mc = np.mean((np.abs(z[:, 0]) <= 0.05) & (np.abs(z[:, 1]) <= math.radians(3.0)))
    assert placement_probability(cov, 0.05, math.radians(3.0)) == pytest.approx(mc, abs=0.004)


def test_placement_probability_closed_form_and_edge_cases():
    # uncorrelated: the product of two one-dimensional probabilities, (2 Phi(k) - 1)
    cov = np.diag([0.02 ** 2, math.radians(1.5) ** 2])
    assert placement_probability(cov, 0.02, math.radians(3.0)) == pytest.approx(0.682689 * 0.954500, abs=1e-5)
    many = placement_probability(np.stack([cov, cov * 4, np.full((2, 2), np.nan)]), 0.05, math.radians(3.0))
    assert many.shape == (3,) and many[0] > many[1] > 0 and many[2] == 0.0
    assert placement_probability(np.diag([1e-12, 1e-12]), 0.05, 0.05) == pytest.approx(1.0, abs=1e-6)
    with pytest.raises(ValueError, match="max_dr_m"):
        placement_probability(cov, 0.0, 0.05)


# ----------------------------------------------------------------------------- "auto" in the records
def test_auto_is_accepted_and_a_number_still_wins():
    # the default since issue 16, for every record the pipeline holds; the papers' fixed setting
    # is one update away and changes every noise-dependent key
    assert SplitMergeParams() == SplitMergeParams(**AUTO_LINES) and SplitMergeParams().split_threshold_m == "auto"
    assert Config() == Config().updated(AUTO_CONFIG) and SegmentationParams().range_sigma_m == "auto"
    fixed = Config().updated(FIXED_CONFIG)
    assert set(FIXED_CONFIG) == set(AUTO_CONFIG) and fixed.lines.split_threshold_m == 0.05
    def at(cfg, key):
        return functools.reduce(getattr, key.split("."), cfg)

    assert all(at(fixed, k) != at(Config(), k) for k in FIXED_CONFIG), "a fixed key left at its auto default"
    assert noise_config("fixed") == FIXED_CONFIG and noise_config() == AUTO_CONFIG
    assert SegmentationParams(range_sigma_m="auto").range_sigma_m == "auto"
    assert SplitMergeParams(split_threshold_m=0.07).split_threshold_m == 0.07
    for bad in ("Auto", "", None, True):
        with pytest.raises(ValueError, match='split_threshold_m must be a number or "auto"'):
            SplitMergeParams(split_threshold_m=bad)
    with pytest.raises(ValueError, match="> 0"):
        SplitMergeParams(split_threshold_m=-0.1)
    with pytest.raises(ValueError, match="place_confidence"):
        SplitMergeParams(place_confidence=1.5)


def test_the_fixed_config_round_trips_through_toml():
    # RANSAC's, Hough's and incremental's fixed range_sigma_m is None (each line's own residuals)
    # under a default of "auto": TOML has no null, so the file says "none" (a left-out key would
    # read back as "auto")
    fixed = Config().updated(FIXED_CONFIG)
    assert fixed.lines.ransac.range_sigma_m is None and Config().lines.ransac.range_sigma_m == "auto"
    assert Config.from_toml(fixed.to_toml()) == fixed
    assert Config.from_toml(Config().to_toml()) == Config()
    with pytest.raises(ValueError, match="split_threshold_m"):  # a field that cannot be None
        Config().updated({"lines.split_threshold_m": "none"})
    # reading the word must not hide the clear error for a value that is no number at all
    for key in ("lines.merge_dr_m", "lines.ransac.range_sigma_m"):
        with pytest.raises(ValueError, match=f"{key.rsplit('.', 1)[1]} must be a number"):
            Config().updated({key: np.array([0.1, 0.2])})


def test_config_round_trips_auto_through_toml():
    cfg = Config().updated({"lines": {**AUTO_LINES, "split_threshold_m": 0.04}, "segmentation.range_sigma_m": "auto"})
    back = Config.from_toml(cfg.to_toml())
    assert back.lines.split_threshold_m == 0.04 and back.lines.range_sigma_m == "auto"
    assert back.segmentation.range_sigma_m == "auto" and back.lines.place_confidence == 0.8


@pytest.mark.parametrize("sigma", [0.003, 0.01, 0.03])
def test_auto_split_threshold_follows_the_noise(sigma):
    scan = _wall_scan(sigma)
    est = scan_sigma(scan)
    assert est == pytest.approx(sigma, rel=0.15)
    lines, steps = split_and_merge(scan, trace=True, split_threshold_m="auto", range_sigma_m="auto")
    used = {s.threshold for s in steps if s.kind in ("fit", "accept", "split")}
    # five of the true sigmas (the estimate is within 15 % of it), at least 2 cm
    assert len(used) == 1 and used.pop() == pytest.approx(max(5 * sigma, MIN_SPLIT_M), rel=0.15)
    # one straight wall: one line, whatever the noise (a fixed 2 cm threshold shatters it at 3 cm)
    assert len(lines) == 1 and abs(lines[0].r - 3.0) < 0.01
    if sigma == 0.03:
        assert len(split_and_merge(scan, split_threshold_m=0.02, place_confidence=0)) > 1


def test_a_noise_free_scan_uses_the_floors():
    scan = _wall_scan(0.0)
    assert scan_sigma(scan) == 0.002 and auto_split_threshold(scan_sigma(scan)) == MIN_SPLIT_M
    tiny = Scan(ranges=[1.0, 1.0, 1.0], angles=[0.0, 0.01, 0.02])
    assert scan_sigma(tiny) == 0.01  # too few beams to estimate: the fallback


def test_auto_segmentation_links_a_noisy_grazing_wall_that_a_small_fixed_sigma_breaks():
    # a wall 1 m ahead seen with 5 cm of noise: neighbours' gaps (7 cm standard deviation) pass
    # the breakpoint of a 5 mm sensor (the 8 cm floor) but not that of the estimated noise
    theta = np.radians(np.arange(-40.0, 40.25, 0.5))
    rng = np.random.default_rng(1)
    scan = Scan(ranges=1.0 / np.cos(theta) + rng.normal(0, 0.05, theta.size), angles=theta)
    auto = segment_labels(scan, range_sigma_m="auto")
    small = segment_labels(scan, range_sigma_m=0.005)
    n_auto, n_small = len(set(auto.tolist()) - {-1}), len(set(small.tolist()) - {-1})
    assert n_auto <= 2 and n_small >= 5


# ----------------------------------------------------------------------------- the "auto" split test
def _polyline_scan(corners, sigma, seed, step_deg=0.25):
    """A scan from the origin of the polyline through ``corners`` (each beam meets one piece),
    with Gaussian range noise ``sigma``; also each beam's piece."""
    corners = np.asarray(corners, float)
    a0, a1 = (math.degrees(math.atan2(c[1], c[0])) for c in (corners[0], corners[-1]))
    theta = np.radians(np.arange(min(a0, a1) + 0.5, max(a0, a1) - 0.5, step_deg))
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    ranges, piece = np.full(theta.size, np.inf), np.full(theta.size, -1)
    for k, (p, q) in enumerate(zip(corners[:-1], corners[1:], strict=True)):
        d = q - p
        den = u[:, 0] * d[1] - u[:, 1] * d[0]
        s = (p[0] * d[1] - p[1] * d[0]) / den  # range along the ray
        t = (p[0] * u[:, 1] - p[1] * u[:, 0]) / den  # where on the piece
        hit = (s > 0) & (t >= 0) & (t <= 1) & (s < ranges)
        ranges[hit], piece[hit] = s[hit], k
    rng = np.random.default_rng(seed)
    return Scan(ranges=ranges + rng.normal(0.0, sigma, theta.size), angles=theta), piece


def _finds(lines, r, alpha_deg, dr=0.02, dalpha_deg=2.0):
    return any(abs(ln.r - r) < dr and abs(math.degrees(math.remainder(ln.alpha - math.radians(alpha_deg),
                                                                      2 * math.pi))) < dalpha_deg for ln in lines)


def test_auto_splits_a_step_in_a_wall_seen_at_a_grazing_angle():
    # a corridor wall 1 m to the side with an 8 cm step towards the sensor at x = 4 m, 2 cm of
    # range noise: 5 sigma is 10 cm, but across a wall seen at 7-20 deg that noise is 3-7 mm
    def split_at_step(lines, piece):  # no line has five or more beams on each side of the step
        across = any(min(np.sum(piece[ln.indices] == 0), np.sum(piece[ln.indices] == 2)) >= 5 for ln in lines)
        return not across and _finds(lines, 1.0, 90.0)

    auto_ok = fixed_ok = 0
    for seed in range(30):
        scan, piece = _polyline_scan([(0.6, 1.0), (4.0, 1.0), (4.0, 0.92), (9.0, 0.92)], 0.02, seed)
        auto_ok += split_at_step(split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.02), piece)
        fixed_ok += split_at_step(split_and_merge(scan, split_threshold_m=auto_split_threshold(0.02),
                                                  range_sigma_m=0.02), piece)
    assert auto_ok >= 28 and fixed_ok <= 5


def test_auto_does_not_shatter_a_straight_grazing_wall():
    one = 0
    for seed in range(30):
        scan, _ = _polyline_scan([(0.6, 1.0), (9.0, 1.0)], 0.02, seed)
        lines = split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.02)
        one += len(lines) == 1 and _finds(lines, 1.0, 90.0)
    assert one >= 28


@pytest.mark.parametrize("sigma", [0.005, 0.02])
def test_auto_finds_a_far_wall_the_breakpoints_cut_at_every_beam(sigma):
    # a wall 1 m to the side from 7 to 14 m ahead: the beams meet it at 4-8 deg, the breakpoint
    # detector (10 deg) cuts every pair, and each point is 0.3-0.6 m from the next
    found = 0
    for seed in range(20):
        scan, piece = _polyline_scan([(7.2, 1.0), (14.0, 1.0)], sigma, seed)
        # no segment of 5 points (at 2 cm the noise lets a pair through now and then)
        assert (segment_labels(scan, range_sigma_m=sigma, min_points=5) == -1).all()
        assert split_and_merge(scan, **FIXED_LINES) == []  # the fixed thresholds fit nothing to it
        lines = split_and_merge(scan, split_threshold_m="auto", range_sigma_m=sigma)
        found += len(lines) == 1 and _finds(lines, 1.0, 90.0) and lines[0].n_points >= 0.75 * piece.size
    assert found >= 19


def test_auto_joins_no_beams_the_breakpoints_did_not_cut_and_no_short_chains():
    # a wall 2 m ahead at 0.5 deg steps; 21 of its beams carry no label, as the pipeline leaves the
    # beams of a circle or a leg (their neighbours are 1.7 cm apart: never cut)
    theta = np.radians(np.arange(-30.0, 30.25, 0.5))
    scan = Scan(ranges=2.0 / np.cos(theta), angles=theta)
    labels = segment_labels(scan, range_sigma_m=0.005)
    labels[40:61] = -1
    lines = split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.005, segments=labels)
    assert lines and not any(np.isin(ln.indices, np.arange(40, 61)).any() for ln in lines)
    # three lone points of a far wall seen at 4-5 deg: fewer than min_points, no line
    scan, _ = _polyline_scan([(10.0, 1.0), (14.0, 1.0)], 0.005, 0)
    assert 3 <= scan.n_beams < SplitMergeParams.min_points
    assert split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.005, min_points=5) == []


@pytest.mark.parametrize("bend_deg", [1.5, 2.0])
def test_auto_splits_a_bend_no_single_point_shows(bend_deg):
    # two walls 3 m ahead meeting at a gentle bend, 1 cm of noise: the chord misses the apex by
    # 2.6-3.5 cm, under 5 sigma (5 cm), but the fitted line's residuals are wider than 1 cm allows
    bend = math.radians(bend_deg)
    found = found_fixed = by_residuals = 0
    for seed in range(30):
        scan, _ = _polyline_scan([(3.0, -2.0), (3.0, 0.0), (3.0 + 2.0 * math.tan(bend), 2.0)], 0.01, seed)

        def both(lines):
            return (_finds(lines, 3.0, 0.0, 0.02, bend_deg / 3)
                    and _finds(lines, 3.0 * math.cos(bend), -bend_deg, 0.02, bend_deg / 3))

        lines, steps = split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.01, trace=True)
        found += both(lines)
        by_residuals += any(s.test == "residual" for s in steps)
        found_fixed += both(split_and_merge(scan, split_threshold_m=0.05, range_sigma_m=0.01))
    assert found >= 27 and found_fixed <= 2 and by_residuals >= 25


def test_auto_splits_a_shallow_recess_in_a_grazing_wall():
    # a corridor wall 1 m to the side with a 3 cm deep recess from x = 3 to 5 m, 2 cm of range
    # noise: no point of the recess is 5 sigma off a line through it all, and its residuals are
    # well within 2 cm, but across a wall seen at 11-19 deg the noise is 4-6 mm and the recess's
    # 40 beams all lie to one side
    separated = 0
    for seed in range(30):
        scan, piece = _polyline_scan([(0.6, 1.0), (3.0, 1.0), (3.0, 1.03), (5.0, 1.03), (5.0, 1.0), (9.0, 1.0)],
                                     0.02, seed)
        lines = split_and_merge(scan, split_threshold_m="auto", range_sigma_m=0.02)
        across = any(min(np.sum(piece[ln.indices] == 2), np.sum(np.isin(piece[ln.indices], (0, 4)))) >= 5
                     for ln in lines)
        separated += not across and _finds(lines, 1.03, 90.0, 0.01, 1.0)
    assert separated >= 20


def test_the_shift_test_finds_a_shifted_stretch_and_rarely_noise():
    # the residual tests of "auto" on points of one straight wall (their distances along the
    # normal, known sigma): Gaussian noise alone fails them rarely; 16 of 200 points moved 2
    # sigma to one side (a recess, a chair against the wall) fail them 99 times in 100, more than
    # half of the time by the shift test alone (the mean-square test, asked first, passed them:
    # their squares add a third to the sum)
    from labkit.lines.split_merge import _misfit

    rng = np.random.default_rng(3)
    n, sigma, r = 200, 0.01, 2.0
    rho = np.full(n, r)  # head-on: the noise across the line is sigma
    noise_only = sum(_misfit(r + rng.normal(0.0, sigma, n), rho, r, sigma) is not None for _ in range(2000))
    assert noise_only <= 10  # 0.5 %
    found = by_shift = 0
    for _ in range(200):
        v = r + rng.normal(0.0, sigma, n)
        v[100:116] += 2 * sigma
        res = _misfit(v, rho, float(np.mean(v)), sigma)
        found += res is not None
        by_shift += res is not None and res[0] == "shift" and 96 <= res[1][0] <= 104 and res[1][1] == 16
    assert found >= 198 and by_shift >= 100


def _shift_by_definition(res, sd):
    # the shift test as documented (labkit.lines.split_merge.SHIFT_Z), every window written out
    from numpy.lib.stride_tricks import sliding_window_view

    from labkit.lines.split_merge import SHIFT_MIN_M, SHIFT_Z

    n, best, best_z, w = len(res), None, SHIFT_Z, 4
    while 2 * w <= n:
        sums = sliding_window_view(res, w).sum(axis=1)
        zs = np.abs(sums) / np.sqrt(sliding_window_view(sd * sd, w).sum(axis=1))
        k = int(np.flatnonzero(zs == zs.max())[0])  # the first of the largest
        if zs[k] > best_z and abs(sums[k]) > SHIFT_MIN_M * w:
            best, best_z = (k, w), zs[k]
        w *= 2
    return best


def test_the_shift_test_is_its_definition_near_its_limits():
    # _misfit skips the windows when no window of 4 has a mean over SHIFT_MIN_M (a window of 8,
    # 16, ... is made of windows of 4); a brute-force referee over every window must agree,
    # stretches shifted by 0.5-2.5 sigma (2.5 mm to 5 cm; the limit is 1 cm) on walls seen head-on and at a slant
    from labkit.lines.split_merge import MIN_SPLIT_M, SPLIT_SIGMAS, _misfit

    rng = np.random.default_rng(11)
    shifts = 0
    for trial in range(1500):
        n = int(rng.integers(8, 200))
        sigma = float(rng.choice([0.005, 0.01, 0.02]))
        r = 2.0
        rho = r / rng.uniform(0.2, 1.0, n)  # each point's cos(incidence) = r / rho
        v = r + rng.normal(0.0, sigma, n) * rng.uniform(0.2, 1.0, n)
        if trial % 4:
            k, w = int(rng.integers(0, n - 4)), int(rng.integers(4, max(5, n // 2)))
            v[k:k + w] += rng.choice([-1, 1]) * rng.uniform(0.5, 2.5) * sigma
        sd = np.maximum(np.abs(v) * sigma / rho, MIN_SPLIT_M / SPLIT_SIGMAS)
        got = _misfit(v, rho, r, sigma)
        if got is not None and got[0] == "residual":
            continue
        z = (v - r) / sd
        want = _shift_by_definition(v - r, sd) if float(z @ z) > 25 else None
        assert (None if got is None else got[1][:2]) == want, trial
        shifts += want is not None
    assert shifts > 40, shifts


# ----------------------------------------------------------------------------- placing lines
def test_a_line_the_data_cannot_place_is_dropped_with_its_reason():
    # a long wall 3 m ahead and a 0.25 m stub, 12 beams, 6 m away: at 3 cm its angle is not known to 3 deg
    rng = np.random.default_rng(3)
    theta = np.radians(np.arange(-30.0, 30.0 + 0.125, 0.25))
    ranges = 3.0 / np.cos(theta)
    stub = np.radians(np.arange(40.0, 43.0, 0.25))
    stub_r = 6.0 / np.cos(stub - math.radians(41.5))
    scan = Scan(ranges=np.concatenate([ranges, stub_r]) + rng.normal(0, 0.03, theta.size + stub.size),
                angles=np.concatenate([theta, stub]))
    every = split_and_merge(scan, **{**AUTO_LINES, "place_confidence": 0})
    placed, steps = split_and_merge(scan, trace=True, **AUTO_LINES)
    assert len(every) == 2 and len(placed) == 1 and abs(placed[0].r - 3.0) < 0.02
    (rej,) = [s for s in steps if s.test == "place_confidence"]
    assert rej.kind == "reject" and rej.value < 0.8 and rej.first == theta.size
    # what the user trusts decides: a looser trust keeps it
    assert len(split_and_merge(scan, place_dalpha_deg=30.0, place_dr_m=1.0, **AUTO_LINES)) == 2


def test_the_pipeline_follows_the_noise_with_auto_and_given_values_win():
    scan = _wall_scan(0.03, seed=5)
    f = extract_features(scan, Config().updated({"lines": AUTO_LINES, "segmentation.range_sigma_m": "auto"}))
    assert len(f.lines) == 1
    fixed = extract_features(scan, Config().updated({"lines": {"split_threshold_m": 0.02, "place_confidence": 0}}))
    assert len(fixed.lines) > 1


def test_a_noise_given_as_a_number_reaches_the_detectors_own_segmentation():
    # a detector called without segments segments the scan itself: its breakpoints follow its own
    # range_sigma_m, a number as "auto" does (they used the default 1 cm: at 3 cm of noise walls
    # broke into pieces, and AUTO_LINES with the true sigma found 0.73 / 0.10 of the walls on the
    # simulated set against 0.80 / 0.04 with the estimate). The estimate given as a number gives
    # what "auto" gives; a number gives what the segmentation at that number gives.
    from labkit import detect_circles, detect_legs
    from labkit.experiments import nguyen_set

    items = [it for it in nguyen_set(6, noise_levels=(0.03,))]
    for item in items:
        scan = item.scan
        sigma = float(scan_sigma(scan))
        assert _keys(split_and_merge(scan, **{**AUTO_LINES, "range_sigma_m": sigma})) == \
            _keys(split_and_merge(scan, **AUTO_LINES))
        own = segment_labels(scan, range_sigma_m=0.03)
        assert not np.array_equal(own, segment_labels(scan, range_sigma_m=0.01))  # (the test means something)
        for detect in (split_and_merge, detect_circles, detect_legs):
            assert _keys(detect(scan, range_sigma_m=0.03)) == _keys(detect(scan, range_sigma_m=0.03, segments=own))


def _keys(features) -> list:
    return [(f.first, f.last, round(float(getattr(f, "r", getattr(f, "radius", 0.0))), 9)) for f in features]


def test_the_placing_probability_is_what_happens():
    """Calibration against simulation: the same 12-beam stub 6 m away under 400 draws of 3 cm noise.
    The share of its fitted lines that land within 5 cm and 3 deg of the true line is the truth;
    the mean probability the lines' covariances claim must match it (binomial s.e. 0.024)."""
    from labkit.geometry import angle_difference

    stub = np.radians(np.arange(40.0, 43.0, 0.25))
    ranges = 6.0 / np.cos(stub - math.radians(41.5))
    rng = np.random.default_rng(0)
    hits, claimed = [], []
    for _ in range(400):
        scan = Scan(ranges=ranges + rng.normal(0.0, 0.03, stub.size), angles=stub)
        (line,) = split_and_merge(scan, range_sigma_m=0.03, split_threshold_m=0.15, place_confidence=0)
        hits.append(abs(line.r - 6.0) <= 0.05
                    and abs(float(angle_difference(line.alpha, math.radians(41.5)))) <= math.radians(3.0))
        claimed.append(placement_probability(line.covariance, 0.05, math.radians(3.0)))
    assert 0.2 < np.mean(hits) < 0.6  # a line the data can hardly place
    assert np.mean(claimed) == pytest.approx(np.mean(hits), abs=0.07)


def test_a_detector_told_auto_segments_with_the_estimated_noise_too():
    # the wall 1 m ahead under 5 cm of noise: the fixed setting's breakpoints (1 cm) cut it into
    # five or more segments; split-and-merge with AUTO_LINES (the defaults) and no segments given
    # sees one or two
    theta = np.radians(np.arange(-40.0, 40.25, 0.5))
    rng = np.random.default_rng(1)
    scan = Scan(ranges=1.0 / np.cos(theta) + rng.normal(0, 0.05, theta.size), angles=theta)
    _, steps = split_and_merge(scan, trace=True, **AUTO_LINES)
    assert sum(s.kind == "segment" for s in steps) <= 2
    assert split_and_merge(scan, trace=True)[1] == steps
    _, steps = split_and_merge(scan, trace=True, **FIXED_LINES)
    assert sum(s.kind == "segment" for s in steps) >= 5


# ----------------------------------------------------------------------------- circles and legs
# The noise allowances of the IAV tests (labkit._iav_noise: ratio_sd, angle_noise) are first-order
# propagations; the truth here is what the statistics do when noise is drawn many times.
def _arc_points(center, radius, n, half_span_deg):
    """n points of a circle, in scan order, on the side facing the sensor at the origin."""
    cx, cy = center
    facing = math.atan2(-cy, -cx)
    t = facing + np.radians(np.linspace(half_span_deg, -half_span_deg, n))
    return np.column_stack([cx + radius * np.cos(t), cy + radius * np.sin(t)])


def _noisy(points, sigma, rng, draws):
    """``draws`` copies of ``points`` with Gaussian range noise along each beam."""
    rho = np.hypot(points[:, 0], points[:, 1])
    u = points / rho[:, None]
    return (rho + rng.normal(0.0, sigma, (draws, rho.size)))[..., None] * u


@pytest.mark.parametrize(("n", "half_span", "sigma"), [(5, 60, 0.005), (9, 70, 0.005), (15, 75, 0.003),
                                                       (7, 50, 0.002)])
def test_the_angle_allowances_match_the_noise_they_model(n, half_span, sigma):
    from labkit._iav_noise import angle_noise
    from labkit.iav import NOISE_Z, inscribed_angles

    pts = _arc_points((3.0, 0.4), 0.3, n, half_span)
    spread_max_sq, mean_sd = angle_noise(pts, sigma)
    rng = np.random.default_rng(n)
    draws = _noisy(pts, sigma, rng, 4000)
    angles = np.array([inscribed_angles(p, signed=True) for p in draws])
    # the mean's spread within 10 % (4000 draws: the standard error of an SD is 1.1 %)
    assert np.std(angles.mean(axis=1)) == pytest.approx(mean_sd, rel=0.10)
    # the spread's upper quantile: the share of draws beyond it is near the normal tail of NOISE_Z
    tail = 1 - 0.5 * (1 + math.erf(NOISE_Z / math.sqrt(2)))
    beyond = np.mean(angles.var(axis=1) > spread_max_sq)
    assert tail / 3 < beyond < tail * 2, (beyond, tail)


def test_the_prerequisite_allowance_matches_the_noise_it_models():
    from labkit._iav_noise import ratio_sd
    from labkit.iav import middle_point_offset

    rng = np.random.default_rng(3)
    for n, sigma in ((5, 0.02), (7, 0.01), (4, 0.005)):
        pts = _arc_points((2.5, -0.6), 0.07, n, 70)
        chord = float(np.hypot(*(pts[-1] - pts[0])))
        predicted = ratio_sd(pts[0].tolist(), pts[-1].tolist(), pts[n // 2].tolist(), chord, sigma)
        ratios = [middle_point_offset(p) for p in _noisy(pts, sigma, rng, 4000)]
        # first order: within 15 % while the noise is small against the chord (2 cm on a 12 cm chord is not)
        assert np.std(ratios) == pytest.approx(predicted, rel=0.15 if sigma < 0.02 else 0.3)


def _hall_scores(noise, n, config):
    from labkit.experiments import score_round_objects

    return score_round_objects(n, noise_std_m=noise, config=config)


def test_circles_and_legs_follow_the_noise_at_2_cm():
    fixed = _hall_scores(0.02, 120, Config().updated(FIXED_CONFIG))
    auto = _hall_scores(0.02, 120, None)  # the defaults
    # issue 16's goals, on the simulator's truth (120 scans: each rate has a standard error under 1.5 %)
    assert auto["circles"]["precision"] >= 0.95 and auto["circles"]["recall"] >= 0.9, auto["circles"]
    assert auto["legs"]["precision"] >= 0.9 and auto["legs"]["recall"] >= 0.85, auto["legs"]
    # and what the paper's fixed tests lose there
    assert fixed["circles"]["recall"] < 0.75 and fixed["legs"]["recall"] < 0.8


def test_the_allowances_lose_nothing_at_5_mm():
    fixed = _hall_scores(0.005, 60, Config().updated(FIXED_CONFIG))
    auto = _hall_scores(0.005, 60, None)  # the defaults
    for kind in ("circles", "legs"):
        assert auto[kind]["recall"] >= fixed[kind]["recall"]
        assert auto[kind]["precision"] >= fixed[kind]["precision"] - 0.01


def _flat_pieces(sigma, trials=400, seed=7):
    """Short straight pieces of wall (5-13 beams of 0.5 deg at 1.5-5 m), each its own scan."""
    rng = np.random.default_rng(seed)
    for _ in range(trials):
        d, alpha = rng.uniform(1.5, 5.0), rng.uniform(-0.5, 0.5)
        width = rng.integers(5, 14)
        theta = alpha + math.radians(0.5) * (np.arange(width) - width // 2)
        yield Scan(ranges=d / np.cos(theta - alpha) + rng.normal(0.0, sigma, width), angles=theta)


@pytest.mark.parametrize("sigma", [0.005, 0.02])
def test_short_noisy_walls_are_not_called_circles(sigma):
    # the attack on the allowances: a short straight piece of wall could pass a widened band;
    # it must not become a circle (LINE_Z keeps the mean angle below a line's 180 deg)
    from labkit import detect_circles

    found = sum(len(detect_circles(scan, range_sigma_m=sigma)) for scan in _flat_pieces(sigma))
    assert found <= 4, found  # of 400 (1 measured at 2 cm, 0 at 5 mm)


@pytest.mark.parametrize(("sigma", "fixed_max", "allowed_max"), [(0.005, 0.03, 0.3), (0.02, 0.2, 0.6)])
def test_flat_pieces_of_leg_width_the_leg_allowance_lets_through(sigma, fixed_max, allowed_max):
    # The same attack on legs wins often, and this test records by how much rather than hiding
    # it: a leg has no angle test (Xavier et al.), and 3-7 points of a 10-25 cm piece at 2 cm of
    # noise cannot tell round from flat -- the widened prerequisite band takes in about 49 % of
    # flat pieces at 2 cm and 18 % at 5 mm (measured, 400 pieces), the fixed band 15 % and 0.8 %.
    # That is the price of the allowances, the default (range_sigma_m=0 or FIXED_CONFIG: the paper's test).
    from labkit import detect_legs

    pieces = list(_flat_pieces(sigma))
    fixed = sum(len(detect_legs(s, range_sigma_m=0, reject_occluded=False)) for s in pieces) / len(pieces)
    allowed = sum(len(detect_legs(s, range_sigma_m=sigma, reject_occluded=False)) for s in pieces) / len(pieces)
    assert fixed <= fixed_max and fixed < allowed <= allowed_max, (fixed, allowed)


def test_auto_is_the_scans_estimate_a_number_wins_and_zero_is_the_paper():
    from labkit import detect_circles, detect_legs, sim
    from labkit.circles.iav_circles import CircleParams
    from labkit.circles.legs import LegsParams

    assert CircleParams().range_sigma_m == "auto" and LegsParams().range_sigma_m == "auto"  # the default
    world = sim.World("demo", circles=(sim.Column((3.0, 0.5), 0.3), sim.Column((2.0, -0.8), 0.07)))
    lidar = dataclasses_replace_noise(sim.LIDARS["lms200"], 0.02)
    scan, _ = sim.scan_at(world, lidar, (0.0, 0.0, 0.0), rng=np.random.default_rng(2))
    sigma = scan_sigma(scan)
    for detect in (detect_circles, detect_legs):
        def key(found):
            return [(np.round(f.center, 12).tolist(), f.first, f.last) for f in found]

        auto = detect(scan, range_sigma_m="auto")
        assert auto and key(auto) == key(detect(scan, range_sigma_m=sigma))
    with pytest.raises(ValueError, match="range_sigma_m"):
        detect_circles(scan, range_sigma_m=-0.01)


def test_the_trace_shows_the_widened_limit():
    from labkit import detect_circles, sim

    world = sim.World("demo", circles=(sim.Column((3.0, 0.0), 0.3),))
    lidar = dataclasses_replace_noise(sim.LIDARS["lms200"], 0.02)
    for seed in range(40):
        scan, _ = sim.scan_at(world, lidar, (0.0, 0.0, 0.0), rng=np.random.default_rng(seed))
        _, fixed = detect_circles(scan, trace=True, range_sigma_m=0)
        circles, steps = detect_circles(scan, range_sigma_m=0.02, trace=True)
        accepted = [s for s in steps if s.kind == "accept"]
        if circles and not any(s.kind == "accept" for s in fixed):  # a circle only the allowance finds
            (step,) = accepted
            assert step.value < step.threshold and step.threshold > math.radians(8.6)
            return
    pytest.fail("no scan in 40 where the allowance changed the verdict")


def dataclasses_replace_noise(lidar, sigma):
    import dataclasses

    return dataclasses.replace(lidar, noise_std_m=sigma)


# ----------------------------------------------------------------------------- angular segmentation
def _direction_of(alpha_normal: float) -> float:
    return (alpha_normal + math.pi / 2) % math.pi


@pytest.mark.parametrize("window", [1, 2, 5])
@pytest.mark.parametrize("alpha_deg", [0.0, 35.0, -70.0])
def test_windowed_directions_are_the_walls_direction_on_a_clean_wall(window, alpha_deg):
    from labkit.lines.angular import local_directions

    alpha = math.radians(alpha_deg)
    theta = alpha + np.radians(np.arange(-50.0, 50.1, 0.5))
    scan = Scan(ranges=2.5 / np.cos(theta - alpha), angles=theta)
    phi = local_directions(scan, window)
    assert np.isnan(phi[:window]).all() and np.isnan(phi[-window:]).all()
    inner = phi[window:-window]
    assert np.isfinite(inner).all()
    gap = np.abs(np.angle(np.exp(2j * (inner - _direction_of(alpha))))) / 2  # period pi
    assert gap.max() < 1e-9
    # a straight wall is straight at any noise the test allows for, even a tiny one
    assert np.isfinite(local_directions(scan, window, straight_sigma=1e-6)[window:-window]).all()


@pytest.mark.parametrize("window", [1, 3, 7])
def test_the_window_formula_is_the_spread_the_noise_gives(window):
    """auto_direction_window assumes sigma / (s sqrt(h (h+1) (2h+1) / 3)) radians: check it against
    the spread of 300 noisy walls seen at normal incidence."""
    from labkit.lines.angular import local_directions

    sigma, d, step = 0.01, 3.0, math.radians(0.5)
    theta = step * (np.arange(2 * window + 1) - window)
    rng = np.random.default_rng(window)
    phi = np.array([local_directions(Scan(ranges=d / np.cos(theta) + rng.normal(0, sigma, theta.size),
                                          angles=theta), window)[window] for _ in range(3000)])
    spread = np.std(np.angle(np.exp(2j * (phi - math.pi / 2))) / 2)
    predicted = sigma / (d * step * math.sqrt(window * (window + 1) * (2 * window + 1) / 3))
    assert spread == pytest.approx(predicted, rel=0.08)  # first order, and 3000 draws: 1.3 % standard error


def test_the_auto_window_is_the_narrowest_that_holds_eps_theta():
    from labkit.lines.angular import EPS_THETA, auto_direction_window

    theta = np.radians(np.arange(-60.0, 60.1, 0.5))
    for d, sigma in [(2.0, 0.005), (3.0, 0.01), (3.0, 0.02), (5.0, 0.03)]:
        scan = Scan(ranges=np.full(theta.size, d), angles=theta)
        s = d * math.radians(0.5)

        def spread(h, s=s, sigma=sigma):
            return sigma / (s * math.sqrt(h * (h + 1) * (2 * h + 1) / 3))

        h = auto_direction_window(scan, sigma)
        assert spread(h) <= EPS_THETA and (h == 1 or spread(h - 1) > EPS_THETA), (d, sigma, h)
    empty = Scan(ranges=np.full(5, np.nan), angles=np.radians(np.arange(5.0)))
    assert auto_direction_window(empty, 0.01) == 1


def test_the_straightness_test_rejects_windows_across_a_corner_and_few_on_a_wall():
    from labkit.lines.angular import local_directions

    sigma = 0.01
    rng = np.random.default_rng(3)
    # a right-angle corner at (2, 2): walls x = 2 (below) and y = 2 (to the left), 0.5 deg beams
    theta = np.radians(np.arange(10.0, 80.1, 0.5))
    clean = np.where(theta < math.pi / 4, 2.0 / np.cos(theta), 2.0 / np.sin(theta))
    corner_beam = int(np.argmin(np.abs(theta - math.pi / 4)))
    rejected_on_walls = 0
    for _ in range(40):
        scan = Scan(ranges=clean + rng.normal(0, sigma, theta.size), angles=theta)
        phi = local_directions(scan, 5, straight_sigma=sigma)
        # the windows with three or more beams on each wall are 7 cm or more off any one line: never straight
        assert np.isnan(phi[corner_beam - 2:corner_beam + 3]).all()
        away = np.r_[5:corner_beam - 6, corner_beam + 7:theta.size - 5]
        rejected_on_walls += int(np.isnan(phi[away]).sum())
    # each wall window fails with probability ~1/741 by design; 40 scans x ~120 windows
    assert rejected_on_walls <= 20


def test_auto_angular_follows_the_noise_and_loses_nothing_at_5_mm():
    from functools import partial

    from labkit import angular_segmentation
    from labkit.experiments import SENSOR_NOISE_LEVELS_M, compare_lines, nguyen_set
    from labkit.noise import FIXED_ANGULAR

    rows = compare_lines(nguyen_set(30, noise_levels=SENSOR_NOISE_LEVELS_M),
                         {"paper": partial(angular_segmentation, **FIXED_ANGULAR), "auto": angular_segmentation})
    by = {(r["method"], r["noise_std_m"]): r for r in rows}
    for noise in SENSOR_NOISE_LEVELS_M:
        paper, auto = by["paper", noise], by["auto", noise]
        assert auto["fp_rate"] < paper["fp_rate"], noise
        assert auto["tp_rate"] >= paper["tp_rate"] - 0.01, noise
        if noise >= 0.01:  # three-beam directions are noise there; the windowed ones are not
            assert auto["tp_rate"] > paper["tp_rate"] + 0.1 and auto["fp_rate"] < paper["fp_rate"] / 2, noise


def test_angular_auto_in_the_config_and_its_errors():
    from labkit import angular_segmentation
    from labkit.lines.angular import AngularParams, auto_direction_window
    from labkit.noise import AUTO_CONFIG

    assert AngularParams().direction_window == "auto" and AngularParams().range_sigma_m == "auto"  # the default
    config = Config().updated({**AUTO_CONFIG, "lines.method": "angular"})
    assert config.lines.angular.direction_window == "auto"
    scan = _wall_scan(0.02, seed=4, step_deg=0.5)
    h = auto_direction_window(scan, scan_sigma(scan))
    lines, steps = angular_segmentation(scan, direction_window="auto", range_sigma_m="auto", trace=True)
    (first,) = [s for s in steps if s.kind == "directions"]
    assert first.threshold == h > 1 and f"over {2 * h + 1} beams" in first.reason and "straight at" in first.reason
    assert [ln.first for ln in lines] == [ln.first for ln in angular_segmentation(
        scan, direction_window=h, range_sigma_m=scan_sigma(scan))]  # "auto" is the estimate; a number wins
    assert len(extract_features(scan, config).lines) == 1
    for bad, key in [({"direction_window": 0}, "direction_window"), ({"direction_window": "wide"}, "direction_window"),
                     ({"range_sigma_m": -1.0}, "range_sigma_m")]:
        with pytest.raises(ValueError, match=key):
            angular_segmentation(scan, **bad)


# ----------------------------------------------------------------------------- RANSAC, Hough, incremental
def _others():
    """(function, its distance threshold's name, its AUTO_* setting, the sigmas of its "auto") per extractor."""
    from labkit.lines import hough_lines, incremental_lines, ransac_lines
    from labkit.noise import AUTO_HOUGH, AUTO_INCREMENTAL, AUTO_RANSAC, GROW_SIGMAS, INLIER_SIGMAS

    return {"ransac": (ransac_lines, "threshold_m", AUTO_RANSAC, INLIER_SIGMAS),
            "hough": (hough_lines, "threshold_m", AUTO_HOUGH, INLIER_SIGMAS),
            "incremental": (incremental_lines, "max_error_m", AUTO_INCREMENTAL, GROW_SIGMAS)}


def _key(lines):
    return [(ln.r, ln.alpha, ln.first, ln.last) for ln in lines]


_OTHERS = ("ransac", "hough", "incremental")
_FIXED = {"ransac": FIXED_RANSAC, "hough": FIXED_HOUGH, "incremental": FIXED_INCREMENTAL}


@pytest.mark.parametrize("name", _OTHERS)
def test_the_other_extractors_auto_setting_has_fewer_false_lines_at_2_cm(name):
    # the simulator's ground truth, matched by labkit.evaluation (Nguyen et al.'s 5 cm / 3 deg rule);
    # at 2 cm the fixed settings report many short pieces whose angle the data cannot place (0.36-0.41
    # of their lines false on 408 scans), the auto settings (the defaults) 0.05-0.07
    from functools import partial

    from labkit.experiments import compare_lines, nguyen_set

    fn, _, auto, _ = _others()[name]
    rows = compare_lines(nguyen_set(12, noise_levels=(0.02,)), {"default": partial(fn, **_FIXED[name]), "auto": fn})
    by = {r["method"]: r for r in rows}
    assert by["default"]["fp_rate"] > 0.25, by["default"]
    assert by["auto"]["fp_rate"] < by["default"]["fp_rate"] / 3, (by["auto"], by["default"])
    assert by["auto"]["tp_rate"] > by["default"]["tp_rate"] - 0.15, (by["auto"], by["default"])


@pytest.mark.parametrize("name", _OTHERS)
def test_the_other_extractors_fixed_settings_are_the_fixed_values(name):
    # the fixed setting is the fixed threshold, each line's covariance from its own residuals, and
    # every line; the default call is the auto setting
    from labkit.features import line_segment

    fn, key, auto, _ = _others()[name]
    scan = _wall_scan(0.02, seed=6)
    explicit = fn(scan, **{key: 0.05 if key == "max_error_m" else 0.03}, range_sigma_m=None, place_confidence=0.0,
                  place_dr_m=0.05, place_dalpha_deg=3.0)
    assert _key(fn(scan)) == _key(fn(scan, **auto))
    default = fn(scan, **_FIXED[name])
    assert default and _key(default) == _key(explicit)
    for ln in default:
        own = line_segment(scan.points[ln.indices], ln.indices)
        np.testing.assert_array_equal(ln.covariance, own.covariance)


@pytest.mark.parametrize("name", _OTHERS)
def test_the_other_extractors_keep_a_given_threshold_and_auto_is_the_scans_estimate(name):
    from labkit.features import line_segment

    fn, key, _, sigmas = _others()[name]
    scan = _wall_scan(0.02, seed=7)
    sigma = scan_sigma(scan)
    # a fixed threshold with range_sigma_m="auto": the same lines as the threshold alone, their
    # covariances from the scan's estimated noise
    given = fn(scan, **{key: 0.04}, range_sigma_m="auto")
    assert given and _key(given) == _key(fn(scan, **{key: 0.04}))
    for ln in given:
        np.testing.assert_allclose(ln.covariance, line_segment(scan.points[ln.indices], ln.indices,
                                                               range_sigma=sigma).covariance)
    # "auto" is max(sigmas * sigma, 2 cm) of the scan's estimate
    auto = fn(scan, **{key: "auto"}, range_sigma_m="auto")
    assert _key(auto) == _key(fn(scan, **{key: max(sigmas * sigma, MIN_SPLIT_M)}, range_sigma_m=sigma))
    with pytest.raises(ValueError, match=f'{key} must be a number or "auto"'):
        fn(scan, **{key: "automatic"})
    with pytest.raises(ValueError, match="range_sigma_m"):
        fn(scan, range_sigma_m="estimate")
    with pytest.raises(ValueError, match="place_confidence"):
        fn(scan, place_confidence=1.5)


def _wall_and_stub(seed=3):
    """A long wall 3 m ahead and a 0.25 m stub, 12 beams, 6 m away, at 3 cm of range noise."""
    rng = np.random.default_rng(seed)
    theta = np.radians(np.arange(-30.0, 30.0 + 0.125, 0.25))
    stub = np.radians(np.arange(40.0, 43.0, 0.25))
    ranges = np.concatenate([3.0 / np.cos(theta), 6.0 / np.cos(stub - math.radians(41.5))])
    return Scan(ranges=ranges + rng.normal(0, 0.03, ranges.size), angles=np.concatenate([theta, stub])), theta.size


@pytest.mark.parametrize("name", _OTHERS)
def test_the_other_extractors_drop_a_line_they_cannot_place_with_its_reason(name):
    fn, _, auto, _ = _others()[name]
    scan, n_wall = _wall_and_stub()
    every = fn(scan, **{**auto, "place_confidence": 0.0})
    placed, steps = fn(scan, trace=True, **auto)
    assert any(ln.first >= n_wall for ln in every)  # the stub makes a line
    assert placed and all(ln.last < n_wall for ln in placed) and all(abs(ln.r - 3.0) < 0.02 for ln in placed)
    rejected = [s for s in steps if s.test == "place_confidence"]
    assert rejected and all(s.kind == "reject" and s.value < 0.8 for s in rejected)
    assert any(s.first >= n_wall for s in rejected)
    # replay: the accepted lines less those rejected for their placing are the lines returned
    dropped = {(s.first, s.last) for s in rejected}
    replay = sorted((s.first, s.last) for s in steps if s.kind == "accept" and (s.first, s.last) not in dropped)
    assert replay == sorted((ln.first, ln.last) for ln in placed)
    # what the user trusts decides: a looser trust keeps it
    assert len(fn(scan, **{**auto, "place_dalpha_deg": 30.0, "place_dr_m": 1.0})) == len(every)
