"""The IAV detectors' compiled kernels give numpy's and the readable reference's results bit for bit.

``detect_circles(scan)`` and ``detect_legs(scan)`` at their defaults run compiled tests
(labkit/_iav_engine.py: the cheap tests, the inscribed angles, the noise allowances, the residual
test's circle fits); ``trace=True`` runs the reference, one segment at a time (labkit/circles/).
Compared here: each kernel against the numpy code it replaces, on random runs (hypothesis), then
every field of every circle and leg (floats by their bits) against the reference on random scans,
the simulated worlds at 361-2881 beams and 5 mm-3 cm of noise, and the real recordings
(``../shared/datasets``, skipped when absent). (``tests/test_iav_reference.py`` compares the batch
engine's own trace with the reference; the detectors' default calls are compared here.)
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labkit
from labkit import _iav_batch, _iav_engine, _iav_noise, iav, sim
from labkit.app.experiments import nguyen_lidar, world_scans
from labkit.fitting import fit_circles
from tests.test_iav_reference import RADISH, _canon, _random_scan

#: the detectors with the settings that take the compiled paths (and one the compiled legs do not take)
DEFAULTS = [
    (labkit.detect_circles, {}),
    (labkit.detect_circles, {"range_sigma_m": 0}),
    (labkit.detect_circles, {"range_sigma_m": 0.03, "min_points": 3, "center_method": "geometric"}),
    (labkit.detect_legs, {}),
    (labkit.detect_legs, {"range_sigma_m": 0, "center_method": "iav", "chord_padding_beams": 0.0}),
    (labkit.detect_legs, {"center_method": "geometric", "reject_occluded": False, "min_points": 4}),
]


def same_as_reference(scan) -> int:
    """Every detector of :data:`DEFAULTS` gives the reference's features on ``scan``; how many."""
    found = 0
    for detector, kwargs in DEFAULTS:
        fast = detector(scan, **kwargs)
        reference, _ = detector(scan, **kwargs, trace=True)
        assert _canon(fast) == _canon(reference), (detector.__name__, kwargs)
        found += len(fast)
    return found


def test_the_engine_runs_here_and_shares_the_constants():
    engine = _iav_batch._engine()
    assert engine is not None, "the kernels must run on this machine (else nothing is compared)"
    assert (engine.circle_tests, engine.leg_tests) == (_iav_engine.circle_tests, _iav_engine.leg_tests)
    assert (_iav_engine.NOISE_Z, _iav_engine.LINE_Z, _iav_engine.ARC_LIKE_STD_MAX) == (
        iav.NOISE_Z, iav.LINE_Z, iav.ARC_LIKE_STD_MAX)
    codes = ("ACCEPTED", "FEW", "SHORT", "LONG", "PREREQ", "DEGENERATE", "MEAN", "STD")
    assert [getattr(_iav_engine, c) for c in codes] == [getattr(_iav_batch, c) for c in codes]


def test_numpys_complex_product_is_fused_and_the_plain_one_is_not():
    """What the angle kernel reproduces: numpy's ``b * a`` rounds each part once (a fused
    multiply-add); the textbook product rounded after each operation differs, so the kernel's
    choice is seen by the comparisons below."""
    assert _iav_engine.COMPLEX_FMA
    rng = np.random.default_rng(3)
    a = rng.normal(size=2000) * 5 + 1j * rng.normal(size=2000)
    b = rng.normal(size=2000) - 1j * rng.normal(size=2000) * 3
    ab = b * a
    plain = b.real * a.real - b.imag * a.imag
    assert (ab.real != plain).sum() > 100


