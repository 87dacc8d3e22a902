"""The compiled engines give the readable references' results bit for bit.

``split_and_merge(scan)`` runs the engine (labkit/lines/_split_merge_engine.py),
``split_and_merge(scan, trace=True)`` the readable steps; ``segment_labels`` and
``estimate_range_noise(scan)`` run compiled passes whose numpy references stay in their modules.
Compared here: every field of every line (floats by their bits, arrays by their bytes), on random
scans (hypothesis), full-circle rooms, the simulated worlds at 361-2881 beams and 5 mm-3 cm of
noise, and the real recordings (``../shared/datasets``, skipped when absent). The arithmetic the
engines reproduce (numpy's pairwise sums, BLAS's dot rounding, ``math.remainder``, the C library's
functions) is checked on its own first. Last, ``extract_features``' fused default path
(labkit/_pipeline_engine.py) against its stages called one detector at a time (``pipeline._stages``).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labkit
from labkit import Scan, estimate_range_noise, segment_labels, split_and_merge
from labkit import _kernels as K
from labkit.fitting import line_from_sums, placement_probability
from labkit.lines import _split_merge_engine as engine
from labkit.lines import split_merge
from labkit.noise import FIXED_LINES, _robust_sigma, range_noise_residuals
from labkit.segmentation import _segment_labels_reference
from labkit.sim import Lidar, make_world, scan_at, scenario
from tests.line_scans import HEXAGON_ROOM, SQUARE_ROOM, polygon_scan

#: the settings compared: the default (noise followed), the papers' fixed one, and the other branches
SETTINGS = [{}, FIXED_LINES, {"method": "fit"}, {"merge": "none"}, {"weights": "uniform"},
            {"min_points": 3, "max_gap_m": 0.2, "place_confidence": 0.5}]


def every_field(lines) -> list:
    """Every field of every line, exactly (floats by their bits, arrays by dtype, shape and bytes)."""
    out = []
    for ln in lines:
        out.append((float(ln.r).hex(), float(ln.alpha).hex(), ln.first, ln.last, ln.n_points, float(ln.error).hex(),
                    *((a.dtype.str, a.shape, a.tobytes()) for a in (ln.covariance, ln.start, ln.end, ln.indices))))
    return out


def fresh(scan: Scan) -> Scan:
    """The same beams as a new Scan (the noise estimate is cached on a Scan)."""
    return Scan(ranges=scan.ranges, angles=scan.angles, range_min=scan.range_min, range_max=scan.range_max)


def check_identical(scan: Scan, settings=SETTINGS) -> int:
    """The engine's lines equal the reference's on ``scan`` for every setting; the lines compared."""
    count = 0
    for kw in settings:
        fast = split_and_merge(fresh(scan), **kw)
        reference, _ = split_and_merge(fresh(scan), trace=True, **kw)
        assert every_field(fast) == every_field(reference), f"engine != reference with {kw}"
        count += len(fast)
    s = fresh(scan)
    for adaptive in (True, False):
        assert np.array_equal(segment_labels(s, adaptive=adaptive),
                              _segment_labels_reference(s, 0.08, 2, adaptive, 10.0, "auto"))
    assert np.array_equal(K_residuals(s), range_noise_residuals(s)), "noise residuals differ"
    a, b = estimate_range_noise(fresh(scan)), _robust_sigma(range_noise_residuals(s))
    assert a == b or (math.isnan(a) and math.isnan(b))
    return count


def K_residuals(scan: Scan) -> np.ndarray:
    from labkit._noise_engine import residuals

    return residuals(scan.ranges, scan.angles, scan.valid, scan.is_full_circle)


# ---------------------------------------------------------------------------- the arithmetic
def test_pairwise_sums_are_numpys():
    rng = np.random.default_rng(1)
    for n in [*range(0, 140), 255, 511, 1000, 1024, 1025, 2881, 9000]:
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3, n)
        assert K.pairwise_sum(a, n) == float(np.sum(a))
        if n > 6:
            starts = np.array([0, n // 3, n // 2])
            ends = [n // 3, n // 2, n]
            got = [K.segment_sum(a, s, e - s) for s, e in zip(starts.tolist(), ends, strict=True)]
            assert got == np.add.reduceat(a, starts).tolist()
            assert K.sum_at(a, n // 3, n - n // 3) == float(np.sum(a[n // 3:]))


def test_remainder_and_fit_are_pythons():
    rng = np.random.default_rng(2)
    xs = [*rng.uniform(-3 * math.pi + 1e-9, 3 * math.pi - 1e-9, 2000).tolist(), math.pi, -math.pi, 2 * math.pi,
          -2 * math.pi, 0.0, math.nextafter(math.pi, 4.0), math.nextafter(-math.pi, -4.0)]
    for x in xs:
        assert K.remainder_2pi(x) == math.remainder(x, 2 * math.pi)
    for _ in range(500):
        p = rng.normal(size=(6, 2)) * rng.uniform(0.1, 20) + rng.uniform(-10, 10, 2)
        w = rng.uniform(0.05, 1.0, 6)
        sums = (w.sum(), w @ p[:, 0], w @ p[:, 1], w @ p[:, 0] ** 2, w @ p[:, 1] ** 2, w @ (p[:, 0] * p[:, 1]))
        sums = tuple(float(v) for v in sums)
        assert _call_line_from_sums(*sums) == line_from_sums(*sums)


@K.jit
def _call_line_from_sums(a, b, c, d, e, f):
    return K.line_from_sums(a, b, c, d, e, f)


def test_the_c_library_functions_are_numpys():
    """The engines call cos, sin, atan2, hypot, exp and sqrt of the C library where the references
    call numpy's float64 loops: they must agree on this machine (numpy's SIMD loops may not)."""
    rng = np.random.default_rng(3)
    x, y = rng.uniform(-40, 40, 20000), rng.uniform(-40, 40, 20000)
    probe = K.jit(_libm)
    got = probe(x, y)
    assert np.array_equal(got[0], np.cos(x)) and np.array_equal(got[1], np.sin(x))
    assert np.array_equal(got[2], np.arctan2(x, y)) and np.array_equal(got[3], np.hypot(x, y))
    assert np.array_equal(got[4], np.exp(-np.abs(x))) and np.array_equal(got[5], np.sqrt(np.abs(y)))


def _libm(x, y):
    out = np.empty((6, len(x)))
    for i in range(len(x)):
        out[0, i], out[1, i] = math.cos(x[i]), math.sin(x[i])
        out[2, i], out[3, i] = math.atan2(x[i], y[i]), math.hypot(x[i], y[i])
        out[4, i], out[5, i] = math.exp(-abs(x[i])), math.sqrt(abs(y[i]))
    return out


def test_the_dot_rounding_is_found_and_reproduced():
    assert K.FUSED_DOT is not None, "this machine's BLAS rounds (N, 2) @ (2,) in neither known way"
    rng = np.random.default_rng(4)
    xy = rng.uniform(-30, 30, (3000, 2))
    c, s = math.cos(0.7), math.sin(0.7)
    probe = K.jit(_dots)
    assert np.array_equal(probe(xy[17:2900, 0].copy(), xy[17:2900, 1].copy(), c, s, K.FUSED_DOT),
                          xy[17:2900].dot(np.array([c, s])))


def _dots(x, y, c, s, fused):
    out = np.empty(len(x))
    for i in range(len(x)):
        out[i] = K.dot2(x[i], y[i], c, s, fused)
    return out


def test_the_engine_shares_the_references_constants():
    assert (engine._RESIDUAL_Z, engine._SHIFT_Z, engine._SHIFT_MIN_M) == (
        split_merge.RESIDUAL_Z, split_merge.SHIFT_Z, split_merge.SHIFT_MIN_M)
    from labkit import fitting

    assert np.array_equal(engine._GL_U, fitting._GL_U) and np.array_equal(engine._GL_W, fitting._GL_W)


def test_placing_decides_as_the_reference_and_hands_it_the_near_ties():
    rng = np.random.default_rng(5)
    k = 400
    sd = np.stack([rng.uniform(0.002, 0.08, k), rng.uniform(0.002, 0.12, k)], axis=1)
    rho = rng.uniform(-0.99, 0.99, k)
    cov = np.empty((k, 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = sd[:, 0] ** 2, sd[:, 1] ** 2
    cov[:, 0, 1] = cov[:, 1, 0] = rho * sd[:, 0] * sd[:, 1]
    cov[::37] = np.nan
    chance = placement_probability(cov, 0.05, math.radians(3.0))
    for confidence in (0.2, 0.5, 0.8, 0.95):
        verdict = engine._placing(cov, 0.05, math.radians(3.0), confidence, engine._GL_U, engine._GL_W)
        assert np.array_equal(verdict == 1, chance >= confidence)
    # a confidence equal to a line's probability: too close to call in another summation order
    verdict = engine._placing(cov, 0.05, math.radians(3.0), float(chance[1]), engine._GL_U, engine._GL_W)
    assert verdict[1] == 2


# ---------------------------------------------------------------------------- identity on scans
@st.composite
def random_scans(draw):
    """Rooms of random walls, round things and gaps, at random noise, beam counts and fields of view."""
    n = draw(st.integers(20, 900))
    fov = draw(st.sampled_from([math.pi, 1.5 * math.pi, 2 * math.pi]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    full = fov == 2 * math.pi
    angles = -fov / 2 + (fov / n if full else fov / (n - 1)) * np.arange(n)
    walls = [(rng.uniform(0.5, 8.0), rng.uniform(-math.pi, math.pi)) for _ in range(rng.integers(1, 7))]
    c = np.cos(angles[:, None] - np.array([w[1] for w in walls])[None, :])
    ranges = np.where(c > 0.05, np.array([w[0] for w in walls]) / np.where(c > 0.05, c, 1.0), np.inf).min(axis=1)
    for _ in range(rng.integers(0, 4)):  # a post in front of the walls
        k, w = rng.integers(0, n), rng.integers(1, 12)
        ranges[k:k + w] = np.minimum(ranges[k:k + w], rng.uniform(0.3, 3.0))
    ranges = ranges + rng.normal(0.0, draw(st.sampled_from([0.0, 0.002, 0.005, 0.01, 0.02, 0.03])), n)
    if draw(st.booleans()):  # quantised, as the Radish logs' ranges
        ranges = np.round(ranges / 0.01) * 0.01
    ranges[rng.random(n) < draw(st.sampled_from([0.0, 0.02, 0.1]))] = np.nan
    return Scan(ranges=ranges, angles=angles, range_max=20.0)


@settings(max_examples=60)
@given(random_scans())
def test_engine_equals_reference_on_random_scans(scan):
    check_identical(scan)


@pytest.mark.parametrize("walls", [SQUARE_ROOM, HEXAGON_ROOM], ids=["square", "hexagon"])
def test_engine_equals_reference_across_the_seam(walls):
    """Full-circle rooms: a line across the seam, the merge across it."""
    rng = np.random.default_rng(6)
    for n in (360, 720, 1441):
        clean = polygon_scan(walls, n)
        for noise in (0.0, 0.005, 0.02):
            scan = Scan(ranges=clean.ranges + rng.normal(0, noise, n), angles=clean.angles, range_max=100.0)
            check_identical(scan, SETTINGS[:3])


@pytest.mark.parametrize("beams", [361, 722, 1441, 2881])
@pytest.mark.parametrize("noise", [0.005, 0.02, 0.03])
def test_engine_equals_reference_on_simulated_worlds(beams, noise):
    for world in ("hall", "corridor", "office"):
        sc = scenario(world)
        lidar = Lidar(f"t{beams}", -math.pi / 2, math.pi / (beams - 1), beams, range_max=32.0, noise_std_m=noise)
        geometry = make_world(world)
        rng = np.random.default_rng(beams)
        for t in (0.1 * sc.duration_s, 0.6 * sc.duration_s):
            check_identical(scan_at(geometry, lidar, sc.trajectory.pose_at(t), t, rng=rng)[0], SETTINGS[:3])


RADISH = ("aces", "csail", "freiburg-079", "infinite-corridor", "intel", "orebro")


@pytest.mark.shared
@pytest.mark.parametrize("log", RADISH)
def test_engine_equals_reference_on_the_radish_logs(shared_datasets, log):
    for scan in itertools.islice(labkit.read_scans(shared_datasets / "carmen" / f"{log}-corrected.log.gz"), 0, 300, 15):
        check_identical(scan, SETTINGS[:2])  # every 15th of the first 300 scans


@pytest.mark.shared
def test_engine_equals_reference_on_the_peers_scans(shared_datasets):
    for k in range(1, 7):
        check_identical(labkit.read_json_scan(shared_datasets / "single_scans" / f"laser_scan_{k}.json"))


@pytest.mark.shared
def test_the_identity_tests_can_fail(shared_datasets):
    """The other dot rounding (plain instead of fused, or back) changes a worst point on a real
    scan whose quantised ranges tie: the comparisons above see one bit of difference."""
    scan = next(itertools.islice(labkit.read_scans(shared_datasets / "carmen" / "aces-corrected.log.gz"), 287, None))
    s = fresh(scan)
    reference, _ = split_and_merge(s, trace=True, **FIXED_LINES)
    labels = segment_labels(s, range_sigma_m=FIXED_LINES["range_sigma_m"])
    args = (s.points, s.ranges, s.angles, s.valid, labels, False, 0.05, 0.0, 0.03, 5, 0.3, True, 0.2,
            math.radians(10.0), 0.15, False, 0.08, math.radians(10.0), math.radians(3.0), False)
    same = engine.extract(*args, K.FUSED_DOT)
    other = engine.extract(*args, not K.FUSED_DOT)
    spans = [(ln.first, ln.last) for ln in reference]
    assert list(zip(same[3].tolist(), same[4].tolist(), strict=True)) == spans
    assert list(zip(other[3].tolist(), other[4].tolist(), strict=True)) != spans


# ---------------------------------------------------------------------------- caching and the switch
def _twice(x):
    return 2.0 * x


def test_the_engines_compile_where_no_cache_folder_is_writable(monkeypatch):
    """A read-only install with a read-only home: numba finds no cache folder and refuses
    ``cache=True`` when the module is imported; the engines compile uncached instead, and say so."""
    import numba.core.caching as caching
    import numba.core.config

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # (its name before numba 0.62)
    monkeypatch.setattr(impl, "_locator_classes", [])  # (no folder numba may write to)
    monkeypatch.setattr(numba.core.config, "CACHE_LOCATOR_CLASSES", "", raising=False)
    monkeypatch.setattr(K, "_WARNED", [], raising=False)
    with pytest.warns(RuntimeWarning, match="no writable cache folder"):
        twice = K.jit(_twice)
    assert twice(21.0) == 42.0


def test_LABKIT_NO_JIT_runs_the_readable_code_without_numba(tmp_path):
    """``LABKIT_NO_JIT=1``: numba is never imported and the features are the engine's."""
    import json
    import os
    import subprocess
    import sys

    room = polygon_scan(SQUARE_ROOM, 361)
    scan = Scan(ranges=room.ranges + np.random.default_rng(5).normal(0.0, 0.01, 361), angles=room.angles)
    np.savez(tmp_path / "scan.npz", ranges=scan.ranges, angles=scan.angles)
    code = ("import json, sys, numpy as np, labkit\n"
            f"d = np.load({str(tmp_path / 'scan.npz')!r})\n"
            "s = labkit.Scan(ranges=d['ranges'], angles=d['angles'])\n"
            "lines = labkit.split_and_merge(s)\n"
            "out = {'lines': [[float(x).hex() for x in (ln.r, ln.alpha, ln.error)] + [ln.first, ln.last]"
            " for ln in lines], 'labels': labkit.segment_labels(s).tolist(),"
            " 'sigma': float(labkit.estimate_range_noise(s)).hex(), 'numba': 'numba' in sys.modules}\n"
            "f = labkit.extract_features(labkit.Scan(ranges=d['ranges'], angles=d['angles']))\n"
            "out['features'] = [f.labels.tolist(), f.counts(), [[float(x).hex() for x in (ln.r, ln.alpha, ln.error)]"
            " + [ln.first, ln.last] for ln in f.lines], [[float(x).hex() for x in c.point] for c in f.corners]]\n"
            "print(json.dumps(out))\n")
    env = dict(os.environ, LABKIT_NO_JIT="1")
    got = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True, timeout=120).stdout)
    s = fresh(scan)
    assert got["numba"] is False
    assert got["lines"] == [[float(x).hex() for x in (ln.r, ln.alpha, ln.error)] + [ln.first, ln.last]
                            for ln in split_and_merge(s)]
    assert got["labels"] == segment_labels(s).tolist()
    assert got["sigma"] == float(estimate_range_noise(fresh(scan))).hex()
    assert len(got["lines"]) >= 4
    f = labkit.extract_features(fresh(scan))  # (the fused path here, the stages' readable code there)
    assert got["features"] == [f.labels.tolist(), f.counts(), [[float(x).hex() for x in (ln.r, ln.alpha, ln.error)]
                                                               + [ln.first, ln.last] for ln in f.lines],
                               [[float(x).hex() for x in c.point] for c in f.corners]]


