"""DBSCAN1D: fast == paper reference == scikit-learn, circular data against a brute force."""

from __future__ import annotations

import importlib
from unittest import mock

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from sklearn.cluster import DBSCAN

from labkit.dbscan import DBSCAN1D, Cluster, dbscan1d, dbscan1d_reference

d1 = importlib.import_module("labkit.dbscan")  # the module: `labkit.dbscan1d` itself is the function

QUARTER = 0.25  # grid step: sums and differences of grid values are exact, so "exactly eps" is exact


def sklearn_labels(x, eps, min_pts) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return np.zeros(0, dtype=np.int64)
    return DBSCAN(eps=eps, min_samples=min_pts).fit(x.reshape(-1, 1)).labels_.astype(np.int64)


def circular_distances(x, period) -> np.ndarray:
    v = np.mod(np.asarray(x, dtype=float), period)
    d = np.abs(v[:, None] - v[None, :])
    return np.minimum(d, period - d)


def brute_force(x, eps, min_pts, period=None):
    """O(N^2) DBSCAN from the definitions: core mask, the core points' cluster numbers
    (by first core point in input order, as scikit-learn numbers them) and, for every
    point, the set of clusters with a core point within eps."""
    x = np.asarray(x, dtype=float)
    n = x.size
    d = np.abs(x[:, None] - x[None, :]) if period is None else circular_distances(x, period)
    near = d <= eps
    core = near.sum(axis=1) >= min_pts
    comp = np.full(n, -1)
    k = 0
    for i in range(n):
        if core[i] and comp[i] < 0:
            comp[i] = k
            stack = [i]
            while stack:
                j = stack.pop()
                for t in np.flatnonzero(near[j] & core & (comp < 0)):
                    comp[t] = k
                    stack.append(t)
            k += 1
    member = [set(comp[near[i] & core].tolist()) for i in range(n)]
    return core, comp, member


def brute_labels(x, eps, min_pts, period=None, border="first") -> np.ndarray:
    core, comp, member = brute_force(x, eps, min_pts, period)
    n = len(core)
    first = np.array([comp[i] if core[i] else (min(member[i]) if member[i] else -1) for i in range(n)],
                     dtype=np.int64)
    if border == "first":
        return first
    if border == "noise":
        return np.where(core, comp, -1)
    assert all(len(m) <= 2 for m in member)  # 1-D: at most one cluster on each side
    second = np.array([max(member[i]) if not core[i] and len(member[i]) == 2 else -1 for i in range(n)])
    return np.stack([first, second], axis=1).reshape(n, 2)


grid_values = st.lists(st.integers(-40, 40), min_size=0, max_size=60).map(lambda v: [QUARTER * i for i in v])
grid_eps = st.integers(1, 8).map(lambda k: QUARTER * k)
min_pts_st = st.integers(1, 16)
paths = st.sampled_from(["shifts", "bounds"])


def run_path(path, fn, *args, **kwargs):
    """Run with neighbours counted by shifted comparisons or by searchsorted bounds."""
    limit = 10**9 if path == "shifts" else 0
    with mock.patch.object(d1, "_SHIFT_MAX_MIN_PTS", limit):
        return fn(*args, **kwargs)


