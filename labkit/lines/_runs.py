"""Internals shared by the line extractors (private: not part of labkit's API).

* from the local extractors (:mod:`~labkit.lines.incremental`, :mod:`~labkit.lines.regression`):
  :func:`_runs` (the runs a line may not cross), :class:`_PrefixSums` (O(1) weighted sums of
  any run) and :func:`_fitted` (the final fit of every line, its segment stopped at its end
  beams' rays by :func:`_on_rays`, which split-and-merge's segments follow too);
* from the global extractors (:mod:`~labkit.lines.ransac`, :mod:`~labkit.lines.hough`):
  :func:`_taking_part` (the beams they use), :func:`_fit` (a weighted line in closed form)
  and :func:`_segments` (one line's inliers cut into segments);
* for ``trace=True``: :class:`_Trace`, the :class:`labkit.Step` records of one call;
* for the noise-following settings (``"auto"``) of every extractor that has them: :func:`_noise`
  (a threshold and the covariances' range noise for one scan).

Placing (dropping the lines the data cannot place) is :mod:`labkit.lines.placing`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..features import LineSegment, frozen_array, line_segment
from ..fitting import line_from_sums
from ..noise import auto_split_threshold, scan_sigma
from ..params import AUTO
from ..scan import Scan
from ..segmentation import labels_from
from ..steps import Step


class _Trace(list):
    """The steps of one call of an extractor, as :class:`labkit.Step` records."""

    def __init__(self, algorithm: str):
        super().__init__()
        self.algorithm = algorithm

    def add(self, kind: str, first: int = -1, last: int = -1, r: float = math.nan, alpha: float = math.nan,
            **fields) -> None:
        self.append(Step(self.algorithm, kind, int(first), int(last), float(r), float(alpha), **fields))

    def verdict(self, line: LineSegment, kept: bool, min_length_m: float, what: str = "line") -> None:
        """The last step of every line: ``accept`` (it is returned) or ``reject`` (shorter than
        ``min_length_m``), with the line fitted to its beams, ``beams`` its beams."""
        length = f"{line.length:.3f} m"
        self.add("accept" if kept else "reject", line.first, line.last, line.r, line.alpha, value=line.length,
                 threshold=min_length_m, test="" if kept else "min_length_m", beams=tuple(line.indices.tolist()),
                 reason=f"{what} of {line.n_points} points, {length} long" + (
                     "" if kept else f" < min_length_m={min_length_m} m"))


def _runs(scan: Scan, segments, max_gap_m: float, min_points: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """The runs a line may not cross, shared by the extractors of this module and
    :mod:`labkit.lines.regression`.

    Returns ``(beams, runs)``: ``beams`` the usable beams in scan order (valid, and with a
    label >= 0 when ``segments`` is given); ``runs`` the ``(a, b)`` such that
    ``beams[a:b]`` is a run: neighbouring usable beams whose points are at most ``max_gap_m``
    apart and (with ``segments``) share a label and have no valid beam labelled -1 between
    them (invalid beams between them are skipped). Runs of fewer than ``min_points`` beams
    are left out. The seam of a full-circle scan always ends a run.
    """
    if segments is None:
        usable = scan.valid
        labels = None
    else:
        labels = labels_from(scan, segments)
        usable = labels >= 0
    beams = np.flatnonzero(usable)
    if beams.size == 0:
        return beams, []
    p = scan.points.take(beams, axis=0)
    d = p[1:] - p[:-1]
    linked = np.hypot(d[:, 0], d[:, 1]) <= max_gap_m
    if labels is not None:
        lab = labels.take(beams)
        linked &= lab[1:] == lab[:-1]
        # a valid beam labelled -1 (taken by another detector) is a boundary, not a dropout
        taken = np.concatenate(([0], np.cumsum(scan.valid & ~usable)))
        linked &= taken.take(beams[1:]) == taken.take(beams[:-1] + 1)
    cut = np.flatnonzero(~linked) + 1  # a run starts at 0 and after every unlinked pair
    starts = np.concatenate(([0], cut))
    stops = np.concatenate((cut, [beams.size]))
    keep = stops - starts >= min_points
    return beams, list(zip(starts[keep].tolist(), stops[keep].tolist(), strict=True))


class _PrefixSums:
    """Prefix sums of ``w, w x, w y, w x^2, w y^2, w x y`` over points laid end to end:
    ``sums(a, b)`` gives the weighted sums of the points ``a..b-1`` (for
    :func:`labkit.fitting.line_from_sums`) in O(1). ``table`` is the (N + 1, 6) array, row
    ``i`` the sums over points ``0..i-1``."""

    __slots__ = ("table",)

    def __init__(self, xy: np.ndarray, w: np.ndarray):
        x, y = xy[:, 0], xy[:, 1]
        wx, wy = w * x, w * y
        terms = np.stack([w, wx, wy, wx * x, wy * y, wx * y], axis=1)
        self.table = np.zeros((len(w) + 1, 6))
        np.cumsum(terms, axis=0, out=self.table[1:])

    def __call__(self, a: int, b: int) -> list[float]:
        return (self.table[b] - self.table[a]).tolist()


def _fitted(xy: np.ndarray, beams: np.ndarray, spans, min_length_m: float,
            steps: _Trace | None = None, range_sigma: float | None = None) -> list[LineSegment]:
    """Step 7, shared with :mod:`labkit.lines.regression`: every line, the points ``a..b-1`` of
    ``xy`` (beams ``beams[a:b]``) for each ``(a, b)`` of ``spans``, fitted by
    :func:`labkit.features.line_segment`, its segment stopped at the rays of its first and last
    beams (:func:`_on_rays`); lines shorter than ``min_length_m`` are dropped (each line's
    verdict is added to ``steps`` if given). ``range_sigma``: the range noise of the lines'
    covariances (None: each line's own residuals)."""
    lines = []
    for a, b in spans:
        line = line_segment(xy[a:b], beams[a:b], range_sigma=range_sigma)
        start, end, moved = _on_rays(xy[a].tolist(), xy[b - 1].tolist(), line.r, line.alpha)
        if moved:
            line = dataclasses.replace(line, start=frozen_array(start), end=frozen_array(end))
        kept = line.length >= min_length_m
        if kept:
            lines.append(line)
        if steps is not None:
            steps.verdict(line, kept, min_length_m)
    return lines


def _on_rays(p_first, p_last, r: float, alpha: float) -> tuple[tuple[float, float], tuple[float, float], bool]:
    """The ends of the segment of the line ``(r, alpha)`` whose first and last points (sensor
    frame; plain floats) are ``p_first`` and ``p_last``, and whether one of them was stopped.

    Each end is its point projected onto the line, but never past the ray of its own beam (on
    the side away from the other end): there it is where that ray meets the line. A noisy end
    point seen at a grazing angle projects along the line, over the rays of the next beams, and
    the segment would claim a surface where they saw another (a wall metres behind, a chair in
    front). Every consecutive-run extractor's segments follow this rule (split-and-merge,
    incremental, regression)."""
    c, sn = math.cos(alpha), math.sin(alpha)
    (x0, y0), (x1, y1) = p_first, p_last
    d0, d1 = x0 * c + y0 * sn - r, x1 * c + y1 * sn - r
    sx, sy, ex, ey = x0 - d0 * c, y0 - d0 * sn, x1 - d1 * c, y1 - d1 * sn
    inside = x0 * y1 - y0 * x1  # the side of the first ray the last point is on (and - for the last ray)
    moved = False
    # past its ray: where the ray meets the line, at r / (r + d) of the point (if it meets it ahead)
    if (x0 * sy - y0 * sx) * inside < 0 and r + d0 > 0:
        sx, sy, moved = x0 * (r / (r + d0)), y0 * (r / (r + d0)), True
    if (x1 * ey - y1 * ex) * inside > 0 and r + d1 > 0:
        ex, ey, moved = x1 * (r / (r + d1)), y1 * (r / (r + d1)), True
    return (sx, sy), (ex, ey), moved


def _taking_part(scan: Scan, segments, max_range: float = math.inf):
    """The beams a global extractor uses: valid ones (given a segmentation, those in a
    segment) nearer than ``max_range``. Returns the per-beam labels (None without a
    segmentation) and the beams' indices, points (row k is beam ``beams[k]``), ranges and
    the least-squares weights of labkit's fits (1 / range)."""
    labels = None if segments is None else labels_from(scan, segments)
    use = scan.valid if labels is None else labels >= 0
    if math.isfinite(max_range):
        with np.errstate(invalid="ignore"):  # NaN ranges of invalid beams
            use = use & (scan.ranges < max_range)
    beams = np.flatnonzero(use)
    rho = scan.ranges[beams]
    return labels, beams, scan.points[beams], rho, 1.0 / rho


def _fit(p: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """``(r, alpha)`` of the weighted least-squares line through points ``p`` (M, 2), weights ``w``
    (the closed form of :func:`labkit.fitting.fit_line_polar`)."""
    x, y = p[:, 0], p[:, 1]
    wx, wy = w * x, w * y
    return line_from_sums(float(w.sum()), float(wx.sum()), float(wy.sum()), float(wx @ x), float(wy @ y),
                          float(wx @ y))


def _segments(xy: np.ndarray, beams: np.ndarray, labels: np.ndarray | None, inliers: np.ndarray, min_points: int,
              min_length_m: float, max_gap_m: float, steps: _Trace | None = None,
              range_sigma: float | None = None) -> list[LineSegment]:
    """The segments of one line: its inliers (positions into ``xy``/``beams``, ascending) cut
    where neighbouring inliers are more than ``max_gap_m`` apart (or, given per-beam
    ``labels``, in different range segments); runs with ``min_points`` points or more and
    at least ``min_length_m`` long become segments. Shared by :mod:`labkit.lines.hough`.
    Given ``steps``, every run ends in an ``accept`` or a ``reject`` step. ``range_sigma``: the
    range noise of the segments' covariances (None: each segment's own residuals)."""
    if inliers.size < min_points:
        if steps is not None and inliers.size:
            b = beams[inliers]
            steps.add("reject", b[0], b[-1], value=inliers.size, threshold=min_points, test="min_points",
                      beams=tuple(b.tolist()), reason=f"{inliers.size} inliers < min_points={min_points}")
        return []
    p = xy[inliers]
    gap = np.hypot(*(p[1:] - p[:-1]).T)
    cut = gap > max_gap_m
    if labels is not None:
        lab = labels[beams[inliers]]
        cut |= lab[1:] != lab[:-1]
    cut |= _seen_past(xy, inliers, max_gap_m)
    bounds = np.concatenate([[0], np.flatnonzero(cut) + 1, [inliers.size]]).tolist()
    out = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        if b - a < min_points:
            if steps is not None:
                run = beams[inliers[a:b]]
                steps.add("reject", run[0], run[-1], value=b - a, threshold=min_points, test="min_points",
                          beams=tuple(run.tolist()), reason=f"a run of {b - a} inliers < min_points={min_points}")
            continue
        seg = line_segment(p[a:b], beams[inliers[a:b]], range_sigma=range_sigma)
        kept = seg.length >= min_length_m
        if kept:
            out.append(seg)
        if steps is not None:
            steps.verdict(seg, kept, min_length_m, "a run")
    return out


def _ends_off(rho: np.ndarray, c: np.ndarray, r: float, margin: float) -> np.ndarray:
    """Which beams end more than ``margin`` off the line ``x cos(alpha) + y sin(alpha) = r``
    along their own rays, in front of it or behind it: ``rho`` their ranges, ``c`` the cosine of
    each beam's angle from the line's normal. A ray meets the line (at range ``r / c``) only
    when ``c > 0``; a beam whose ray does not is no evidence. Split-and-merge's merges and the
    global extractors' segments are cut at such a beam."""
    return (c > 0) & (np.abs(rho * c - r) > margin * c)


def _seen_past(xy: np.ndarray, inliers: np.ndarray, margin: float) -> np.ndarray:
    """For each pair of neighbouring inliers (positions into ``xy``, ascending), whether the
    line was not seen between them: a point between them in scan order ends more than ``margin``
    off the line along its own ray, behind it (its beam saw through the line: a doorway, a
    window, a gap between shelves) or in front of it (something hid the stretch the line would
    claim: a post, a chair leg, a person). A segment across it would claim what no beam saw, as
    split-and-merge's merges may not (its ``"beam_between"`` test). The line is the
    least-squares fit of all the inliers; a point whose ray does not meet it is no evidence."""
    first, last = int(inliers[0]), int(inliers[-1])
    if last - first + 1 == inliers.size:  # no point between the inliers
        return np.zeros(inliers.size - 1, dtype=bool)
    r, alpha = _fit(xy[inliers], np.ones(inliers.size))
    q = xy[first:last + 1]
    rho = np.hypot(q[:, 0], q[:, 1])
    far = _ends_off(rho, (q[:, 0] * math.cos(alpha) + q[:, 1] * math.sin(alpha)) / rho, r, margin)
    far[inliers - first] = False
    count = np.concatenate([[0], np.cumsum(far)])  # far points among the first k
    return count[inliers[1:] - first] > count[inliers[:-1] - first + 1]


def _noise(scan: Scan, threshold_m, range_sigma_m, sigmas: float) -> tuple[float, float | None]:
    """A distance threshold for ``scan`` and the range noise of its lines' covariances.

    ``range_sigma_m``: a number as given, ``"auto"`` the scan's estimate
    (:func:`labkit.noise.scan_sigma`), None each line's own residuals (the covariances of
    :func:`labkit.features.line_segment`). ``threshold_m``: a number as given, ``"auto"``
    ``sigmas`` of that range noise (of the scan's estimate when it is None), at least
    :data:`labkit.noise.MIN_SPLIT_M` (2 cm)."""
    sigma = scan_sigma(scan) if range_sigma_m == AUTO else range_sigma_m
    if threshold_m == AUTO:
        threshold_m = auto_split_threshold(scan_sigma(scan) if sigma is None else sigma, sigmas)
    return threshold_m, sigma
