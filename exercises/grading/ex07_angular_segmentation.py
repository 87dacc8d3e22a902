"""Hidden tests of exercise 7: ``local_directions(points)``, ``mean_direction(phi)`` and
``parallel_walls(points, direction, eps_dist)``, the three steps of angular segmentation.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, assert_labels_result


def _assert_directions(result, expected, what):
    """Directions modulo pi to 1e-7, NaN where expected, and in [0, pi): the message names the points, not values."""
    got = np.asarray(result, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    assert got.shape == expected.shape, f"{what}: one direction per point, got shape {got.shape}"
    nan_want, nan_got = np.isnan(expected), np.isnan(got)
    wrong = np.flatnonzero(nan_want != nan_got)
    assert wrong.size == 0, (f"{what}: point {wrong[0]} should {'' if nan_want[wrong[0]] else 'not '}be NaN "
                             "(the first and last point, and triplets with a NaN point, have no direction)")
    ok = ~nan_want
    outside = np.flatnonzero(ok & ~((got >= 0) & (got < np.pi)))
    assert outside.size == 0, f"{what}: point {outside[0]} has a direction outside [0, pi): take it modulo pi"
    err = np.abs(np.angle(np.exp(2j * (got[ok] - expected[ok])))) / 2
    bad = np.flatnonzero(err >= 1e-7)
    assert bad.size == 0, (f"{what}: {bad.size} of {err.size} directions differ from the reference (modulo pi): "
                           "TLS through the centred triplet, atan2(2 Sxy, Sxx - Syy) / 2")


def _assert_direction(result, expected, what):
    assert isinstance(result, (float, int, np.floating, np.integer)), \
        f"{what}: return one number, got {type(result).__name__}"
    _assert_directions(np.array([result]), np.array([expected]), what)


def _offsets(points, direction):
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return -points[:, 0] * np.sin(direction) + points[:, 1] * np.cos(direction)


def _wall_labels(points, direction, eps_dist):
    """Groups of offsets, numbered by increasing offset: DBSCAN with min_pts = 1 on the sorted offsets."""
    d = _offsets(points, direction)
    if d.size == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.argsort(d, kind="stable")
    labels = np.empty(d.size, dtype=np.int64)
    labels[order] = labkit.dbscan1d(d[order], eps_dist, 1)
    return labels


def _scan_points(rng, n_walls=3):
    """A scan of a few walls (no gaps), as points, with labkit's local directions."""
    n = int(rng.integers(20, 300))
    start = rng.uniform(-np.pi, np.pi - 2.0)
    angles = start + np.linspace(0.0, rng.uniform(0.5, 1.2), n)
    ranges = np.empty(n)
    cuts = np.sort(rng.choice(np.arange(3, n - 3), size=n_walls - 1, replace=False))
    for part in np.split(np.arange(n), cuts):
        centre = angles[part].mean()
        alpha = centre + rng.uniform(-0.3, 0.3)
        ranges[part] = rng.uniform(1.0, 6.0) / np.cos(angles[part] - alpha)
    ranges += rng.normal(0.0, rng.uniform(0.0, 0.02), n)
    scan = labkit.Scan(ranges=np.abs(ranges), angles=angles, range_max=1e6)
    return scan.points, labkit.local_directions(scan)


def _random_walls(rng):
    direction = rng.uniform(-np.pi, np.pi)
    offsets = rng.choice(rng.uniform(-5.0, 5.0, int(rng.integers(1, 6))), size=int(rng.integers(1, 120)))
    along = rng.uniform(-10.0, 10.0, offsets.size)
    normal, u = np.array([-np.sin(direction), np.cos(direction)]), np.array([np.cos(direction), np.sin(direction)])
    points = offsets[:, None] * normal + along[:, None] * u + rng.normal(0.0, 0.005, (offsets.size, 2))
    return points, direction, float(rng.uniform(0.02, 0.3))


def _check_walls(parallel_walls, points, direction, eps, what):
    try:
        assert_labels_result(parallel_walls(points, direction, eps), _wall_labels(points, direction, eps), item="point")
    except AssertionError as error:
        raise AssertionError(f"{what} ({len(points)} points): {error}") from None


