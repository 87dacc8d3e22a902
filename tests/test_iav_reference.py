"""The IAV detectors' two faces give the same features and the same steps.

``detect_circles``, ``detect_arcs``, ``detect_legs`` and ``detect_lines_iav`` read as Xavier et
al. (2005): with ``trace=True`` they run their reference, one segment at a time through one short
function per test of the paper (labkit/circles/iav_circles.py, legs.py, lines/iav_lines.py);
without it, the batch engine of labkit/_iav_batch.py, which tests every segment of a scan at once.
Here both run on the same scans with the same parameters, the engine made to record its own trace
as well (its ``want_trace``), and everything is compared bit for bit: every field of every feature
and of every :class:`labkit.Step` (floats by ``float.hex``, arrays by their bytes).

Bit for bit holds because the reference's geometry (labkit.iav) computes as the engine does, one
operation for another: the rays as complex numbers, the sums of the angles taken in order, the
prerequisite's ratio over the squared chord, the noise allowances by the same functions. Two places
could part them in the last bit without an error here: the residual test's circle fit sums a lone
segment's points in another order than a batch of several (fitting.fit_circles' one-run path), and
the IAV centre's side is summed in another order; only the residual test's verdict and the side's
sign reach the features, so they would differ only for a segment within a rounding error of the
residual limit or with its points balanced on the chord.

The scans: random ranges and random worlds (hypothesis), the simulated worlds (hall, office,
corridor, random polygons) at 361 to 2881 beams with 5 mm to 3 cm of noise, the peer's six JSON scans
and the first scans of the six Radish logs (``../shared/datasets``; skipped when absent).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import labkit
from labkit import Scan, sim
from labkit.circles import iav_circles, legs
from labkit.experiments import nguyen_lidar, world_scans
from labkit.lines import iav_lines

RADISH = ("aces", "csail", "freiburg-079", "infinite-corridor", "intel", "orebro")

#: each detector with the settings that take different paths through it
CONFIGS = [
    (labkit.detect_circles, {}),
    (labkit.detect_circles, {"range_sigma_m": 0}),
    (labkit.detect_circles, {"arc_like": True, "center_method": "geometric"}),
    (labkit.detect_circles, {"arc_like": True, "range_sigma_m": 0, "v_corner_stride": 1, "max_chord_m": 1.0}),
    (labkit.detect_legs, {}),
    (labkit.detect_legs, {"range_sigma_m": 0, "center_method": "iav", "chord_padding_beams": 0.0}),
    (labkit.detect_legs, {"iav_mean_range_deg": (80.0, 140.0), "iav_std_max_deg": 10.0, "center_method": "geometric",
                          "reject_occluded": False}),
    (labkit.detect_arcs, {}),
    (labkit.detect_arcs, {"center_method": "iav", "mean_range_deg": (90.0, 170.0)}),
    (labkit.detect_lines_iav, {}),
    (labkit.detect_lines_iav, {"seg_threshold_m": 0.08, "mean_tolerance_deg": 2.0}),
]
_ENGINES = ((iav_circles, "circle_engine"), (legs, "leg_engine"), (iav_lines, "line_engine"))


@contextlib.contextmanager
def engine_traces():
    """While open, each call of a detector's engine also records the engine's own steps (its
    ``want_trace``) in the list yielded; what the detector returns is unchanged."""
    recorded: list = []

    def spy_on(real):
        def spy(*args, **kwargs):
            found, steps = real(*args, **{**kwargs, "want_trace": True})
            recorded.append(steps)
            return found, steps

        return spy

    with pytest.MonkeyPatch.context() as mp:
        for module, name in _ENGINES:
            mp.setattr(module, name, spy_on(getattr(module, name)))
        yield recorded


def _canon(value):
    """``value`` written exactly: floats as hex, arrays as dtype, shape and bytes, records field by field."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value).__name__,) + tuple((f.name, _canon(getattr(value, f.name)))
                                               for f in dataclasses.fields(value))
    if isinstance(value, np.ndarray):
        return (value.dtype.str, value.shape, np.ascontiguousarray(value).tobytes())
    if isinstance(value, (list, tuple)):
        return (type(value).__name__,) + tuple(_canon(v) for v in value)
    if isinstance(value, (float, np.floating)):
        return float(value).hex()
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    return value