# ------------------------------------------------------------------ sorted input: three implementations agree
@settings(max_examples=400, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, path=paths)
@example(values=[], eps=0.25, min_pts=1, path="shifts")
@example(values=[1.0], eps=0.25, min_pts=1, path="shifts")
@example(values=[1.0], eps=0.25, min_pts=2, path="bounds")
@example(values=[0.0, 0.25], eps=0.25, min_pts=2, path="shifts")
@example(values=[0.0, 0.5], eps=0.25, min_pts=2, path="bounds")
@example(values=[0.0, 0.0, 0.0], eps=0.25, min_pts=3, path="shifts")
def test_fast_equals_reference_equals_sklearn_on_sorted_grid_data(values, eps, min_pts, path):
    x = np.sort(np.array(values, dtype=float))
    fast = run_path(path, dbscan1d, x, eps, min_pts)
    ref, clusters = dbscan1d_reference(x, eps, min_pts)
    np.testing.assert_array_equal(fast, ref)
    np.testing.assert_array_equal(fast, sklearn_labels(x, eps, min_pts))
    assert fast.dtype == np.int64 and fast.shape == x.shape
    # the paper's cluster records: ids in order, and each cluster's points inside its range
    assert [c.id for c in clusters] == list(range(len(clusters)))
    for c in clusters:
        assert isinstance(c, Cluster)
        inside = np.flatnonzero(ref == c.id)
        assert c.lower <= inside.min() and inside.max() <= c.upper


@settings(max_examples=300, deadline=None)
@given(values=st.lists(st.floats(-1e3, 1e3, allow_nan=False), max_size=50),
       eps=st.floats(1e-6, 50.0), min_pts=min_pts_st, path=paths)
def test_fast_equals_reference_on_arbitrary_floats(values, eps, min_pts, path):
    """Same floating-point rule, |x_i - x_j| <= eps, in both: identical labels on any data."""
    x = np.sort(np.array(values, dtype=float))
    np.testing.assert_array_equal(run_path(path, dbscan1d, x, eps, min_pts), dbscan1d_reference(x, eps, min_pts)[0])


@pytest.mark.parametrize(
    ("q", "eps", "xj"),
    [
        (-5.930895186477008, 1.3123043888688055, -4.618590797608202),  # xj <= q + eps, but xj - q > eps
        (9.233143873275736, 3.6242249139268945, 12.857368787202631),
        (-3.763370959790291, 2.1172089184139056, -1.646162041376385),  # xj > q + eps, but xj - q <= eps
        (-3.4053656700181563, 3.942355088438593, 0.5369894184204368),
    ],
)
@pytest.mark.parametrize("path", ["shifts", "bounds"])
def test_rounding_of_x_plus_eps_does_not_decide(q, eps, xj, path):
    """searchsorted(x, x + eps) rounds the sum; the bounds are corrected to the paper's
    |x_i - x_j| <= eps, which the shifted comparisons use directly."""
    x = np.array(sorted([q, q, xj, xj]))
    want = dbscan1d_reference(x, eps, 3)[0]
    np.testing.assert_array_equal(run_path(path, dbscan1d, x, eps, 3), want)
    assert ((xj - q) <= eps) == (want[0] == want[-1] == 0)


def test_exactly_eps_apart_counts():
    x = np.array([0.0, 0.5, 1.0, 3.0])
    assert dbscan1d(x, 0.5, 2).tolist() == [0, 0, 0, -1]
    assert dbscan1d(x, 0.5, 3).tolist() == [0, 0, 0, -1]  # 0.5 has 3 neighbours, 0 and 1 are its border
    assert dbscan1d(x, 0.49, 2).tolist() == [-1, -1, -1, -1]


def test_min_pts_one_makes_every_point_a_cluster_of_its_own_or_shared():
    x = np.array([0.0, 0.1, 5.0])
    assert dbscan1d(x, 0.2, 1).tolist() == [0, 0, 1]
    assert dbscan1d([], 1.0, 1).tolist() == []
    assert dbscan1d([7.0], 1.0, 1).tolist() == [0]
    assert dbscan1d([7.0], 1.0, 2).tolist() == [-1]


# ------------------------------------------------------------------ unsorted input
@settings(max_examples=300, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, path=paths, data=st.data())
def test_unsorted_input_gives_sklearn_labels_in_callers_order(values, eps, min_pts, path, data):
    """scikit-learn numbers clusters by their first core point in input order and gives a
    border point to the lowest-numbered cluster reaching it; dbscan1d does the same, so
    the labels agree exactly, not just up to relabelling."""
    perm = data.draw(st.permutations(range(len(values))))
    x = np.array(values, dtype=float)[list(perm)] if values else np.zeros(0)
    got = run_path(path, dbscan1d, x, eps, min_pts)
    np.testing.assert_array_equal(got, sklearn_labels(x, eps, min_pts))
    np.testing.assert_array_equal(got, brute_labels(x, eps, min_pts))


