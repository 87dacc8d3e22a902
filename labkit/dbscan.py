"""DBSCAN for one-dimensional data, in linear time on sorted input (Meglicki 2021).

On a line, the eps-neighbourhood of a point in sorted data is a run of consecutive
points, and a cluster is a run too. That makes DBSCAN linear after sorting. This
module has two implementations of the same clustering:

* :func:`dbscan1d_reference` follows the paper's Algorithms 1-4 line by line, with
  plain Python loops. It is the version to read next to the paper and to step
  through in a notebook. Its comments give the algorithm and line numbers.
* :func:`dbscan1d` is the fast one. It is vectorised numpy and needs no compiler.
  It also sorts unsorted input, handles wrap-around (periodic) data such as
  angles, and offers three policies for border points. :class:`DBSCAN1D` wraps it
  in a scikit-learn style estimator.

``labkit.dbscan1d`` is the function (the package re-exports it); this module is
``labkit.dbscan`` (``from labkit.dbscan import Cluster``).

Semantics (both implementations, and scikit-learn's ``DBSCAN``)
----------------------------------------------------------------
* ``x_j`` is in the eps-neighbourhood of ``x_i`` when ``|x_i - x_j| <= eps``. The
  difference is taken in floating point, as in Algorithm 2, line 7. A point is its
  own neighbour.
* A point is a *core point* when its neighbourhood holds at least ``min_pts``
  points.
* Clusters are the connected groups of core points (cores within eps of each other
  are linked) together with their *border points*: non-core points within eps of a
  core point.
* Labels are ``int64`` with ``-1`` for noise. Clusters are numbered 0, 1, ... in
  the order of their first core point *in the caller's order*. This is the order
  scikit-learn finds them in, so for sorted input they are numbered left to right.
* A border point can be within eps of two clusters, one on each side, but not more
  (two cores on the same side of it are within eps of each other). By default
  (``border="first"``) it joins the cluster with the lower number: the one that
  scikit-learn, and the original DBSCAN, would expand into it first.

Computing it fast
-----------------
Take sorted data and ``m = min_pts``. A point is a core point when its ``m - 1``
nearest sorted neighbours on one side are within eps, or enough on both sides.
:func:`dbscan1d` compares the array with itself shifted by ``1 .. m - 1`` places, so
the work does not depend on eps. A non-core point has at most ``m - 2`` other
neighbours. So any core point within eps of it is at most ``m - 2`` places away. The
same holds for a core point and the previous core point of its cluster. A few more
shifted boolean ANDs therefore find, for every point, whether a core point within eps
lies on its left or on its right. A core point with none on its left starts a
cluster. One cumulative sum numbers the clusters. There are no Python loops over
points, and the cost is O(N min_pts). Above ``min_pts = 32``, or when the
``(min_pts - 1) N`` booleans would pass 128 MB, the neighbourhood bounds come from
:func:`numpy.searchsorted` instead, in O(N log N). That is Algorithm 2's upper pass,
corrected to the exact floating-point rule; the lower bounds follow by counting.
Unsorted input is sorted first: one SIMD sort of uint64 keys with the indices packed
into their low bits, a few times faster than :func:`numpy.argsort`.

Agreement with scikit-learn: its neighbour searches compute the distance another way.
Its trees compare squared distances, and its brute-force search expands
``(x_i - x_j)**2``. That can decide differently from ``|x_i - x_j| <= eps`` only for a
pair within a rounding error of eps. On data whose differences and squares are
exact, such as multiples of a power of two, the labels are identical.

Circular data (``period=p``)
-----------------------------
Values are taken modulo ``p``. The distance is the shorter way round the circle.
Across the wrap it is computed as ``(x_j + p) - x_i``, so ties at exactly eps across
the wrap are decided up to the rounding of that sum. A cluster may wrap from
``p - eps`` across ``0``. It is still one cluster, numbered like any other by its
first core point in the caller's order. So for sorted input, a cluster that wraps
holds the smallest value and gets label 0. If the core points go round the whole
circle with no gap larger than eps, every point is in that one cluster. When
``eps >= p / 2``, every point is within eps of every other point.

References
----------
B. Meglicki, "Linear time DBSCAN for sorted 1D data and laser range scan
segmentation", 2021: section 2 (Algorithms 1-4; wrap-around data and border
policies in section 2.7).
M. Ester, H.-P. Kriegel, J. Sander, X. Xu, "A density-based algorithm for
discovering clusters in large spatial databases with noise", KDD 1996.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ._checks import check_int, check_positive

__all__ = ["Cluster", "dbscan1d_reference", "dbscan1d", "DBSCAN1D"]

#: ``dbscan1d`` counts neighbours by shifted comparisons up to this ``min_pts`` (and while the
#: ``(min_pts - 1) * N`` booleans they keep fit in ``_SHIFT_MAX_BYTES``), with ``searchsorted``
#: bounds beyond. Both give identical labels; the tests run both.
_SHIFT_MAX_MIN_PTS = 32
_SHIFT_MAX_BYTES = 1 << 27

_BORDERS = ("first", "noise", "all")
_CHUNK = 1 << 15  # elements per chunk of floating-point differences (256 kB: stays in cache)


# ============================================================================ validation
def _check_x(x, name: str = "x") -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a one-dimensional array of numbers") from None
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, shape (N,), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise ValueError(f"{name} must be finite, but {name}[{bad}] = {arr[bad]}")
    return arr


def _check_period(period) -> float | None:
    if period is None:
        return None
    return check_positive("period", period)


def _check_border(border) -> str:
    if border not in _BORDERS:
        raise ValueError(f"border must be one of {_BORDERS}, got {border!r}")
    return border


# ============================================================================ reference
class Cluster(NamedTuple):
    """A cluster found by :func:`dbscan1d_reference`: the inclusive range
    ``lower .. upper`` of sorted positions it spans, and its label ``id``.

    With ``border="first"`` semantics a border point in the range may carry the label
    of the cluster on its left, which reached it first.
    """

    lower: int
    upper: int
    id: int


_NOT_VISITED = -2
_NOISE = -1


def _calculate_neighborhood(x: list[float], eps: float) -> tuple[list[int], list[int]]:
    """Algorithm 2: inclusive bounds ``L``, ``U`` of every point's eps-neighbourhood."""
    n = len(x)
    upper = [0] * n  # line 2: U
    lower = [0] * n  # line 3: L
    u = 0  # line 4
    lo = n - 1  # line 5
    for i in range(n):  # line 6
        while u < n and abs(x[i] - x[u]) <= eps:  # line 7: the search only moves forward
            u += 1  # line 8
        upper[i] = u - 1  # line 9
    for i in range(n - 1, -1, -1):  # line 10
        while lo >= 0 and abs(x[i] - x[lo]) <= eps:  # line 11
            lo -= 1  # line 12
        lower[i] = lo + 1  # line 13
    return lower, upper  # line 14