def both_faces(detector, scan: Scan, **kwargs) -> tuple[int, int]:
    """The detector's engine (``trace=False``) and its reference (``trace=True``) on ``scan``: the
    same features and the same steps, bit for bit. Returns the numbers of features and steps."""
    with engine_traces() as recorded:
        fast = detector(scan, **kwargs)
        assert len(recorded) == 1, "trace=False must run the engine, once"
        engine_steps = recorded[0]
        reference, steps = detector(scan, **kwargs, trace=True)
        assert len(recorded) == 1, "trace=True must run the reference, not the engine"
    assert _canon(reference) == _canon(fast), (detector.__name__, kwargs)
    assert _canon(steps) == _canon(engine_steps), (detector.__name__, kwargs)
    return len(fast), len(steps)


def all_faces(scan: Scan) -> dict:
    """:func:`both_faces` for every setting of :data:`CONFIGS`; features and steps per detector."""
    counts: dict = {}
    for detector, kwargs in CONFIGS:
        found, steps = both_faces(detector, scan, **kwargs)
        f, s = counts.get(detector.__name__, (0, 0))
        counts[detector.__name__] = (f + found, s + steps)
    return counts


# ---------------------------------------------------------------------------- random scans
def _random_scan(seed: int, n: int, step_deg: float, full: bool, noise: float, dropouts: float) -> Scan:
    """Ranges built from random pieces: walls at any incidence, columns and legs of random radius,
    clutter, with range noise and invalid beams (NaN, inf, 0)."""
    rng = np.random.default_rng(seed)
    if full:
        angles = -math.pi + np.arange(n) * (2 * math.pi / n)
    else:  # (at most 359 degrees)
        angles = np.radians(-90.0 + step_deg * np.arange(min(n, int(359 / step_deg))))
        n = angles.size
    ranges = np.empty(n)
    i = 0
    while i < n:
        m = int(rng.integers(1, 60))
        theta = angles[i:i + m]
        kind = rng.integers(0, 3)
        if kind == 0:  # a wall: r = d / cos(theta - phi)
            d, phi = rng.uniform(0.5, 8.0), theta[0] + rng.uniform(-1.2, 1.2)
            r = d / np.maximum(np.cos(theta - phi), 0.05)
        elif kind == 1:  # a column or a leg centred on one of the beams
            radius, dist = rng.choice([0.04, 0.07, 0.15, 0.3, 0.6]), rng.uniform(0.8, 6.0)
            bearing = theta[len(theta) // 2]
            s = dist * np.sin(theta - bearing)
            inside = np.abs(s) < radius
            r = np.where(inside, dist * np.cos(theta - bearing) - np.sqrt(np.maximum(radius ** 2 - s * s, 0.0)),
                         dist + rng.uniform(0.5, 3.0))
        else:  # clutter
            r = rng.uniform(0.3, 10.0, len(theta))
        ranges[i:i + m] = r
        i += m
    ranges = ranges + rng.normal(0.0, noise, n)
    bad = rng.random(n) < dropouts
    ranges[bad] = rng.choice([np.nan, np.inf, 0.0], int(bad.sum()))
    return Scan(ranges=ranges, angles=angles)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 500), step=st.sampled_from([0.25, 0.5, 1.0]),
       full=st.booleans(), noise=st.sampled_from([0.0, 0.002, 0.01, 0.03]), dropouts=st.sampled_from([0.0, 0.03]))
def test_random_scans(seed, n, step, full, noise, dropouts):
    all_faces(_random_scan(seed, n, step, full, noise, dropouts))


@settings(max_examples=20, deadline=None)
@given(objects=st.lists(st.tuples(st.floats(-4, 4), st.floats(0.5, 6), st.floats(0.04, 0.6)), min_size=1, max_size=6),
       walls=st.lists(st.tuples(st.floats(-6, 6), st.floats(0.5, 8), st.floats(-6, 6), st.floats(0.5, 8)), max_size=3),
       corner=st.floats(0.3, 1.2), full=st.booleans(), seed=st.integers(0, 1000))