# ---------------------------------------------------------------------------- the kernels against numpy
@st.composite
def runs(draw):
    """Runs of points back to back: arcs with noise, corners, nearly straight runs, clutter."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    sizes = rng.integers(3, draw(st.sampled_from([8, 20, 150])), draw(st.integers(1, 5)))
    pts = [rng.normal(0.0, 3.0, (int(draw(st.integers(0, 3))), 2))]  # points before the runs
    for m in sizes:
        kind = rng.integers(0, 4)
        if kind == 0:
            t = np.sort(rng.uniform(0.0, rng.uniform(0.3, 6.0), m))
            q = rng.uniform(-5, 5, 2) + rng.uniform(0.05, 3.0) * np.c_[np.cos(t), np.sin(t)]
            q += rng.normal(0.0, rng.uniform(0.0, 0.05), (m, 2))
        elif kind == 1:
            h = m // 2
            q = np.r_[np.c_[np.linspace(0, 1, h), np.zeros(h)], np.c_[np.ones(m - h), np.linspace(0.05, 1, m - h)]]
            q += rng.normal(0.0, 0.01, (m, 2))
        elif kind == 2:
            q = np.c_[np.linspace(0.0, 2.0, m), rng.normal(0.0, 1e-3, m)]
        else:
            q = rng.normal(0.0, 1.0, (m, 2))
        pts.append(q)
    ends = np.cumsum(sizes) + len(pts[0])
    return np.concatenate(pts), ends - sizes, ends


def _same(a, b) -> bool:
    return all(np.array_equal(x, y, equal_nan=True) and np.asarray(x).dtype == np.asarray(y).dtype
               for x, y in zip(a, b, strict=True))


@settings(max_examples=50, deadline=None)
@given(runs(), st.sampled_from(["geometric", "algebraic"]), st.sampled_from([0, 5, 50]))
def test_circle_fits_are_numpys(r, method, steps):
    pts, starts, ends = r
    fast = _iav_engine.fit_circles(pts, starts, ends, method, max_iterations=steps)
    if fast is not None:  # (None: a nearly straight run needs numpy's least squares; the caller runs numpy)
        assert _same(fast, fit_circles(pts, starts, ends, method, max_iterations=steps))


@settings(max_examples=60, deadline=None)
@given(runs(), st.sampled_from([0.005, 0.02, 1e-9]))
def test_angle_noise_is_numpys(r, sigma):
    pts, starts, ends = r
    with np.errstate(all="ignore"):
        assert _same(_iav_engine.angle_noise_runs(pts, starts, ends, sigma),
                     _iav_noise.angle_noise_reference(pts, starts, ends, sigma))


@settings(max_examples=60, deadline=None)
@given(runs(), st.sampled_from([0.005, 0.01, 0.03]), st.integers(0, 2**32 - 1))
def test_the_residual_test_is_numpys(r, sigma, seed):
    """The circle tried first is the run's own, nudged, or none (NaN); numpy's side fits with numpy."""
    pts, starts, ends = r
    rng = np.random.default_rng(seed)
    k = len(starts)
    fits = fit_circles(pts, starts, ends, "algebraic")
    centers = fits.centers + rng.normal(0.0, 0.01, (k, 2))
    radii = fits.radii * rng.uniform(0.97, 1.03, k)
    centers[rng.random(k) < 0.2] = np.nan
    fast = _iav_engine.wider_than_noise(pts, starts, ends, sigma, centers, radii, _iav_noise.EARLY_STEPS,
                                        _iav_noise.EARLY_FACTOR)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_iav_noise, "_JIT", False)
        reference = _iav_noise.wider_than_noise(pts, starts, ends, sigma, centers, radii)
    if fast is not None:
        assert np.array_equal(fast, reference)


# ---------------------------------------------------------------------------- the detectors against the reference
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 500), step=st.sampled_from([0.25, 0.5, 1.0]),
       full=st.booleans(), noise=st.sampled_from([0.0, 0.005, 0.02, 0.03]), dropouts=st.sampled_from([0.0, 0.05]))
def test_detectors_equal_the_reference_on_random_scans(seed, n, step, full, noise, dropouts):
    same_as_reference(_random_scan(seed, n, step, full, noise, dropouts))


@pytest.mark.parametrize("beams", [361, 722, 1441, 2881])
def test_detectors_equal_the_reference_on_simulated_worlds(beams):
    found = 0
    rng = np.random.default_rng(beams)
    for world, noise in zip(("hall", "office", "corridor"), (0.005, 0.02, 0.03), strict=True):
        for scan, _ in world_scans(world, nguyen_lidar(beams, noise), 2, rng):
            found += same_as_reference(scan)
    assert found > 0


@pytest.mark.shared
def test_detectors_equal_the_reference_on_real_scans(shared_datasets):
    found = 0
    for k in range(1, 7):
        found += same_as_reference(labkit.read_json_scan(shared_datasets / "single_scans" / f"laser_scan_{k}.json"))
    for log in RADISH:
        path = shared_datasets / "carmen" / f"{log}-corrected.log.gz"
        for scan in itertools.islice(labkit.read_scans(path), 0, 240, 120):
            found += same_as_reference(scan)
    assert found > 10


def test_a_difference_is_seen(monkeypatch):
    """The comparison can fail: kernels whose angles' mean is one bit off give other circles."""
    world = sim.World("demo", circles=(sim.Column((3.0, 0.0), 0.3),))
    scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    assert same_as_reference(scan) > 0
    real = _iav_engine.circle_tests

    def off_by_a_bit(*args):
        verdict, ratio, mean, std, side, lim = real(*args)
        return verdict, ratio, np.nextafter(mean, math.inf), std, side, lim

    monkeypatch.setattr(_iav_batch._engine(), "circle_tests", off_by_a_bit)
    with pytest.raises(AssertionError):
        same_as_reference(scan)