def _neighborhood_size(i: int, lower: list[int], upper: list[int]) -> int:
    """Algorithm 3: the size of point ``i``'s neighbourhood, in O(1)."""
    return upper[i] - lower[i] + 1  # line 2


def _expand_cluster(p: int, lower: list[int], upper: list[int], c: list[int], cluster_id: int,
                    min_pts: int) -> Cluster:
    """Algorithm 4: label everything density-reachable from core point ``p``."""
    n = len(c)
    c[p] = cluster_id  # line 2
    u = upper[p]  # line 3
    lo = lower[p]  # line 4
    i = p + 1  # line 6: walk up while inside the (growing) cluster bound u
    while i <= n - 1 and i <= u:
        if c[i] == _NOT_VISITED:  # line 7
            c[i] = cluster_id  # line 8
            if _neighborhood_size(i, lower, upper) >= min_pts:  # line 9: a core point
                u = upper[i]  # line 10: pushes the bound up
        elif c[i] == _NOISE:  # line 11: noise so far, a border point after all
            c[i] = cluster_id  # line 12
        i += 1
    u = i - 1  # line 14
    i = p - 1  # line 16: the same walk downwards
    while i >= 0 and i >= lo:
        if c[i] == _NOT_VISITED:  # line 17
            c[i] = cluster_id  # line 18
            if _neighborhood_size(i, lower, upper) >= min_pts:  # line 19
                lo = lower[i]  # line 20
        elif c[i] == _NOISE:  # line 21
            c[i] = cluster_id  # line 22
        i -= 1
    lo = i + 1  # line 24
    return Cluster(lo, u, cluster_id)  # line 26


