"""Hidden tests of exercise 5, ``iepf_lines(points, threshold_m, min_points)`` and ``corner(line1, line2)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, random_iepf_trace


def _reference_runs(rng, n_beams=None, **limits):
    """A random scan of walls (valid beams only) and the runs labkit's split step accepts on it.

    One range segment of all valid beams, no gap splits, no merging: ``(points, threshold_m,
    min_points, runs)`` with ``runs`` the ``(first, last)`` of every ``accept`` step of
    ``labkit.split_and_merge(..., trace=True)``, in the order it accepted them (scan order).
    """
    scan, threshold_m, min_points, steps = random_iepf_trace(rng, n_beams, **limits)
    runs = [(step.first, step.last) for step in steps if step.kind == "accept"]
    return scan.xy, threshold_m, min_points, runs


def _as_runs(result, where):
    """The student's runs as a list of (int, int), or an AssertionError saying what is wrong."""
    assert isinstance(result, (list, tuple)), f"{where}: return a list of (first, last) pairs, got {type(result).__name__}"
    runs = []
    for pair in result:
        assert isinstance(pair, (list, tuple, np.ndarray)) and len(pair) == 2, (
            f"{where}: each run is a pair (first, last), got a {type(pair).__name__}")
        for v in pair:
            assert isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) \
                and float(v) == int(v), f"{where}: indices are ints, got a {type(v).__name__}"
        runs.append((int(pair[0]), int(pair[1])))
    return runs


def _check_runs(iepf_lines, points, threshold_m, min_points, expected, where):
    result = _as_runs(iepf_lines(points, threshold_m, min_points), where)
    expected = list(expected)
    if result == expected:
        return
    if sorted(result) == sorted(expected):
        raise AssertionError(f"{where}: the right lines in another order (scan order: the left half first)")
    if len(result) != len(expected):
        raise AssertionError(f"{where} ({len(points)} points): {len(result)} lines, not the number the split step "
                             "accepts (ends protected? runs shorter than min_points dropped?)")
    first = next(k for k, (a, b) in enumerate(zip(result, expected, strict=True)) if a != b)
    raise AssertionError(f"{where} ({len(points)} points): line {first} of {len(expected)} starts or ends at another "
                         "point than the reference (the worst point ends the left half?)")


def _check_corner(corner, line1, line2, expected, where):
    result = corner(line1, line2)
    assert isinstance(result, (list, tuple, np.ndarray)) and np.shape(result) == (2,), (
        f"{where}: return the point (x, y), got a {type(result).__name__} of shape {np.shape(result)}")
    error = float(np.max(np.abs(np.asarray(result, dtype=float) - expected)))
    if not error <= 1e-7:
        raise AssertionError(f"{where}: the point is off by more than 1e-07 m (the sign of x or y? the determinant?)")


def _line_through(point, alpha):
    """The line through ``point`` with normal direction ``alpha``, in normal form (r >= 0)."""
    r = float(point[0] * np.cos(alpha) + point[1] * np.sin(alpha))
    if r < 0:
        r, alpha = -r, alpha + np.pi
    return r, float(labkit.wrap_angle(alpha))


def _random_corner(rng):
    """Two lines through a random point at least 5 degrees apart, and that point: closed-form truth."""
    point = rng.uniform(-10.0, 10.0, 2)
    alpha1 = rng.uniform(-np.pi, np.pi)
    alpha2 = alpha1 + rng.choice([-1.0, 1.0]) * rng.uniform(np.radians(5.0), np.radians(175.0))
    return _line_through(point, alpha1), _line_through(point, alpha2), point


# ---------------------------------------------------------------------------- iepf_lines
def test_hidden_random__iepf_lines(iepf_lines, rng):
    """The accepted runs of labkit's split step on 20 random scans."""
    for trial in range(20):
        _check_runs(iepf_lines, *_reference_runs(rng), f"random scan {trial}")


#: Runs whose answer is exact (points, threshold_m, min_points, lines): the grader moves each to a random place.
RUNS = [
    ([[0.0, 0.0], [1.0, 0.0]], 0.01, 2, [(0, 1)]),
    ([[0.0, 0.0], [1.0, 0.0]], 0.01, 3, []),
    ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]], 0.1, 4, [(0, 4)]),  # worst is protected
    ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]], 0.1, 2, [(0, 1), (2, 4)]),
    ([[0.0, 0.0], [1.0, 0.3], [2.0, 0.0]], 0.01, 10, []),
    # a vertical chord x = 5: split at point 3 (0.5 m off), then (0..3) at point 2 (0.33 m from its chord)
    ([[5.0, -2.0], [5.0, -1.0], [5.0, 0.0], [4.5, 1.0], [5.0, 2.0]], 0.2, 2, [(0, 2)]),
]


