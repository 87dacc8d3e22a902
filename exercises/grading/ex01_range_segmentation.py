"""Hidden tests of exercise 1: ``segment(ranges, angles, threshold_m, min_points)`` -> one label per beam, and
``adaptive_threshold(ranges, angles, threshold_m, incidence_deg, range_sigma_m)`` -> one breakpoint distance per
pair of neighbouring beams (Borges & Aldon 2004, floored at ``threshold_m``; NaN next to an invalid beam).

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import math

import numpy as np

import labkit
from labkit.grading import Moved, assert_labels_result, random_wall_beams

FUNCTIONS = ("segment", "adaptive_threshold")


def reference_thresholds(ranges, angles, threshold_m, incidence_deg, range_sigma_m):
    """labkit's breakpoint distances for every pair of neighbours, NaN where either beam is invalid."""
    ranges, angles = np.asarray(ranges, dtype=np.float64), np.asarray(angles, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(ranges) & (ranges > 0)
    d = labkit.breakpoint_thresholds(ranges[:-1], ranges[1:], np.diff(angles), threshold_m,
                                     incidence_deg=incidence_deg, range_sigma_m=range_sigma_m)
    return np.where(valid[:-1] & valid[1:], d, np.nan)


def triangle_side(r, bearing, dphi, incidence_deg):
    """|P_a P_b| by plane geometry, not by the law of sines: P_a = r (cos bearing, sin bearing); a surface leaves
    P_a at ``incidence_deg`` to the beam (turned towards the next beam) and meets the next beam, ``dphi`` further
    round, at P_b. Two lines intersected with np.linalg.solve."""
    lam = math.radians(incidence_deg)
    p_a = r * np.array([math.cos(bearing), math.sin(bearing)])
    along = np.array([math.cos(bearing + lam), math.sin(bearing + lam)])  # the surface's direction
    beam = np.array([math.cos(bearing + dphi), math.sin(bearing + dphi)])  # the next beam's direction
    t, _ = np.linalg.solve(np.column_stack([along, -beam]), -p_a)  # p_a + t along = s beam
    return float(t)


def assert_thresholds(result, expected, ranges, angles, *, atol=1e-12):
    """The student's thresholds against ``expected`` (NaN where no link is possible), in words a student can use."""
    expected = np.asarray(expected, dtype=np.float64)
    if not isinstance(result, np.ndarray):
        raise AssertionError(f"thresholds must be a numpy array, got {type(result).__name__}")
    if result.shape != expected.shape:
        raise AssertionError(f"thresholds must have shape {expected.shape} (one per pair of neighbouring beams), "
                             f"got {result.shape}")
    if not np.issubdtype(result.dtype, np.floating):
        raise AssertionError(f"thresholds must be floats, got dtype {result.dtype}")
    wrong = np.flatnonzero(~np.isclose(result, expected, rtol=1e-9, atol=atol, equal_nan=True))
    if wrong.size:
        i = int(wrong[0])
        r_a, r_b = np.asarray(ranges, dtype=np.float64)[i:i + 2]
        step = math.degrees(float(np.diff(np.asarray(angles, dtype=np.float64)[i:i + 2])[0]))
        raise AssertionError(f"thresholds are wrong: the pair of beams {i} and {i + 1} (ranges {r_a} and {r_b} m, "
                             f"{step:.4f} deg apart) should have {expected[i]!r} m, got {result[i]!r} m")


def test_visible(segment, adaptive_threshold, rng):
    """The visible examples again, turned and scaled (the threshold with them): every gap scales as the
    threshold does, so the labels stay; the breakpoint distances do not turn with the scan and scale with
    the ranges (and with the floor and the noise), angles apart stay. Earned by a function, not by a table
    of the visible answers."""
    moved = Moved(rng, shift=False)
    walls, degrees = [1.0, 1.0, 1.0, 3.0, 3.0, np.nan, 2.0], np.radians(np.arange(7.0))
    holes = [1.0, 1.0, 0.0, 1.0, 1.0, np.inf, 1.0, -1.0, 1.0, 1.0]
    examples = [
        (walls, degrees, 0.08, 2, [0, 0, 0, 1, 1, -1, -1]),
        (walls, degrees, 0.08, 1, [0, 0, 0, 1, 1, -1, 2]),
        (walls, degrees, 0.08, 3, [0, 0, 0, -1, -1, -1, -1]),
        (walls, degrees, 0.04, 2, [0, 0, 0, -1, -1, -1, -1]),
        (holes, np.radians(np.arange(10.0)), 0.08, 2, [0, 0, -1, 1, 1, -1, -1, -1, 2, 2]),
    ]
    for k, (ranges, angles, threshold_m, min_points, labels) in enumerate(examples):
        s = moved.scale
        result = segment(s * np.asarray(ranges), angles + moved.angle, s * threshold_m, min_points)
        try:
            assert_labels_result(result, np.asarray(labels, dtype=np.int64))
        except AssertionError as error:
            raise AssertionError(f"visible example {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}: "
                                 f"{error}") from None

    half, one = np.radians(0.5), np.radians(1.0)
    # (ranges, angles, threshold_m, incidence_deg, range_sigma_m, thresholds): the visible cell's examples
    thresholds = [
        ([1.0, 1.0, 10.0, 10.0], half * np.arange(4.0), 0.08, 10.0, 0.01, [0.08287284, 0.08287284, 0.55872839]),
        ([0.5, 0.5], [0.0, half], 0.08, 10.0, 0.01, [0.08]),
        ([10.0, 12.0], [0.0, one], 0.05, 10.0, 0.02, [1.17563692]),
        ([10.0, 12.0], [0.0, one], 0.05, 20.0, 0.02, [0.59606000]),
        ([4.0, 4.0, 4.0], [0.0, half, half + one], 0.08, 10.0, 0.01, [0.24149136, 0.47625477]),
        ([1.0, 1.0, np.nan, 1.0, 0.0, 1.0], half * np.arange(6.0), 0.08, 10.0, 0.01,
         [0.08287284, np.nan, np.nan, np.nan, np.nan]),
    ]
    for k, (ranges, angles, threshold_m, incidence_deg, sigma, expected) in enumerate(thresholds):
        s = moved.scale
        ranges, angles = s * np.asarray(ranges), np.asarray(angles) + moved.angle
        result = adaptive_threshold(ranges, angles, s * threshold_m, incidence_deg, s * sigma)
        try:
            assert_thresholds(result, s * np.asarray(expected), ranges, angles, atol=1e-8 * s)
        except AssertionError as error:
            raise AssertionError(f"visible threshold example {k + 1}, turned by {moved.angle:.3f} rad and scaled "
                                 f"by {s} (ranges, threshold_m and range_sigma_m): {error}") from None


def random_threshold_scan(rng, **kwargs):
    """Random wall beams and the thresholds' parameters, the sweep narrowed where needed so that every angle
    step stays below the incidence (a wider step must raise ValueError; the edge cases try that)."""
    incidence_deg = float(rng.uniform(5.0, 30.0))
    beams = random_wall_beams(rng, **kwargs)
    angles = beams["angles"]
    widest = np.diff(angles).max() if angles.size > 1 else 0.0
    if widest >= 0.8 * math.radians(incidence_deg):
        beams["angles"] = angles[0] + (angles - angles[0]) * (rng.uniform(0.1, 0.8) * math.radians(incidence_deg)
                                                              / widest)
    return beams, float(rng.uniform(0.03, 0.3)), incidence_deg, float(rng.uniform(0.0, 0.03))


def check_thresholds(adaptive_threshold, beams, threshold_m, incidence_deg, sigma, as_list=False):
    ranges, angles = beams["ranges"], beams["angles"]
    reference = reference_thresholds(ranges, angles, threshold_m, incidence_deg, sigma)
    if as_list:
        ranges, angles = ranges.tolist(), angles.tolist()
    result = adaptive_threshold(ranges, angles, threshold_m, incidence_deg=incidence_deg, range_sigma_m=sigma)
    try:
        assert_thresholds(result, reference, ranges, angles)
    except AssertionError as error:
        setting = f"{len(ranges)} beams as {'lists' if as_list else 'arrays'}, threshold_m={threshold_m:.3f}, " \
            f"incidence_deg={incidence_deg:.2f}, range_sigma_m={sigma:.4f}"
        raise AssertionError(f"adaptive_threshold on a scan of {setting}: {error}") from None


def test_hidden_random(segment, adaptive_threshold, rng):
    """60 random scans of walls (thresholds 3 to 30 cm, min_points 1 to 6) against ``labkit.segment_labels``."""
    for trial in range(60):
        beams = random_wall_beams(rng)
        threshold_m = float(rng.uniform(0.03, 0.3))
        min_points = int(rng.integers(1, 7))
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m=threshold_m, min_points=min_points,
                                           adaptive=False)
        ranges, angles = beams["ranges"], beams["angles"]
        result = segment(ranges, angles, threshold_m, min_points)
        try:
            assert_labels_result(result, reference)
        except AssertionError as error:
            setting = f"{ranges.size} beams, threshold_m={threshold_m:.3f}, min_points={min_points}"
            raise AssertionError(f"random scan {trial} ({setting}): {error}") from None

    for _ in range(30):  # 30 random scans of walls, against labkit.breakpoint_thresholds
        check_thresholds(adaptive_threshold, *random_threshold_scan(rng))
    for trial in range(20):  # against the triangle, built by intersecting two lines
        r, dphi = float(rng.uniform(0.2, 30.0)), math.radians(rng.uniform(0.1, 2.0))
        incidence_deg, bearing = float(rng.uniform(5.0, 45.0)), float(rng.uniform(-3.0, 3.0))
        ranges = np.array([r, r * rng.uniform(1.0, 2.0)])[:: 1 if trial % 2 else -1]  # the smaller one first or last
        result = adaptive_threshold(ranges, np.array([bearing, bearing + dphi]), 1e-9, incidence_deg, 0.0)
        side = triangle_side(r, bearing, dphi, incidence_deg)
        assert isinstance(result, np.ndarray) and result.shape == (1,), f"one threshold for two beams: {result!r}"
        assert math.isclose(float(result[0]), side, rel_tol=1e-9), (
            f"ranges {ranges.tolist()} m, {math.degrees(dphi):.3f} deg apart, incidence_deg={incidence_deg:.2f}, "
            f"no noise, no floor: the triangle gives {side!r} m, got {float(result[0])!r} m")