def dbscan1d_reference(x, eps: float, min_pts: int) -> tuple[np.ndarray, list[Cluster]]:
    """DBSCAN of sorted 1-D data, written as the paper's Algorithms 1-4.

    Plain Python loops, O(N): one pass each way for the neighbourhood bounds
    (Algorithm 2), then one pass that expands a cluster from every core point not
    yet visited (Algorithms 1 and 4). Use :func:`dbscan1d` for real work. It gives
    the same labels, much faster, and also takes unsorted and circular data.

    Parameters
    ----------
    x : array_like of shape (N,)
        Finite values sorted in ascending order.
    eps : float
        Neighbourhood radius, > 0. ``|x_i - x_j| <= eps`` counts.
    min_pts : int
        Neighbourhood size (the point itself included) that makes a core point, >= 1.

    Returns
    -------
    labels : ndarray of shape (N,), int64
        Cluster label per point, -1 for noise. The paper numbers clusters from 1 and
        keeps NOISE and NOT_VISITED as sentinels. Here labels start at 0, as in
        scikit-learn, and border points keep the first cluster that reached them.
    clusters : list of Cluster
        ``(lower, upper, id)`` per cluster in the order found (left to right): the
        inclusive range of positions each cluster expanded over.

    Examples
    --------
    >>> labels, clusters = dbscan1d_reference([0.0, 0.1, 0.2, 0.3, 5.0, 9.0, 9.1, 9.2], eps=0.15, min_pts=3)
    >>> labels
    array([ 0,  0,  0,  0, -1,  1,  1,  1])
    >>> clusters
    [Cluster(lower=0, upper=3, id=0), Cluster(lower=5, upper=7, id=1)]
    """
    arr = _check_x(x)
    eps = check_positive("eps", eps)
    min_pts = check_int("min_pts", min_pts, 1)
    if arr.size > 1 and np.any(arr[1:] < arr[:-1]):
        bad = int(np.flatnonzero(arr[1:] < arr[:-1])[0])
        raise ValueError(f"x must be sorted ascending (Algorithm 1 requires it), but x[{bad + 1}] < x[{bad}]")
    xs = arr.tolist()
    n = len(xs)
    # Algorithm 1
    c = [_NOT_VISITED] * n  # lines 2, 5-6: every point starts NOT_VISITED
    cluster_id = 0  # line 3 (the paper starts at 1; labels here start at 0)
    clusters: list[Cluster] = []  # line 4
    lower, upper = _calculate_neighborhood(xs, eps)  # line 7
    for i in range(n):  # line 8
        if c[i] != _NOT_VISITED:  # lines 9-10: already in a cluster (or noise)
            continue
        if _neighborhood_size(i, lower, upper) < min_pts:  # line 11
            c[i] = _NOISE  # line 12: may still become a border point of a later cluster
        else:
            cluster = _expand_cluster(i, lower, upper, c, cluster_id, min_pts)  # line 14
            clusters.append(cluster)  # line 15
            cluster_id += 1  # line 16
    return np.array(c, dtype=np.int64), clusters  # line 17


# ============================================================================ fast version
def _is_sorted(v: np.ndarray) -> bool:
    return v.size < 2 or not bool(np.any(v[1:] < v[:-1]))