def test_hidden_edges__iepf_lines(iepf_lines, rng):
    """Two points, short and straight runs, protected ends, moved to a random place, as lists and arrays; a long
    straight run; short random scans."""
    for case, (run, threshold_m, min_points, expected) in enumerate(RUNS):
        moved = Moved(rng)
        points = moved.points(run)
        for as_list in (True, False):
            _check_runs(iepf_lines, points.tolist() if as_list else points, moved.scale * threshold_m, min_points,
                        expected, f"edge case {case} ({'a list' if as_list else 'an array'})")
    n = int(rng.integers(500, 800))
    along = np.cumsum(rng.uniform(0.005, 0.02, n))
    points = Moved(rng).points(np.column_stack([along, rng.uniform(-1e-4, 1e-4, n)]))
    _check_runs(iepf_lines, points, float(rng.uniform(0.001, 0.01)) * 2, int(rng.integers(2, 8)), [(0, n - 1)],
                "a long straight run")
    for trial in range(6):
        _check_runs(iepf_lines, *_reference_runs(rng, int(rng.integers(2, 8))), f"a short random scan {trial}")


def test_own_work__iepf_lines(iepf_lines, rng):
    """More runs: right answers where labkit cannot be imported."""
    for trial in range(5):
        _check_runs(iepf_lines, *_reference_runs(rng, 300, threshold_m=float(rng.uniform(0.03, 0.08)),
                                                 min_points=int(rng.integers(3, 6))), f"own work, scan {trial}")


# ---------------------------------------------------------------------------- corner
def test_hidden_random__corner(corner, rng):
    """200 random corners against the point their lines were drawn through."""
    for trial in range(200):
        _check_corner(corner, *_random_corner(rng), f"random corner {trial}")


def test_hidden_edges__corner(corner, rng):
    """Corners through the origin, across the wrap, as lists and tuples; parallel lines (ValueError)."""
    point = rng.uniform(-5.0, 5.0, 2)
    alpha = rng.uniform(-np.pi, np.pi)
    cases = [("a line through the sensor", (0.0, float(labkit.wrap_angle(alpha))), _line_through(point, alpha + 1.2),
              None),
             ("lines at right angles", _line_through(point, alpha), _line_through(point, alpha + np.pi / 2), point),
             ("a normal at pi", _line_through([-rng.uniform(0.5, 5.0), point[1]], np.pi),
              _line_through(point, rng.uniform(0.3, 2.8)), None),
             ("a normal a hair above -pi", (float(rng.uniform(0.5, 5.0)), -np.pi + 1e-12),
              _line_through(point, rng.uniform(0.3, 2.8)), None)]
    for where, line1, line2, expected in cases:
        if expected is None:  # the point both lines pass through, solved here by Cramer's rule
            (r1, a1), (r2, a2) = line1, line2
            det = np.cos(a1) * np.sin(a2) - np.sin(a1) * np.cos(a2)
            expected = np.array([r1 * np.sin(a2) - r2 * np.sin(a1), r2 * np.cos(a1) - r1 * np.cos(a2)]) / det
        for form in (tuple, list):
            _check_corner(corner, form(line1), form(line2), expected, f"edge corner: {where}")
    for where, turn in [("parallel lines", 0.0), ("parallel lines, normals opposite", np.pi),
                        ("parallel lines, normals pi and -pi", None)]:
        r1, r2 = rng.uniform(0.5, 5.0, 2)
        if turn is None:
            line1, line2 = (float(r1), np.pi), (float(r2), -np.pi + 1e-13)
        else:
            a = float(rng.uniform(-np.pi, np.pi))
            line1, line2 = (float(r1), a), (float(r2), float(labkit.wrap_angle(a + turn)))
        try:
            corner(line1, line2)
        except ValueError:
            continue
        raise AssertionError(f"{where} never meet: expected ValueError")


def test_own_work__corner(corner, rng):
    """Twenty more random corners: right answers where labkit cannot be imported."""
    for trial in range(20):
        _check_corner(corner, *_random_corner(rng), f"own work, corner {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {
    "iepf_lines": '''
import labkit


def iepf_lines(points, threshold_m, min_points):
    points = np.asarray(points, dtype=float)
    scan = labkit.Scan(ranges=np.hypot(points[:, 0], points[:, 1]), angles=np.arctan2(points[:, 1], points[:, 0]))
    _, steps = labkit.split_and_merge(scan, split_threshold_m=threshold_m, min_points=min_points, merge=None,
                                      min_length_m=0.0, max_gap_m=1e9, segment_threshold_m=1e9,
                                      adaptive_segmentation=False, trace=True)
    return [(s.first, s.last) for s in steps if s.kind == "accept"]
''',
    "corner": '''
import labkit


def corner(line1, line2):
    point = labkit.geometry.intersect_lines(line1[0], line1[1], line2[0], line2[1])
    if point is None:
        raise ValueError("parallel")
    return tuple(point)
''',
}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "the ends of the run are not protected": ("keep = min_points // 2", "keep = 0"),
    "the halves come out of scan order": (
        "stack.append((a + worst + 1, b))  # the right half, done after the left one\n"
        "            stack.append((a, a + worst + 1))  # the worst point ends the left half",
        "stack.append((a, a + worst + 1))  # the worst point ends the left half\n"
        "            stack.append((a + worst + 1, b))  # the right half, done after the left one"),
    "the worst point is in both halves": ("(a + worst + 1, b))", "(a + worst, b))"),
    "short runs are kept": ("if n < min_points:", "if n < 2:"),
    "y of the corner has the wrong sign": ("(r2 * c1 - r1 * c2) / det", "(r1 * c2 - r2 * c1) / det"),
    "parallel lines are not refused": ("if abs(det) < 1e-9:", "if False:"),
}
