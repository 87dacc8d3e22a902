"""What makes :func:`labkit.lines.split_and_merge` fast (private: not part of labkit's API).

:mod:`labkit.lines.split_merge` reads as the algorithm; the tricks it leans on live here, each
tested against its plain version (``tests/test_split_merge.py``):

* :class:`Runs` -- the range segments laid end to end with prefix sums of ``w, wx, wy, wxx, wyy,
  wxy``, so that the weighted line fit of any run of points costs two subtractions
  (:func:`labkit.fitting.line_from_sums`) instead of a pass over the points;
* :class:`Line` -- a line during split-and-merge, a slotted record with plain floats;
* :func:`wide_gaps` -- the gaps between neighbouring points wider than ``max_gap_m``, measured only
  where ``|dx| + |dy|`` says they could be;
* :func:`grazing_links` and :func:`grazing_runs` -- the walls seen at a grazing angle joined again,
  by label arithmetic over the whole scan;
* :func:`shifted_stretch` -- the shift test's search over windows of 4, 8, 16... points by running
  sums, with an early exit;
* :func:`line_segments` -- every line's covariance and RMS error in one vectorised pass.
"""

from __future__ import annotations

import math

import numpy as np

from ..features import LineSegment
from ..fitting import line_covariances_rms, line_from_sums
from ..scan import Scan
from ..segmentation import SegmentationParams, breakpoint_thresholds
from ._runs import _on_rays

__all__ = ["Runs", "Line", "wide_gaps", "grazing_links", "grazing_runs", "shifted_stretch", "line_segments",
           "covariances"]


class Runs:
    """Range segments laid end to end (points ``xy``, beams ``idx``) with prefix sums of
    ``w, wx, wy, wxx, wyy, wxy``: the sums of any sub-run, hence its weighted line fit, in O(1)."""

    __slots__ = ("xy", "x", "y", "idx", "c")

    def __init__(self, xy: np.ndarray, w: np.ndarray, idx: np.ndarray):
        self.xy, self.idx = xy, idx
        self.x, self.y = x, y = xy[:, 0], xy[:, 1]
        c = np.empty((len(x) + 1, 6))  # row i: the sums over points 0..i-1
        c[0] = 0.0
        t = c[1:]  # the terms of every point, summed up in place below
        t[:, 0] = w
        np.multiply(w, x, out=t[:, 1])  # w x
        np.multiply(w, y, out=t[:, 2])  # w y
        np.multiply(t[:, 1], x, out=t[:, 3])  # w x x
        np.multiply(t[:, 2], y, out=t[:, 4])  # w y y
        np.multiply(t[:, 1], y, out=t[:, 5])  # w x y
        # the running sums down the columns; read as three columns of complex numbers, each
        # complex add sums two columns at once: the same sums, in half the steps
        z = t.view(np.complex128)
        np.add.accumulate(z, axis=0, out=z)  # (= cumsum, with less overhead)
        self.c = c

    def sums(self, a: int, b: int) -> list[float]:
        """The weighted sums of the points ``a..b-1``, as plain floats (scalar arithmetic on
        them is fastest, and converting only the sums used is much cheaper than the whole table)."""
        return (self.c[b] - self.c[a]).tolist()

    def fit(self, a: int, b: int) -> tuple[float, float]:
        """The weighted least-squares line ``(r, alpha)`` of the points ``a..b-1``."""
        return line_from_sums(*self.sums(a, b))

    def lines(self, spans: list[tuple[int, int]]) -> list[Line]:
        """A :class:`Line` for each run ``a..b-1`` of ``spans``; their sums, end points and
        beams are gathered in one go."""
        if not spans:
            return []
        ab = np.array(spans)
        a, b = ab[:, 0], ab[:, 1]  # (indexing: unpacking an array costs an IndexError)
        sums = (self.c.take(b, axis=0) - self.c.take(a, axis=0)).tolist()
        p_first, p_last = self.xy.take(a, axis=0).tolist(), self.xy.take(b - 1, axis=0).tolist()
        first, last = self.idx.take(a).tolist(), self.idx.take(b - 1).tolist()
        return [Line(self.idx[i:j], s, f, g, p, q)
                for (i, j), s, f, g, p, q in zip(spans, sums, first, last, p_first, p_last, strict=True)]


