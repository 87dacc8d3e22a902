"""Hidden tests of exercise 6: ``neighbourhood_bounds(x, eps)``, ``dbscan_sorted(x, eps, min_pts,
border)`` and ``dbscan_circular(x, eps, min_pts, period, border)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.

The references are independent of the code under test: scikit-learn's DBSCAN (on the values, or on
a precomputed matrix of circular distances), a brute-force search for the bounds, and labkit's
``dbscan1d`` for the inputs too large for a distance matrix. Random data mostly lie on a 0.25 grid
(with periods that are multiples of 0.25), where every difference is exact, so "exactly eps apart"
is decided the same way by every method.

Time: every graded call takes well under a second for an O(N) solution (0.1 to 0.3 s for the
largest, on the course's 2-core machine). The two large inputs of ``test_hidden_edges`` have
neighbourhoods of about 2000 points, so that a search that starts again from every point, or any
O(N^2) pass, takes ten seconds or more: the grader's 5 s per call stops it, and a call that still
takes over ``LARGE_CALL_S`` fails with a message that says why.
"""

import time

import numpy as np
from sklearn.cluster import DBSCAN

from labkit import dbscan1d
from labkit.grading import Moved, assert_labels_result

FUNCTIONS = ("neighbourhood_bounds", "dbscan_sorted", "dbscan_circular")
#: Packages the student's code cannot import when graded (labkit never can): the DBSCANs of PyPI.
MASKED = ("sklearn", "dbscan1d")
#: Seconds one call on a large input may take (an O(N) solution: 0.1 to 0.3 s; O(N^2): 10 s and more).
LARGE_CALL_S = 3.0


def _sklearn_labels(x, eps, min_pts, period=None):
    """scikit-learn's labels for both border policies, ``{"first": ..., "noise": ...}``: fitted on the
    values, or on the circular distances; "noise" keeps its core points only."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return {"first": np.zeros(0, dtype=np.int64), "noise": np.zeros(0, dtype=np.int64)}
    if period is None:
        fit = DBSCAN(eps=eps, min_samples=min_pts).fit(x[:, None])
    else:
        d = np.abs(x[:, None] - x[None, :])
        fit = DBSCAN(eps=eps, min_samples=min_pts, metric="precomputed").fit(np.minimum(d, period - d))
    first = fit.labels_.astype(np.int64)
    noise = np.full(x.size, -1, dtype=np.int64)
    noise[fit.core_sample_indices_] = first[fit.core_sample_indices_]
    return {"first": first, "noise": noise}


def _bounds(x, eps):
    """Bounds by brute force over all pairs."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    gap = np.abs(x[:, None] - x[None, :]) <= eps
    return gap.argmax(axis=1), x.size - 1 - gap[:, ::-1].argmax(axis=1)


def _check_bounds(neighbourhood_bounds, x, eps, setting):
    bounds = neighbourhood_bounds(x, eps)
    assert isinstance(bounds, tuple) and len(bounds) == 2, f"{setting}: return a tuple (L, U)"
    for name, value, want in zip("LU", bounds, _bounds(x, eps), strict=True):
        try:
            assert_labels_result(value, want, name=name, item="point")
        except AssertionError as error:
            raise AssertionError(f"{setting}: {error}") from None


def _check_labels(result, want, setting):
    try:
        assert_labels_result(result, want, item="point")
    except AssertionError as error:
        raise AssertionError(f"{setting}: {error}") from None


def _timed(name, what, function, *args):
    """``function(*args)``, failed when it takes longer than ``LARGE_CALL_S``."""
    start = time.perf_counter()
    result = function(*args)
    seconds = time.perf_counter() - start
    assert seconds < LARGE_CALL_S, f"{name} on {what} took {seconds:.1f} s: is every pass O(N)?"
    return result


def _grid(rng, n, values):
    """``n`` sorted points on a 0.25 grid of ``values`` values: ties, duplicates, exact differences."""
    return np.sort(rng.integers(0, values, size=n) * 0.25)