def _argsort(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(order, v[order])`` with ``v[order]`` ascending.

    For large inputs the order comes from one SIMD-accelerated sort of uint64 keys,
    several times faster than :func:`numpy.argsort`. The high bits of a key hold the
    value, as a fixed-point number over the data's range (or, for ranges that overflow,
    as the float's order-preserving bit pattern). The low ``log2 N`` bits hold the
    index. Values that share a key's high bits come out in index order. A check finds
    the places where that is out of value order, and those groups are sorted again.
    """
    n = v.size
    if n < 5000:  # below this, the packing does not pay
        order = np.argsort(v)
        return order, v.take(order)
    nbits = int(n - 1).bit_length()
    low = np.uint64((1 << nbits) - 1)
    lo, hi = float(v.min()), float(v.max())
    if math.isfinite(hi - lo):
        fixed = np.subtract(v, lo)
        fixed *= (2.0 ** (64 - nbits) - 4096.0) / (hi - lo)  # monotone, below 2**(64 - nbits)
        ukey = fixed.view(np.uint64)
        np.copyto(ukey, fixed, casting="unsafe")  # float -> integer, in place
        ukey <<= np.uint64(nbits)
    else:
        key = np.ascontiguousarray(v).view(np.int64).copy()
        flip = key >> np.int64(63)  # -1 for negative numbers: their magnitude bits are reversed
        flip &= np.int64(0x7FFF_FFFF_FFFF_FFFF)
        key ^= flip
        key ^= np.int64(-(1 << 63))  # and the sign bit: unsigned order == float order
        ukey = key.view(np.uint64)
        ukey &= ~low
    ukey |= np.arange(n, dtype=np.uint64)
    ukey.sort()
    order = np.bitwise_and(ukey, low).view(np.int64)
    s = v.take(order)
    bad = np.flatnonzero(s[1:] < s[:-1])
    if bad.size:
        # sort again, by value, every group of equal high bits that holds a descent
        shift = np.uint64(nbits)
        groups = ukey[bad] >> shift
        groups = groups[np.concatenate([[True], groups[1:] != groups[:-1]])]
        first = np.searchsorted(ukey, groups << shift)
        size = np.searchsorted(ukey, (groups + np.uint64(1)) << shift) - first
        total = int(size.sum())
        if total > n // 8:
            fix = np.argsort(s, kind="stable")  # timsort: fast on nearly sorted input
            return order.take(fix), s.take(fix)
        pos = np.arange(total) + np.repeat(first - (np.cumsum(size) - size), size)
        src = pos[np.lexsort((s[pos], np.repeat(np.arange(groups.size), size)))]
        order[pos], s[pos] = order[src], s[src]
    return order, s


def _shift_or(target: np.ndarray, source: np.ndarray, k: int, wrap: bool) -> None:
    """``target[i + k] |= source[i]``, with ``i + k`` taken modulo N when ``wrap``."""
    n = target.size
    np.bitwise_or(target[k:], source[:n - k], out=target[k:])
    if wrap:
        np.bitwise_or(target[:k], source[n - k:], out=target[:k])


def _shifted(a: np.ndarray, k: int, size: int, wrap: bool) -> np.ndarray:
    """``a[i + k]`` for ``i < size``, with ``i + k`` taken modulo N when ``wrap``."""
    return np.concatenate([a[k:], a[:k]]) if wrap else a[k:k + size]


def _labels_by_shifts(s: np.ndarray, ext: np.ndarray | None, eps: float, min_pts: int, border: str,
                      order: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """DBSCAN of sorted ``s`` from comparing ``s`` with itself shifted by 1 .. min_pts-1.

    ``near[k-1][i]`` says that ``i`` and ``i + k`` are neighbours. For circular data the
    index is taken modulo N, and ``ext`` is ``s`` followed by its first values plus the
    period. Three facts make a few shifts enough:

    * A point with ``min_pts - 1`` neighbours on one side is a core point. So counting
      up to ``min_pts - 1`` places on each side decides it.
    * A non-core point has at most ``min_pts - 2`` neighbours besides itself. So a core
      point within eps of it is at most ``K = max(1, min_pts - 2)`` places away.
    * A core point's previous core point, if within eps, is at most ``K`` places away
      too. The points in between are within eps of both and of each other, so with
      ``min_pts - 2`` or more of them they would be core points themselves.

    ``K`` shifted ANDs give "a core point within eps on the left" (and on the right).
    A core point without one on its left starts a cluster. A cumulative sum over the
    starts then numbers the clusters from left to right. A point takes the cluster of
    its nearest core point on the left if that one is within eps, else the next one.
    Labels come back as int32 (int64 beyond 2**31 points).
    """
    n = s.size
    wrap = ext is not None
    src = ext if wrap else s
    kmax = min(max(min_pts - 1, 1), n - 1)
    nears = np.empty((kmax, n), dtype=bool)
    count = np.zeros(n, dtype=np.int8)  # neighbours besides the point itself, up to 2 (min_pts - 1)
    buf = np.empty(min(n, _CHUNK))
    for k in range(1, kmax + 1):
        size = n if wrap else n - k
        near = nears[k - 1, :size]
        for c0 in range(0, size, _CHUNK):  # in chunks: the differences stay in cache
            c1 = min(c0 + _CHUNK, size)
            d = buf[:c1 - c0]
            np.subtract(src[c0 + k:c1 + k], s[c0:c1], out=d)
            np.less_equal(d, eps, out=near[c0:c1])  # |x_i - x_j| <= eps, as in Algorithm 2, line 7
        if not near.any():
            kmax = k - 1
            break  # farther shifts are farther away
        count[:size] += near  # i has its right neighbour i + k
        count[k:] += near[:n - k]  # i + k has its left neighbour i
        if wrap:
            count[:k] += near[n - k:]
    core = count >= min_pts - 1
    del count, buf
    itype = np.int32 if n < 2**31 else np.int64
    if not core.any():
        second = np.full(n, -1, dtype=itype) if border == "all" else None
        return np.full(n, -1, dtype=itype), second, core

    reach = [nears[k - 1, :n if wrap else n - k] for k in range(1, min(max(1, min_pts - 2), kmax) + 1)]
    core_left = np.zeros(n, dtype=bool)  # a core point within eps on the left
    core_right = np.zeros(n, dtype=bool)  # ... on the right
    tmp = np.empty(n, dtype=bool)
    for k, near in enumerate(reach, start=1):
        size = near.size
        t = tmp[:size]
        np.bitwise_and(near, core[:size], out=t)
        _shift_or(core_left, t, k, wrap)
        np.bitwise_and(near, _shifted(core, k, size, wrap), out=t)
        np.bitwise_or(core_right[:size], t, out=core_right[:size])
    start = core & ~core_left
    if border == "noise":
        clustered = core
    else:
        left_or_core = core | core_left
        clustered = left_or_core | core_right
    second = np.full(n, -1, dtype=itype) if border == "all" else None
    if not start.any():  # circular data, core points all the way round: one cluster
        lab = np.full(n, -1, dtype=itype)
        lab[clustered] = 0
        return lab, second, core

    lab = np.cumsum(start, dtype=itype)
    lab -= 1  # the cluster of the nearest core point at or before i (-1: none yet)
    n_runs = int(lab[-1]) + 1
    if border != "noise":
        np.bitwise_and(core_right, ~left_or_core, out=tmp)
        lab += tmp  # reached from the right only: the next cluster
    first_start = int(np.argmax(start))
    if wrap:  # before the first start: the last cluster, which wraps round; after it: the first
        head = lab[:first_start]
        head[head < 0] = n_runs - 1
        tail = lab[n - 1 - int(np.argmax(start[::-1])):]
        tail[tail >= n_runs] = 0

    # Number the clusters by their first core point in the caller's order.
    head_cores = wrap and bool(core[:first_start].any())
    rank = None  # sorted order is the caller's order, and no cluster wraps
    if order is not None or head_cores:
        where = np.arange(n) if order is None else order
        key = np.minimum.reduceat(np.where(core, where, n), np.flatnonzero(start))
        if head_cores:
            key[-1] = min(key[-1], int(np.where(core[:first_start], where[:first_start], n).min()))
        rank = np.empty(n_runs, dtype=itype)
        rank[np.argsort(key)] = np.arange(n_runs)

    # Border points between two clusters: the core point within eps on their right starts one.
    two = None
    if n_runs > 1 and (border == "all" or (border == "first" and (rank is not None or wrap))):
        start_right = np.zeros(n, dtype=bool)
        for k, near in enumerate(reach, start=1):
            size = near.size
            t = tmp[:size]
            np.bitwise_and(near, _shifted(start, k, size, wrap), out=t)
            np.bitwise_or(start_right[:size], t, out=start_right[:size])
        two = np.flatnonzero(start_right & core_left & ~core)
        left = lab[two]
        right = (left + 1) % n_runs

    if rank is not None:
        lab = rank.take(lab)  # -1 (not clustered) picks something; cleared below
    np.logical_not(clustered, out=tmp)
    lab[tmp] = -1
    if two is not None and two.size:
        if rank is not None:
            left, right = rank.take(left), rank.take(right)
        lab[two] = np.minimum(left, right)
        if second is not None:
            second[two] = np.maximum(left, right)
    return lab, second, core


def _upper_bounds(ext: np.ndarray, n: int, eps: float) -> np.ndarray:
    """``U[i]`` = the last index ``j`` of ``ext`` with ``ext[j] - ext[i] <= eps`` (i < n).

    :func:`numpy.searchsorted` on ``ext[i] + eps`` gives it up to the rounding of that
    sum. Any bound the rounding moved is walked back to the exact rule, one distinct
    value at a time.
    """
    q = ext[:n]
    m = ext.size
    u = np.searchsorted(ext, q + eps, side="right") - 1
    todo = np.flatnonzero((ext[u] - q) > eps)  # went one value too far
    while todo.size:
        u[todo] = np.searchsorted(ext, ext[u[todo]], side="left") - 1
        todo = todo[(ext[u[todo]] - q[todo]) > eps]
    nxt = np.minimum(u + 1, m - 1)
    todo = np.flatnonzero((u + 1 < m) & ((ext[nxt] - q) <= eps))  # stopped one value short
    while todo.size:
        u[todo] = np.searchsorted(ext, ext[u[todo] + 1], side="right") - 1
        nxt = np.minimum(u[todo] + 1, m - 1)
        todo = todo[(u[todo] + 1 < m) & ((ext[nxt] - q[todo]) <= eps)]
    return u


def _core_by_bounds(s: np.ndarray, ext: np.ndarray | None, eps: float, min_pts: int) -> np.ndarray:
    """Core mask from Algorithm 2's bounds: ``U`` by searchsorted, ``L`` by counting.

    ``L[i]`` is the first ``j`` with ``U[j] >= i`` (the relation is symmetric), i.e. the
    number of ``j`` with ``U[j] < i``: a cumulative count of the ``U`` values.
    """
    n = s.size
    if ext is None:
        u = _upper_bounds(s, n, eps)
        ends = np.bincount(u, minlength=n).cumsum()  # ends[k] = #{j : U[j] <= k}
        lower = np.zeros(n, dtype=np.intp)
        lower[1:] = ends[:-1]
        return u - lower + 1 >= min_pts
    # circular: the right neighbours of i are i+1 .. u[i] in ext (indices >= n are copies
    # of i - n). Each j adds one left neighbour to every point of its right window.
    u = _upper_bounds(ext, n, eps)
    idx = np.arange(n)
    right = u - idx
    delta = np.bincount(idx + 1, minlength=2 * n + 1) - np.bincount(u + 1, minlength=2 * n + 1)
    cover = np.cumsum(delta)[:2 * n]
    left = cover[:n] + cover[n:]  # fold the copies back onto their points
    return 1 + right + left >= min_pts


def _wrap_extension(s: np.ndarray, period: float, eps: float, min_pts: int) -> np.ndarray:
    """``s`` followed by copies ``s[:k] + period``: enough for every right window."""
    n = s.size
    need = np.searchsorted(s, s[-1] + eps - period, side="right") + 1
    k = min(n, max(int(need), min(min_pts - 1, n - 1)))
    return np.concatenate([s, s[:k] + period])


def _cluster_sorted(s: np.ndarray, eps: float, min_pts: int, period: float | None, border: str,
                    order: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Labels of sorted ``s`` in sorted order, numbered by first core point in the
    caller's order.

    ``order`` maps sorted to caller positions (``None`` when the input was sorted
    already). Returns the labels, the second memberships (``border="all"``, else
    ``None``) and the core mask.
    """
    n = s.size
    if n == 0:
        return np.zeros(0, dtype=np.int64), (np.zeros(0, dtype=np.int64) if border == "all" else None), \
            np.zeros(0, dtype=bool)
    wrap = period is not None
    if wrap and eps >= period / 2:  # every point is within eps of every other one
        core = np.full(n, n >= min_pts)
        labels = np.full(n, 0 if n >= min_pts else -1, dtype=np.int64)
        return labels, (np.full(n, -1, dtype=np.int64) if border == "all" else None), core
    ext = _wrap_extension(s, period, eps, min_pts) if wrap else None
    if min_pts <= _SHIFT_MAX_MIN_PTS and (min_pts - 1) * n <= _SHIFT_MAX_BYTES:
        return _labels_by_shifts(s, ext, eps, min_pts, border, order)
    return _labels_from_core(s, _core_by_bounds(s, ext, eps, min_pts), eps, period, border, order)


def _labels_from_core(s: np.ndarray, core: np.ndarray, eps: float, period: float | None, border: str,
                      order: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Labels of sorted ``s`` given its core mask, for any ``min_pts``.

    Consecutive core points are in one cluster exactly when they are neighbours, so the
    clusters are runs, numbered by a cumulative sum over the gaps. A border point only
    needs its nearest core point on each side.
    """
    n = s.size
    wrap = period is not None
    labels = np.full(n, -1, dtype=np.int64)
    second = np.full(n, -1, dtype=np.int64) if border == "all" else None
    ci = np.flatnonzero(core)
    m = ci.size
    if m == 0:
        return labels, second, core

    xc = s if m == n else s.take(ci)
    gap = (xc[1:] - xc[:-1]) > eps
    run = np.zeros(m, dtype=np.int64)
    np.cumsum(gap, out=run[1:])
    n_runs = int(run[-1]) + 1
    merged = wrap and n_runs > 1 and bool((xc[0] + period) - xc[-1] <= eps)  # the last run wraps round
    starts = np.concatenate([[0], np.flatnonzero(gap) + 1]) if merged or order is not None else None
    if merged:
        run[starts[-1]:] = 0
    if order is None:
        core_labels = run  # numbered by their smallest index already, also when merged
    else:  # number the clusters by their first core point in the caller's order
        key = np.minimum.reduceat(order.take(ci), starts)
        if merged:
            key[0] = min(key[0], key[-1])
            key = key[:-1]
        rank = np.empty(key.size, dtype=np.int64)
        rank[np.argsort(key)] = np.arange(key.size)
        core_labels = rank.take(run)
    if m == n:
        return core_labels, second, core
    labels[ci] = core_labels
    if border == "noise":
        return labels, second, core

    # Border points: only the nearest core on each side can reach them. Non-core point
    # nc[j] has nc[j] - j core points before it, so its left core is ci[nc[j] - j - 1].
    nc = np.flatnonzero(~core)
    xn = s.take(nc)
    left = nc - np.arange(nc.size) - 1
    right = left + 1
    before = int(np.searchsorted(left, 0))  # non-core points before the first core
    after = int(np.searchsorted(right, m))  # ... and from here on, after the last one
    left[:before] = m - 1  # circular data: wrap round to the last core
    right[after:] = 0  # ... and to the first
    d_left = xn - xc.take(left)
    d_right = xc.take(right) - xn
    if wrap:
        d_left[:before] = (xn[:before] + period) - xc[m - 1]
        d_right[after:] = (xc[0] + period) - xn[after:]
    else:
        d_left[:before] = np.inf
        d_right[after:] = np.inf
    near_left = d_left <= eps
    near_right = d_right <= eps
    lab_left = core_labels.take(left)
    lab_right = core_labels.take(right)
    both = near_left & near_right
    first = np.where(near_left, lab_left, np.where(near_right, lab_right, -1))
    if order is not None or wrap:  # otherwise the left cluster has the lower number already
        first[both] = np.minimum(lab_left[both], lab_right[both])
    labels[nc] = first
    if second is not None:
        second[nc[both]] = np.maximum(lab_left[both], lab_right[both])
        second[second == labels] = -1  # both sides in the same cluster
    return labels, second, core


def _dbscan1d(x, eps, min_pts, period, border, *, x_name="x", min_pts_name="min_pts", want_core=False):
    """Validated entry: labels (N,) or (N, 2) in caller order, and the core mask if asked."""
    arr = _check_x(x, x_name)
    eps = check_positive("eps", eps)
    min_pts = check_int(min_pts_name, min_pts, 1)
    period = _check_period(period)
    border = _check_border(border)
    v = arr
    if period is not None:
        v = np.mod(arr, period)
        v[v >= period] = 0.0  # np.mod(-tiny, p) rounds to p
    core = None
    if _is_sorted(v):
        with np.errstate(over="ignore"):  # a difference beyond the float range is inf: not a neighbour
            labels, second, core = _cluster_sorted(v, eps, min_pts, period, border, None)
        labels = labels.astype(np.int64, copy=False)
    else:
        order, s = _argsort(v)
        with np.errstate(over="ignore"):
            labels_s, second_s, core_s = _cluster_sorted(s, eps, min_pts, period, border, order)
        labels = np.empty(v.size, dtype=np.int64)
        labels[order] = labels_s.astype(np.int64, copy=False)
        if want_core:
            core = np.empty_like(core_s)
            core[order] = core_s
        second = None
        if second_s is not None:
            second = np.empty(v.size, dtype=np.int64)
            second[order] = second_s
    if second is not None:
        labels = np.stack([labels, second.astype(np.int64, copy=False)], axis=1)
    return labels, core


def dbscan1d(x, eps: float, min_pts: int, *, period: float | None = None, border: str = "first") -> np.ndarray:
    """DBSCAN of 1-D data: vectorised, linear after sorting, and the same labels as scikit-learn.

    Parameters
    ----------
    x : array_like of shape (N,)
        Finite values, in any order. Sorted input is detected with one O(N) pass and
        is not sorted again.
    eps : float
        Neighbourhood radius, > 0, in the units of ``x``. ``|x_i - x_j| <= eps``
        counts (the difference taken in floating point).
    min_pts : int
        Neighbourhood size that makes a core point, the point itself included, >= 1
        (scikit-learn's ``min_samples``).
    period : float, optional
        For circular data: values are taken modulo ``period``, and distances go the
        shorter way round (``np.pi`` for line directions, ``2 * np.pi`` for headings).
        See the module notes for how clusters that wrap are numbered.
    border : {"first", "noise", "all"}
        What happens to a border point, a non-core point within eps of a core point:

        * ``"first"`` (default): it joins the lowest-numbered cluster that reaches it.
          The labels are then identical to ``sklearn.cluster.DBSCAN(eps,
          min_samples=min_pts)`` on the same data, numbering included (up to pairs
          within a rounding error of eps, see the module notes).
        * ``"noise"``: it is labelled -1, so clusters are their core points only
          (as in Campello et al. 2013, HDBSCAN's DBSCAN*).
        * ``"all"``: it belongs to every cluster that reaches it. In 1-D that is at
          most two, one on each side. The result has shape (N, 2): column 0 is the
          ``"first"`` label, and column 1 is the other cluster (the higher number) for
          a border point between two clusters, -1 otherwise.

    Returns
    -------
    labels : ndarray of shape (N,) (or (N, 2) for ``border="all"``), int64
        Cluster label per point in the caller's order, -1 for noise. Clusters are
        numbered 0, 1, ... by their first core point in the caller's order.

    Raises
    ------
    ValueError
        ``x`` not one-dimensional or not finite, ``eps`` not a finite number > 0,
        ``min_pts`` not an integer >= 1, ``period`` not a finite number > 0, or an
        unknown ``border``. The message names the argument.

    Examples
    --------
    >>> dbscan1d([0.0, 0.1, 0.2, 5.0, 9.0, 9.1, 9.2], eps=0.15, min_pts=2)
    array([ 0,  0,  0, -1,  1,  1,  1])
    >>> dbscan1d([9.1, 0.1, 5.0, 9.0, 0.0], eps=0.15, min_pts=2)  # any order
    array([ 0,  1, -1,  0,  1])

    Line directions are defined modulo pi, so 179 degrees is next to 1 degree:

    >>> dbscan1d(np.radians([1.0, 2.0, 90.0, 178.0, 179.0]), np.radians(3.0), 2, period=np.pi)
    array([ 0,  0, -1,  0,  0])

    A border point between two clusters:

    >>> x = [0, 1, 1, 2, 4, 6, 7, 7, 8]
    >>> dbscan1d(x, 2, 4)
    array([0, 0, 0, 0, 0, 1, 1, 1, 1])
    >>> dbscan1d(x, 2, 4, border="noise")
    array([ 0,  0,  0,  0, -1,  1,  1,  1,  1])
    >>> dbscan1d(x, 2, 4, border="all")[4]
    array([0, 1])

    References
    ----------
    B. Meglicki, "Linear time DBSCAN for sorted 1D data and laser range scan
    segmentation", 2021, section 2.
    """
    return _dbscan1d(x, eps, min_pts, period, border)[0]


class DBSCAN1D:
    """scikit-learn style estimator around :func:`dbscan1d`.

    Parameters
    ----------
    eps : float, default 0.5
        Neighbourhood radius, > 0.
    min_samples : int, default 5
        Neighbourhood size (the point itself included) that makes a core point.
    period : float, optional
        Circular data; see :func:`dbscan1d`.
    border : {"first", "noise", "all"}, default "first"
        Border-point policy; see :func:`dbscan1d`.

    Attributes
    ----------
    labels_ : ndarray of shape (N,), int64
        Cluster labels, -1 for noise. For ``border="all"``, each point's first cluster.
    memberships_ : ndarray of shape (N, 2), int64
        Only for ``border="all"``: both clusters of each point (see :func:`dbscan1d`).
    core_sample_indices_ : ndarray of shape (n_core,), int64
        Indices of the core points, ascending.
    components_ : ndarray of shape (n_core, 1)
        The core points' values (modulo ``period`` for circular data).

    Examples
    --------
    >>> model = DBSCAN1D(eps=0.15, min_samples=2).fit(np.array([[0.0], [0.1], [5.0]]))
    >>> model.labels_, model.core_sample_indices_
    (array([ 0,  0, -1]), array([0, 1]))
    """

    def __init__(self, eps: float = 0.5, min_samples: int = 5, *, period: float | None = None,
                 border: str = "first") -> None:
        self.eps = eps
        self.min_samples = min_samples
        self.period = period
        self.border = border

    def fit(self, X, y=None) -> DBSCAN1D:
        """Cluster ``X`` of shape (N,) or (N, 1); ``y`` is ignored."""
        try:
            arr = np.asarray(X, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("X must be an array of numbers of shape (N,) or (N, 1)") from None
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        elif arr.ndim != 1:
            raise ValueError(f"X must have shape (N,) or (N, 1), got shape {arr.shape}")
        labels, core = _dbscan1d(arr, self.eps, self.min_samples, self.period, self.border,
                                 x_name="X", min_pts_name="min_samples", want_core=True)
        if labels.ndim == 2:
            self.memberships_ = labels
            labels = labels[:, 0].copy()
        self.labels_ = labels
        self.core_sample_indices_ = np.flatnonzero(core).astype(np.int64)
        values = arr
        if self.period is not None:
            values = np.mod(values, float(self.period))
        self.components_ = values[self.core_sample_indices_].reshape(-1, 1)
        return self

    def fit_predict(self, X, y=None) -> np.ndarray:
        """``fit(X)`` and return ``labels_``."""
        return self.fit(X).labels_

    def __repr__(self) -> str:
        extra = "" if self.period is None else f", period={self.period!r}"
        extra += "" if self.border == "first" else f", border={self.border!r}"
        return f"DBSCAN1D(eps={self.eps!r}, min_samples={self.min_samples!r}{extra})"
