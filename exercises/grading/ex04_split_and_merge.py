"""Hidden tests of exercise 4, ``split_index(points, threshold_m, min_points)`` and
``similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max)``.

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
from labkit.grading import Moved, random_iepf_trace


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
    assert result is None or (isinstance(result, (int, np.integer)) and not isinstance(result, (bool, np.bool_))), (
        f"{where}: return an int index or None, got {type(result).__name__}")
    if expected is None and result is not None:
        raise AssertionError(f"{where}: a run of {len(run)} points that is not split (no allowed point farther from "
                             "the chord than threshold_m), got an index")
    if expected is not None and result is None:
        raise AssertionError(f"{where}: a run of {len(run)} points that is split, got None")
    if result != expected:
        raise AssertionError(f"{where}: a run of {len(run)} points split at another point than the reference (the "
                             "farthest allowed point, the first of equals; the ends protected?)")


def _as_segment(r, alpha):
    return labkit.LineSegment(r=r, alpha=alpha, covariance=np.full((2, 2), np.nan), start=np.zeros(2),
                              end=np.zeros(2), first=0, last=1, n_points=2, error=0.0, indices=np.arange(2))


def _check_similar(similar, r1, alpha1, r2, alpha2, dr_max, dalpha_max, where):
    expected, _ = labkit.lines_similar(_as_segment(r1, alpha1), _as_segment(r2, alpha2), merge="thresholds",
                                       merge_dr_m=dr_max, merge_dalpha_deg=math.degrees(dalpha_max))
    result = similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max)
    assert isinstance(result, (bool, np.bool_)), f"{where}: similar must return True or False, got {result!r}"
    assert result == expected, f"{where}: {'similar' if expected else 'different'} lines, got {result}"


def _random_pair(rng, kind):
    """Two lines and the thresholds: 0 nearly equal, 1 across the wrap at +-pi, 2 through the sensor with the
    normals turned around, 3 unrelated; 4 near a right angle through the sensor (where turning around starts),
    5 similar lines either side of +-pi, 6 one line near the sensor with opposite normals."""
    dr_max, dalpha_max = float(rng.uniform(0.02, 0.3)), float(np.radians(rng.uniform(2.0, 20.0)))
    if kind == 0:
        r1, alpha1 = rng.uniform(0.0, 6.0), rng.uniform(-np.pi, np.pi)
        r2, alpha2 = abs(r1 + rng.normal(0.0, dr_max)), alpha1 + rng.normal(0.0, dalpha_max)
    elif kind == 1:
        r1, alpha1 = rng.uniform(0.0, 6.0), np.pi - rng.uniform(0.0, dalpha_max)
        r2, alpha2 = abs(r1 + rng.normal(0.0, dr_max)), alpha1 + rng.uniform(0.0, 2 * dalpha_max)
    elif kind == 2:
        r1, r2, alpha1 = rng.uniform(0.0, dr_max), rng.uniform(0.0, dr_max), rng.uniform(-np.pi, np.pi)
        alpha2 = alpha1 + np.pi + rng.normal(0.0, dalpha_max)
    elif kind == 3:
        r1, r2, alpha1, alpha2 = *rng.uniform(0.0, 6.0, 2), *rng.uniform(-np.pi, np.pi, 2)
    elif kind == 4:
        (r1, r2), alpha1 = rng.uniform(0.0, dr_max / 2, 2), rng.uniform(-np.pi, np.pi)
        alpha2 = alpha1 + rng.choice([-1.0, 1.0]) * (np.pi / 2 + rng.uniform(-3.0, 3.0) * dalpha_max)
    elif kind == 5:  # similar lines either side of +-pi
        r1 = rng.uniform(0.5, 6.0)
        r2, alpha1 = r1 + rng.uniform(-0.5, 0.5) * dr_max, np.pi - rng.uniform(0.05, 0.45) * dalpha_max
        alpha2 = -np.pi + rng.uniform(0.05, 0.45) * dalpha_max
    else:  # one line near the sensor with opposite normals: similar once turned around
        (r1, r2), alpha1 = rng.uniform(0.0, dr_max / 2.5, 2), rng.uniform(-np.pi, np.pi)
        alpha2 = alpha1 + np.pi + rng.uniform(-0.5, 0.5) * dalpha_max
    r1, r2 = float(r1), float(r2)
    alpha1, alpha2 = float(labkit.wrap_angle(alpha1)), float(labkit.wrap_angle(alpha2))
    if rng.random() < 0.5:
        r1, alpha1, r2, alpha2 = r2, alpha2, r1, alpha1
    return r1, alpha1, r2, alpha2, dr_max, dalpha_max


# ---------------------------------------------------------------------------- split_index
def test_hidden_random__split_index(split_index, rng):
    """Every split decision of ``labkit.split_and_merge`` on 20 random scans."""
    n_decisions = 0
    for trial in range(20):
        for run, threshold_m, min_points, expected in _split_decisions(rng):
            _check_split(split_index, run, threshold_m, min_points, expected, f"random scan {trial}")
            n_decisions += 1
    assert n_decisions > 100


#: Runs whose answer is exact: the grader moves each (a random turn, a power-of-two scale and a shift, the threshold
#: scaled) before it asks. (points, threshold_m, min_points, expected)
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


def test_hidden_edges__split_index(split_index, rng):
    """Short, straight and protected runs, moved to a random place, as lists and arrays; the decisions on random
    runs of two to five points."""
    for case, (run, threshold_m, min_points, expected) in enumerate(SPLIT_CASES):
        moved = Moved(rng)
        points = moved.points(run)
        for as_list in (True, False):
            where = f"edge case {case} ({'a list' if as_list else 'an array'})"
            _check_split(split_index, points.tolist() if as_list else points, moved.scale * threshold_m, min_points,
                         expected, where)
    for trial in range(6):
        for run, threshold_m, min_points, expected in _split_decisions(rng, int(rng.integers(2, 6))):
            _check_split(split_index, run, threshold_m, min_points, expected, f"a short random run {trial}")


def _protected_run(rng):
    """A run along a random line with its farthest point next to an end, protected by ``min_points``, and another
    one farther than the threshold inside: closed-form truth."""
    n, min_points = int(rng.integers(6, 12)), int(rng.integers(4, 6))
    keep = min_points // 2
    inside = int(rng.integers(keep, n - keep))
    offsets = rng.uniform(-0.005, 0.005, n)
    offsets[[0, -1]] = 0.0
    threshold_m = float(rng.uniform(0.05, 0.1))
    offsets[inside] = rng.choice([-1.0, 1.0]) * rng.uniform(1.5, 2.0) * threshold_m
    offsets[rng.choice([keep - 1, n - keep])] = rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 4.0) * threshold_m
    points = np.column_stack([np.arange(n) * rng.uniform(0.05, 0.2), offsets])
    moved = Moved(rng)
    return moved.points(points), moved.scale * threshold_m, min_points, inside


def test_own_work__split_index(split_index, rng):
    """More split decisions, and runs whose farthest point is protected: right answers where labkit cannot be
    imported."""
    decisions = _split_decisions(rng, 400, threshold_m=float(rng.uniform(0.03, 0.08)), min_points=int(rng.integers(3, 6)))
    for _, (run, threshold_m, min_points, expected) in zip(range(40), decisions, strict=False):
        _check_split(split_index, run, threshold_m, min_points, expected, "own work")
    for trial in range(3):
        _check_split(split_index, *_protected_run(rng), f"own work, a protected end {trial}")


# ---------------------------------------------------------------------------- similar
def test_hidden_random__similar(similar, rng):
    """2000 pairs of lines of every kind against ``labkit.lines_similar``."""
    for trial in range(2000):
        _check_similar(similar, *_random_pair(rng, trial % 4), f"random pair {trial}")


DEG = np.pi / 180
#: Pairs whose answer is exact, with thresholds 5 cm and 5 degrees: the grader turns and scales each (dr_max scaled).
SIMILAR_CASES = [
    (2.0, 0.3, 2.0, 0.3),  # the same line
    (2.0, np.pi, 2.0, -np.pi + 1e-9),  # pi and -pi + 1e-9: the same direction
    (2.0, np.pi, 2.01, -179.0 * DEG), (2.0, -179.0 * DEG, 2.01, 178.0 * DEG), (2.0, 175.0 * DEG, 2.0, -175.0 * DEG),
    (0.0, 0.0, 0.0, np.pi), (0.0, np.pi / 2, 0.0, -np.pi / 2),  # through the sensor, either normal
    (0.01, 90.0 * DEG, 0.01, -89.0 * DEG), (0.03, 0.0, 0.03, np.pi),  # 6 cm apart once turned around
    (3.0, 0.0, 3.0, np.pi), (0.01, 0.0, 0.01, np.pi / 2),  # facing each other; at right angles
    (1.0, 0.0, 1.0, 91.0 * DEG), (1.0, 0.0, 1.0, 89.0 * DEG),
]


def test_hidden_edges__similar(similar, rng):
    """Lines across the wrap, through the sensor, facing each other, at right angles: turned and scaled to a random
    place, both orders; random pairs near a right angle through the sensor."""
    for case, (r1, alpha1, r2, alpha2) in enumerate(SIMILAR_CASES):
        moved = Moved(rng, shift=False)
        line1, line2 = moved.line(r1, alpha1), moved.line(r2, alpha2)
        _check_similar(similar, *line1, *line2, moved.scale * 0.05, 5.0 * DEG, f"edge case {case}")
        _check_similar(similar, *line2, *line1, moved.scale * 0.05, 5.0 * DEG, f"edge case {case}, swapped")
    for trial in range(12):
        _check_similar(similar, *_random_pair(rng, 4), f"a pair through the sensor near a right angle {trial}")
    for trial in range(4):
        _check_similar(similar, *_random_pair(rng, 5), f"similar lines either side of the wrap {trial}")
        _check_similar(similar, *_random_pair(rng, 6), f"one line with opposite normals {trial}")


def test_own_work__similar(similar, rng):
    """Twenty more random pairs of every kind: right answers where labkit cannot be imported."""
    for trial in range(21):
        _check_similar(similar, *_random_pair(rng, trial % 7), f"own-work pair {trial}")


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
