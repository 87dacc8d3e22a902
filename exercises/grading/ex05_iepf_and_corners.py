"""Hidden tests of exercise 5, ``iepf_lines(points, threshold_m, min_points)`` and ``corner(line1, line2)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, random_iepf_trace

FUNCTIONS = ("iepf_lines", "corner")
#: Packages the student's code cannot import when graded (labkit never can): a Ramer-Douglas-Peucker.
MASKED = ("rdp",)


def _reference_runs(rng, n_beams=None, **limits):
    """A random scan of walls (valid beams only) and the runs labkit's split step accepts on it.

    One range segment of all valid beams, no gap splits, no merging: ``(points, threshold_m,
    min_points, runs)`` with ``runs`` the ``(first, last)`` of every ``accept`` step of
    ``labkit.split_and_merge(..., trace=True)``, in the order it accepted them (scan order).
    """
    scan, threshold_m, min_points, steps = random_iepf_trace(rng, n_beams, **limits)
    runs = [(step.first, step.last) for step in steps if step.kind == "accept"]
    return scan.xy, threshold_m, min_points, runs


def _as_runs(result):
    """The student's runs as a list of (int, int), or an AssertionError saying what is wrong."""
    assert isinstance(result, (list, tuple)), f"return a list of (first, last) pairs, got {result!r}"
    runs = []
    for pair in result:
        assert isinstance(pair, (list, tuple, np.ndarray)) and len(pair) == 2, (
            f"each run is a pair (first, last), got {pair!r}")
        for v in pair:
            assert not isinstance(v, (bool, np.bool_)) and float(v) == int(v), f"indices are ints, got {pair!r}"
        runs.append((int(pair[0]), int(pair[1])))
    return runs


def _check_runs(iepf_lines, points, threshold_m, min_points, expected, where):
    result = _as_runs(iepf_lines(points, threshold_m, min_points))
    assert result == list(expected), (
        f"{where}: {len(points)} points, threshold_m={threshold_m:.3f}, min_points={min_points}: "
        f"iepf_lines should give {list(expected)}, got {result}"
    )


def _check_corner(corner, line1, line2, expected, where):
    result = corner(line1, line2)
    assert isinstance(result, (list, tuple, np.ndarray)) and np.shape(result) == (2,), (
        f"return the point (x, y), got {result!r}")
    assert np.allclose(np.asarray(result, dtype=float), expected, rtol=0.0, atol=1e-7), (
        f"{where}: corner({line1}, {line2}) should be ({expected[0]:.6f}, {expected[1]:.6f}), got {result}")


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


L_RUN = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [4.0, 0.0], [5.0, 0.0],
         [5.0, 1.0], [5.0, 2.0], [5.0, 3.0], [5.0, 4.0], [5.0, 5.0]]
U_RUN = [[0.0, 4.0], [0.0, 3.0], [0.0, 2.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0],
         [3.0, 1.0], [3.0, 2.0]]  # every worst point unique: no ties for a turned copy to break otherwise
VISIBLE_RUNS = [
    (L_RUN, 0.1, 2, [(0, 5), (6, 10)]),
    (L_RUN[:6], 0.1, 2, [(0, 5)]),
    (L_RUN[:3], 0.1, 5, []),
    (U_RUN, 0.1, 2, [(0, 4), (5, 7), (8, 9)]),
    (U_RUN, 0.1, 4, [(0, 4)]),
]
VISIBLE_CORNERS = [((2.0, 0.0), (1.0, np.pi / 2), (2.0, 1.0)),
                   ((np.sqrt(2.0), np.pi / 4), (0.5, 0.0), (0.5, 1.5)),
                   ((1.0, np.pi), (1.0, -np.pi / 2), (-1.0, -1.0))]


def test_visible(iepf_lines, corner, rng):
    """The visible examples again, moved: runs turned, scaled and shifted (the threshold scaled), lines
    moved with the plane and their corner with them. Earned by functions, not a table of the answers."""
    moved = Moved(rng)
    for k, (run, threshold_m, min_points, expected) in enumerate(VISIBLE_RUNS):
        _check_runs(iepf_lines, moved.points(run), moved.scale * threshold_m, min_points, expected,
                    f"visible run {k + 1}, moved (turned by {moved.angle:.3f} rad, scaled by {moved.scale})")
    for k, (line1, line2, point) in enumerate(VISIBLE_CORNERS):
        _check_corner(corner, moved.line(*line1), moved.line(*line2), moved.points([point])[0],
                      f"visible corner {k + 1}, moved")