# ---------------------------------------------------------------------------- the pipeline's default path
# extract_features runs labkit._pipeline_engine where the engines cover the Config: the same stages
# with the scan's quantities worked out once. Compared with the stages as pipeline.py reads them
# (pipeline._stages: each detector called with its section, each detector compared with its readable
# reference above and in tests/test_iav_engine.py), every field of every feature, by its bits.
from labkit import Config, pipeline  # noqa: E402
from labkit import _noise_engine as NE  # noqa: E402
from labkit import _pipeline_engine as fused  # noqa: E402
from labkit import _segmentation_engine as SE  # noqa: E402
from labkit._kernels import H_STATUS, S_STATUS  # noqa: E402
from labkit.noise import FIXED_CONFIG  # noqa: E402
from labkit.segmentation import segment_order  # noqa: E402
from tests.test_iav_reference import _canon, _random_scan  # noqa: E402

#: configurations the fused path covers (every branch of its plan), and one it hands back to the stages
CONFIGS = [Config(), Config().updated(FIXED_CONFIG),
           Config().updated({"lines": {"method": "split_and_merge", "skip_round": False, "weights": "uniform"},
                             "legs": {"center_method": "iav", "reject_occluded": False},
                             "circles": {"center_method": "geometric", "min_points": 3}}),
           Config().updated({"legs.enabled": False, "corners.enabled": False, "lines.merge": "none"}),
           Config().updated({"circles.enabled": False, "segmentation.adaptive": False, "lines.method": "none"}),
           Config().updated({"legs": {"iav_std_max_deg": 20.0}, "circles": {"arc_like": True}, "arcs.enabled": True})]


