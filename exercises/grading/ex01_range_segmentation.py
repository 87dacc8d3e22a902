"""Hidden tests of exercise 1: ``segment(ranges, angles, threshold_m, min_points)`` -> one label per beam, and
``adaptive_threshold(ranges, angles, threshold_m, incidence_deg, range_sigma_m)`` -> one breakpoint distance per
pair of neighbouring beams (Borges & Aldon 2004, floored at ``threshold_m``; NaN next to an invalid beam).

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import math

import numpy as np

import labkit
from labkit.grading import assert_labels_result, random_threshold_case, random_wall_beams

INVALID = (np.nan, np.inf, -np.inf, 0.0, -1.0)  # the kinds of invalid reading (a negative one scaled below)


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


def assert_thresholds(result, expected):
    """The student's thresholds against ``expected`` (NaN where no link is possible), without the values."""
    expected = np.asarray(expected, dtype=np.float64)
    if not isinstance(result, np.ndarray):
        raise AssertionError(f"thresholds must be a numpy array, got {type(result).__name__}")
    if result.shape != expected.shape:
        raise AssertionError(f"thresholds must have one value per pair of neighbouring beams, got shape {result.shape}")
    if not np.issubdtype(result.dtype, np.floating):
        raise AssertionError(f"thresholds must be floats, got dtype {result.dtype}")
    nan_wrong = np.flatnonzero(np.isnan(expected) != np.isnan(result))
    if nan_wrong.size:
        raise AssertionError(f"{nan_wrong.size} pairs are nan where they should not be, or not nan next to an invalid "
                             f"beam (the first: beams {nan_wrong[0]} and {nan_wrong[0] + 1})")
    wrong = np.flatnonzero(~np.isclose(result, expected, rtol=1e-9, atol=1e-12, equal_nan=True))
    if wrong.size:
        raise AssertionError(f"{wrong.size} of {expected.size} thresholds differ from the reference (the first: beams "
                             f"{wrong[0]} and {wrong[0] + 1})")


def _check_labels(segment, beams, threshold_m, min_points, what, as_list=False):
    reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m=threshold_m, min_points=min_points,
                                      adaptive=False)
    ranges, angles = beams["ranges"], beams["angles"]
    if as_list:
        ranges, angles = ranges.tolist(), angles.tolist()
    try:
        assert_labels_result(segment(ranges, angles, threshold_m, min_points), reference)
    except AssertionError as error:
        count = f"{len(ranges)} beam{'s' if len(ranges) != 1 else ''}{' as lists' if as_list else ''}"
        raise AssertionError(f"{what} ({count}): {error}") from None


def _check_thresholds(adaptive_threshold, case, what, as_list=False):
    beams, threshold_m, incidence_deg, sigma = case
    ranges, angles = beams["ranges"], beams["angles"]
    reference = reference_thresholds(ranges, angles, threshold_m, incidence_deg, sigma)
    if as_list:
        ranges, angles = ranges.tolist(), angles.tolist()
    result = adaptive_threshold(ranges, angles, threshold_m, incidence_deg=incidence_deg, range_sigma_m=sigma)
    try:
        assert_thresholds(result, reference)
    except AssertionError as error:
        count = f"{len(ranges)} beam{'s' if len(ranges) != 1 else ''}{' as lists' if as_list else ''}"
        raise AssertionError(f"{what} ({count}): {error}") from None


def _mismatched(rng):
    n, m = (int(k) for k in rng.choice(6, size=2, replace=False))
    return rng.uniform(0.5, 5.0, n), np.sort(rng.uniform(-1.0, 1.0, m))


# ---------------------------------------------------------------------------- segment
def test_hidden_random__segment(segment, rng):
    """60 random scans of walls (thresholds 3 to 30 cm, min_points 1 to 6) against ``labkit.segment_labels``."""
    for trial in range(60):
        _check_labels(segment, random_wall_beams(rng), float(rng.uniform(0.03, 0.3)), int(rng.integers(1, 7)),
                      f"random scan {trial}")


