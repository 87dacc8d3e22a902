"""Hidden tests of exercise 6, ``neighbourhood_bounds(x, eps)`` and ``dbscan_sorted(x, eps, min_pts)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import time

import numpy as np
from sklearn.cluster import DBSCAN

from labkit.dbscan1d import dbscan1d
from labkit.grading import Moved, assert_labels_result

FUNCTIONS = ("neighbourhood_bounds", "dbscan_sorted")
#: Packages the student's code cannot import when graded (labkit never can): the DBSCANs of PyPI.
MASKED = ("sklearn", "dbscan1d")


def _expected(x, eps, min_pts):
    """Bounds by brute force and scikit-learn's labels."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    gap = np.abs(x[:, None] - x[None, :]) <= eps
    labels = DBSCAN(eps=eps, min_samples=min_pts).fit(x[:, None]).labels_
    return gap.argmax(axis=1), x.size - 1 - gap[:, ::-1].argmax(axis=1), labels


def test_visible(neighbourhood_bounds, dbscan_sorted, rng):
    """The visible examples again, scaled by a power of two and shifted by a whole multiple of it (eps
    scaled too): differences scale exactly, so ties at exactly eps stay ties and the bounds and labels
    stay. Earned by functions, not by a table of the visible answers."""
    s = Moved(rng).scale
    shift = float(rng.integers(-50, 51))
    first = [0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0]
    two = [0.0, 0.1, 0.2, 0.3, 5.0, 9.0, 9.1, 9.2]
    examples = [(first, 2.0, 4, [0, 0, 0, 0, 0, 1, 1, 1, 1]), (two, 0.15, 3, [0, 0, 0, 0, -1, 1, 1, 1]),
                (two, 0.15, 5, [-1] * 8), ([0.0, 2.0, 2.5, 3.0], 0.5, 3, [-1, 0, 0, 0]),
                ([0.0, 0.5, 3.0], 1.0, 1, [0, 0, 1])]
    where = f"scaled by {s} and shifted by {s * shift:g}"
    bounds = neighbourhood_bounds(s * (np.array(first) + shift), s * 2.0)
    assert isinstance(bounds, tuple) and len(bounds) == 2, f"visible example 1, {where}: return a tuple (L, U)"
    wanted = [("L", bounds[0], [0, 0, 0, 0, 3, 4, 5, 5, 5]), ("U", bounds[1], [3, 3, 3, 4, 5, 8, 8, 8, 8])]
    for name, value, want in wanted:
        try:
            assert_labels_result(value, np.array(want, dtype=np.int64), name=name, item="point")
        except AssertionError as error:
            raise AssertionError(f"visible example 1, {where}: {error}") from None
    for k, (x, eps, min_pts, labels) in enumerate(examples):
        try:
            assert_labels_result(dbscan_sorted(s * (np.array(x) + shift), s * eps, min_pts),
                                 np.array(labels, dtype=np.int64), item="point")
        except AssertionError as error:
            raise AssertionError(f"visible example {k + 1}, {where}, eps={s * eps:g}, min_pts={min_pts}: "
                                 f"{error}") from None


def test_hidden_random(neighbourhood_bounds, dbscan_sorted, rng):
    """120 random sorted data sets: labels against scikit-learn's DBSCAN, bounds by brute force."""
    for trial in range(120):
        n = int(rng.integers(2, 401))
        if trial % 2 == 0:  # a 0.25 grid: exact differences, so "exactly eps apart" is exact
            x = np.sort(rng.integers(0, int(rng.integers(2, 300)), size=n) * 0.25)
            eps = 0.25 * int(rng.integers(1, 7))
        else:
            x = np.sort(rng.uniform(-20.0, 20.0, size=n) * rng.uniform(0.05, 1.0))
            eps = float(rng.uniform(0.01, 1.0))
        min_pts = int(rng.integers(1, 9))
        setting = f"random data {trial} ({n} points, eps={eps:g}, min_pts={min_pts})"
        gap = np.abs(x[:, None] - x[None, :]) <= eps
        want_lower, want_upper = gap.argmax(axis=1), n - 1 - gap[:, ::-1].argmax(axis=1)
        bounds = neighbourhood_bounds(x, eps)
        assert isinstance(bounds, tuple) and len(bounds) == 2, f"{setting}: return a tuple (L, U)"
        for name, value, want in [("L", bounds[0], want_lower), ("U", bounds[1], want_upper)]:
            try:
                assert_labels_result(value, want, name=name, item="point")
            except AssertionError as error:
                raise AssertionError(f"{setting}: {error}") from None
        reference = DBSCAN(eps=eps, min_samples=min_pts).fit(x[:, None]).labels_
        try:
            assert_labels_result(dbscan_sorted(x, eps, min_pts), reference, item="point")
        except AssertionError as error:
            raise AssertionError(f"{setting}: {error}") from None