def test_hidden_random(iepf_lines, corner, rng):
    """The accepted runs of labkit's split step on 20 random scans; 200 random corners."""
    for trial in range(20):
        points, threshold_m, min_points, expected = _reference_runs(rng)
        _check_runs(iepf_lines, points, threshold_m, min_points, expected, f"scan {trial}")
    for trial in range(200):
        line1, line2, point = _random_corner(rng)
        _check_corner(corner, line1, line2, point, f"random corner {trial}")


def test_hidden_edges(iepf_lines, corner, rng):
    """Two points, short and straight runs, protected ends, lists and arrays, 720 points in a line;
    corners through the origin, across the wrap, as lists; parallel lines."""
    runs = [
        ([[0.0, 0.0], [1.0, 0.0]], 0.01, 2, [(0, 1)]),
        ([[0.0, 0.0], [1.0, 0.0]], 0.01, 3, []),
        ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]], 0.1, 4, [(0, 4)]),  # worst is protected
        ([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]], 0.1, 2, [(0, 1), (2, 4)]),
        ([[0.0, 0.0], [1.0, 0.3], [2.0, 0.0]], 0.01, 10, []),
        # a vertical chord x = 5: split at point 3 (0.5 m off), then (0..3) at point 2 (0.33 m from its chord)
        ([[5.0, -2.0], [5.0, -1.0], [5.0, 0.0], [4.5, 1.0], [5.0, 2.0]], 0.2, 2, [(0, 2)]),
        ([[x, 0.5 * x] for x in np.linspace(0.0, 10.0, 720)], 0.001, 5, [(0, 719)]),
    ]
    for case, (run, threshold_m, min_points, expected) in enumerate(runs):
        for as_list in (True, False):
            points = [list(map(float, p)) for p in run] if as_list else np.array(run, dtype=float)
            _check_runs(iepf_lines, points, threshold_m, min_points, expected,
                        f"edge case {case} ({'a list' if as_list else 'an array'})")

    corners = [((0.0, 0.3), (2.0, 0.3 + np.pi / 2), _crossing(0.0, 0.3, 2.0, 0.3 + np.pi / 2)),
               ((1.0, np.pi), (2.0, np.pi / 2), (-1.0, 2.0)),
               ((1.0, -np.pi + 1e-12), (1.0, np.pi / 2), (-1.0, 1.0)),
               ([3.0, 0.0], [4.0, -np.pi / 2], (3.0, -4.0))]
    for case, (line1, line2, point) in enumerate(corners):
        _check_corner(corner, line1, line2, np.asarray(point, dtype=float), f"edge corner {case}")
    for line1, line2 in [((1.0, 0.0), (2.0, 0.0)), ((1.0, 0.0), (1.0, np.pi)), ((0.0, 0.5), (0.0, 0.5 - np.pi)),
                         ((2.0, np.pi), (3.0, -np.pi + 1e-13))]:
        try:
            result = corner(line1, line2)
        except ValueError:
            continue
        raise AssertionError(f"corner({line1}, {line2}): parallel lines never meet, expected ValueError, "
                             f"got {result!r}")


def _crossing(r1, alpha1, r2, alpha2):
    """Closed form for two perpendicular lines: the foot of one plus the other's offset along it."""
    n1, n2 = np.array([np.cos(alpha1), np.sin(alpha1)]), np.array([np.cos(alpha2), np.sin(alpha2)])
    assert abs(n1 @ n2) < 1e-12
    return r1 * n1 + r2 * n2


def test_own_work(iepf_lines, corner, rng):
    """More runs and corners: right answers where labkit cannot be imported."""
    for trial in range(5):
        points, threshold_m, min_points, expected = _reference_runs(rng, 300, threshold_m=0.05, min_points=4)
        _check_runs(iepf_lines, points, threshold_m, min_points, expected, f"own work, scan {trial}")
    for trial in range(20):
        line1, line2, point = _random_corner(rng)
        _check_corner(corner, line1, line2, point, f"own work, corner {trial}")


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