def _few_beams(rng, n, invalid=()):
    """``n`` random beams a few centimetres apart, the beams at ``invalid`` replaced by a random invalid reading."""
    angles = float(rng.uniform(-3.0, 2.0)) + np.cumsum(rng.uniform(0.0005, 0.002, n))
    ranges = rng.uniform(0.5, 3.0) + rng.normal(0.0, 0.005, n)
    for i in invalid:
        ranges[i] = INVALID[int(rng.integers(len(INVALID)))] * (rng.uniform(0.1, 5.0) if i % 2 else 1.0)
    return {"ranges": ranges, "angles": angles}


def test_hidden_edges__segment(segment, rng):
    """Empty and one-beam scans, an invalid beam between two, no valid beam, huge thresholds and min_points, two
    and three beams, lists; mismatched lengths."""
    cases = [("an empty scan", {"ranges": np.zeros(0), "angles": np.zeros(0)}, 0.08, int(rng.integers(1, 4)))]
    cases += [("one valid beam", _few_beams(rng, 1), 0.08, m) for m in (1, 2)]
    cases += [("one invalid beam", _few_beams(rng, 1, [0]), 0.08, m) for m in (1, 2)]
    cases += [("an invalid beam between two", _few_beams(rng, 3, [1]), 0.08, 1)]
    cases += [("a scan of two or three beams", random_wall_beams(rng, n), 0.1, m) for n in (2, 2, 3, 3) for m in (1, 2)]
    cases += [("no valid beam", random_wall_beams(rng, invalid_fraction=1.0, max_beams=50), 0.1, 1) for _ in range(3)]
    cases += [("a threshold larger than any gap", random_wall_beams(rng, max_beams=200), 1e9, 1) for _ in range(3)]
    cases += [("min_points larger than the scan", random_wall_beams(rng, max_beams=30), 0.5, 1000) for _ in range(2)]
    for what, beams, threshold_m, min_points in cases:
        for as_list in (False, True):
            _check_labels(segment, beams, threshold_m, min_points, what, as_list)
    for _ in range(4):
        ranges, angles = _mismatched(rng)
        try:
            segment(ranges, angles, 0.08, 2)
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError("ranges and angles of different lengths must raise ValueError")


def _zeros_and_negatives(rng):
    """Beams a few centimetres apart with two zero readings in a row and two equal negative ones in a row: their
    points would lie next to each other (at the sensor, and opposite the beams), so only the rule that they are no
    returns keeps them out of segments."""
    beams = _few_beams(rng, int(rng.integers(10, 20)))
    at = rng.choice(np.arange(1, beams["ranges"].size - 5), 1)[0]
    beams["ranges"][[at, at + 1]] = 0.0
    beams["ranges"][[at + 3, at + 4]] = -float(rng.uniform(0.5, 3.0))
    return beams


def test_own_work__segment(segment, rng):
    """Five more random scans, and one with zero and negative readings in a row: right answers where labkit
    cannot be imported."""
    for trial in range(5):
        _check_labels(segment, random_wall_beams(rng), float(rng.uniform(0.03, 0.3)), int(rng.integers(1, 7)),
                      f"own-work scan {trial}")
    _check_labels(segment, _zeros_and_negatives(rng), 0.08, 2, "own-work scan with zero and negative readings")


