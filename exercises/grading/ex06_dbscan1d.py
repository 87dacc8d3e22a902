"""Hidden tests of exercise 6: ``neighbourhood_bounds(x, eps)``, ``dbscan_sorted(x, eps, min_pts,
border)`` and ``dbscan_circular(x, eps, min_pts, period, border)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.

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
from labkit.grading import assert_labels_result

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


def _check_bounds(neighbourhood_bounds, x, eps, setting, want=None):
    bounds = neighbourhood_bounds(x, eps)
    assert isinstance(bounds, tuple) and len(bounds) == 2, f"{setting}: return a tuple (L, U)"
    for name, value, expected in zip("LU", bounds, _bounds(x, eps) if want is None else want, strict=True):
        try:
            assert_labels_result(value, expected, name=name, item="point")
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


def _line_data(rng, trial):
    """Random sorted data on the line: on the 0.25 grid (exact ties at eps) every other time, else continuous."""
    n = int(rng.integers(2, 301))
    if trial % 2 == 0:
        return _grid(rng, n, int(rng.integers(2, 300))), 0.25 * int(rng.integers(1, 7)), int(rng.integers(1, 9))
    x = np.sort(rng.uniform(-20.0, 20.0, size=n) * rng.uniform(0.05, 1.0))
    return x, float(rng.uniform(0.01, 1.0)), int(rng.integers(1, 9))


def _circle_data(rng, trial):
    """Random sorted data on a circle: on the grid with a period on it every other time, else continuous."""
    n = int(rng.integers(1, 151))
    if trial % 2 == 0:
        period = 0.25 * int(rng.integers(8, 200))
        return _grid(rng, n, int(period * 4)), 0.25 * int(rng.integers(1, 7)), int(rng.integers(1, 9)), period
    period = float(rng.choice([np.pi, 2 * np.pi, 360.0, rng.uniform(1.0, 50.0)]))
    x = np.sort(rng.uniform(0.0, period, size=n))
    return x, float(rng.uniform(0.005, 0.1)) * period, int(rng.integers(1, 9)), period


def _moved(rng, x, eps, period=None):
    """The same clustering problem elsewhere: scaled by a power of two and shifted (on a circle: turned) by a
    whole number of grid steps, so every difference stays exact. Returns (x, eps, period)."""
    scale = float(2.0 ** rng.integers(-2, 3))
    x = np.asarray(x, dtype=np.float64) * scale
    if period is None:
        return x + 0.25 * scale * int(rng.integers(-400, 400)), eps * scale, None
    period *= scale
    return np.sort((x + 0.25 * scale * int(rng.integers(0, 400))) % period), eps * scale, period


def _stretched(rng, x, eps, period=None):
    """The scene ``x`` (on the 0.25 grid) scaled by a power of two, with random lone points more than eps from each
    other and from the scene: on the line beyond its ends, on a circle in its widest gap made wider by a random
    length (the period with it, so a cluster across the wrap stays one) where that gap is wider than eps. The same
    clusters, border points and wrap, with numbers never seen before. Returns (x, eps, period)."""
    x = np.sort(np.asarray(x, dtype=np.float64))
    scale = float(2.0 ** rng.integers(-1, 3))
    x, eps = x * scale, eps * scale
    step = 0.25 * scale * (int(eps / (0.25 * scale)) + 1 + int(rng.integers(0, 3)))  # > eps, on the grid
    lone = int(rng.integers(1, 5))
    if period is None:
        left = int(rng.integers(0, lone + 1))
        noise = np.concatenate([x[0] - step * np.arange(1, left + 1), x[-1] + step * np.arange(1, lone - left + 1)])
        return np.sort(np.concatenate([x, noise])) + 0.25 * scale * int(rng.integers(-400, 400)), eps, None
    period *= scale
    gaps = np.diff(x)
    at = int(np.argmax(gaps)) if gaps.size else 0
    if not gaps.size or gaps[at] <= eps:
        return x, eps, period  # every gap links: no room for more points
    stretch = max(step * (lone + 1) - gaps[at], 0.0) + 0.25 * scale * int(rng.integers(0, 8))
    x = np.concatenate([x[:at + 1], x[at] + step * np.arange(1, lone + 1), x[at + 1:] + stretch])
    return np.sort(x), eps, period + stretch


#: Scenes on the line (x, eps, min_pts) with a border point between two clusters, and one on the left of a cluster.
LINE_SCENES = [([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4), ([0.0, 2.0, 2.5, 3.0], 0.5, 3),
               ([0.0, 0.25, 0.5, 1.5, 2.5, 2.75, 3.0], 1.0, 3)]
#: Scenes on a circle (x, eps, min_pts, period): a cluster across the wrap, a border point between two clusters
#: across it, one on the left of a cluster's first core point across it.
CIRCLE_SCENES = [([0.5, 1.0, 4.0, 4.5, 5.0, 9.0, 9.5], 1.0, 3, 10.0),
                 ([1.0, 3.0, 4.0, 4.0, 5.0, 9.0, 10.0, 10.0, 11.0], 2.0, 4, 12.0),
                 ([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4, 10.0),
                 ([0.0, 2.0, 3.0, 4.0, 6.0, 7.0, 8.0], 2.0, 3, 10.0)]


def _line_scenes(rng):
    return [(*_stretched(rng, x, eps)[:2], m) for x, eps, m in LINE_SCENES]


def _circle_scenes(rng):
    return [(x, eps, m, period) for (x, eps, period), m in
            ((_stretched(rng, x, eps, period), m) for x, eps, m, period in CIRCLE_SCENES)]


# ---------------------------------------------------------------------------- neighbourhood_bounds
def test_hidden_random__neighbourhood_bounds(neighbourhood_bounds, rng):
    """80 random sorted data sets: the bounds by brute force."""
    for trial in range(80):
        x, eps, _ = _line_data(rng, trial)
        _check_bounds(neighbourhood_bounds, x, eps, f"random data {trial} ({x.size} points)")


EDGE_LINES = [([], 1.0, 1), ([], 0.5, 3), ([2.0], 1.0, 1), ([2.0], 1.0, 2), ([-1.5], 0.25, 5),
              *[([3.0] * 7, 0.25, m) for m in (1, 7, 8)], ([0.0, 1.0], 1.0, 2), ([0.0, 1.0], 0.75, 2),
              ([0.0, 1.0], 0.75, 1)]


def _edge_lines(rng):
    """The edge cases on the line, moved; huge eps; random grids; (x as a list or an array, eps, min_pts, what)."""
    cases = [(*_moved(rng, x, eps)[:2], m, f"edge case {k}") for k, (x, eps, m) in enumerate(EDGE_LINES)]
    cases += [(np.sort(rng.uniform(0, 10, 50)), 1e6, m, "a huge eps") for m in (1, 50, 51)]
    cases += [(_grid(rng, 60, 40), 0.25 * int(rng.integers(1, 4)), 1, "min_pts = 1") for _ in range(5)]
    cases += [(_grid(rng, 30, 40), 0.5, 40, "min_pts larger than N") for _ in range(2)]
    return [(list(x) if k % 2 == 0 else np.asarray(x, dtype=np.float64), eps, m, what)
            for k, (x, eps, m, what) in enumerate(cases)]


def test_hidden_edges__neighbourhood_bounds(neighbourhood_bounds, rng):
    """N = 0 and 1, equal points, huge eps, lists; 100 000 points in O(N)."""
    for x, eps, _, what in _edge_lines(rng):
        _check_bounds(neighbourhood_bounds, x, eps, f"{what} ({len(x)} points as {type(x).__name__})")
    x = _grid(rng, 100_000, 400)  # about 250 points per grid value, eps 1: neighbourhoods of about 2250
    bounds = _timed("neighbourhood_bounds", "100 000 sorted points", neighbourhood_bounds, x, 1.0)
    want = np.searchsorted(x, x - 1.0, side="left"), np.searchsorted(x, x + 1.0, side="right") - 1
    _check_bounds(lambda *args: bounds, x, 1.0, "100 000 sorted points", want)


def test_own_work__neighbourhood_bounds(neighbourhood_bounds, rng):
    """Six more data sets: right answers where labkit cannot be imported."""
    for trial in range(6):
        x = _grid(rng, int(rng.integers(2, 200)), 100)
        _check_bounds(neighbourhood_bounds, x, 0.25 * int(rng.integers(1, 5)), f"own-work data {trial}")


# ---------------------------------------------------------------------------- dbscan_sorted
def test_hidden_random__dbscan_sorted(dbscan_sorted, rng):
    """80 random sorted data sets, either border policy: on the grid against scikit-learn, continuous ones
    against labkit."""
    for trial in range(80):
        x, eps, min_pts = _line_data(rng, trial)
        border = ("first", "noise")[trial % 4 // 2]
        want = _sklearn_labels(x, eps, min_pts)[border] if trial % 2 == 0 else dbscan1d(x, eps, min_pts, border=border)
        _check_labels(dbscan_sorted(x, eps, min_pts, border), want,
                      f"random data {trial} ({x.size} points, border {border!r})")
    for trial, (x, eps, min_pts) in enumerate(_line_scenes(rng)):  # border points between and beside clusters
        want = _sklearn_labels(x, eps, min_pts)
        for border in ("first", "noise"):
            _check_labels(dbscan_sorted(x, eps, min_pts, border), want[border],
                          f"random data with border points {trial} (border {border!r})")


def test_hidden_edges__dbscan_sorted(dbscan_sorted, rng):
    """N = 0 and 1, min_pts 1 and > N, equal points, huge eps, lists, both policies, an unknown policy; 100 000
    points in O(N)."""
    for x, eps, min_pts, what in _edge_lines(rng):
        want = _sklearn_labels(x, eps, min_pts)
        for border in ("first", "noise"):
            _check_labels(dbscan_sorted(x, eps, min_pts, border), want[border],
                          f"{what} ({len(x)} points as {type(x).__name__}, border {border!r})")
    for border in ("last", "all", None, "".join(rng.choice(list("abcdefgh"), 5))):  # the type is graded
        try:
            dbscan_sorted([0.0, 1.0], 1.0, 1, border)
        except ValueError:
            pass
        else:
            raise AssertionError("an unknown border policy must raise ValueError (only 'first' and 'noise' are)")
    x = _grid(rng, 100_000, 400)
    labels = _timed("dbscan_sorted", "100 000 sorted points", dbscan_sorted, x, 1.0, 2250, "first")
    _check_labels(labels, dbscan1d(x, 1.0, 2250), "100 000 sorted points")


def test_own_work__dbscan_sorted(dbscan_sorted, rng):
    """Six more data sets, both policies: right answers where neither labkit nor scikit-learn can be imported."""
    for trial in range(6):
        x = _grid(rng, int(rng.integers(2, 200)), 100)
        eps, min_pts = 0.25 * int(rng.integers(1, 5)), int(rng.integers(1, 8))
        for border in ("first", "noise"):
            _check_labels(dbscan_sorted(x, eps, min_pts, border), dbscan1d(x, eps, min_pts, border=border),
                          f"own-work data {trial} (border {border!r})")
    for trial, (x, eps, min_pts) in enumerate(_line_scenes(rng)):
        for border in ("first", "noise"):
            _check_labels(dbscan_sorted(x, eps, min_pts, border), dbscan1d(x, eps, min_pts, border=border),
                          f"own-work data with border points {trial} (border {border!r})")


# ---------------------------------------------------------------------------- dbscan_circular
def test_hidden_random__dbscan_circular(dbscan_circular, rng):
    """60 random data sets on a circle, either policy: on the grid against scikit-learn on the circular
    distances, continuous ones against labkit."""
    for trial in range(60):
        x, eps, min_pts, period = _circle_data(rng, trial)
        border = ("first", "noise")[trial % 4 // 2]
        want = (_sklearn_labels(x, eps, min_pts, period)[border] if trial % 2 == 0
                else dbscan1d(x, eps, min_pts, period=period, border=border))
        _check_labels(dbscan_circular(x, eps, min_pts, period, border), want,
                      f"random circular data {trial} ({x.size} points, border {border!r})")
    for trial, (x, eps, min_pts, period) in enumerate(_circle_scenes(rng)):  # clusters and borders across the wrap
        want = _sklearn_labels(x, eps, min_pts, period)
        for border in ("first", "noise"):
            _check_labels(dbscan_circular(x, eps, min_pts, period, border), want[border],
                          f"random circular data across the wrap {trial} (border {border!r})")


RING = (np.arange(40) * 0.25).tolist()  # every 0.25 round a circle of 10
EDGE_CIRCLES = [([], 1.0, 1, 10.0), ([3.0], 1.0, 1, 10.0), ([3.0], 1.0, 2, 10.0),
                (RING, 0.25, 3, 10.0), (RING[::2], 0.5, 3, 10.0), (RING[::2], 0.25, 1, 10.0),  # round the circle
                ([0.0, 0.25, 9.75], 0.25, 3, 10.0), ([0.0, 9.5, 9.75], 0.25, 2, 10.0),  # across the wrap
                ([0.0, 0.5, 4.5, 9.5], 0.5, 2, 10.0), ([0.0, 1.0, 2.0, 8.0, 9.0], 1.0, 3, 10.0),
                ([1.0, 3.0, 4.0, 4.0, 5.0, 9.0, 10.0, 10.0, 11.0], 2.0, 4, 12.0),  # a border point between two
                ([0.0, 1.0, 1.0, 2.0, 4.0, 6.0, 7.0, 7.0, 8.0], 2.0, 4, 10.0),  # ... three ways across the wrap
                ([0.0, 2.0, 3.0, 4.0, 6.0, 7.0, 8.0], 2.0, 3, 10.0)]


def test_hidden_edges__dbscan_circular(dbscan_circular, rng):
    """One cluster all the way round, eps >= period / 2, clusters and border points across the wrap (scaled, with
    lone points added where there is room), lists, both policies, an unknown policy; 60 000 points in O(N)."""
    cases = [(*(_stretched(rng, x, eps, period) if x else _moved(rng, x, eps, period)), m, f"circular edge case {k}")
             for k, (x, eps, m, period) in enumerate(EDGE_CIRCLES)]
    cases = [(x, eps, period, m, what) for x, eps, period, m, what in cases]
    cases += [(_grid(rng, 12, 16), e, 4.0, m, "eps >= period / 2") for e in (2.0, 3.0) for m in (12, 13)]
    cases += [(_grid(rng, int(rng.integers(5, 40)), 40), 0.25 * int(rng.integers(1, 5)), 10.0,
               int(rng.integers(1, 6)), "random data on a small circle") for _ in range(3)]
    for k, (x, eps, period, min_pts, what) in enumerate(cases):
        want = _sklearn_labels(x, eps, min_pts, period)
        data = list(x) if k % 2 else np.asarray(x, dtype=np.float64)
        for border in ("first", "noise"):
            _check_labels(dbscan_circular(data, eps, min_pts, period, border), want[border],
                          f"{what} ({len(x)} points as {type(data).__name__}, border {border!r})")
    for border in ("last", "all", None):
        try:
            dbscan_circular([0.0, 1.0], 1.0, 1, 4.0, border)
        except ValueError:
            pass
        else:
            raise AssertionError("an unknown border policy must raise ValueError (only 'first' and 'noise' are)")
    x = _grid(rng, 60_000, 240)
    labels = _timed("dbscan_circular", "60 000 points on a circle", dbscan_circular, x, 1.0, 2250, 60.0, "first")
    _check_labels(labels, dbscan1d(x, 1.0, 2250, period=60.0), "60 000 points on a circle")


def test_own_work__dbscan_circular(dbscan_circular, rng):
    """Six more data sets on a circle: right answers where neither labkit nor scikit-learn can be imported."""
    for trial in range(6):
        x = _grid(rng, int(rng.integers(2, 200)), 100)
        eps, min_pts = 0.25 * int(rng.integers(1, 5)), int(rng.integers(1, 8))
        for border in ("first", "noise"):
            _check_labels(dbscan_circular(x, eps, min_pts, 25.0, border),
                          dbscan1d(x, eps, min_pts, period=25.0, border=border),
                          f"own-work circular data {trial} (border {border!r})")
    for trial, (x, eps, min_pts, period) in enumerate(_circle_scenes(rng)):
        for border in ("first", "noise"):
            _check_labels(dbscan_circular(x, eps, min_pts, period, border),
                          dbscan1d(x, eps, min_pts, period=period, border=border),
                          f"own-work circular data across the wrap {trial} (border {border!r})")


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