def test_large_unsorted_input_with_near_ties():
    """Over 2048 points the order comes from packed uint64 keys; values that differ only
    in their lowest bits come out in index order and must be put right."""
    rng = np.random.default_rng(3)
    base = np.repeat(rng.integers(0, 400, 60).astype(float), 60)  # duplicates
    tiny = 1.0 + rng.integers(0, 1 << 12, 2000) * 2.0**-52  # differ in the last 12 bits only
    x = np.concatenate([base * QUARTER, tiny, rng.integers(0, 4000, 500) * QUARTER])
    rng.shuffle(x)
    order, s = d1._argsort(x)
    assert np.all(np.diff(s) >= 0) and np.array_equal(np.sort(order), np.arange(x.size))
    np.testing.assert_array_equal(s, x[order])
    for eps, min_pts in [(0.25, 5), (1.0, 30)]:
        got = dbscan1d(x, eps, min_pts)
        np.testing.assert_array_equal(got, sklearn_labels(x, eps, min_pts))
    # negative numbers and -0.0 (whose bit pattern is the largest of all)
    y = np.concatenate([-x[:3000], [-0.0] * 50, [0.0] * 50, x[3000:]])
    rng.shuffle(y)
    order, s = d1._argsort(y)
    assert np.all(np.diff(s) >= 0) and np.array_equal(np.sort(order), np.arange(y.size))
    np.testing.assert_array_equal(dbscan1d(y, 0.25, 5), sklearn_labels(y, 0.25, 5))


@pytest.mark.parametrize(
    "values",
    [
        np.concatenate([[1e10], 1.0 + np.arange(5000) * 2.0**-52]),  # one group of 5000: the stable-sort fallback
        np.concatenate([[-1e308, 1e308], np.arange(5000.0)]),  # the range overflows: float bit patterns
        np.concatenate([-np.arange(3000.0), [-0.0] * 100, [0.0] * 100, np.arange(3000.0) * 1e-300]),
    ],
    ids=["one-big-group", "overflowing-range", "signs-and-zeros"],
)
def test_packed_argsort_edge_cases(values):
    x = np.random.default_rng(0).permutation(values)
    order, s = d1._argsort(x)
    assert np.array_equal(np.sort(order), np.arange(x.size))
    np.testing.assert_array_equal(s, x[order])
    np.testing.assert_array_equal(s, np.sort(x))


def test_sorted_input_is_not_sorted_again():
    x = np.arange(10.0)
    with mock.patch.object(d1, "_argsort", side_effect=AssertionError("sorted input was sorted")):
        assert dbscan1d(x, 1.0, 3).tolist() == [0] * 10
        assert dbscan1d(x, 1.0, 3, period=20.0).tolist() == [0] * 10


def test_caller_order_numbering():
    # the cluster around 9 has the first core point in input order, so it is cluster 0
    x = [9.0, 0.0, 9.1, 0.1, 9.2, 0.2]
    assert dbscan1d(x, 0.15, 2).tolist() == [0, 1, 0, 1, 0, 1]
    assert dbscan1d(sorted(x), 0.15, 2).tolist() == [0, 0, 0, 1, 1, 1]


# ------------------------------------------------------------------ border policies
@settings(max_examples=300, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, border=st.sampled_from(["noise", "all"]),
       shuffle=st.booleans(), path=paths)