# ---------------------------------------------------------------------------- local_directions
def test_hidden_random__local_directions(local_directions, rng):
    """30 random scans of one to four walls against labkit.local_directions."""
    for trial in range(30):
        points, reference = _scan_points(rng, int(rng.integers(1, 5)))
        _assert_directions(local_directions(points), reference, f"random scan {trial} ({len(points)} points)")


def test_hidden_edges__local_directions(local_directions, rng):
    """Fewer than 3 points, NaN points, lines along the axes (moved), lists, 100 000 points."""
    for n in (0, 1, 2):
        _assert_directions(local_directions(rng.uniform(-5.0, 5.0, (n, 2))), np.full(n, np.nan), f"{n} points")
    moved = Moved(rng, shift=True)
    xs = np.sort(rng.uniform(-3.0, 3.0, int(rng.integers(4, 12))))
    for points, d in [(np.column_stack([np.full(xs.size, rng.uniform(-3, 3)), xs]), np.pi / 2),
                      (np.column_stack([xs, np.full(xs.size, rng.uniform(-3, 3))]), 0.0)]:
        for turn, where in [(None, "a straight line along an axis"), (moved, "a straight line, turned")]:
            pts = points if turn is None else turn.points(points)
            want = np.full(xs.size, np.mod(d + (0.0 if turn is None else turn.angle), np.pi))
            want[[0, -1]] = np.nan
            _assert_directions(local_directions(pts), want, where)
            _assert_directions(local_directions(pts.tolist()), want, f"{where}, as a list")
    points, reference = _scan_points(rng)
    points, reference = points.copy(), reference.copy()
    hole = int(rng.integers(3, len(points) - 3))
    points[hole] = np.nan
    reference[hole - 1:hole + 2] = np.nan
    _assert_directions(local_directions(points), reference, "a scan with a NaN point")
    angles = np.linspace(-1.0, 1.0, 100_000) + rng.uniform(-0.5, 0.5)
    scan = labkit.Scan(ranges=3.0 / np.cos(angles - rng.uniform(-0.2, 0.2)) + rng.normal(0, 0.001, angles.size),
                       angles=angles)
    _assert_directions(local_directions(scan.points), labkit.local_directions(scan), "100 000 points")


def test_own_work__local_directions(local_directions, rng):
    """Three more scans: right answers where labkit cannot be imported."""
    for _ in range(3):
        points, reference = _scan_points(rng)
        _assert_directions(local_directions(points), reference, "another scan")


# ---------------------------------------------------------------------------- mean_direction
def test_hidden_random__mean_direction(mean_direction, rng):
    """30 random sets of directions against labkit.circular_mean with period pi."""
    for trial in range(30):
        centre = rng.uniform(-np.pi, 2 * np.pi)
        phi = centre + rng.normal(0.0, rng.uniform(0.01, 0.5), int(rng.integers(1, 200)))
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi),
                          f"random directions {trial} ({phi.size} of them)")


def test_hidden_edges__mean_direction(mean_direction, rng):
    """One direction, directions beyond [0, pi) and across 0, lists; no direction and cancelling ones
    (ValueError)."""
    near_zero = rng.uniform(0.01, 0.3)
    cases = [("one direction", [float(rng.uniform(0.0, np.pi))]),
             ("one direction beyond pi", [float(np.pi + rng.uniform(0.01, 1.0))]),
             ("negative directions", list(-rng.uniform(0.05, 0.5, 2))),
             ("directions a turn apart, across 0", [float(3 * np.pi + near_zero), float(rng.uniform(0.0, 0.1))]),
             ("directions either side of 0", [float(near_zero), float(np.pi - near_zero / 2)])]
    for what, phi in cases:
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi), f"{what} (a list)")
    a = float(rng.uniform(0.0, np.pi))
    for what, bad in [("no directions", []), ("two directions at right angles (they cancel)", [a, a + np.pi / 2])]:
        try:
            mean_direction(np.array(bad))
        except ValueError:
            pass
        else:
            raise AssertionError(f"mean_direction of {what} must raise ValueError (no mean direction)")


