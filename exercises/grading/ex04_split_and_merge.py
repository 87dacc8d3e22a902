"""Hidden tests of exercise 4, ``split_index(points, threshold_m, min_points)`` and
``similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import math

import numpy as np

import labkit
from labkit.grading import Moved, random_iepf_trace

FUNCTIONS = ("split_index", "similar")
#: Packages the student's code cannot import when graded (labkit never can): a Ramer-Douglas-Peucker.
MASKED = ("rdp",)


def _split_decisions(rng, n_beams=None, **limits):
    """A random scan of walls (valid beams only) and every split decision split-and-merge took on it.

    One range segment of all valid beams, no gap splits, no merging: only split decisions. Yields
    ``(run, threshold_m, min_points, expected)``: the points of a run, and the index where IEPF
    split it or None.
    """
    scan, threshold_m, min_points, steps = random_iepf_trace(rng, n_beams, **limits)
    for step, after in zip(steps, steps[1:], strict=False):
        if step.kind == "fit":
            expected = step.at - step.first if after.kind == "split" else None
            yield scan.xy[step.first:step.last + 1], threshold_m, min_points, expected


def _check_split(split_index, run, threshold_m, min_points, expected, where):
    result = split_index(run, threshold_m, min_points)
    assert (result is None and expected is None) or (result is not None and result == expected), (
        f"{where}: run of {len(run)} points, threshold_m={threshold_m:.3f}, min_points={min_points}:"
        f" split_index should be {expected}, got {result!r}"
    )
    assert result is None or not isinstance(result, bool), "return an int index or None"


def _as_segment(r, alpha):
    return labkit.LineSegment(r=r, alpha=alpha, covariance=np.full((2, 2), np.nan), start=np.zeros(2),
                              end=np.zeros(2), first=0, last=1, n_points=2, error=0.0, indices=np.arange(2))


def _check_similar(similar, r1, alpha1, r2, alpha2, dr_max, dalpha_max):
    expected, _ = labkit.lines_similar(_as_segment(r1, alpha1), _as_segment(r2, alpha2), merge="thresholds",
                                       merge_dr_m=dr_max, merge_dalpha_deg=math.degrees(dalpha_max))
    result = similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max)
    assert isinstance(result, (bool, np.bool_)), f"similar must return True or False, got {result!r}"
    assert result == expected, (
        f"similar({r1:.4f}, {alpha1:.4f}, {r2:.4f}, {alpha2:.4f}, dr_max={dr_max:.3f}, dalpha_max={dalpha_max:.4f})"
        f" should be {expected}, got {result}"
    )


def test_visible(split_index, similar, rng):
    """The visible examples again, moved: runs of points turned, scaled and shifted (the threshold
    scaled), lines turned and scaled (dr_max scaled). Distances scale alike, so every answer stays.
    Earned by functions, not by a table of the visible answers."""
    moved = Moved(rng)
    s = moved.scale
    roof = [[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]]
    steps = [[0.0, 0.0], [1.0, 1.0], [2.0, 0.2], [3.0, 0.1], [4.0, 0.0]]
    runs = [(roof, 0.1, 2, 1), (roof, 0.6, 2, None), ([[0.0, 1.0], [1.0, 2.0], [2.0, 3.0], [3.0, 4.0]], 0.01, 2, None),
            ([[1.0, -1.0], [0.9375, -0.5], [1.25, 0.0], [1.0, 1.0], [1.0, 3.0]], 0.1, 2, 2),
            (steps, 0.1, 2, 1), (steps, 0.1, 4, 2), (steps, 0.3, 4, None)]
    for k, (run, threshold_m, min_points, expected) in enumerate(runs):
        _check_split(split_index, moved.points(run), s * threshold_m, min_points, expected,
                     f"visible run {k + 1}, moved (turned by {moved.angle:.3f} rad, scaled by {s})")
    dr_max, dalpha_max = 0.05, np.radians(5.0)
    pairs = [((2.0, 10.0), (2.03, 12.0), True), ((2.0, 10.0), (2.1, 10.0), False),
             ((2.0, 10.0), (2.0, 20.0), False), ((3.0, 178.0), (3.01, -179.0), True),
             ((0.02, 10.0), (0.01, -170.0), True), ((2.0, 0.0), (2.0, 180.0), False)]
    for k, ((r1, a1), (r2, a2), expected) in enumerate(pairs):
        alpha1, alpha2 = (float(moved.bearing(np.radians(a))) for a in (a1, a2))
        result = similar(s * r1, alpha1, s * r2, alpha2, s * dr_max, dalpha_max)
        assert isinstance(result, (bool, np.bool_)), f"similar must return True or False, got {result!r}"
        assert result == expected, (
            f"visible pair {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}: similar({s * r1:.4f}, "
            f"{alpha1:.4f}, {s * r2:.4f}, {alpha2:.4f}, dr_max={s * dr_max:.3f}, dalpha_max={dalpha_max:.4f}) "
            f"should be {expected}, got {result}")


def test_hidden_random(split_index, similar, rng):
    """Every split decision of ``labkit.split_and_merge`` on 20 random scans; 2000 pairs of lines."""
    n_decisions = 0
    for trial in range(20):
        for run, threshold_m, min_points, expected in _split_decisions(rng):
            _check_split(split_index, run, threshold_m, min_points, expected, f"scan {trial}")
            n_decisions += 1
    assert n_decisions > 100

    for trial in range(2000):
        dr_max, dalpha_max = float(rng.uniform(0.02, 0.3)), float(np.radians(rng.uniform(2.0, 20.0)))
        kind = trial % 4
        if kind == 0:  # nearly equal lines
            r1, alpha1 = rng.uniform(0.0, 6.0), rng.uniform(-np.pi, np.pi)
            r2, alpha2 = abs(r1 + rng.normal(0.0, dr_max)), alpha1 + rng.normal(0.0, dalpha_max)
        elif kind == 1:  # across the wrap at +-pi
            r1, alpha1 = rng.uniform(0.0, 6.0), np.pi - rng.uniform(0.0, dalpha_max)
            r2, alpha2 = abs(r1 + rng.normal(0.0, dr_max)), alpha1 + rng.uniform(0.0, 2 * dalpha_max)
        elif kind == 2:  # through the sensor, normals turned around
            r1, r2, alpha1 = rng.uniform(0.0, dr_max), rng.uniform(0.0, dr_max), rng.uniform(-np.pi, np.pi)
            alpha2 = alpha1 + np.pi + rng.normal(0.0, dalpha_max)
        else:  # unrelated
            r1, r2, alpha1, alpha2 = *rng.uniform(0.0, 6.0, 2), *rng.uniform(-np.pi, np.pi, 2)
        r1, r2 = float(r1), float(r2)
        alpha1, alpha2 = float(labkit.wrap_angle(alpha1)), float(labkit.wrap_angle(alpha2))
        if rng.random() < 0.5:
            r1, alpha1, r2, alpha2 = r2, alpha2, r1, alpha1
        _check_similar(similar, r1, alpha1, r2, alpha2, dr_max, dalpha_max)


SPLIT_CASES = [
    ([[0.0, 0.0], [1.0, 0.0]], 0.01, 2, None),  # two points lie on their chord
    ([[0.0, 0.0], [1.0, 0.3], [2.0, 0.0]], 0.01, 2, 1),
    ([[0.0, 0.0], [1.0, 0.3], [2.0, 0.0]], 0.01, 10, 1),  # too short to protect the ends
    ([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]], 1e-6, 2, None),  # straight
    ([[0.0, 0.0], [1.0, 0.5], [2.0, 0.7], [3.0, 0.0]], 0.1, 10, 2),  # 4 <= 2 * 5: every point
    ([[0.0, 0.0], [1.0, 0.5], [2.0, 0.7], [3.0, 0.0]], 0.1, 1, 2),  # min_points = 1: every point
    ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]], 0.1, 4, None),  # worst is protected
    ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.95], [4.0, 0.0]], 0.1, 2, 3),
    ([[5.0, -2.0], [5.1, -1.0], [5.0, 0.0], [4.7, 1.0], [5.0, 2.0]], 0.2, 2, 3),  # a vertical chord
    ([[-1.0, -1.0], [0.0, 0.2], [1.0, 1.0]], 0.1, 2, 1),  # a diagonal chord: 0.2 / sqrt(2) = 0.14 m
    ([[-1.0, -1.0], [0.0, 0.2], [1.0, 1.0]], 0.15, 2, None),
]
DEG = np.pi / 180
SIMILAR_CASES = [
    (2.0, 0.3, 2.0, 0.3),  # the same line
    (2.0, np.pi, 2.0, -np.pi + 1e-9),  # pi and -pi + 1e-9: the same direction
    (2.0, np.pi, 2.01, -179.0 * DEG), (2.0, -179.0 * DEG, 2.01, 178.0 * DEG), (2.0, 175.0 * DEG, 2.0, -175.0 * DEG),
    (0.0, 0.0, 0.0, np.pi), (0.0, np.pi / 2, 0.0, -np.pi / 2),  # through the sensor, either normal
    (0.01, 90.0 * DEG, 0.01, -89.0 * DEG), (0.03, 0.0, 0.03, np.pi),  # 6 cm apart once turned around
    (3.0, 0.0, 3.0, np.pi), (0.01, 0.0, 0.01, np.pi / 2),  # facing each other; at right angles
    (1.0, 0.0, 1.0, 91.0 * DEG), (1.0, 0.0, 1.0, 89.0 * DEG),
]


def test_hidden_edges(split_index, similar, rng):
    """Short, straight and protected runs, lists; lines across the wrap, through the sensor, facing."""
    for case, (run, threshold_m, min_points, expected) in enumerate(SPLIT_CASES):
        for as_list in (True, False):
            where = f"edge case {case} ({'a list' if as_list else 'an array'})"
            _check_split(split_index, run if as_list else np.array(run), threshold_m, min_points, expected, where)
    for r1, alpha1, r2, alpha2 in SIMILAR_CASES:
        _check_similar(similar, r1, alpha1, r2, alpha2, 0.05, 5.0 * DEG)
        _check_similar(similar, r2, alpha2, r1, alpha1, 0.05, 5.0 * DEG)


def test_own_work(split_index, similar, rng):
    """More split decisions and line pairs: right answers where labkit cannot be imported."""
    decisions = _split_decisions(rng, 400, threshold_m=0.05, min_points=4)
    for _, (run, threshold_m, min_points, expected) in zip(range(40), decisions, strict=False):
        _check_split(split_index, run, threshold_m, min_points, expected, "own work")
    for r1, alpha1, r2, alpha2 in [(0.02, 0.2, 0.01, 0.2 - np.pi), (2.0, 3.1, 2.02, -3.1), (2.0, 0.0, 2.0, np.pi)]:
        _check_similar(similar, r1, alpha1, r2, alpha2, 0.05, 0.1)


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {
    "split_index": '''
import labkit


def split_index(points, threshold_m, min_points):
    points = np.asarray(points, dtype=float)
    r, alpha = labkit.line_through_points(points[0], points[-1])
    distance = np.abs(labkit.geometry.signed_distance_to_line(points, r, alpha))
    keep = min_points // 2
    lo, hi = (keep, len(points) - keep) if len(points) > 2 * keep else (0, len(points))
    worst = lo + int(np.argmax(distance[lo:hi]))
    return worst if distance[worst] > threshold_m else None
''',
    "similar": '''
import labkit


def similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max):
    def line(r, alpha):
        return labkit.LineSegment(r=r, alpha=alpha, covariance=np.eye(2), start=np.zeros(2), end=np.ones(2),
                                  first=0, last=1, n_points=2, error=0.0, indices=np.arange(2))

    return labkit.lines_similar(line(r1, alpha1), line(r2, alpha2), merge_dr_m=dr_max,
                                merge_dalpha_deg=math.degrees(dalpha_max))[0]
''',
}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "the ends of the run are not protected": ("keep = min_points // 2", "keep = 0"),
    "angles compared without wrapping": ("dalpha = wrap(alpha2 - alpha1)", "dalpha = alpha2 - alpha1"),
    "normals never turned around": ("if abs(dalpha) > np.pi / 2:", "if False:"),
}
