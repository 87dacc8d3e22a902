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
:func:`dbscan1d` compares the sorted array with itself shifted by ``1 .. min_pts - 1``
places, with no Python loop over points; the tricks that make it fast (shifted boolean
ANDs, a packed-key sort) live in the private module ``labkit._dbscan_fast``, and the tests
check that it gives the reference's labels.

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

from typing import NamedTuple

import numpy as np

from ._dbscan_fast import argsort_values, cluster_sorted, is_sorted
from ._validate import check_int, check_positive

__all__ = ["Cluster", "dbscan1d_reference", "dbscan1d", "DBSCAN1D"]

_BORDERS = ("first", "noise", "all")


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
    """A cluster found by :func:`dbscan1d_reference`.

    With ``border="first"`` semantics a border point in the range may carry the label
    of the cluster on its left, which reached it first.

    Parameters
    ----------
    lower : int
        The first sorted position of the cluster.
    upper : int
        The last one (inclusive).
    id : int
        Its label.
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
    if is_sorted(v):
        with np.errstate(over="ignore"):  # a difference beyond the float range is inf: not a neighbour
            labels, second, core = cluster_sorted(v, eps, min_pts, period, border, None)
        labels = labels.astype(np.int64, copy=False)
    else:
        order, s = argsort_values(v)
        with np.errstate(over="ignore"):
            labels_s, second_s, core_s = cluster_sorted(s, eps, min_pts, period, border, order)
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

    References
    ----------
    B. Meglicki, "Linear time DBSCAN for sorted 1D data and laser range scan
    segmentation", 2021, section 2.

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
    """
    return _dbscan1d(x, eps, min_pts, period, border)[0]


class DBSCAN1D:
    """A scikit-learn style estimator around :func:`dbscan1d`.

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