def test_border_noise_and_all_against_brute_force(values, eps, min_pts, border, shuffle, path):
    x = np.array(values, dtype=float)
    if not shuffle:
        x = np.sort(x)
    got = run_path(path, dbscan1d, x, eps, min_pts, border=border)
    np.testing.assert_array_equal(got, brute_labels(x, eps, min_pts, border=border))
    first = dbscan1d(x, eps, min_pts)
    if border == "all":
        assert got.shape == (x.size, 2)
        np.testing.assert_array_equal(got[:, 0], first)
        both = got[:, 1] >= 0
        assert np.all(got[both, 0] < got[both, 1])
    else:
        core = brute_force(x, eps, min_pts)[0]
        np.testing.assert_array_equal(got[core], first[core])
        assert np.all(got[~core] == -1)


def test_border_point_between_two_clusters():
    x = [0, 1, 1, 2, 4, 6, 7, 7, 8]  # 4 is within 2 of the cores 2 and 6, and has 3 neighbours
    assert dbscan1d(x, 2, 4).tolist() == [0, 0, 0, 0, 0, 1, 1, 1, 1]
    assert dbscan1d(x, 2, 4, border="noise").tolist() == [0, 0, 0, 0, -1, 1, 1, 1, 1]
    assert dbscan1d(x, 2, 4, border="all")[:, 1].tolist() == [-1, -1, -1, -1, 1, -1, -1, -1, -1]
    # reversed input: the cluster around 7 is found first and keeps the border point
    assert dbscan1d(x[::-1], 2, 4).tolist() == [0, 0, 0, 0, 0, 1, 1, 1, 1]
    assert dbscan1d(x[::-1], 2, 4, border="all")[4].tolist() == [0, 1]


# ------------------------------------------------------------------ circular data
periods = st.integers(4, 48).map(lambda k: QUARTER * k)


@settings(max_examples=400, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, period=periods, shuffle=st.booleans(),
       border=st.sampled_from(["first", "noise", "all"]), path=paths)
@example(values=[0.0, 1.0, 2.0, 3.0], eps=1.0, min_pts=3, period=4.0, shuffle=False, border="first",
         path="shifts")  # one cluster all the way round
@example(values=[3.75, 0.0, 0.25, 2.0], eps=0.25, min_pts=2, period=4.0, shuffle=False, border="first",
         path="bounds")  # a cluster across the wrap
def test_circular_against_brute_force(values, eps, min_pts, period, shuffle, border, path):
    x = np.array(values, dtype=float)
    if not shuffle:
        x = np.sort(np.mod(x, period))
    got = run_path(path, dbscan1d, x, eps, min_pts, period=period, border=border)
    want = brute_labels(x, eps, min_pts, period, border)
    np.testing.assert_array_equal(got, want)


@settings(max_examples=150, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, period=periods)
def test_circular_matches_sklearn_on_the_modular_distance_matrix(values, eps, min_pts, period):
    x = np.array(values, dtype=float)
    if x.size == 0:
        return
    got = dbscan1d(x, eps, min_pts, period=period)
    d = circular_distances(x, period)
    want = DBSCAN(eps=eps, min_samples=min_pts, metric="precomputed").fit(d).labels_
    np.testing.assert_array_equal(got, want)
    # as partitions of the core points, and border points next to a core of their cluster
    core = (d <= eps).sum(axis=1) >= min_pts
    for i in np.flatnonzero(~core & (got >= 0)):
        assert np.any((d[i] <= eps) & core & (got == got[i]))


