"""Thresholds that follow the range noise ("auto") and the placing of lines (issue 16).

Truth here is independent of the code under test: Monte Carlo for the placing probability,
the simulator's known noise for the thresholds, closed-form geometry for the lines.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit import Config, Scan, extract_features, split_and_merge
from labkit.fitting import placement_probability
from labkit.lines.split_merge import SplitMergeParams
from labkit.noise import AUTO_LINES, MIN_SPLIT_M, auto_split_threshold, scan_sigma
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
    # not the default yet (the Radish logs with 1 deg steps get worse: see the README)
    assert SplitMergeParams().split_threshold_m == 0.05 and SplitMergeParams().place_confidence == 0
    assert SplitMergeParams(**AUTO_LINES).split_threshold_m == "auto"
    assert SegmentationParams(range_sigma_m="auto").range_sigma_m == "auto"
    assert SplitMergeParams(split_threshold_m=0.07).split_threshold_m == 0.07
    for bad in ("Auto", "", None, True):
        with pytest.raises(ValueError, match='split_threshold_m must be a number or "auto"'):
            SplitMergeParams(split_threshold_m=bad)
    with pytest.raises(ValueError, match="> 0"):
        SplitMergeParams(split_threshold_m=-0.1)
    with pytest.raises(ValueError, match="place_confidence"):
        SplitMergeParams(place_confidence=1.5)


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
        (line,) = split_and_merge(scan, range_sigma_m=0.03, split_threshold_m=0.15)
        hits.append(abs(line.r - 6.0) <= 0.05
                    and abs(float(angle_difference(line.alpha, math.radians(41.5)))) <= math.radians(3.0))
        claimed.append(placement_probability(line.covariance, 0.05, math.radians(3.0)))
    assert 0.2 < np.mean(hits) < 0.6  # a line the data can hardly place
    assert np.mean(claimed) == pytest.approx(np.mean(hits), abs=0.07)


def test_a_detector_told_auto_segments_with_the_estimated_noise_too():
    # the wall 1 m ahead under 5 cm of noise: the default breakpoints (1 cm) cut it into five or
    # more segments; split-and-merge with AUTO_LINES and no segments given sees one or two
    theta = np.radians(np.arange(-40.0, 40.25, 0.5))
    rng = np.random.default_rng(1)
    scan = Scan(ranges=1.0 / np.cos(theta) + rng.normal(0, 0.05, theta.size), angles=theta)
    _, steps = split_and_merge(scan, trace=True, **AUTO_LINES)
    assert sum(s.kind == "segment" for s in steps) <= 2
    _, steps = split_and_merge(scan, trace=True)
    assert sum(s.kind == "segment" for s in steps) >= 5