# ---------------------------------------------------------------------------- adaptive_threshold
def test_hidden_random__adaptive_threshold(adaptive_threshold, rng):
    """30 random scans of walls against ``labkit.breakpoint_thresholds``; 20 pairs of beams against the triangle
    built by intersecting two lines (no floor, no noise)."""
    for trial in range(30):
        _check_thresholds(adaptive_threshold, random_threshold_case(rng), f"random scan {trial}")
    for trial in range(20):
        r, dphi = float(rng.uniform(0.2, 30.0)), math.radians(rng.uniform(0.1, 2.0))
        incidence_deg, bearing = float(rng.uniform(5.0, 45.0)), float(rng.uniform(-3.0, 3.0))
        ranges = np.array([r, r * rng.uniform(1.0, 2.0)])[:: 1 if trial % 2 else -1]  # the smaller one first or last
        result = adaptive_threshold(ranges, np.array([bearing, bearing + dphi]), 1e-9, incidence_deg, 0.0)
        side = triangle_side(r, bearing, dphi, incidence_deg)
        assert isinstance(result, np.ndarray) and result.shape == (1,), (
            f"two beams have one threshold: an array of shape (1,), got {type(result).__name__}")
        assert math.isclose(float(result[0]), side, rel_tol=1e-9), (
            f"a pair of beams {trial} (no noise, no floor): the threshold differs from the side of the triangle built "
            "by intersecting the surface with the next beam (r the smaller range? lambda in radians?)")


def test_hidden_edges__adaptive_threshold(adaptive_threshold, rng):
    """Empty, one and two beams, invalid readings of every kind, lists, uneven steps; wrong arguments."""
    def case(beams, sigma=None):
        return beams, float(rng.uniform(0.03, 0.1)), float(rng.uniform(8.0, 30.0)), \
            float(rng.uniform(0.0, 0.02)) if sigma is None else sigma

    drawn = [("no beams", case({"ranges": np.zeros(0), "angles": np.zeros(0)})),
             ("one beam", case(_few_beams(rng, 1))),
             ("every kind of invalid reading", case(_few_beams(rng, 9, [0, 2, 4, 6, 8]))),
             ("uneven steps, no noise", case({"ranges": np.full(6, rng.uniform(2.0, 9.0)),
                                              "angles": np.cumsum(np.radians(rng.choice([0.25, 0.5, 1.5], 6)))}, 0.0)),
             ("near the sensor, where the floor decides", ({"ranges": rng.uniform(0.2, 0.5, 8),
                                                           "angles": np.cumsum(np.radians(rng.uniform(0.2, 0.5, 8)))},
                                                          float(rng.uniform(0.1, 0.2)), 10.0, 0.0))]
    drawn += [("a scan of two or three beams", random_threshold_case(rng, n_beams=n)) for n in (2, 2, 3, 3)]
    drawn += [("no valid beam", random_threshold_case(rng, invalid_fraction=1.0, max_beams=50)) for _ in range(2)]
    drawn += [("many invalid beams", random_threshold_case(rng, invalid_fraction=0.6, max_beams=200)) for _ in range(2)]
    for what, drawn_case in drawn:
        for as_list in (False, True):
            _check_thresholds(adaptive_threshold, drawn_case, what, as_list)

    step = math.radians(rng.uniform(0.2, 2.0))
    bad = [("ranges and angles of different lengths", *_mismatched(rng), {}),
           ("an incidence_deg of 0", [1.0, 1.0], [0.0, step], {"incidence_deg": 0.0}),
           ("an incidence_deg of 90 or more", [1.0, 1.0], [0.0, step], {"incidence_deg": float(rng.uniform(90, 180))}),
           ("a negative incidence_deg", [1.0, 1.0], [0.0, step], {"incidence_deg": -float(rng.uniform(1, 60))})]
    incidence = float(rng.uniform(5.0, 20.0))
    steps = np.radians([0.5, incidence * rng.uniform(1.0, 2.0)])
    bad.append(("an angle step wider than incidence_deg", [1.0, 1.0, 1.0], np.concatenate([[0.0], np.cumsum(steps)]),
                {"incidence_deg": incidence}))
    for what, ranges, angles, kwargs in bad:
        try:
            adaptive_threshold(np.asarray(ranges), np.asarray(angles), 0.08, **kwargs)
        except ValueError:
            pass
        else:
            raise AssertionError(f"adaptive_threshold with {what} must raise ValueError")


def test_own_work__adaptive_threshold(adaptive_threshold, rng):
    """Five more random scans: right answers where labkit cannot be imported."""
    for trial in range(5):
        _check_thresholds(adaptive_threshold, random_threshold_case(rng), f"own-work scan {trial}")


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