def test_circular_cluster_across_the_wrap_and_around_the_circle():
    deg = np.radians
    # directions of one wall seen at 179 and 1 degrees: one cluster, numbered by its first core
    x = deg([179.0, 1.0, 178.5, 0.5, 90.0, 91.0, 90.5])
    assert dbscan1d(x, deg(2.0), 2, period=np.pi).tolist() == [0, 0, 0, 0, 1, 1, 1]
    assert dbscan1d(x, deg(2.0), 2).tolist() == [0, 1, 0, 1, 2, 2, 2]  # without period: split
    # sorted input: the wrapping cluster holds the smallest value and is cluster 0
    s = np.sort(np.mod(x, np.pi))
    assert dbscan1d(s, deg(2.0), 2, period=np.pi).tolist() == [0, 0, 1, 1, 1, 0, 0]
    # evenly spread round the whole circle: one cluster, every point in it
    ring = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    assert set(dbscan1d(ring, deg(10.5), 3, period=2 * np.pi).tolist()) == {0}
    assert set(dbscan1d(ring, deg(10.5), 4, period=2 * np.pi).tolist()) == {-1}
    # eps of half the period or more: everything is within eps of everything
    assert dbscan1d([0.0, 1.0, 2.0], 1.5, 3, period=3.0).tolist() == [0, 0, 0]
    assert dbscan1d([0.0, 1.0, 2.0], 1.5, 4, period=3.0).tolist() == [-1, -1, -1]


@pytest.mark.parametrize("path", ["shifts", "bounds"])
def test_wrapping_cluster_numbered_by_its_first_core_in_callers_order(path):
    # sorted: runs {0, 0.25}, {5, 5.25}, {9.5, 9.75}; the last run wraps into the first.
    # The first core point in input order (9.75) lies in the last run: that cluster is 0.
    x = [9.75, 5.0, 0.0, 5.25, 9.5, 0.25]
    got = run_path(path, dbscan1d, x, 0.25, 2, period=10.0)
    assert got.tolist() == [0, 1, 0, 1, 0, 0]
    np.testing.assert_array_equal(got, brute_labels(x, 0.25, 2, period=10.0))


@settings(max_examples=300, deadline=None)
@given(values=grid_values, eps=grid_eps, min_pts=min_pts_st, period=st.one_of(st.none(), periods), path=paths)
@example(values=[3.75, 0.0], eps=0.25, min_pts=2, period=4.0, path="shifts")  # a neighbour across the wrap
def test_core_points_against_brute_force(values, eps, min_pts, period, path):
    model = DBSCAN1D(eps, min_pts, period=period)
    run_path(path, model.fit, np.array(values, dtype=float))
    core = brute_force(values, eps, min_pts, period)[0] if values else np.zeros(0, bool)
    np.testing.assert_array_equal(model.core_sample_indices_, np.flatnonzero(core))


@pytest.mark.parametrize("path", ["shifts", "bounds"])
@pytest.mark.parametrize("border", ["first", "noise", "all"])
@pytest.mark.parametrize(
    ("x", "eps", "min_pts", "period", "want"),
    [
        # 0.25 is a border point of the cluster at the top, reached across the wrap
        ([0.25, 2.0, 3.25, 3.5, 3.75], 0.5, 3, 4.0, [0, -1, 0, 0, 0]),
        # 0.25 is between the cluster at 9 (across the wrap) and the one at 1.5, found first
        ([0.25, 1.0, 1.25, 1.5, 1.75, 2.0, 8.5, 8.75, 9.0, 9.25, 9.5], 0.75, 5, 10.0,
         [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]),
    ],
)
def test_circular_border_points_across_the_wrap(x, eps, min_pts, period, want, border, path):
    got = run_path(path, dbscan1d, x, eps, min_pts, period=period, border=border)
    np.testing.assert_array_equal(got, brute_labels(x, eps, min_pts, period, border))
    if border == "first":
        assert got.tolist() == want


def test_circular_values_outside_one_period_are_reduced():
    assert dbscan1d([-0.1, 0.1, 2 * np.pi + 0.05], 0.2, 3, period=2 * np.pi).tolist() == [0, 0, 0]
    assert dbscan1d([-1e-300, 0.5], 0.1, 1, period=1.0).tolist() == [0, 1]  # np.mod(-tiny, 1) == 1.0