def the_features(f) -> tuple:
    """Every field of a :class:`labkit.Features` but the timings, exactly; and the timings' stages."""
    fields = (f.stamp_ns, f.n_beams, f.labels, f.lines, f.corners, f.circles, f.arcs, f.legs, f.people)
    return _canon(fields), tuple(f.timings)


def fused_equals_stages(scan: Scan, configs=CONFIGS) -> int:
    """The fused path's features equal the stages' for every config on ``scan``; how many features."""
    a, b = estimate_range_noise(fresh(scan)), _robust_sigma(range_noise_residuals(fresh(scan)))
    assert a == b or (math.isnan(a) and math.isnan(b))
    found = 0
    for cfg in configs:
        assert fused.plan_for(cfg) is not None
        fast = labkit.extract_features(fresh(scan), cfg)
        stages = pipeline._stages(fresh(scan), cfg)
        assert the_features(fast) == the_features(stages), cfg
        found += sum(fast.counts().values())
    return found


def test_the_fused_path_runs_here_and_hands_back_what_it_does_not_cover():
    assert pipeline._engine() == (fused.plan_for, fused.extract) and fused.READY
    for changes in ({"lines.method": "ransac"}, {"lines.merge": "chi2"}):
        cfg = Config().updated(changes)
        assert fused.plan_for(cfg) is None
        scan = polygon_scan(SQUARE_ROOM, 361)
        assert the_features(labkit.extract_features(fresh(scan), cfg)) == the_features(pipeline._stages(scan, cfg))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 600), step=st.sampled_from([0.25, 0.5, 1.0]),
       full=st.booleans(), noise=st.sampled_from([0.0, 0.005, 0.02, 0.03]), dropouts=st.sampled_from([0.0, 0.05]))