def test_hidden_edges(segment, adaptive_threshold, rng):
    """Empty and one-beam scans, no valid beam, huge thresholds and min_points, lists, mismatched lengths."""
    cases = [({"ranges": np.zeros(0), "angles": np.zeros(0)}, 0.08, 2)]
    cases += [({"ranges": np.array([r]), "angles": np.array([0.3])}, 0.08, m) for r in (1.0, np.nan) for m in (1, 2)]
    cases += [({"ranges": np.array([1.0, np.nan, 1.0]), "angles": np.array([0.0, 0.001, 0.002])}, 0.08, 1)]
    cases += [(random_wall_beams(rng, n), 0.1, m) for n in (2, 2, 3, 3) for m in (1, 2)]
    cases += [(random_wall_beams(rng, invalid_fraction=1.0, max_beams=50), 0.1, 1) for _ in range(3)]
    cases += [(random_wall_beams(rng, max_beams=200), 1e9, 1) for _ in range(3)]
    cases += [(random_wall_beams(rng, max_beams=30), 0.5, 1000) for _ in range(2)]
    for case, (beams, threshold_m, min_points) in enumerate(cases):
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m=threshold_m, min_points=min_points,
                                           adaptive=False)
        for as_list in (False, True):
            ranges, angles = beams["ranges"], beams["angles"]
            if as_list:
                ranges, angles = ranges.tolist(), angles.tolist()
            result = segment(ranges, angles, threshold_m, min_points)
            try:
                assert_labels_result(result, reference)
            except AssertionError as error:
                setting = f"{len(ranges)} beams as {'lists' if as_list else 'arrays'}, threshold_m={threshold_m}, " \
                    f"min_points={min_points}"
                raise AssertionError(f"edge case {case} ({setting}): {error}") from None

    for n_ranges, n_angles in [(3, 2), (2, 3), (0, 1), (1, 0)]:
        try:
            segment(np.ones(n_ranges), np.linspace(0.0, 1.0, n_angles), 0.08, 2)
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError(f"{n_ranges} ranges and {n_angles} angles must raise ValueError")

    # adaptive_threshold: empty, one and two beams, invalid readings of every kind, lists, uneven steps
    fixed = [({"ranges": np.zeros(0), "angles": np.zeros(0)}, 0.08, 10.0, 0.01),
             ({"ranges": np.array([2.0]), "angles": np.array([0.3])}, 0.08, 10.0, 0.01),
             ({"ranges": np.array([np.nan, 3.0, np.inf, 3.0, -1.0, 3.0, 0.0, 3.0, -np.inf]),
               "angles": np.radians(0.25 * np.arange(9.0))}, 0.05, 10.0, 0.01),
             ({"ranges": np.full(6, 8.0), "angles": np.radians([0.0, 0.5, 1.0, 2.5, 3.0, 5.0])}, 0.08, 10.0, 0.0)]
    drawn = [random_threshold_scan(rng, n_beams=n) for n in (2, 2, 3, 3)]
    drawn += [random_threshold_scan(rng, invalid_fraction=1.0, max_beams=50) for _ in range(2)]
    drawn += [random_threshold_scan(rng, invalid_fraction=0.6, max_beams=200) for _ in range(2)]
    for case in fixed + drawn:
        for as_list in (False, True):
            check_thresholds(adaptive_threshold, *case, as_list=as_list)

    bad = [("ranges and angles of different lengths", ([1.0, 1.0, 1.0], [0.0, 0.01]), {}),
           ("ranges and angles of different lengths", ([1.0], [0.0, 0.01]), {}),
           ("incidence_deg = 0", ([1.0, 1.0], [0.0, 0.01]), {"incidence_deg": 0.0}),
           ("incidence_deg = 90", ([1.0, 1.0], [0.0, 0.01]), {"incidence_deg": 90.0}),
           ("incidence_deg = -10", ([1.0, 1.0], [0.0, 0.01]), {"incidence_deg": -10.0}),
           ("an angle step of 12 degrees with incidence_deg = 10",
            ([1.0, 1.0, 1.0], np.radians([0.0, 1.0, 13.0])), {"incidence_deg": 10.0})]
    for what, (ranges, angles), kwargs in bad:
        try:
            adaptive_threshold(np.asarray(ranges), np.asarray(angles), 0.08, **kwargs)
        except ValueError:
            pass
        else:
            raise AssertionError(f"adaptive_threshold with {what} must raise ValueError")