# ------------------------------------------------------------------ estimator
def test_estimator_matches_sklearn():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.normal(0, 0.3, 200), rng.normal(5, 0.5, 300), rng.uniform(-5, 10, 100)])
    rng.shuffle(x)
    x = np.round(x * 64) / 64  # a dyadic grid: distances exact in every implementation
    ours = DBSCAN1D(eps=0.125, min_samples=8).fit(x.reshape(-1, 1))
    theirs = DBSCAN(eps=0.125, min_samples=8).fit(x.reshape(-1, 1))
    np.testing.assert_array_equal(ours.labels_, theirs.labels_)
    np.testing.assert_array_equal(ours.core_sample_indices_, theirs.core_sample_indices_)
    np.testing.assert_array_equal(ours.components_, theirs.components_)
    np.testing.assert_array_equal(DBSCAN1D(eps=0.125, min_samples=8).fit_predict(x), theirs.labels_)
    model = DBSCAN1D(0.125, 8, border="all").fit(x)
    assert model.memberships_.shape == (x.size, 2)
    np.testing.assert_array_equal(model.labels_, theirs.labels_)
    assert "border='all'" in repr(model)


def test_estimator_rejects_bad_shapes():
    with pytest.raises(ValueError, match="X must have shape"):
        DBSCAN1D().fit(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="min_samples"):
        DBSCAN1D(min_samples=0).fit(np.zeros(3))
    with pytest.raises(ValueError, match="X must be finite"):
        DBSCAN1D().fit([[1.0], [np.nan]])


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"x": [[1.0, 2.0]]}, "x"),
        ({"x": [1.0, np.nan]}, "x"),
        ({"x": [1.0, np.inf]}, "x"),
        ({"x": ["a"]}, "x"),
        ({"eps": 0.0}, "eps"),
        ({"eps": -1.0}, "eps"),
        ({"eps": np.nan}, "eps"),
        ({"eps": np.inf}, "eps"),
        ({"eps": "1"}, "eps"),
        ({"min_pts": 0}, "min_pts"),
        ({"min_pts": 2.5}, "min_pts"),
        ({"min_pts": True}, "min_pts"),
        ({"period": 0.0}, "period"),
        ({"period": np.inf}, "period"),
        ({"border": "last"}, "border"),
    ],
)
def test_validation_names_the_argument(kwargs, name):
    args = {"x": [0.0, 1.0], "eps": 1.0, "min_pts": 2} | kwargs
    extra = {k: args.pop(k) for k in ("period", "border") if k in args}
    with pytest.raises(ValueError, match=rf"^{name} "):
        dbscan1d(args["x"], args["eps"], args["min_pts"], **extra)
    if not extra:
        with pytest.raises(ValueError, match=rf"^{name} "):
            dbscan1d_reference(args["x"], args["eps"], args["min_pts"])


def test_reference_requires_sorted_input():
    with pytest.raises(ValueError, match="x must be sorted"):
        dbscan1d_reference([1.0, 0.0], 1.0, 1)


@pytest.mark.parametrize("path", ["shifts", "bounds"])
@pytest.mark.parametrize(("min_pts", "want"), [(2, [0, 0, -1, 1, 1]), (4, [-1] * 5)])
def test_differences_beyond_the_float_range_do_not_warn(path, min_pts, want):
    """1.5e308 - (-1.5e308) overflows to inf (not a neighbour); warnings are errors in the tests."""
    x = [-1.5e308, -1e308, 0.0, 1e308, 1.5e308]
    assert dbscan1d_reference(x, 0.6e308, min_pts)[0].tolist() == want
    assert run_path(path, dbscan1d, x, 0.6e308, min_pts).tolist() == want
    assert run_path(path, dbscan1d, x[::-1], 0.6e308, min_pts).tolist() == want


def test_numpy_integer_arguments_are_accepted():
    assert dbscan1d(np.array([1, 2, 3]), np.float32(1.0), np.int64(2)).tolist() == [0, 0, 0]