def test_the_fused_path_equals_the_stages_on_random_scans(seed, n, step, full, noise, dropouts):
    fused_equals_stages(_random_scan(seed, n, step, full, noise, dropouts), CONFIGS[:3])


@pytest.mark.parametrize("beams", [180, 361, 541, 722, 1441, 2881])
def test_the_fused_path_equals_the_stages_on_simulated_worlds(beams):
    from labkit.app.experiments import nguyen_lidar, world_scans

    found = 0
    rng = np.random.default_rng(beams)
    for world, noise in zip(("hall", "office", "corridor"), (0.005, 0.02, 0.03), strict=True):
        for scan, _ in world_scans(world, nguyen_lidar(beams, noise), 1, rng):
            found += fused_equals_stages(scan, CONFIGS if beams == 361 else CONFIGS[:2])
    assert found > 0


@pytest.mark.shared
def test_the_fused_path_equals_the_stages_on_real_scans(shared_datasets):
    found = 0
    for k in range(1, 7):
        found += fused_equals_stages(labkit.read_json_scan(shared_datasets / "single_scans" / f"laser_scan_{k}.json"),
                                     CONFIGS[:2])
    for log in RADISH:
        path = shared_datasets / "carmen" / f"{log}-corrected.log.gz"
        for scan in itertools.islice(labkit.read_scans(path), 0, 300, 60):
            found += fused_equals_stages(scan, CONFIGS[:2])
    assert found > 100


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from([0.0, -1.0, 0.05, 0.5, 1.0, 3.0, 29.999, 30.0, 31.0, math.inf, -math.inf, math.nan]),
                min_size=0, max_size=40), st.floats(0.0, 1.0))
