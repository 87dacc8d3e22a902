"""Hidden tests of exercise 7: ``local_directions(points)``, ``mean_direction(phi)`` and
``parallel_walls(points, direction, eps_dist)``, the three steps of angular segmentation.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, assert_labels_result

FUNCTIONS = ("local_directions", "mean_direction", "parallel_walls")


def _assert_directions(result, expected, what):
    """Directions modulo pi to 1e-7, NaN where expected, and in [0, pi)."""
    got = np.asarray(result, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    assert got.shape == expected.shape, f"{what}: shape {got.shape}, expected {expected.shape}"
    nan_want, nan_got = np.isnan(expected), np.isnan(got)
    wrong = np.flatnonzero(nan_want != nan_got)
    assert wrong.size == 0, (f"{what}: point {wrong[0]} should {'' if nan_want[wrong[0]] else 'not '}be NaN "
                             "(the first and last point, and triplets with a NaN point, have no direction)")
    ok = ~nan_want
    outside = np.flatnonzero(ok & ~((got >= 0) & (got < np.pi)))
    assert outside.size == 0, f"{what}: {got[outside[0]]} is not in [0, pi): take the direction modulo pi"
    err = np.abs(np.angle(np.exp(2j * (got[ok] - expected[ok])))) / 2
    if err.size:
        k = int(np.argmax(err))
        assert err[k] < 1e-7, (f"{what}: direction {got[ok][k]:.6f}, expected {expected[ok][k]:.6f} (modulo pi): "
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


def test_visible(local_directions, mean_direction, parallel_walls, rng):
    """The visible examples again, turned, scaled and shifted: directions turn with the plane, groups of
    parallel walls stay (with eps_dist scaled). Earned by functions, not by a table of the answers."""
    moved = Moved(rng)
    where = f"turned by {moved.angle:.3f} rad, scaled by {moved.scale}, shifted"
    line = moved.points([[0.0, 1.0], [1.0, 2.0], [2.0, 3.0], [3.0, 4.0]])  # the line y = x + 1
    want = np.full(4, np.mod(np.pi / 4 + moved.angle, np.pi))
    want[[0, -1]] = np.nan
    _assert_directions(local_directions(line), want, f"visible line y = x + 1, {where}")
    phi = np.radians([178.0, 179.5, 2.5, 4.0]) + moved.angle
    _assert_direction(mean_direction(phi), np.mod(np.radians(1.0) + moved.angle, np.pi),
                      f"visible mean of 178, 179.5, 2.5, 4 deg, {where}")
    walls = np.array([[0.0, -0.8], [2.0, -0.8], [4.0, -0.79], [1.0, 1.6], [3.0, 1.6], [5.0, 1.62]])
    labels = parallel_walls(moved.points(walls), float(moved.bearing(0.0)), 0.05 * moved.scale)
    try:
        assert_labels_result(labels, np.array([0, 0, 0, 1, 1, 1]), item="point")
    except AssertionError as error:
        raise AssertionError(f"visible corridor walls, {where}: {error}") from None


def test_hidden_random(local_directions, mean_direction, parallel_walls, rng):
    """30 random scans of walls (directions against labkit.local_directions), 30 random sets of directions
    (against labkit.circular_mean with period pi), 30 random sets of parallel walls."""
    for trial in range(30):
        points, reference = _scan_points(rng, int(rng.integers(1, 5)))
        _assert_directions(local_directions(points), reference, f"random scan {trial} ({len(points)} points)")
    for trial in range(30):
        centre = rng.uniform(-np.pi, 2 * np.pi)
        phi = centre + rng.normal(0.0, rng.uniform(0.01, 0.5), int(rng.integers(1, 200)))
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi),
                          f"random directions {trial} ({phi.size} around {np.degrees(centre):.0f} deg)")
    for trial in range(30):
        direction = rng.uniform(-np.pi, np.pi)
        offsets = rng.choice(rng.uniform(-5.0, 5.0, int(rng.integers(1, 6))), size=int(rng.integers(1, 120)))
        along = rng.uniform(-10.0, 10.0, offsets.size)
        normal, u = np.array([-np.sin(direction), np.cos(direction)]), np.array([np.cos(direction), np.sin(direction)])
        points = offsets[:, None] * normal + along[:, None] * u + rng.normal(0.0, 0.005, (offsets.size, 2))
        eps = float(rng.uniform(0.02, 0.3))
        try:
            assert_labels_result(parallel_walls(points, direction, eps), _wall_labels(points, direction, eps),
                                 item="point")
        except AssertionError as error:
            raise AssertionError(f"random parallel walls {trial} ({offsets.size} points, direction "
                                 f"{direction:.3f}, eps_dist {eps:.3f}): {error}") from None


def test_hidden_edges(local_directions, mean_direction, parallel_walls, rng):
    """Fewer than 3 points, NaN points, vertical and horizontal lines, lists, 100 000 points; the mean of
    one direction, directions beyond [0, pi), an empty input (ValueError); walls exactly eps_dist apart."""
    for n in (0, 1, 2):
        _assert_directions(local_directions(np.ones((n, 2)) * np.arange(n)[:, None]), np.full(n, np.nan),
                           f"{n} points")
    xs = np.linspace(-2.0, 3.0, 9)
    axes_lines = [(np.column_stack([np.full(9, 2.0), xs]), np.pi / 2), (np.column_stack([xs, np.full(9, -1.0)]), 0.0)]
    for points, d in axes_lines:
        want = np.full(9, d)
        want[[0, -1]] = np.nan
        _assert_directions(local_directions(points), want, "a straight line along an axis")
        _assert_directions(local_directions(points.tolist()), want, "a straight line along an axis, as a list")
    points, reference = _scan_points(rng)
    points = points.copy()
    hole = int(rng.integers(3, len(points) - 3))
    points[hole] = np.nan
    reference = reference.copy()
    reference[hole - 1:hole + 2] = np.nan
    _assert_directions(local_directions(points), reference, f"a scan with a NaN point at {hole}")
    angles = np.linspace(-1.0, 1.0, 100_000)
    scan = labkit.Scan(ranges=3.0 / np.cos(angles - 0.3) + rng.normal(0, 0.001, angles.size), angles=angles)
    _assert_directions(local_directions(scan.points), labkit.local_directions(scan), "100 000 points")

    for phi in ([2.0], [np.pi + 0.1], [-0.1, -0.2], [3 * np.pi + 0.05, 0.02]):
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi), f"mean of {phi} (a list)")
    for bad in ([], [0.0, np.pi / 2]):
        try:
            mean_direction(np.array(bad))
        except ValueError:
            pass
        else:
            raise AssertionError(f"mean_direction({bad}) must raise ValueError (no mean direction)")

    on_grid = np.array([0, 0, 0.25, 0.5, 1.5, 1.5, 1.75, 3.0, 3.0, 3.25, 3.5, 5.0])  # offsets, exact ties
    grid = np.column_stack([rng.uniform(-3, 3, 12), on_grid])
    for eps, want in [(0.25, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2, 3]), (0.2, [0, 0, 1, 2, 3, 3, 4, 5, 5, 6, 7, 8])]:
        try:
            assert_labels_result(parallel_walls(grid, 0.0, eps), np.array(want), item="point")
            assert_labels_result(parallel_walls(grid[::-1].tolist(), 0.0, eps), np.array(want)[::-1], item="point")
        except AssertionError as error:
            raise AssertionError(f"walls exactly eps_dist = {eps} apart (offsets on a 0.25 grid): {error}") from None
    assert_labels_result(parallel_walls(np.zeros((0, 2)), 0.3, 0.1), np.zeros(0, dtype=np.int64), item="point")


def test_own_work(local_directions, mean_direction, parallel_walls, rng):
    """A few more right answers, graded where labkit cannot be imported."""
    for _ in range(3):
        points, reference = _scan_points(rng)
        _assert_directions(local_directions(points), reference, "another scan")
        phi = rng.uniform(0.0, 0.3, 20) + rng.uniform(0, np.pi)
        _assert_direction(mean_direction(phi), labkit.circular_mean(phi, period=np.pi), "more directions")
        direction = rng.uniform(-np.pi, np.pi)
        pts = rng.uniform(-5.0, 5.0, (40, 2))
        assert_labels_result(parallel_walls(pts, direction, 0.2), _wall_labels(pts, direction, 0.2), item="point")


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