def test_random_worlds(objects, walls, corner, full, seed):
    """Columns, legs, walls and a rounded room corner (an arc between two walls) in random places."""
    rounded = (sim.Wall((6.0, -3.0), (6.0, 3.0 - corner)), sim.Wall((6.0 - corner, 3.0), (2.0, 3.0)))
    world = sim.World("random", walls=rounded + tuple(sim.Wall((x0, y0), (x1, y1)) for x0, y0, x1, y1 in walls
                                                      if math.hypot(x1 - x0, y1 - y0) > 0.1),
                      circles=tuple(sim.Column((x, y), r) for y, x, r in objects),
                      arcs=(sim.Arc((6.0 - corner, 3.0 - corner), corner, 0.0, math.pi / 2),))
    lidar = (sim.Lidar.from_fov("ring", 360.0, 1.0, full_circle=True, noise_std_m=0.01) if full
             else sim.Lidar.from_fov("half", 180.0, 0.5, noise_std_m=0.005))
    scan, _ = sim.scan_at(world, lidar, (0.0, 0.0, 0.3), rng=np.random.default_rng(seed))
    all_faces(scan)


def test_given_range_segments_with_their_own_points():
    """Segments given as RangeSegment records carry their own points (the detectors test those)."""
    scan, _ = sim.scan_at(sim.make_world("hall"), sim.LIDARS["lms200"], (0.0, 0.0, 0.0), 3.0,
                          rng=np.random.default_rng(1))
    segments = labkit.range_segments(scan)
    shifted = [labkit.RangeSegment(s.indices, s.points + 0.01 * k) for k, s in enumerate(segments)]
    for segs in (segments, shifted, labkit.segment_labels(scan, adaptive=False)):
        for detector in (labkit.detect_circles, labkit.detect_legs, labkit.detect_lines_iav, labkit.detect_arcs):
            both_faces(detector, scan, segments=segs)


# ---------------------------------------------------------------------------- the simulated worlds
NOISES = (0.005, 0.01, 0.02, 0.03)


@pytest.mark.parametrize("beams", [361, 722, 1441, 2881])
@pytest.mark.parametrize("world", ["hall", "office", "corridor", "random_polygons"])
def test_simulated_worlds(world, beams):
    """Two scans per world and beam count, each world seen at every noise level."""
    found = steps = 0
    rng = np.random.default_rng(beams)
    first = [361, 722, 1441, 2881].index(beams) % 2
    for k, noise in enumerate(NOISES[first::2]):
        for scan, _ in world_scans(world, nguyen_lidar(beams, noise), 1, rng, first_room=beams + k):
            for f, s in all_faces(scan).values():
                found, steps = found + f, steps + s
    assert found > 0 and steps > 20


def test_the_hall_bag_with_its_walking_people():
    """The bundled hall recording: legs and people, columns, a bench, the rolling cylinder."""
    counts = {}
    for scan in itertools.islice(labkit.read_scans(labkit.bundled_data("hall.bag")), 0, 300, 30):
        for name, (f, _) in all_faces(scan).items():
            counts[name] = counts.get(name, 0) + f
    assert counts["detect_legs"] > 0 and counts["detect_circles"] > 0, counts


# ---------------------------------------------------------------------------- real scans
@pytest.mark.shared
def test_the_peers_json_scans(shared_datasets):
    for k in range(1, 7):
        all_faces(labkit.read_json_scan(shared_datasets / "single_scans" / f"laser_scan_{k}.json"))


@pytest.mark.shared
@pytest.mark.parametrize("log", RADISH)
def test_the_radish_logs(shared_datasets, log):
    path = shared_datasets / "carmen" / f"{log}-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    for scan in itertools.islice(labkit.read_scans(path), 0, 24, 4):
        all_faces(scan)


# ---------------------------------------------------------------------------- the check itself
def test_a_difference_between_the_faces_is_seen(monkeypatch):
    """The comparison can fail: a reference that tests the prerequisite band one bit differently
    (inclusive instead of strict) disagrees with the engine on a segment whose ratio is on the band."""
    points = np.array([[2.0, -0.1], [1.9, 0.0], [2.0, 0.1]])
    scan = Scan(ranges=np.hypot(*points.T), angles=np.arctan2(points[:, 1], points[:, 0]))
    edge = labkit.middle_point_offset(scan.points)  # about 0.5: the band (0.1, edge) leaves it out, just
    kwargs = dict(chord_padding_beams=0.0, range_sigma_m=0, middle_range=(0.1, edge), reject_occluded=False)
    assert both_faces(labkit.detect_legs, scan, **kwargs) == (0, 1)
    monkeypatch.setattr(legs, "_in_band", lambda ratio, band, either_side=False: band[0] <= ratio <= band[1])
    with pytest.raises(AssertionError):
        both_faces(labkit.detect_legs, scan, **kwargs)