class Line:
    """A line during split-and-merge: its beams (all, ``first`` and ``last``), weighted sums,
    fit, first and last points, and their projections onto the line (``start``, ``end``)."""

    __slots__ = ("idx", "first", "last", "s", "r", "alpha", "p_first", "p_last", "start", "end", "cov")

    def __init__(self, idx: np.ndarray, s: list[float], first: int, last: int, p_first, p_last):
        self.idx, self.s, self.first, self.last = idx, s, first, last
        self.r, self.alpha = r, alpha = line_from_sums(*s)
        self.p_first, self.p_last = p_first, p_last
        # the first and last points projected onto the line, but never past the rays of the
        # first and last beams (a noisy end point at a grazing angle projects over the next rays)
        self.start, self.end, _ = _on_rays(p_first, p_last, r, alpha)
        self.cov = None

    @property
    def length(self) -> float:
        dx, dy = self.end[0] - self.start[0], self.end[1] - self.start[1]
        return math.sqrt(dx * dx + dy * dy)  # (not math.hypot, whose rounding differs between Pythons)

    def joined(self, other: Line) -> Line:
        """The line through this line's points and ``other``'s (which follows it), refitted
        from the summed sums."""
        idx = np.concatenate([self.idx, other.idx])
        idx.setflags(write=False)
        return Line(idx, [u + v for u, v in zip(self.s, other.s, strict=True)], self.first, other.last,
                    self.p_first, other.p_last)


def wide_gaps(x: np.ndarray, y: np.ndarray, max_gap_m: float) -> dict[int, float]:
    """``{i: gap}`` for the neighbouring points ``i, i + 1`` that may be more than ``max_gap_m``
    apart (every such pair, in ascending ``i``, and a few just under it). As ``hypot(dx, dy) <=
    |dx| + |dy|``, only the few neighbours with ``|dx| + |dy|`` near ``max_gap_m`` are measured."""
    dx, dy = x[1:] - x[:-1], y[1:] - y[:-1]
    near = (np.abs(dx) + np.abs(dy) > 0.99 * max_gap_m).nonzero()[0]
    return dict(zip(near.tolist(), np.hypot(dx[near], dy[near]).tolist(), strict=True))


#: With ``split_threshold_m="auto"``: neighbouring lone beams that the breakpoint detector cut
#: (its ``incidence_deg``, 10 deg) are joined again when the line between their points makes at
#: least this angle (degrees) with the beams; ``min_points`` or more in a row are a wall seen at a
#: grazing angle (:func:`grazing_runs`). On the simulated sets 2-5 deg find the same walls to
#: within 0.003 of TruePos.
GRAZING_DEG = 3.0


def grazing_links(p: np.ndarray, r: np.ndarray, a: np.ndarray, k: np.ndarray, threshold_m: float,
                  sigma: float) -> np.ndarray:
    """Which pairs of neighbouring beams ``(k, k + 1)`` (points ``p``, ranges ``r``, angles ``a``
    of the scan) the breakpoint detector cut (its ``incidence_deg``) though the line between their
    points makes :data:`GRAZING_DEG` or more with the beams: the same surface seen at a grazing
    angle, nothing between them (no beam)."""
    gap = np.hypot(p[k + 1, 0] - p[k, 0], p[k + 1, 1] - p[k, 1])
    dphi = np.abs(a[k + 1] - a[k])
    ra, rb = r[k], r[k + 1]
    return (gap > breakpoint_thresholds(ra, rb, dphi, threshold_m, incidence_deg=SegmentationParams.incidence_deg,
                                        range_sigma_m=sigma)) & (
        gap <= breakpoint_thresholds(ra, rb, dphi, threshold_m, incidence_deg=GRAZING_DEG, range_sigma_m=sigma))


def grazing_runs(scan: Scan, labels: np.ndarray, threshold_m: float, min_points: int,
                 sigma: float) -> tuple[np.ndarray, np.ndarray | None]:
    """``labels`` with the walls seen at a grazing angle that the breakpoint detector cut to
    pieces joined again (relabelled in scan order), and at which beams ``k`` the pair
    ``(k, k + 1)`` was joined (None: none). See :func:`labkit.lines.split_merge.join_grazing_walls`."""
    n = len(labels)
    free = scan.valid & (labels < 0)
    k = np.flatnonzero(free[:-1] & free[1:])  # pairs of lone beams
    m = min_points - 1  # pairs in a chain of min_points beams
    if len(k) < m or not (k[m - 1:] - k[:len(k) - m + 1] == m - 1).any():  # (no m of them in a row)
        return labels, None
    link = np.zeros(n - 1, dtype=bool)
    link[k[grazing_links(scan.points, scan.ranges, scan.angles, k, threshold_m, sigma)]] = True
    edges = np.flatnonzero(np.diff(np.concatenate([[False], link, [False]]).astype(np.int8)))
    firsts, lasts = edges[0::2], edges[1::2]  # chain j: beams firsts[j] .. lasts[j]
    long = lasts - firsts + 1 >= min_points
    if not long.any():
        return labels, None
    firsts, lasts = firsts[long], lasts[long]
    # the pairs between a chain and the segment it continues, either side
    ends = np.concatenate([firsts - 1, lasts])
    ends = ends[(ends >= 0) & (ends < n - 1)]
    ends = ends[scan.valid[ends] & scan.valid[ends + 1]]
    link[ends[grazing_links(scan.points, scan.ranges, scan.angles, ends, threshold_m, sigma)]] = True
    same = (labels[:-1] == labels[1:]) & (labels[:-1] >= 0)  # pairs the segmentation joined
    joined = np.zeros(n - 1, dtype=bool)
    for f, e in zip(firsts.tolist(), lasts.tolist(), strict=True):
        joined[max(f - 1, 0):e + 1] = link[max(f - 1, 0):e + 1]
    out = labels.copy()
    top = int(labels.max()) + 1
    runs = np.flatnonzero(np.diff(np.concatenate([[False], joined | same, [False]]).astype(np.int8)))
    firsts, lasts = runs[0::2], runs[1::2]
    count = np.concatenate([[0], np.add.accumulate(joined)])
    new = count[lasts] > count[firsts]  # (a run with no new pair is a segment as it was)
    for j, (f, e) in enumerate(zip(firsts[new].tolist(), lasts[new].tolist(), strict=True)):
        out[f:e + 1] = top + j
    if scan.is_full_circle and labels[0] >= 0 and labels[0] == labels[-1] and out[0] != out[-1]:
        out[out == out[-1]] = out[0]  # the segment across the seam stays one
    # labels in scan order again: each segment is a run of beams, numbered where it starts; one
    # crossing the seam keeps the first number at its end too
    seen = out >= 0
    start = seen.copy()
    start[1:] &= out[1:] != out[:-1]
    number = np.add.accumulate(start) - 1
    if seen[0] and out[0] == out[-1]:
        number[np.flatnonzero(start)[-1]:] = 0
    return np.where(seen, number, -1), np.concatenate([joined & ~same, [False]])