def test_the_scans_beams_are_the_scans_own(ranges, range_min):
    """valid and points of the compiled pass (the fused path's, and Scan.valid and Scan.points'
    once the engines are loaded): numpy's mask and ``polar_to_cartesian``, by their bits."""
    from labkit.scan import polar_to_cartesian

    rng = np.random.default_rng(len(ranges))
    r = np.array(ranges) * rng.uniform(0.5, 1.5, len(ranges))
    angles = -3.0 + np.cumsum(rng.uniform(0.01, 6.0 / max(len(r), 1), len(r)))
    scan = Scan(ranges=r, angles=angles, range_min=range_min, range_max=30.0)
    with np.errstate(invalid="ignore"):
        want_valid = np.isfinite(r) & (r > 0) & (r >= range_min) & (r < 30.0)
    want_points = polar_to_cartesian(r, angles)
    want_points[~want_valid] = np.nan
    valid, points = fused._scan_beams(fresh(scan))
    assert "labkit._segmentation_engine" in sys.modules
    for v, p in ((valid, points), (scan.valid, scan.points)):
        assert _canon((v, p)) == _canon((want_valid, want_points))
        assert not v.flags.writeable and not p.flags.writeable


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(-1, 4), min_size=1, max_size=30), st.lists(st.integers(0, 29), max_size=4),
       st.booleans())
def test_the_runs_of_a_stage_are_the_stages_own(sizes, firsts, seam):
    """The segments _runs lays out: pipeline._mask_segments, then segment_order and the points
    gathered, as the detectors' _runs_from_labels does."""
    labels = np.concatenate([np.full(abs(s) + 1, k if s >= 0 else -1) for k, s in enumerate(sizes)]).astype(np.int64)
    labels = np.where(labels >= 0, np.unique(labels[labels >= 0], return_inverse=True)[1].reshape(-1)[
        np.cumsum(labels >= 0) - 1], -1) if (labels >= 0).any() else labels
    if seam and labels[0] >= 0 and labels[-1] >= 0:
        labels[labels == labels[-1]] = labels[0]  # a segment across the seam
    n = labels.size
    points = np.random.default_rng(n).normal(size=(n, 2))
    firsts = [f for f in firsts if f < n]

    class _Taken:
        def __init__(self, first):
            self.first = first

    rest_ref = pipeline._mask_segments(labels, [_Taken(f) for f in firsts])
    idx_ref, starts_ref, ends_ref = segment_order(rest_ref)
    rest, idx, xy, starts, ends = SE.runs(labels, np.array(firsts, dtype=np.int64), points)
    assert _canon((rest, idx, starts, ends)) == _canon((rest_ref, idx_ref, starts_ref, ends_ref))
    assert _canon(np.ascontiguousarray(xy.T)) == _canon(points.take(idx_ref, axis=0))