def test_own_work(segment, adaptive_threshold, rng):
    """Five more random scans: right answers where labkit cannot be imported."""
    for _ in range(5):
        beams = random_wall_beams(rng)
        threshold_m, min_points = float(rng.uniform(0.03, 0.3)), int(rng.integers(1, 7))
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m=threshold_m, min_points=min_points,
                                           adaptive=False)
        args = beams["ranges"], beams["angles"], threshold_m, min_points
        assert_labels_result(segment(*args), reference)
    for _ in range(5):
        check_thresholds(adaptive_threshold, *random_threshold_scan(rng))


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"segment": '''
import labkit


def segment(ranges, angles, threshold_m, min_points):
    scan = labkit.Scan(ranges=ranges, angles=angles)
    return labkit.segment_labels(scan, threshold_m=threshold_m, min_points=min_points, adaptive=False)
''', "adaptive_threshold": '''
import labkit


def adaptive_threshold(ranges, angles, threshold_m=0.08, incidence_deg=10.0, range_sigma_m=0.01):
    ranges, angles = np.asarray(ranges, dtype=float), np.asarray(angles, dtype=float)
    d = labkit.breakpoint_thresholds(ranges[:-1], ranges[1:], np.diff(angles), threshold_m,
                                     incidence_deg=incidence_deg, range_sigma_m=range_sigma_m)
    valid = np.isfinite(ranges) & (ranges > 0)
    return np.where(valid[:-1] & valid[1:], d, np.nan)
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "rejected segments keep their numbers": ("number = np.cumsum(kept) - 1", "number = np.arange(kept.size)"),
    "a segment of exactly min_points beams is rejected": ("sizes >= min_points", "sizes > min_points"),
    "zero and negative readings count as valid": (
        "valid = np.isfinite(ranges) & (ranges > 0)", "valid = np.isfinite(ranges)"
    ),
    "the threshold uses the larger of the two ranges": ("r = np.minimum(ranges[:-1], ranges[1:])",
                                                        "r = np.maximum(ranges[:-1], ranges[1:])"),
    "lambda passed to sin in degrees": ("lam = np.radians(incidence_deg)", "lam = incidence_deg"),
    "no 3 sigma_r term": ("+ 3 * range_sigma_m", ""),
    "sigma_r once instead of three times": ("+ 3 * range_sigma_m", "+ range_sigma_m"),
    "sin(lambda) instead of sin(lambda - dphi)": ("np.sin(lam - dphi)", "np.sin(lam)"),
    "no floor at threshold_m": ("np.maximum(d_max, threshold_m)", "d_max"),
    "one angle step for the whole scan": ("dphi = np.diff(angles)",
                                          "dphi = np.full(angles.size - 1, angles[1] - angles[0]) if angles.size > 1 "
                                          "else np.zeros(0)"),
    "a gap next to an invalid beam keeps a number": ("thresholds[~linked] = np.nan", "pass"),
    "incidence_deg is not checked": ("if not 0 < incidence_deg < 90:", "if False:"),
}