def test_hidden_edges(neighbourhood_bounds, dbscan_sorted, rng):
    """N = 0 and 1, min_pts 1 and > N, equal points, huge eps, lists; 200 000 points in O(N)."""
    cases = [([], 1.0, 1), ([], 0.5, 3), ([2.0], 1.0, 1), ([2.0], 1.0, 2), ([-1.5], 0.1, 5)]
    cases += [([3.0] * 7, 0.1, m) for m in (1, 7, 8)]
    cases += [([0.0, 1.0], 1.0, 2), ([0.0, 1.0], 0.75, 2), ([0.0, 1.0], 0.75, 1)]
    cases += [(np.sort(rng.uniform(0, 10, 50)).tolist(), 1e6, m) for m in (1, 50, 51)]
    cases += [(np.sort(rng.integers(0, 40, 60) * 0.25).tolist(), 0.25 * int(rng.integers(1, 4)), 1) for _ in range(5)]
    cases += [(np.sort(rng.integers(0, 40, 30) * 0.25).tolist(), 0.5, 40) for _ in range(2)]
    for case, (x, eps, min_pts) in enumerate(cases):
        want_lower, want_upper, want_labels = _expected(x, eps, min_pts)
        for as_list in (True, False):
            data = list(x) if as_list else np.array(x, dtype=np.float64)
            setting = f"edge case {case} ({len(x)} points as {'a list' if as_list else 'an array'}, eps={eps}, " \
                f"min_pts={min_pts})"
            try:
                bounds = neighbourhood_bounds(data, eps)
                assert isinstance(bounds, tuple) and len(bounds) == 2, "return a tuple (L, U)"
                assert_labels_result(bounds[0], want_lower, name="L", item="point")
                assert_labels_result(bounds[1], want_upper, name="U", item="point")
                assert_labels_result(dbscan_sorted(data, eps, min_pts), want_labels, item="point")
            except AssertionError as error:
                raise AssertionError(f"{setting}: {error}") from None

    # 200 000 sorted points, about 25 per grid value, eps = 1.0: about 225 neighbours each.
    x = np.sort(rng.integers(0, 8000, size=200_000) * 0.25)
    start = time.perf_counter()
    lower, upper = neighbourhood_bounds(x, 1.0)
    labels = dbscan_sorted(x, 1.0, 230)
    seconds = time.perf_counter() - start
    assert seconds < 6.0, f"200 000 points took {seconds:.1f} s: is every pass O(N)?"
    for name, result, reference in [
        ("L", lower, np.searchsorted(x, x - 1.0, side="left")),
        ("U", upper, np.searchsorted(x, x + 1.0, side="right") - 1),
        ("labels", labels, dbscan1d(x, 1.0, 230)),
    ]:
        assert_labels_result(result, reference, name=name, item="point")


def test_own_work(neighbourhood_bounds, dbscan_sorted, rng):
    """Six more data sets: right answers where neither labkit nor scikit-learn can be imported."""
    for _ in range(6):
        x = np.sort(rng.integers(0, 100, size=int(rng.integers(2, 200))) * 0.25)
        eps, min_pts = 0.25 * int(rng.integers(1, 5)), int(rng.integers(1, 8))
        reference = dbscan1d(x, eps, min_pts)
        lower, upper = neighbourhood_bounds(x, eps)
        assert_labels_result(lower, np.searchsorted(x, x - eps, side="left"), name="L", item="point")
        assert_labels_result(upper, np.searchsorted(x, x + eps, side="right") - 1, name="U", item="point")
        assert_labels_result(dbscan_sorted(x, eps, min_pts), reference, item="point")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"dbscan": '''
from labkit.dbscan1d import dbscan1d


def neighbourhood_bounds(x, eps):
    x = np.asarray(x, dtype=np.float64)
    return np.searchsorted(x, x - eps, side="left"), np.searchsorted(x, x + eps, side="right") - 1


def dbscan_sorted(x, eps, min_pts):
    return dbscan1d(x, eps, min_pts)
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "neighbours strictly closer than eps (< instead of <=)": ("abs(xs[u] - xs[i]) <= eps", "abs(xs[u] - xs[i]) < eps"),
    "the point itself not counted in its neighbourhood": (
        "size = (upper - lower + 1).tolist()", "size = (upper - lower).tolist()"
    ),
    "a border point between two clusters joins the later one": (
        "if labels[j] == noise:", "if labels[j] != not_visited:"
    ),
    "noise on the left of a cluster's first core point never becomes a border point": (
        "for j in range(lower[p], p):", "for j in range(p, p):"
    ),
}
