"""The fast DBSCAN1D, for :func:`labkit.dbscan1d` (private: :mod:`labkit.dbscan` reads as the paper).

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

"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: ``dbscan1d`` counts neighbours by shifted comparisons up to this ``min_pts`` (and while the
#: ``(min_pts - 1) * N`` booleans they keep fit in ``_SHIFT_MAX_BYTES``), with ``searchsorted``
#: bounds beyond. Both give identical labels; the tests run both.
_SHIFT_MAX_MIN_PTS = 32
_SHIFT_MAX_BYTES = 1 << 27

_CHUNK = 1 << 15  # elements per chunk of floating-point differences (256 kB: stays in cache)


def is_sorted(v: np.ndarray) -> bool:
    return v.size < 2 or not bool(np.any(v[1:] < v[:-1]))


def argsort_values(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
    src = s if ext is None else ext
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
    itype: type[np.signedinteger[Any]] = np.int32 if n < 2**31 else np.int64
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


def cluster_sorted(s: np.ndarray, eps: float, min_pts: int, period: float | None, border: str,
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
    if period is not None and eps >= period / 2:  # every point is within eps of every other one
        core = np.full(n, n >= min_pts)
        labels = np.full(n, 0 if n >= min_pts else -1, dtype=np.int64)
        return labels, (np.full(n, -1, dtype=np.int64) if border == "all" else None), core
    ext = None if period is None else _wrap_extension(s, period, eps, min_pts)
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
    if not merged and order is None:
        core_labels = run  # numbered by their smallest index already
    else:
        starts = np.concatenate([[0], np.flatnonzero(gap) + 1])
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