def test_the_erf_shortcut_of_placing_is_exact():
    """From z = 6 on the placing's erf approximation is 1.0 exactly (the shortcut skips its exp):
    the formula in Python floats, and the kernel against it on both sides of the shortcut."""
    def cdf(x):
        z = abs(x) / math.sqrt(2.0)
        t = 1.0 / (1.0 + 0.3275911 * z)
        poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))))
        return 0.5 * (1.0 + math.copysign(1.0 - poly * math.exp(-z * z), x))

    for z in np.linspace(engine._ERF_ONE, 60.0, 5000).tolist():
        assert cdf(z * math.sqrt(2.0)) == 1.0 and cdf(-z * math.sqrt(2.0)) == 0.0
    for x in np.random.default_rng(7).uniform(-12.0, 12.0, 3000).tolist():
        assert engine._normal_cdf(x) == cdf(x)


def test_the_fused_identity_test_can_fail(monkeypatch):
    """One bit off in one point of the fused pass's beams (the first point of a line, whose end
    it gives), and the comparison sees it."""
    room = polygon_scan(SQUARE_ROOM, 361)
    scan = Scan(ranges=room.ranges + np.random.default_rng(3).normal(0.0, 0.01, 361), angles=room.angles)
    fused_equals_stages(scan, CONFIGS[:1])
    beams = fused.beams
    first = labkit.extract_features(fresh(scan)).lines[1].first

    def one_bit_off(*args):
        valid, points = beams(*args)
        points[first, 0] = np.nextafter(points[first, 0], np.inf)
        return valid, points

    monkeypatch.setattr(fused, "beams", one_bit_off)
    with pytest.raises(AssertionError):
        fused_equals_stages(scan, CONFIGS[:1])


@settings(max_examples=150, deadline=None)
@given(st.lists(st.sampled_from([0.0, 0.001, 0.002, 0.0025, 0.01, 0.3, 1e-300, 7.0]), min_size=1, max_size=60),
       st.integers(0, 2**32 - 1))
def test_the_median_of_the_noise_is_numpys(values, seed):
    """The quickselect of the fused noise estimate: numpy.partition's value at every k, with ties."""
    a = np.array(values) * np.random.default_rng(seed).choice([1.0, 1.0, 1.5], len(values))
    for k in range(len(a)):
        assert NE.kth_smallest(a, k) == np.partition(a, k)[k]


def test_the_noise_estimate_with_a_nan_residual_is_numpys(monkeypatch):
    """Where a residual is NaN the compiled start hands the robust sigma to numpy's partition."""
    z = np.random.default_rng(8).normal(0.0, 0.01, 200)
    z[[5, 50, 199]] = np.nan
    monkeypatch.setattr(NE, "robust_start", lambda *args: (np.abs(z), math.nan, z[:0], False))
    from labkit import noise

    got = NE.robust_sigma(None, None, None, False, noise.MIN_RESIDUALS, noise._MAD_TO_SIGMA, noise._CUT,
                          noise._CUT_SD)
    assert got.hex() == _robust_sigma(z).hex() and math.isfinite(got)


def test_the_fused_path_on_scans_with_little_in_them():
    """No beam, one, two, none valid, every beam valid but apart: the stages' (empty) features."""
    scans = [Scan(ranges=np.zeros(0), angles=np.zeros(0)), Scan(ranges=[1.0], angles=[0.0]),
             Scan(ranges=[1.0, 1.0], angles=[0.0, 0.01]), Scan(ranges=np.full(50, np.nan), angles=np.arange(50.0) / 10),
             Scan(ranges=np.arange(1.0, 41.0), angles=np.arange(40.0) / 10, range_max=100.0)]
    for scan in scans:
        fused_equals_stages(scan, CONFIGS[:1])


# ---------------------------------------------------------------------------- the stages' passes
def _hall_scan() -> Scan:
    """A simulated hall at 361 beams with lines, corners, circles, legs and people in it."""
    from labkit.app.experiments import nguyen_lidar, world_scans

    return world_scans("hall", nguyen_lidar(361, 0.005), 1, np.random.default_rng(361))[0][0]