def test_visible(neighbourhood_bounds, dbscan_sorted, dbscan_circular, rng):
    """The visible examples again, scaled by a power of two (eps and period too) and, on the line,
    shifted by a whole multiple of it: differences scale exactly, so ties at exactly eps stay ties and
    the bounds and labels stay. Earned by functions, not by a table of the visible answers."""
    s = Moved(rng).scale
    shift = float(rng.integers(-50, 51))
    first = [0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0]
    two = [0.0, 0.1, 0.2, 0.3, 5.0, 9.0, 9.1, 9.2]
    left = [0.0, 2.0, 2.5, 3.0]
    examples = [(first, 2.0, 4, "first", [0, 0, 0, 0, 0, 1, 1, 1, 1]),
                (two, 0.15, 3, "first", [0, 0, 0, 0, -1, 1, 1, 1]),
                (two, 0.15, 5, "first", [-1] * 8), (left, 0.5, 3, "first", [-1, 0, 0, 0]),
                ([0.0, 0.5, 3.0], 1.0, 1, "first", [0, 0, 1]),
                (first, 2.0, 4, "noise", [0, 0, 0, 0, -1, 1, 1, 1, 1]), (left, 0.5, 3, "noise", [-1, -1, 0, -1])]
    where = f"scaled by {s} and shifted by {s * shift:g}"
    bounds = neighbourhood_bounds(s * (np.array(first) + shift), s * 2.0)
    assert isinstance(bounds, tuple) and len(bounds) == 2, f"visible example 1, {where}: return a tuple (L, U)"
    wanted = [("L", bounds[0], [0, 0, 0, 0, 3, 4, 5, 5, 5]), ("U", bounds[1], [3, 3, 3, 4, 5, 8, 8, 8, 8])]
    for name, value, want in wanted:
        try:
            assert_labels_result(value, np.array(want, dtype=np.int64), name=name, item="point")
        except AssertionError as error:
            raise AssertionError(f"visible example 1, {where}: {error}") from None
    for k, (x, eps, min_pts, border, labels) in enumerate(examples):
        _check_labels(dbscan_sorted(s * (np.array(x) + shift), s * eps, min_pts, border), labels,
                      f"visible example {k + 1}, {where}, eps={s * eps:g}, min_pts={min_pts}, border={border!r}")
    circular = [([0.5, 1.0, 4.0, 4.5, 5.0, 9.0, 9.5], 1.0, 3, 10.0, "first", [0, 0, 1, 1, 1, 0, 0]),
                ([0.5, 1.0, 4.0, 4.5, 5.0, 9.0, 9.5], 1.0, 3, 10.0, "noise", [0, -1, 1, 1, 1, -1, 0]),
                ([0.0, 1.0, 2.0, 3.0], 1.0, 3, 4.0, "first", [0, 0, 0, 0]),
                ([1.0, 3.0, 4.0, 4.0, 5.0, 9.0, 10.0, 10.0, 11.0], 2.0, 4, 12.0, "first", [0, 0, 0, 0, 0, 1, 1, 1, 1])]
    for k, (x, eps, min_pts, period, border, labels) in enumerate(circular):
        _check_labels(dbscan_circular(s * np.array(x), s * eps, min_pts, s * period, border), labels,
                      f"visible circular example {k + 1}, scaled by {s}: eps={s * eps:g}, min_pts={min_pts}, "
                      f"period={s * period:g}, border={border!r}")