def test_own_work__mean_direction(mean_direction, rng):
    """Three more sets of directions: right answers where labkit cannot be imported."""
    for _ in range(3):
        phi = rng.uniform(0.0, 0.3, 20) + rng.uniform(0, np.pi)
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi), "more directions")


# ---------------------------------------------------------------------------- parallel_walls
def test_hidden_random__parallel_walls(parallel_walls, rng):
    """30 random sets of parallel walls, grouped as labkit.dbscan1d(min_pts=1) groups the sorted offsets."""
    for trial in range(30):
        _check_walls(parallel_walls, *_random_walls(rng), f"random parallel walls {trial}")


def test_hidden_edges__parallel_walls(parallel_walls, rng):
    """Walls exactly eps_dist apart (offsets on a grid, scaled by a power of two), lists, reversed order; no
    points."""
    steps = rng.choice([0.0, 0.25, 0.5, 1.0, 1.25], size=int(rng.integers(6, 14)))
    scale = float(2.0 ** rng.integers(-2, 2))
    offsets = scale * np.cumsum(steps)  # exact: gaps of exactly eps_dist (0.25 or 0.5 scaled) and more
    grid = np.column_stack([rng.uniform(-3, 3, offsets.size), offsets])
    for eps in (0.25 * scale, 0.5 * scale, 0.2 * scale):
        want = _wall_labels(grid, 0.0, eps)
        for what, points, expected in [("walls exactly eps_dist apart", grid, want),
                                       ("walls exactly eps_dist apart, reversed, as a list", grid[::-1].tolist(),
                                        want[::-1])]:
            try:
                assert_labels_result(parallel_walls(points, 0.0, eps), expected, item="point")
            except AssertionError as error:
                raise AssertionError(f"{what}: {error}") from None
    assert_labels_result(parallel_walls(np.zeros((0, 2)), float(rng.uniform(-3, 3)), 0.1), np.zeros(0, dtype=np.int64),
                         item="point")


def test_own_work__parallel_walls(parallel_walls, rng):
    """Three more sets of points: right answers where labkit cannot be imported."""
    for _ in range(3):
        direction = rng.uniform(-np.pi, np.pi)
        _check_walls(parallel_walls, rng.uniform(-5.0, 5.0, (40, 2)), direction, 0.2, "more walls")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"angular": '''
import labkit


def local_directions(points):
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    scan = labkit.Scan(ranges=np.hypot(points[:, 0], points[:, 1]), angles=np.arctan2(points[:, 1], points[:, 0]))
    return labkit.local_directions(scan)


def mean_direction(phi):
    return labkit.circular_mean(phi, period=np.pi)


def parallel_walls(points, direction, eps_dist):
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    d = -points[:, 0] * np.sin(direction) + points[:, 1] * np.cos(direction)
    order = np.argsort(d, kind="stable")
    labels = np.empty(d.size, dtype=np.int64)
    labels[order] = labkit.dbscan1d(d[order], eps_dist, 1)
    return labels
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "direction not taken modulo pi": ("phi = np.mod(0.5 * np.arctan2(2 * sxy, sxx - syy), np.pi)",
                                      "phi = 0.5 * np.arctan2(2 * sxy, sxx - syy)"),
    "mean of the directions, not of the doubled angles (wrap at pi ignored)": (
        "c, s = np.cos(2 * phi).sum(), np.sin(2 * phi).sum()", "c, s = np.cos(phi).sum(), np.sin(phi).sum()"),
    "arithmetic mean of directions": (
        "mean = np.mod(0.5 * np.arctan2(s, c), np.pi)", "mean = np.mod(np.mean(phi), np.pi)"),
    "offset along the line instead of across it": (
        "d = -pts[:, 0] * np.sin(direction) + pts[:, 1] * np.cos(direction)",
        "d = pts[:, 0] * np.cos(direction) + pts[:, 1] * np.sin(direction)"),
    "walls split at gaps of exactly eps_dist (< instead of <=)": ("gaps > eps_dist", "gaps >= eps_dist"),
}