def test_the_fused_records_are_frozen_and_pickle():
    """Every array of every record the fused path builds is read-only (as the stages' records are),
    the features come back from a pickle as they went in, field by field, and the Features record
    is one its own ``__init__`` would build."""
    import pickle

    features = labkit.extract_features(fresh(_hall_scan()))
    assert all(len(getattr(features, k)) for k in features.LAYERS if k != "arcs"), features.counts()
    for layer in features.LAYERS:
        for record in getattr(features, layer):
            for f in dataclasses.fields(record):
                value = getattr(record, f.name)
                if isinstance(value, np.ndarray):
                    assert not value.flags.writeable, (layer, f.name)
    assert the_features(pickle.loads(pickle.dumps(features))) == the_features(features)
    # built by its fields in one update: the same instance dictionary as Features(...) gives, still frozen
    rebuilt = labkit.Features(*(getattr(features, f.name) for f in dataclasses.fields(labkit.Features)))
    assert type(features) is labkit.Features and list(vars(features)) == list(vars(rebuilt))
    assert the_features(rebuilt) == the_features(features) and repr(rebuilt) == repr(features)
    with pytest.raises(dataclasses.FrozenInstanceError):
        features.lines = ()  # type: ignore[misc]


def _one_bit_off(kernel, which: int):
    """``kernel`` with every float of its result ``which`` one bit larger."""
    def off(*args):
        out = list(kernel(*args))
        out[which] = np.nextafter(out[which], np.inf)
        return tuple(out)
    return off


@pytest.mark.parametrize("name, which, config", [("stage_pass", 2, 0), ("line_pass", 0, 0), ("lines_pass", 0, 2),
                                                   ("leg_pass", 3, 2), ("circle_pass", 4, 2)])
def test_the_passes_identity_tests_can_fail(monkeypatch, name, which, config):
    """One bit off in the floats a pass hands back (the two passes of the default Config: the legs'
    and circles', the lines' and corners'; the staged passes of a Config they do not cover: the
    lines' r, alpha, ..., the leg runs' padded chords and angles, the circle runs' angles and
    limits), and the comparison with the stages sees it."""
    scan = _hall_scan()
    configs = CONFIGS[config:config + 1]
    assert (fused.plan_for(configs[0]).packed is None) == (config == 2)
    fused_equals_stages(scan, configs)
    monkeypatch.setattr(fused, name, _one_bit_off(getattr(fused, name), which))
    with pytest.raises(AssertionError):
        fused_equals_stages(scan, configs)


def test_two_passes_cover_the_default_and_hand_the_rest_to_the_stages(monkeypatch):
    """The configurations :func:`labkit._iav_engine.stage_pass` and ``line_pass`` cover run them
    once per scan; a scan they cannot finish (a fit for numpy's least squares, a subnormal distance,
    a placing too close to call) gets the staged path's features, the same."""
    covered = [fused.plan_for(cfg).packed is not None for cfg in CONFIGS]
    assert covered == [True, True, False, True, False, False]
    scan = _hall_scan()
    calls = []
    stage_pass, line_pass = fused.stage_pass, fused.line_pass

    def counted(*args):
        calls.append(1)
        return stage_pass(*args)

    monkeypatch.setattr(fused, "stage_pass", counted)
    fused_equals_stages(scan, [CONFIGS[0], CONFIGS[1], CONFIGS[3]])
    assert len(calls) == 3

    def refused_lines(*args):
        fo, io = line_pass(*args)
        io[H_STATUS] = 2
        return fo, io

    def refused_stages(*args):
        labels, rest, fo, io = stage_pass(*args)
        io[S_STATUS] = 1
        return labels, rest, fo, io

    staged = []
    monkeypatch.setattr(fused, "_staged", lambda *a, _s=fused._staged: staged.append(1) or _s(*a))
    monkeypatch.setattr(fused, "stage_pass", refused_stages)
    fused_equals_stages(scan, CONFIGS[:1])
    monkeypatch.setattr(fused, "stage_pass", stage_pass)
    monkeypatch.setattr(fused, "line_pass", refused_lines)
    fused_equals_stages(scan, CONFIGS[:1])
    assert len(staged) == 2


def test_the_passes_hypot_is_pythons():
    """``math.hypot`` is CPython's own algorithm, which the C library's ``hypot`` (numba's) misses in
    the last bit about once in 170 pairs; the passes' :func:`labkit._kernels.py_hypot` gives
    Python's on pairs of every scale a scan has, and the zeros, infinities and NaN; and the passes
    hand a subnormal distance to Python."""
    from numba import njit

    @njit
    def both(x, y):
        out = np.empty((2, len(x)))
        for i in range(len(x)):
            out[0, i], out[1, i] = K.py_hypot(x[i], y[i]), math.hypot(x[i], y[i])
        return out

    assert K.py_hypot_is_pythons()
    rng = np.random.default_rng(33)
    x, y = rng.normal(size=(2, 200_000)) * 10.0 ** rng.integers(-4, 3, (2, 200_000))
    ours, libm = both(x, y)
    python = np.array([math.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)])
    assert np.array_equal(ours, python)
    assert not np.array_equal(libm, python)  # (what the port is for)
    assert not K.py_hypot_in_range(1e-310, 0.0) and K.py_hypot_in_range(0.0, 0.0) and K.py_hypot_in_range(1e-310, 1.0)