def shifted_stretch(res: np.ndarray, sd: np.ndarray, z_limit: float, min_mean_m: float):
    """The stretch of consecutive residuals ``res`` (each of standard deviation ``sd``) that lies
    most to one side: over windows of ``w`` = 4, 8, 16, ... points up to half the run, the window
    whose sum exceeds ``z_limit sigma sqrt(w)`` by the most (its standard score), its mean at least
    ``min_mean_m``; ``(k, w, mean)`` (from the ``k``-th residual) or None.

    Running sums give every window's sum and variance by one subtraction; a window of 8, 16, ...
    points is made of windows of 4, so when no window of 4 has a mean over ``min_mean_m`` none
    can have, and most runs at a few millimetres of noise end there."""
    n = len(res)
    c = np.zeros(n + 1)
    np.add.accumulate(res, out=c[1:])  # (= cumsum, with less overhead)
    if float(np.abs(c[4:] - c[:-4]).max()) <= min_mean_m * 4:
        return None
    v2 = np.zeros(n + 1)
    np.add.accumulate(sd * sd, out=v2[1:])
    best, best_z = None, z_limit
    w = 4
    while 2 * w <= n:
        s, s2 = c[w:] - c[:-w], v2[w:] - v2[:-w]
        zw = np.abs(s) / np.sqrt(s2)
        k = int(zw.argmax())
        if zw.item(k) > best_z and abs(s.item(k)) > min_mean_m * w:
            best, best_z = (k, w, s.item(k) / w), zw.item(k)
        w *= 2
    return best


def covariances(idx: np.ndarray, starts: np.ndarray, alpha: np.ndarray, p: np.ndarray, ranges: np.ndarray, weights,
                sigma: float, r: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Covariances of lines whose beams ``idx[starts[k]:starts[k + 1]]`` have the points ``p``
    (and, given the lines' ``r``, their RMS errors: :func:`labkit.fitting.line_covariances_rms`)."""
    w = np.ones(len(idx)) if weights == "uniform" else 1.0 / ranges.take(idx)
    var = np.full(len(idx), sigma * sigma)
    return line_covariances_rms(p[:, 0], p[:, 1], w, starts, alpha, var, r=r)


def line_segments(lines: list[Line], points, ranges, weights, sigma: float) -> list[LineSegment]:
    """LineSegment records, with every line's covariance and RMS error in one vectorised pass."""
    if not lines:
        return []
    counts = np.array([len(ln.idx) for ln in lines])
    idx = np.concatenate([ln.idx for ln in lines])
    starts = counts.cumsum() - counts
    p = points.take(idx, axis=0)  # = points[idx]
    alpha, r = np.array([ln.alpha for ln in lines]), np.array([ln.r for ln in lines])
    cov, rms = covariances(idx, starts, alpha, p, ranges, weights, sigma, r)  # and the RMS distances to the lines
    assert rms is not None, "given r, covariances gives the RMS distances too"
    rms = rms.tolist()
    # read-only records (the beams already are): each covariance, start and end is a view of these
    cov.setflags(write=False)
    ends = np.array([ln.start + ln.end for ln in lines])
    ends.setflags(write=False)
    pairs = list(ends.reshape(-1, 2))  # start 0, end 0, start 1, ...
    return [LineSegment(ln.r, ln.alpha, c, start, end, ln.first, ln.last, n, error, ln.idx)
            for ln, c, start, end, n, error in zip(lines, cov, pairs[0::2], pairs[1::2], counts.tolist(), rms,
                                                   strict=True)]