def test_hidden_random(neighbourhood_bounds, dbscan_sorted, dbscan_circular, rng):
    """80 random sorted data sets on the line (bounds by brute force; labels on the grid against
    scikit-learn, continuous ones against labkit; either border policy) and 60 on a circle (on the grid
    against scikit-learn on the circular distances, continuous ones against labkit)."""
    for trial in range(80):
        n = int(rng.integers(2, 301))
        if trial % 2 == 0:  # a 0.25 grid: exact differences, so "exactly eps apart" is exact
            x = _grid(rng, n, int(rng.integers(2, 300)))
            eps = 0.25 * int(rng.integers(1, 7))
        else:
            x = np.sort(rng.uniform(-20.0, 20.0, size=n) * rng.uniform(0.05, 1.0))
            eps = float(rng.uniform(0.01, 1.0))
        min_pts, border = int(rng.integers(1, 9)), ("first", "noise")[trial % 4 // 2]
        setting = f"random data {trial} ({n} points, eps={eps:g}, min_pts={min_pts}, border={border!r})"
        _check_bounds(neighbourhood_bounds, x, eps, setting)
        want = _sklearn_labels(x, eps, min_pts)[border] if trial % 2 == 0 else dbscan1d(x, eps, min_pts, border=border)
        _check_labels(dbscan_sorted(x, eps, min_pts, border), want, setting)
    for trial in range(60):
        n = int(rng.integers(1, 151))
        if trial % 2 == 0:  # the grid again, and a period on it
            period = 0.25 * int(rng.integers(8, 200))
            x = _grid(rng, n, int(period * 4))
            eps = 0.25 * int(rng.integers(1, 7))
        else:
            period = float(rng.choice([np.pi, 2 * np.pi, 360.0, rng.uniform(1.0, 50.0)]))
            x = np.sort(rng.uniform(0.0, period, size=n))
            eps = float(rng.uniform(0.005, 0.1)) * period
        min_pts, border = int(rng.integers(1, 9)), ("first", "noise")[trial % 4 // 2]
        setting = (f"random circular data {trial} ({n} points, eps={eps:g}, min_pts={min_pts}, "
                   f"period={period:g}, border={border!r})")
        want = (_sklearn_labels(x, eps, min_pts, period)[border] if trial % 2 == 0
                else dbscan1d(x, eps, min_pts, period=period, border=border))
        _check_labels(dbscan_circular(x, eps, min_pts, period, border), want, setting)


def test_hidden_edges(neighbourhood_bounds, dbscan_sorted, dbscan_circular, rng):
    """N = 0 and 1, min_pts 1 and > N, equal points, huge eps, lists, an unknown border policy; on the
    circle one cluster all the way round, eps >= period / 2, clusters and border points across the
    wrap; 100 000 points on the line and 60 000 on a circle with large neighbourhoods, in O(N)."""
    cases = [([], 1.0, 1), ([], 0.5, 3), ([2.0], 1.0, 1), ([2.0], 1.0, 2), ([-1.5], 0.1, 5)]
    cases += [([3.0] * 7, 0.1, m) for m in (1, 7, 8)]
    cases += [([0.0, 1.0], 1.0, 2), ([0.0, 1.0], 0.75, 2), ([0.0, 1.0], 0.75, 1)]
    cases += [(np.sort(rng.uniform(0, 10, 50)).tolist(), 1e6, m) for m in (1, 50, 51)]
    cases += [(_grid(rng, 60, 40).tolist(), 0.25 * int(rng.integers(1, 4)), 1) for _ in range(5)]
    cases += [(_grid(rng, 30, 40).tolist(), 0.5, 40) for _ in range(2)]
    for case, (x, eps, min_pts) in enumerate(cases):
        want = _sklearn_labels(x, eps, min_pts)
        as_list = case % 2 == 0  # every other case as a Python list
        data = list(x) if as_list else np.array(x, dtype=np.float64)
        setting = f"edge case {case} ({len(x)} points as {'a list' if as_list else 'an array'}, eps={eps}, " \
            f"min_pts={min_pts})"
        _check_bounds(neighbourhood_bounds, data, eps, setting)
        for border in ("first", "noise"):
            _check_labels(dbscan_sorted(data, eps, min_pts, border), want[border], f"{setting}, border={border!r}")

    ring = (np.arange(40) * 0.25).tolist()  # every 0.25 round a circle of 10
    circular = [([], 1.0, 1, 10.0), ([3.0], 1.0, 1, 10.0), ([3.0], 1.0, 2, 10.0),
                (ring, 0.25, 3, 10.0), (ring[::2], 0.5, 3, 10.0), (ring[::2], 0.25, 1, 10.0),  # round the circle
                ([0.0, 0.25, 9.75], 0.25, 3, 10.0), ([0.0, 9.5, 9.75], 0.25, 2, 10.0),  # across the wrap
                ([0.0, 0.5, 4.5, 9.5], 0.5, 2, 10.0), ([0.0, 1.0, 2.0, 8.0, 9.0], 1.0, 3, 10.0),
                ([1.0, 3.0, 4.0, 4.0, 5.0, 9.0, 10.0, 10.0, 11.0], 2.0, 4, 12.0),  # a border point between two
                ([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4, 10.0),  # ... three ways across the wrap
                ([0.0, 2.0, 3.0, 4.0, 6.0, 7.0, 8.0], 2.0, 3, 10.0)]
    circular += [(_grid(rng, 12, 16).tolist(), e, m, 4.0) for e in (2.0, 3.0) for m in (12, 13)]  # eps >= p/2
    circular += [(_grid(rng, int(rng.integers(5, 40)), 40).tolist(), 0.25 * int(rng.integers(1, 5)),
                  int(rng.integers(1, 6)), 10.0) for _ in range(3)]
    for case, (x, eps, min_pts, period) in enumerate(circular):
        want = _sklearn_labels(x, eps, min_pts, period)
        as_list = case % 2 == 1
        data = list(x) if as_list else np.array(x, dtype=np.float64)
        for border in ("first", "noise"):
            _check_labels(dbscan_circular(data, eps, min_pts, period, border), want[border],
                          f"circular edge case {case} ({len(x)} points as {'a list' if as_list else 'an array'}, "
                          f"eps={eps}, min_pts={min_pts}, period={period}, border={border!r})")

    for border in ("last", "all", None):  # the exception's type is graded, not its wording
        for name, function, args in [("dbscan_sorted", dbscan_sorted, ([0.0, 1.0], 1.0, 1, border)),
                                     ("dbscan_circular", dbscan_circular, ([0.0, 1.0], 1.0, 1, 4.0, border))]:
            try:
                function(*args)
            except ValueError:
                pass
            else:
                raise AssertionError(f"{name}(..., border={border!r}) must raise ValueError (only 'first' and "
                                     "'noise' are policies)")

    # Large inputs, about 250 points per grid value and eps = 1.0: neighbourhoods of about 2250 points.
    x = _grid(rng, 100_000, 400)
    bounds = _timed("neighbourhood_bounds", "100 000 sorted points", neighbourhood_bounds, x, 1.0)
    assert isinstance(bounds, tuple) and len(bounds) == 2, "100 000 sorted points: return a tuple (L, U)"
    assert_labels_result(bounds[0], np.searchsorted(x, x - 1.0, side="left"), name="L", item="point")
    assert_labels_result(bounds[1], np.searchsorted(x, x + 1.0, side="right") - 1, name="U", item="point")
    labels = _timed("dbscan_sorted", "100 000 sorted points", dbscan_sorted, x, 1.0, 2250, "first")
    assert_labels_result(labels, dbscan1d(x, 1.0, 2250), name="labels of 100 000 points", item="point")
    x = _grid(rng, 60_000, 240)
    labels = _timed("dbscan_circular", "60 000 points on a circle", dbscan_circular, x, 1.0, 2250, 60.0, "first")
    assert_labels_result(labels, dbscan1d(x, 1.0, 2250, period=60.0), name="labels of 60 000 circular points",
                         item="point")


def test_own_work(neighbourhood_bounds, dbscan_sorted, dbscan_circular, rng):
    """Six more data sets on the line and six on a circle: right answers where neither labkit nor
    scikit-learn can be imported."""
    for _ in range(6):
        x = _grid(rng, int(rng.integers(2, 200)), 100)
        eps, min_pts = 0.25 * int(rng.integers(1, 5)), int(rng.integers(1, 8))
        lower, upper = neighbourhood_bounds(x, eps)
        assert_labels_result(lower, np.searchsorted(x, x - eps, side="left"), name="L", item="point")
        assert_labels_result(upper, np.searchsorted(x, x + eps, side="right") - 1, name="U", item="point")
        for border in ("first", "noise"):
            assert_labels_result(dbscan_sorted(x, eps, min_pts, border), dbscan1d(x, eps, min_pts, border=border),
                                 item="point")
            assert_labels_result(dbscan_circular(x, eps, min_pts, 25.0, border),
                                 dbscan1d(x, eps, min_pts, period=25.0, border=border), item="point")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"dbscan": '''
from labkit import dbscan1d


def neighbourhood_bounds(x, eps):
    x = np.asarray(x, dtype=np.float64)
    return np.searchsorted(x, x - eps, side="left"), np.searchsorted(x, x + eps, side="right") - 1


def dbscan_sorted(x, eps, min_pts, border="first"):
    return dbscan1d(x, eps, min_pts, border=border)


def dbscan_circular(x, eps, min_pts, period, border="first"):
    return dbscan1d(x, eps, min_pts, period=period, border=border)
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
    "border='noise' is ignored: border points keep their cluster": (
        'keep_border = border == "first"', "keep_border = True"
    ),
    "border='noise' still gives a cluster the noise on its left": (
        "if keep_border:  # noise on its left", "if True:  # noise on its left"
    ),
    "an unknown border policy is taken for 'noise' instead of raising ValueError": (
        'raise ValueError(f"border must be \'first\' or \'noise\', got {border!r}")\n    keep_border',
        "pass\n    keep_border"
    ),
    "circular: no wrap, neighbours counted on the line only": (
        "ext = [v - period for v in xs] + xs + [v + period for v in xs]",
        "ext = [v - 3 * period for v in xs] + xs + [v + 3 * period for v in xs]"
    ),
    "circular: a cluster across the wrap keeps two numbers": (
        "if cluster > 0 and (xs[cores[0]] + period) - xs[cores[-1]] <= eps:", "if False:"
    ),
    "circular: a border point between two clusters joins the higher-numbered one": (
        "labels[i] = min(reached)", "labels[i] = max(reached)"
    ),
    "circular: a border point joins the cluster on its left, also across the wrap": (
        "labels[i] = min(reached)", "labels[i] = reached[0]"
    ),
    "circular: border='noise' keeps border points": ('if border == "noise":', 'if border == "none":'),
    "circular: eps >= period / 2 not special-cased (a point counted twice)": (
        "if eps >= period / 2:", "if False:"
    ),
}