def test_the_passes_time_their_stages_by_perf_counters_clock():
    """The passes read the clock :func:`time.perf_counter` reads (so a stage's time is its own);
    every stage's time is >= 0 and they add up to no more than the total."""
    import time

    from numba import njit

    @njit
    def clock():
        return K.monotonic_ns()

    clock()
    assert K.MONOTONIC_CLOCK
    for _ in range(5):
        before = time.perf_counter()
        now = clock() * 1e-9
        after = time.perf_counter()
        assert before <= now <= after
    features = labkit.extract_features(fresh(_hall_scan()))
    t = features.timings
    assert list(t) == ["segmentation", "legs", "circles", "lines", "corners", "arcs", "total"]
    assert min(t.values()) >= 0.0 and sum(t.values()) - t["total"] <= t["total"] * (1 + 1e-9)


def test_split_and_merges_pass_identity_test_can_fail(monkeypatch):
    """The same for :func:`labkit.split_and_merge`'s default path."""
    scan = _hall_scan()
    check_identical(scan, SETTINGS[:1])
    monkeypatch.setattr(engine, "lines_pass", _one_bit_off(engine.lines_pass, 0))
    with pytest.raises(AssertionError):
        check_identical(scan, SETTINGS[:1])


def test_the_records_hand_near_ties_to_the_reference():
    """A line the compiled placing cannot call (2) is kept exactly when the reference's own
    probability reaches the confidence; the lines it calls are kept as called."""
    s = fresh(_hall_scan())
    labels = segment_labels(s, range_sigma_m=0.01)
    out, ints, beams = engine.lines_pass(s.points, s.ranges, s.angles, s.valid, labels, False, 0.05, 0.0, 0.03, 5,
                                         0.3, True, 0.2, math.radians(10.0), 0.15, False, 0.08, math.radians(10.0),
                                         math.radians(3.0), False, K.FUSED_DOT, 0.01, True, 0.05, math.radians(3.0),
                                         0.8, engine._GL_U, engine._GL_W)
    k = len(out)
    assert k >= 4
    chance = placement_probability(out[:, 7:].reshape(-1, 2, 2), 0.05, math.radians(3.0))
    confidence = float(np.median(chance))
    ints[:, 4] = 2
    ints[0, 4] = 0  # called: dropped whatever its chance
    kept = engine.records(out.copy(), ints, beams.copy(), 0.05, 3.0, confidence)
    want = [i for i in range(1, k) if chance[i] >= confidence]
    assert 0 < len(want) < k - 1
    assert [ln.first for ln in kept] == ints[want, 0].tolist()
    assert [float(ln.r).hex() for ln in kept] == [float(x).hex() for x in out[want, 0]]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 12), st.booleans(), st.sampled_from([10.0, 30.0, 60.0]),
       st.sampled_from([0.05, 0.3, 2.0]), st.sampled_from([0.0, 0.1, 1.0]))
def test_the_corners_pass_is_find_corners(seed, k, wrap, min_angle_deg, max_gap_m, max_extension_m):
    """Random lines (some ending on neighbouring beams, some parallel, some dropped by the placing):
    the compiled corners are :func:`labkit.find_corners`' own, field by field."""
    from labkit import _pipeline_engine as pe
    from labkit.features import LineSegment, find_corners

    rng = np.random.default_rng(seed)
    out = np.zeros((k, 11))
    out[:, 0] = rng.uniform(0.2, 6.0, k)
    out[:, 1] = rng.choice([rng.uniform(-math.pi, math.pi), 0.5, math.pi / 2], k)  # (repeats: parallel lines)
    out[:, 3:7] = rng.uniform(-4.0, 4.0, (k, 4))
    out[1:, 3:5] = out[:-1, 5:7] + rng.choice([0.0, 0.01, 0.2, 1.0], (k - 1, 1))  # ends near the next start
    ints = np.zeros((k, 5), np.int64)
    ints[:, 0] = np.cumsum(rng.integers(1, 12, k))
    ints[:, 1] = ints[:, 0] + rng.integers(0, 3, k)
    ints[:, 4] = rng.random(k) < 0.8
    keep = np.flatnonzero(ints[:, 4]).tolist()
    frozen = out.copy()
    frozen.setflags(write=False)
    lines = [LineSegment(float(out[i, 0]), float(out[i, 1]), frozen[i, 7:].reshape(2, 2), frozen[i, 3:5],
                         frozen[i, 5:7], int(ints[i, 0]), int(ints[i, 1]), 2, 0.0, np.zeros(2, np.int64))
             for i in keep]
    kw = {"min_angle_deg": min_angle_deg, "max_gap_m": max_gap_m, "max_extension_m": max_extension_m}
    got = pe._corners(lines, (frozen, ints, keep), kw, wrap) if len(lines) > 1 else []
    want = find_corners.unchecked(lines, **kw, wrap=wrap) if len(lines) > 1 else []
    assert _canon(got) == _canon(want)
