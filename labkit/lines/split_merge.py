"""Split-and-merge line extraction, with the iterative end-point fit (IEPF) variant.

The algorithm of the course slides (after Nguyen et al. 2005), as :func:`split_and_merge` runs it:

1. Initialise a list of lists L: every range segment (:mod:`labkit.segmentation`) is a list.
2. Take the next list from L and fit a line to it.
3. Find the worst point, the one farthest from the line; it may not be one of the first or
   last ``min_points // 2`` points (``minPointsPerLine`` in the slides).
4. If its distance is under ``split_threshold_m``, accept the line and go to 2.
5. Otherwise split the list at that point, put both halves back into L and go to 2.
6. When every list is done, merge similar neighbouring lines: ``|r1 - r2|`` and
   ``|alpha1 - alpha2|`` under thresholds (the angle difference taken across the wrap, so
   170 deg and -170 deg are 20 deg apart), or a chi-square test on the covariances, and
   refit the merged line from all its points.

:func:`iepf` is steps 2-5 bare, on one list of points. :func:`split_and_merge` adds what real
scans need, each a named stage of its own below:

* a list is first split at its widest gap between neighbouring points wider than ``max_gap_m``
  (:func:`_widest_gap`); lists with fewer than ``min_points`` points make no line, and their
  points, stranded between two lines (often the beams around a corner), join the neighbouring
  line when they are within three range sigmas of it (:func:`_absorb`);
* the split test follows the sensor's range noise by default (``"auto"``, :class:`_SplitTest`):
  ``range_sigma_m`` is estimated from each scan (:mod:`labkit.noise`), each point is measured
  against five of its own sigmas across the line (at least 2 cm), the fit's residuals against
  sigma, and a stretch of points lying to one side of the line is cut out; a far wall seen at a
  grazing angle, which the range segmentation cut at every beam, is joined again first
  (:func:`join_grazing_walls`);
* two lines are never merged across a valid beam between them that ends more than ``max_gap_m``
  off the merged line (:func:`_merge`): behind it, the beam saw through it (a doorway, a slot
  between shelves); in front of it, something else stopped the beam (a chair leg, a person), so
  the stretch of wall behind was never seen. Lines shorter than ``min_length_m`` are dropped;
* last, the lines the data cannot place are dropped (:mod:`labkit.lines.placing`): by its
  covariance, a line must lie within the trusted ``|dr|`` and ``|dalpha|`` of the true line with
  probability ``place_confidence``.

:data:`labkit.noise.FIXED_LINES` gives the papers' fixed 5 cm threshold instead, with every line
reported.

A line's segment runs between its first and last points projected onto it, but never past the
rays of its first and last beams: a noisy end point seen at a grazing angle projects along the
line over the next beams' rays, and the segment would claim a surface where they saw another.

``method="fit"`` measures the worst point from the least-squares line (the slides);
``method="endpoints"`` from the chord through the list's first and last points -- the iterative
end-point fit of the lab report and of Xavier et al. (2005) -- which is cheaper and is refitted by
least squares only once a line is accepted.

Every fit inside the split loop is O(1): prefix sums of ``w``, ``w x``, ``w y``, ``w x^2``,
``w y^2`` and ``w x y`` over a segment give the weighted sums of any run of it by two
subtractions, and the closed form of :func:`labkit.fitting.fit_line_polar` needs nothing else
(:class:`labkit.lines._split_merge_fast.Runs`, where this module's speed tricks live). Only the
worst-point search touches every point.

``split_and_merge(..., trace=True)`` also returns the steps taken, as :class:`labkit.Step`
records, so a notebook, a widget (:func:`labkit.viz.step_plots.step_viewer`) or the rerun viewer
(:func:`labkit.viz.rr.log_steps`) can replay them.
"""

from __future__ import annotations

import math
import warnings
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

from .._jit import ENABLED as _JIT
from ..features import LineSegment, line_segment  # noqa: F401 - used in doctests
from ..noise import MIN_SPLIT_M, SPLIT_SIGMAS, auto_split_threshold, chi2_upper_over_dof, noise_sigma
from ..params import AUTO, Params, checked_by, param
from ..scan import Scan
from ..segmentation import SegmentationParams, detector_labels, segment_labels, segment_order
from ..steps import Step
from ._runs import _ends_off, _Trace
from ._split_merge_fast import (
    GRAZING_DEG,
    Line,
    Runs,
    covariances,
    grazing_links,
    grazing_runs,
    line_segments,
    shifted_stretch,
    wide_gaps,
)
from .placing import placed

__all__ = ["split_and_merge", "iepf", "lines_similar", "join_grazing_walls", "SplitMergeParams", "GRAZING_DEG",
           "RESIDUAL_Z", "SHIFT_Z", "SHIFT_MIN_M"]

_ENGINE = False if _JIT else None  # (False: not imported yet)


def _engine():
    """labkit.lines._split_merge_engine, or None where it does not run (LABKIT_NO_JIT=1, or a BLAS
    whose rounding it does not reproduce). Imported on the first scan, not with labkit: numba's
    import alone costs some 0.35 s of CPU, which a process that extracts nothing should not pay."""
    global _ENGINE
    if _ENGINE is False:
        from . import _split_merge_engine as engine

        _ENGINE = engine if _JIT and engine.READY else None
    return _ENGINE

_METHODS = ("fit", "endpoints")


@dataclass(frozen=True)
class SplitMergeParams(Params):
    """Parameters of :func:`split_and_merge`.

    Both ``"iepf"`` and ``"split_and_merge"`` in the
    registry, and the ``[lines]`` table of :class:`labkit.Config`, each default once: lengths
    in metres (``_m``), angles in degrees (``_deg``)."""

    split_threshold_m: float = param(AUTO, "split when the worst point is farther than this from the line, metres; "
                                           "auto: each point against 5 sigma of the scan's range noise across the "
                                           "line (at least 2 cm), and the fit's residuals against sigma",
                                     lo=0, strict=True, auto=True)
    min_points: int = param(5, "fewest points of a line (Xavier et al. line_min_pts)", lo=2)
    min_length_m: float = param(0.15, "shortest line kept, metres (Xavier et al. line_min_len)", lo=0)
    max_gap_m: float = param(0.3, "split a run at a gap wider than this between neighbouring points, metres",
                             lo=0, strict=True)
    merge: str = param("thresholds", "merge test of neighbouring lines: thresholds, chi2 or none",
                       choices=("thresholds", "chi2", "none"), optional=True)
    merge_dr_m: float = param(0.2, "merge when |dr| is under this, metres", lo=0, strict=True)
    merge_dalpha_deg: float = param(10.0, "and |dalpha| under this, degrees", lo=0, strict=True)
    merge_chi2: float = param(9.21, "chi-square merge threshold (2 dof, 99 %)", lo=0, strict=True)
    range_sigma_m: float = param(AUTO, "range noise of the sensor, metres (breakpoints, line covariances, "
                                                "chi2 merge, placing); auto: estimated from each scan (labkit.noise)",
                                 lo=0, strict=True, auto=True)
    place_dr_m: float = param(0.05, "report a line only if it is likely within this of the true r, metres",
                              lo=0, strict=True)
    place_dalpha_deg: float = param(3.0, "and within this of the true alpha, degrees", lo=0, strict=True)
    place_confidence: float = param(0.8, "with at least this probability by its covariance (0: report every "
                                         "line, the papers)",
                                    lo=0, hi=1)
    weights: str = param("inverse_range", "point weights of the fits: inverse_range (1/rho, the slides) or uniform",
                         choices=("inverse_range", "uniform"), optional=True)


# ============================================================================ the bare algorithm
def iepf(points, threshold_m: float = 0.05, min_points: int = SplitMergeParams.min_points) -> list[tuple[int, int]]:
    """The split of the slides on one list of points (steps 2-5), by iterative end-point fit.

    The list's worst point is the one farthest from its chord (the line through its first and
    last points), among those that are not one of the first or last ``min_points // 2`` (unless
    the list is too short to leave any). Farther than ``threshold_m``, the list is split there
    (the worst point ends the left half); otherwise it is a line. Lists with fewer than
    ``min_points`` points make no line. No gaps, no noise tests, no merge: what
    :func:`split_and_merge` accepts on a single range segment with a fixed ``split_threshold_m``,
    no gap wider than ``max_gap_m`` and nothing stranded.

    Parameters
    ----------
    points : array_like of shape (N, 2), metres
        One run of points in scan order.
    threshold_m : float, metres
        The split threshold. Default 0.05 m (the papers').
    min_points : int
        ``minPointsPerLine``, at least 2. Default 5.

    Returns
    -------
    list of (int, int)
        The accepted lines as half-open index ranges ``[a, b)`` of ``points``, in order.

    Examples
    --------
    Two walls meeting in a corner at index 5:

    >>> corner = [[x, 0.0] for x in range(6)] + [[5.0, y] for y in range(1, 7)]
    >>> iepf(corner)
    [(0, 6), (6, 12)]
    """
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or not np.isfinite(p).all():
        raise ValueError(f"points must be finite, of shape (N, 2), got shape {p.shape}")
    if not (threshold_m > 0 and math.isfinite(threshold_m)):
        raise ValueError(f"threshold_m must be a finite number > 0, got {threshold_m!r}")
    if isinstance(min_points, bool) or not isinstance(min_points, (int, np.integer)) or min_points < 2:
        raise ValueError(f"min_points must be a whole number >= 2, got {min_points!r}")
    keep = min_points // 2
    accepted, lists = [], [(0, len(p))]  # step 1: L holds the whole list
    while lists:
        a, b = lists.pop()  # step 2: the next list
        if b - a < min_points:
            continue
        lo, hi = (a + keep, b - keep) if b - a > 2 * keep else (a, b)
        d = _chord_distances(p[a:b])[lo - a:hi - a]  # step 3: the worst point, from the chord
        worst = lo + int(d.argmax())
        if d.max() > threshold_m and a < worst < b - 1:  # step 5: split there, the left half first
            lists += [(worst + 1, b), (a, worst + 1)]
        else:  # step 4: a line
            accepted.append((a, b))
    return accepted


def _chord_distances(p: np.ndarray) -> np.ndarray:
    """How far each point of ``p`` lies from the chord through its first and last points."""
    a, b = p[0], p[-1]
    u = b - a
    length = math.hypot(u[0], u[1])
    if length == 0.0:
        return np.hypot(p[:, 0] - a[0], p[:, 1] - a[1])
    return np.abs(u[0] * (p[:, 1] - a[1]) - u[1] * (p[:, 0] - a[0])) / length


# ============================================================================ split-and-merge
@checked_by(SplitMergeParams)
def split_and_merge(
    scan: Scan,
    *,
    method: str = "endpoints",
    split_threshold_m: float | str = SplitMergeParams.split_threshold_m,
    min_points: int = SplitMergeParams.min_points,
    min_length_m: float = SplitMergeParams.min_length_m,
    max_gap_m: float = SplitMergeParams.max_gap_m,
    merge: str | None = SplitMergeParams.merge,
    merge_dr_m: float = SplitMergeParams.merge_dr_m,
    merge_dalpha_deg: float = SplitMergeParams.merge_dalpha_deg,
    merge_chi2: float = SplitMergeParams.merge_chi2,
    range_sigma_m: float | str = SplitMergeParams.range_sigma_m,
    weights: str | None = SplitMergeParams.weights,
    place_dr_m: float = SplitMergeParams.place_dr_m,
    place_dalpha_deg: float = SplitMergeParams.place_dalpha_deg,
    place_confidence: float = SplitMergeParams.place_confidence,
    segment_threshold_m: float | None = None,
    adaptive_segmentation: bool | None = None,
    segments=None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Extract line segments from a scan by split-and-merge.

    Parameters
    ----------
    scan : Scan
        Invalid beams (NaN, inf, 0, out of range) are masked and break segments.
    method : {"endpoints", "fit"}
        Measure the worst point from the chord through the first and last point (iterative
        end-point fit, the default) or from the least-squares line (the slides). The fitted
        line is pulled towards the longer of two walls meeting at a corner, so the worst
        point often sits near the end of the short wall and "fit" peels it off a few points
        at a time, losing short walls; the chord passes through both ends and finds the
        corner. Over 30 scans of the simulated corridor with the fixed 5 cm threshold the chord
        finds every wall of 10 beams or more, "fit" 0.87 of them (``tests/test_split_merge.py``).
    split_threshold_m : float or "auto"
        Split when the worst point is farther than this from the line; default ``"auto"``.
        A fixed threshold (the papers' 0.05 m) suits one sensor only: 5 cm is ten times an LMS200's 5 mm and
        shatters walls at the 3 cm of cheap scanners (on the simulated sets of
        ``benchmarks/evaluation.py`` its FalsePos grows from 0.06 at 5 mm to 0.80 at 3 cm).
        ``"auto"`` follows the scan's range noise sigma (``range_sigma_m``) with two tests. A
        point fails when it is farther from the line than five of its own sigmas across the line,
        ``max(5 sigma |cos(incidence)|, 2 cm)``: range noise moves a point across a wall by the
        cosine of its incidence, so a wall seen at a grazing angle is thin and a step in it is
        not noise (the largest of 722 Gaussian residuals measured from a chord passes 5 sigma
        about once in 20 scans). And a run is split when its fitted line's residuals, each in
        units of its point's own sigma across the line (at least 4 mm), have a mean square per
        degree of freedom above the chi-square quantile at :data:`RESIDUAL_Z` = 3 (a bend too
        gentle for any one point to show), or when a stretch of its points lies to one side
        of that line (:data:`SHIFT_Z`: a recess, a chair against the wall, a bent end; the
        stretch is cut out). All of these also hold for merges, and stranded points join a
        line only within three of their own sigmas. A far wall seen at a few degrees, which the
        breakpoint detector cuts at every beam, is joined again (:func:`join_grazing_walls`): lone
        beams in a row, each cut from the next at :data:`GRAZING_DEG` or more from the beams.
        :func:`labkit.noise.auto_split_threshold` (``max(5 sigma, 2 cm)``, a point seen head-on)
        is the threshold the trace and the merge's worst-point test report. A number gives the
        papers' single threshold, without the per-point and residual tests.
    min_points : int
        ``minPointsPerLine``: runs with fewer points make no line, and the worst point is
        never among the first or last ``min_points // 2`` of a run. Default 5 (Xavier et
        al., ``line_min_pts``).
    min_length_m : float
        Shorter lines are dropped after merging. Default 0.15 m (``line_min_len``).
    max_gap_m : float
        A run is split at its widest gap between neighbours when that gap is wider than
        this; lines whose facing ends are farther apart are never merged, nor are lines
        between which a valid beam ends more than this behind the merged line (it saw through
        it) or in front of it (it hides what the line would claim). Default 0.3 m.
    merge : {"thresholds", "chi2", "none"}
        The merge test (see :func:`lines_similar`); ``"none"`` (or None) skips the merge step.
    merge_dr_m, merge_dalpha_deg, merge_chi2 : float
        Thresholds of the merge test: 0.2 m, 10 degrees, and 9.21 (chi-square, 2 dof, 99%).
        They can be generous because every merge must also pass the split test: the
        refitted line may miss none of its points by more than ``split_threshold_m``. Tight
        thresholds leave short noisy pieces of long walls unmerged: a few degrees of
        angle error on a piece 3 m away shifts its ``r`` by decimetres.
    range_sigma_m : float or "auto"
        Range noise, for the adaptive breakpoints, the lines' covariances and the ``"auto"``
        split threshold. Default ``"auto"``: estimated from the scan
        (:func:`labkit.noise.scan_sigma`); a number: that noise (the fixed settings' 0.01 m).
    weights : {"inverse_range", "uniform"}
        Point weights of the fits: ``1 / rho`` (the slides, the default; None means it too) or
        equal.
    place_dr_m, place_dalpha_deg, place_confidence : float
        What a user trusts: a line is reported only if, by its covariance (from
        ``range_sigma_m``), it lies within ``place_dr_m`` (default 5 cm) in ``r`` and
        ``place_dalpha_deg`` (default 3 degrees) in ``alpha`` of the true line with probability
        ``place_confidence`` (default 0.8; 0: every line is reported, as in the papers):
        :func:`labkit.fitting.placement_probability`. A short piece seen from afar, whose angle
        the data cannot fix to a few degrees, is dropped (a ``"reject"`` step with
        ``test="place_confidence"``). The defaults are Nguyen et al.'s tolerance of a correct
        line; at 0.8 a line matches the wall it belongs to four times in five.
    segment_threshold_m, adaptive_segmentation : float, bool, optional
        A range segmentation of the scan's own (:func:`labkit.segmentation.segment_labels` with
        these, and ``min_points`` as its smallest segment). Default None: the default
        segmentation (the pipeline's), its breakpoints following ``range_sigma_m``.
    segments : ndarray of per-beam labels or list of RangeSegment, optional
        A range segmentation computed elsewhere (shared with other detectors, or with the
        beams of circles and legs set to -1 so that no line is fitted to them); then
        ``segment_threshold_m`` and ``adaptive_segmentation`` are not used.
    trace : bool
        Also return the steps taken, as :class:`labkit.Step` records (``algorithm`` is
        ``"iepf"`` for ``method="endpoints"``, ``"split_and_merge"`` for ``"fit"``). Kinds:
        ``"segment"`` (a range segment enters the list; ``value``: its points), ``"fit"``
        (the line measured against on the beams ``first..last``: the chord or the
        least-squares line; ``at`` the worst point, ``value`` its distance,
        ``threshold`` ``split_threshold_m``), ``"split"`` (split at beam ``at``; with
        ``"auto"``, ``threshold`` is that point's own threshold, or ``test="residual"``: the
        fit's residuals were too wide, ``threshold`` sigma, or ``test="shift"``: the beams
        ``at`` onwards lie ``value`` metres to one side of the fitted line on average, and the
        run is cut before and after them), ``"gap"`` (split at the gap after
        beam ``at``; ``value`` the gap), ``"accept"`` (a run becomes a line), ``"reject"`` (a
        run with too few points, ``test="min_points"``, or a line shorter than ``min_length_m``
        after merging), ``"absorb"`` (``value`` stranded points joined the neighbouring
        lines), ``"merge"`` (two neighbours merged: the merged line on their beams; ``at`` the
        last beam of the first), ``"keep"`` (two neighbours not merged; ``value`` the merge
        statistic or the gap; ``test`` names what failed: ``"merge"``, ``"max_gap_m"``,
        ``"split_threshold_m"``, ``"residual"``, ``"shift"``, or ``"beam_between"`` when a beam between them
        ends more than ``max_gap_m`` behind or in front of the merged line), ``"reject"`` with
        ``test="place_confidence"`` (a line the data cannot place; ``value`` its probability of
        lying within the trusted distance of the truth). Replay: the
        ``accept`` runs, widened by ``absorb``, joined by ``merge`` and less the
        ``reject``-ed lines, are the returned lines.

    Returns
    -------
    lines : list of LineSegment
        In scan order. On a full-circle scan a line may cross the seam (``first > last``).
    steps : list of labkit.Step
        Only with ``trace=True``.

    Examples
    --------
    A wall at x = 2 m seen from the origin:

    >>> theta = np.radians(np.arange(-40.0, 40.5, 0.5))
    >>> lines = split_and_merge(Scan(ranges=2.0 / np.cos(theta), angles=theta))
    >>> [(round(s.r, 6), round(float(np.degrees(s.alpha)), 6), s.first, s.last) for s in lines]
    [(2.0, 0.0, 0, 160)]
    """
    _check_arguments(scan, method, segment_threshold_m, adaptive_segmentation)
    steps = _Trace("iepf" if method == "endpoints" else "split_and_merge") if trace else None
    sigma = noise_sigma(scan, range_sigma_m)
    test = _SplitTest(split_threshold_m, sigma)

    # step 1: the list of lists L, one list per range segment
    labels = _range_segments(scan, segments, segment_threshold_m, adaptive_segmentation, min_points, sigma)
    # steps 1-6 and placing in one compiled pass: the same lines
    if not trace and merge != "chi2" and (engine := _engine()) is not None:
        return engine.split_and_merge(
            scan, labels, fit=method == "fit", threshold_m=test.threshold, noise_sigma=test.noise_sigma,
            absorb_m=test.absorb_m, sigma=sigma, min_points=min_points, min_length_m=min_length_m, max_gap_m=max_gap_m,
            merge=merge, merge_dr_m=merge_dr_m, merge_dalpha_deg=merge_dalpha_deg, weights=weights,
            floor_m=SegmentationParams.threshold_m if segment_threshold_m is None else segment_threshold_m,
            place_dr_m=place_dr_m, place_dalpha_deg=place_dalpha_deg, place_confidence=place_confidence)
    L = _Lists(scan, labels, weights, max_gap_m, test, segment_threshold_m, min_points)
    # steps 2-5 on every list: fit a line, find the worst point, accept the line or split there
    spans: list[tuple[int, int]] = []
    for a, b in L.segments(steps):
        accepted, leftovers = _split(L, a, b, method == "fit", min_points, test, steps)
        spans += _absorb(accepted, leftovers, L, test, steps)
    lines = L.runs.lines(spans)
    # step 6: merge similar neighbours; drop the lines too short, then merge the new neighbours
    merging = _Merging(scan, merge, merge_dr_m, math.radians(merge_dalpha_deg), merge_chi2, max_gap_m, test,
                       weights, sigma, segment_threshold_m, steps)
    lines = merging.merge(lines)
    kept = _drop_short(lines, min_length_m, steps)
    if 1 < len(kept) < len(lines):  # a short piece between two parts of one wall no longer keeps them apart
        kept = merging.merge(kept)
    # line segments, less those the data cannot place
    out = line_segments(kept, scan.points, scan.ranges, weights, sigma)
    if place_confidence > 0 and out:
        out = placed(out, place_dr_m, place_dalpha_deg, place_confidence, steps)
    return (out, list(steps)) if steps is not None else out  # (steps: made when trace is)


def _check_arguments(scan, method, segment_threshold_m, adaptive_segmentation) -> None:
    """What the record does not check: the scan, the method and the segmentation of its own."""
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    if segment_threshold_m is not None and not (isinstance(segment_threshold_m, (int, float, np.floating))
                                                and segment_threshold_m > 0 and math.isfinite(segment_threshold_m)):
        raise ValueError(f"segment_threshold_m must be a finite number > 0, got {segment_threshold_m!r}")
    if adaptive_segmentation is not None and not isinstance(adaptive_segmentation, (bool, np.bool_)):
        raise ValueError(f"adaptive_segmentation must be true or false, got {adaptive_segmentation!r}")


def _range_segments(scan: Scan, segments, threshold_m, adaptive, min_points: int, sigma: float) -> np.ndarray:
    """Step 1's lists as per-beam labels: ``segments`` when given, a segmentation of the scan's own
    when ``threshold_m`` or ``adaptive`` is, else the default one (see :func:`split_and_merge`)."""
    if segments is not None or (threshold_m is None and adaptive is None):
        return detector_labels(scan, segments, sigma)
    return segment_labels.unchecked(
        scan, threshold_m=SegmentationParams.threshold_m if threshold_m is None else threshold_m,
        min_points=min_points, adaptive=SegmentationParams.adaptive if adaptive is None else bool(adaptive),
        range_sigma_m=sigma)


# ---------------------------------------------------------------------------- step 1: the lists
class _Lists:
    """The list of lists L of one scan: its range segments laid end to end in one pass (points,
    weights, prefix sums: :class:`~labkit.lines._split_merge_fast.Runs`), the points' ranges, and
    where neighbouring points are more than ``max_gap_m`` apart. With the noise-aware test, the
    walls seen at a grazing angle are joined first (:func:`join_grazing_walls`)."""

    def __init__(self, scan: Scan, labels: np.ndarray, weights, max_gap_m: float, test: _SplitTest,
                 segment_threshold_m, min_points: int):
        floor = SegmentationParams.threshold_m if segment_threshold_m is None else segment_threshold_m
        self.grazing = None
        if test.noise_sigma:
            labels, self.grazing = join_grazing_walls(scan, labels, floor, min_points, test.noise_sigma)
        self.order, self.starts, self.stops = segment_order(labels)
        self.order.setflags(write=False)  # so are the lines' beams, slices of it
        w = np.ones(len(self.order)) if weights == "uniform" else 1.0 / scan.ranges.take(self.order)
        self.runs = Runs(scan.points.take(self.order, axis=0), w, self.order)
        self.rho = scan.ranges.take(self.order) if test.noise_sigma else None
        self.max_gap_m = max_gap_m
        # the gaps wider than max_gap_m, where a list may have to be cut (not where a grazing wall was joined)
        self.gaps = wide_gaps(self.runs.x, self.runs.y, max_gap_m)
        self.wide = [i for i, gap in self.gaps.items() if gap > max_gap_m and not self.joined_at(i)]

    def joined_at(self, i: int) -> bool:
        """Whether points ``i`` and ``i + 1`` are neighbouring beams of a wall joined at a grazing angle."""
        return (self.grazing is not None and self.order[i + 1] == self.order[i] + 1
                and bool(self.grazing[self.order[i]]))

    def beam(self, i: int) -> int:
        return int(self.order[i])

    def segments(self, steps):
        """Each range segment as the points ``a..b-1`` (a ``"segment"`` step each)."""
        for a, b in zip(self.starts.tolist(), self.stops.tolist(), strict=True):
            if steps is not None:
                joined = self.grazing is not None and bool(self.grazing.take(self.order[a:b - 1]).any())
                graze = " (with beams the breakpoints cut from it: a wall seen at a grazing angle)" if joined else ""
                steps.add("segment", self.beam(a), self.beam(b - 1), value=b - a,
                          reason=f"range segment of {b - a} points{graze}")
            yield a, b


def join_grazing_walls(scan: Scan, labels: np.ndarray, threshold_m: float, min_points: int,
                       sigma: float) -> tuple[np.ndarray, np.ndarray | None]:
    """Join again the walls seen at a grazing angle that the breakpoint detector cut to pieces.

    The ``"auto"`` split test only. The detector (:func:`labkit.segmentation.segment_labels`)
    cuts between two beams when the line joining their points is within ``incidence_deg``
    (10 deg) of the beams: there it cannot tell a wall from a step in depth. A long wall seen far
    away at a few degrees is cut at every beam, each point alone and up to ``max_gap_m`` or more
    from the next (0.3-0.7 m for walls of the simulated corridor 7-13 m away), and no line was
    fitted to it. One cut is a step in depth; a wall is a chain of them: ``min_points`` or more
    lone beams in a row, each cut from the next at :data:`GRAZING_DEG` or more from the beams,
    are joined into a segment, and with the segment at either end when it was cut from it the
    same way. The split tests then cut what is not one line. (Beams without a label closer than
    the detector's threshold were not cut: the pipeline's beams of circles and legs. They stay
    out.)

    Parameters
    ----------
    scan : Scan
        The scan.
    labels : ndarray of int, shape (N,)
        Its range segments' labels, -1 for beams in none.
    threshold_m : float
        The detector's threshold, metres.
    min_points : int
        The fewest lone beams in a row that make a wall.
    sigma : float
        The range noise, metres.

    Returns
    -------
    labels : ndarray of int, shape (N,)
        The labels with those walls joined (relabelled in scan order).
    joined : ndarray of int or None
        The beams ``k`` at which the pair ``(k, k + 1)`` was joined; None: none.
    """
    return grazing_runs(scan, labels, threshold_m, min_points, sigma)


# ---------------------------------------------------------------------------- steps 2-5: the split
def _split(L: _Lists, a: int, b: int, fit: bool, min_points: int, test: _SplitTest,
           steps) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """Steps 2-5 on the list of points ``a..b-1``: the runs accepted as lines and those left
    with too few points, each ``(a, b)``."""
    keep = min_points // 2
    accepted: list[tuple[int, int]] = []
    leftovers: list[tuple[int, int]] = []
    lists = [(a, b)]
    while lists:
        a, b = lists.pop()  # step 2: the next list
        if b - a < min_points:
            _note_too_few(L, a, b, min_points, steps)
            leftovers.append((a, b))
            continue
        g = _widest_gap(L, a, b, steps)
        if g is not None:  # first cut at a gap: the gap ends the left half
            lists += [(g + 1, b), (a, g + 1)]
            continue
        r, alpha = L.runs.fit(a, b) if fit else _chord(L.runs, a, b)  # step 2: its line
        p, worst, v, lo = _worst_point(L.runs, a, b, r, alpha, keep)  # step 3: the worst point
        if steps is not None:
            steps.add("fit", L.beam(a), L.beam(b - 1), r, alpha, at=L.beam(p), value=worst,
                      threshold=test.threshold, reason=f"worst point {worst:.3f} m from the "
                                                       f"{'fitted line' if fit else 'chord'}")
        cut, p, worst = test.cut(L, a, b, r, alpha, fit, p, worst, v, lo, steps)  # step 4: is it a line?
        if cut is None:
            if steps is not None:
                steps.add("accept", L.beam(a), L.beam(b - 1), r, alpha, at=L.beam(p), value=worst,
                          threshold=test.threshold, test="split_threshold_m",
                          reason=f"{worst:.3f} m <= split_threshold_m")
            accepted.append((a, b))
            continue
        bounds = (a, *cut, b)  # step 5: split, the pieces back into L, the first on top
        lists += [(c0, c1) for c0, c1 in reversed(list(zip(bounds[:-1], bounds[1:], strict=True))) if c1 > c0]
    return accepted, leftovers


def _note_too_few(L: _Lists, a: int, b: int, min_points: int, steps) -> None:
    if steps is not None:
        steps.add("reject", L.beam(a), L.beam(b - 1), value=b - a, threshold=min_points, test="min_points",
                  reason=f"{b - a} points < min_points={min_points}")


def _widest_gap(L: _Lists, a: int, b: int, steps) -> int | None:
    """The point before the widest gap of the list ``a..b-1`` wider than ``max_gap_m``, or None."""
    k = bisect_left(L.wide, a) if L.wide else 0
    if not (k < len(L.wide) and L.wide[k] < b - 1):
        return None
    g = max(L.wide[k:bisect_left(L.wide, b - 1)], key=L.gaps.__getitem__)
    if steps is not None:
        steps.add("gap", L.beam(a), L.beam(b - 1), at=L.beam(g), value=L.gaps[g], threshold=L.max_gap_m,
                  test="max_gap_m", reason=f"gap {L.gaps[g]:.3f} m > max_gap_m")
    return g


def _chord(runs: Runs, a: int, b: int) -> tuple[float, float]:
    """The line ``(r, alpha)`` through points ``a`` and ``b - 1`` (IEPF's chord)."""
    x0, y0, x1, y1 = runs.x.item(a), runs.y.item(a), runs.x.item(b - 1), runs.y.item(b - 1)
    alpha = math.atan2(x1 - x0, -(y1 - y0))
    r = x0 * math.cos(alpha) + y0 * math.sin(alpha)
    if r < 0:
        r, alpha = -r, alpha + math.pi
    return r, math.remainder(alpha, 2 * math.pi)


def _worst_point(runs: Runs, a: int, b: int, r: float, alpha: float, keep: int):
    """Step 3: the point of ``a..b-1`` farthest from the line ``(r, alpha)``, not one of the first
    or last ``keep`` unless the list is too short to leave any; returns it, its distance, the
    signed projections ``v`` of the points ``lo..hi-1`` searched, and ``lo``. On a tie the
    first."""
    n = b - a
    lo, hi = (a + keep, b - keep) if n > 2 * keep else (a, b)
    v = runs.xy[lo:hi].dot(np.array([math.cos(alpha), math.sin(alpha)]))  # points on the normal
    k_hi, k_lo = int(v.argmax()), int(v.argmin())
    d_hi, d_lo = v.item(k_hi) - r, r - v.item(k_lo)  # the farther of the two extremes
    if d_hi > d_lo or (d_hi == d_lo and k_hi < k_lo):
        return lo + k_hi, d_hi, v, lo
    return lo + k_lo, d_lo, v, lo


# ---------------------------------------------------------------------------- step 4: the split test
#: With ``split_threshold_m="auto"``, a run whose fit has residuals wider than the range noise
#: allows is split too: its weighted mean square residual (per degree of freedom) must stay under
#: ``sigma^2`` times the upper quantile of chi-square / dof this many standard normal deviations out.
RESIDUAL_Z = 3.0

#: With ``split_threshold_m="auto"``, a run is split where a stretch of its points lies to one side
#: of its fitted line: the sum of the residuals over some window of ``w`` consecutive points (``w`` =
#: 4, 8, 16, ... up to half the run) exceeds this many ``sigma sqrt(w)``, its mean at least
#: :data:`SHIFT_MIN_M`. Unlike the worst-point and mean-square tests, a shift in a stretch does not
#: hide among the run's other points, and noise spread evenly along a line does not mimic one.
SHIFT_Z = 5.0
#: The least mean offset of a shifted stretch, metres: walls are not flat to a centimetre.
SHIFT_MIN_M = 0.01


class _SplitTest:
    """Step 4, whether a list is a line: the worst point against ``split_threshold_m``; with
    ``"auto"`` (``noise_sigma`` > 0) three more stages, in order, each of which can cut the list:

    1. the worst point in units of its own noise across the line (:func:`_beyond_own_noise`);
    2. the fitted line's residuals against the noise (:func:`_misfit`, ``"residual"``);
    3. a stretch of points to one side of the fitted line (:func:`_misfit`, ``"shift"``).
    """

    def __init__(self, split_threshold_m, sigma: float):
        self.noise_sigma = sigma if split_threshold_m == AUTO else 0.0  # > 0: the noise-aware stages
        self.threshold = auto_split_threshold(sigma) if split_threshold_m == AUTO else split_threshold_m
        self.absorb_m = min(self.threshold, 3 * sigma)  # stranded points join a line within this

    def cut(self, L: _Lists, a: int, b: int, r: float, alpha: float, fit: bool, p: int, worst: float,
            v: np.ndarray, lo: int, steps) -> tuple[tuple[int, ...] | None, int, float]:
        """Where to cut the list ``a..b-1`` (the points that start the new pieces; None: it is a
        line), and the worst point and its distance, as the stages found them. ``p`` is its worst
        point, ``worst`` its distance from the line ``(r, alpha)``, ``v`` the projections of the
        points ``lo..`` searched."""
        test, threshold = "split_threshold_m", self.threshold
        failed = worst > threshold
        sigma = self.noise_sigma
        if sigma and not failed and a < p < b - 1 and worst > MIN_SPLIT_M:  # stage 1: the point's own noise
            assert L.rho is not None, "_Lists keeps the ranges when the noise stages are on"
            q, ratio = _beyond_own_noise(v, L.rho[lo:lo + len(v)], r, sigma)
            if ratio > 1.0:
                failed, p = True, lo + q
                worst = abs(v.item(q) - r)
                threshold = worst / ratio
        misfit = None
        if sigma and not failed and b - a > 2:  # stages 2 and 3: the fitted line against the noise
            assert L.rho is not None, "_Lists keeps the ranges when the noise stages are on"
            rf, af = (r, alpha) if fit else L.runs.fit(a, b)
            misfit = _misfit(L.runs.xy[a:b].dot(np.array([math.cos(af), math.sin(af)])), L.rho[a:b], rf, sigma)
            if misfit is not None and misfit[0] == "residual" and a < p < b - 1:
                failed, test, threshold = True, "residual", sigma
        if failed and a < p < b - 1:  # split at the worst point, which ends the left half
            if steps is not None:
                steps.add("split", L.beam(a), L.beam(b - 1), r, alpha, at=L.beam(p), value=worst,
                          threshold=threshold, test=test, reason=self._why(test, worst, threshold, misfit))
            return (p + 1,), p, worst
        if misfit is not None and misfit[0] == "shift":  # cut the stretch out
            k, width, mean = misfit[1]
            if steps is not None:
                steps.add("split", L.beam(a), L.beam(b - 1), rf, af, at=L.beam(a + k), value=abs(mean),
                          threshold=sigma, test="shift",
                          reason=f"beams {L.beam(a + k)}..{L.beam(a + k + width - 1)} lie "
                                 f"{abs(mean):.3f} m to one side of the fitted line on average")
            return (a + k, a + k + width), p, worst
        return None, p, worst

    def _why(self, test: str, worst: float, threshold: float, misfit) -> str:
        if test == "residual":
            return f"residuals wider than range noise {self.noise_sigma:.3f} m allows (RMS {misfit[1]:.3f} m)"
        if threshold < self.threshold:
            return (f"{worst:.3f} m > {threshold:.3f} m, {SPLIT_SIGMAS:g} sigma across the line "
                    "at this point's incidence")
        return f"{worst:.3f} m > split_threshold_m={self.threshold}"

    def line_fails(self, v: np.ndarray, rho: np.ndarray, r: float) -> tuple[str, str] | None:
        """The split test of a merged line (``v`` its points' projections on its normal, ``rho``
        their ranges): the test it fails and why, or None."""
        worst = float(np.max(np.abs(v - r)))
        if worst > self.threshold:
            return "split_threshold_m", f"the merged line misses a point by {worst:.3f} m"
        sigma = self.noise_sigma
        if not sigma:
            return None
        if worst > MIN_SPLIT_M and _beyond_own_noise(v, rho, r, sigma)[1] > 1.0:
            return "split_threshold_m", f"a point misses it by more than {SPLIT_SIGMAS:g} of its sigmas"
        misfit = _misfit(v, rho, r, sigma)
        if misfit is None:
            return None
        if misfit[0] == "residual":
            return "residual", "the merged line's residuals are wider than the range noise allows"
        return "shift", f"{misfit[1][1]} of its points lie {abs(misfit[1][2]):.3f} m to one side of it on average"


def _beyond_own_noise(v: np.ndarray, rho: np.ndarray, r: float, sigma: float) -> tuple[int, float]:
    """Which point is farthest from the line ``(r, alpha)`` in units of its own split threshold
    ``max(SPLIT_SIGMAS sigma |cos(incidence)|, MIN_SPLIT_M)``, and that ratio (> 1: it fails);
    ``v`` are the points' projections on the line's normal, ``rho`` their ranges. Range noise
    moves a point across the line by its cosine of incidence, ``|v| / rho``: a wall seen at a
    grazing angle is thin, and a step in it is not noise."""
    ratio = np.abs(v - r) / np.maximum(np.abs(v) * (SPLIT_SIGMAS * sigma) / rho, MIN_SPLIT_M)
    q = int(ratio.argmax())
    return q, ratio.item(q)


def _misfit(v: np.ndarray, rho: np.ndarray, r: float, sigma: float):
    """How a run of points fails to lie on its fitted line ``r`` within range noise ``sigma``
    (``v``: the points' projections on the line's normal, ``rho``: their ranges), or None.

    Each point's noise across the line is ``sigma |cos(incidence)|``, at least ``MIN_SPLIT_M /
    SPLIT_SIGMAS`` (the split threshold's floor): a wall seen at a grazing angle is thin.
    ``("residual", rms)``: the residuals in those units have a mean square per degree of freedom
    above 1 and above the chi-square quantile at :data:`RESIDUAL_Z` (a bend too gentle for any one
    point to show); ``("shift", (k, w, mean))``: the ``w`` points from the ``k``-th lie to one side
    of the line (:data:`SHIFT_Z`, :data:`SHIFT_MIN_M`; :func:`~labkit.lines._split_merge_fast.shifted_stretch`).
    """
    n = len(v)
    if n <= 2:
        return None
    res = v - r
    sd = np.abs(v)
    sd *= sigma
    sd /= rho
    np.maximum(sd, MIN_SPLIT_M / SPLIT_SIGMAS, out=sd)
    z = res / sd
    total = float(np.sum(z * z))  # (numpy's pairwise sum, the same on every machine, unlike BLAS's z @ z)
    if total > n - 2 and total > (n - 2) * chi2_upper_over_dof(n - 2, RESIDUAL_Z):
        return "residual", math.sqrt(float(res @ res) / n)
    if n < 8 or total <= SHIFT_Z * SHIFT_Z:  # (a shifted stretch's z squared is at most the total)
        return None
    best = shifted_stretch(res, sd, SHIFT_Z, SHIFT_MIN_M)
    return None if best is None else ("shift", best)


# ---------------------------------------------------------------------------- stranded points
def _absorb(accepted: list[tuple[int, int]], leftovers: list[tuple[int, int]], L: _Lists, test: _SplitTest,
            steps) -> list[tuple[int, int]]:
    """Give the points of runs too short for a line to the neighbouring lines they fit.

    A split can strand a few points between two lines, e.g. the beams just around a corner
    when the worst point is not the corner beam itself; left out, they make the corner look
    hidden. Each stranded point joins the line next to it (within the same range segment)
    when it is within ``min(split threshold, 3 sigma)`` of that line (the nearer one if both),
    working outwards from the line. With the ``"auto"`` test a point's threshold is at most three of
    its own sigmas across the line, ``3 max(sigma |cos(incidence)|, MIN_SPLIT_M / SPLIT_SIGMAS)``:
    a wall seen at a grazing angle is thin.
    """
    if not leftovers or not accepted:
        return sorted(accepted)
    threshold, noise_sigma, rho = test.absorb_m, test.noise_sigma, L.rho
    by_end = {b: k for k, (a, b) in enumerate(accepted)}
    by_start = {a: k for k, (a, b) in enumerate(accepted)}
    spans = [list(ab) for ab in accepted]
    x, y = L.runs.x, L.runs.y
    fits: dict[int, tuple[float, float, float]] = {}  # cos(alpha), sin(alpha), r of the lines used

    def distance(k, i):
        if k is None:
            return math.inf
        if k not in fits:
            r, alpha = L.runs.fit(*accepted[k])
            fits[k] = math.cos(alpha), math.sin(alpha), r
        c, s, r = fits[k]
        v = x.item(i) * c + y.item(i) * s
        if noise_sigma:  # in units of the threshold at this point's incidence
            return abs(v - r) * threshold / min(threshold, 3.0 * max(noise_sigma * abs(v) / rho.item(i),
                                                                      MIN_SPLIT_M / SPLIT_SIGMAS))
        return abs(v - r)

    for a, b in leftovers:
        left, right = by_end.get(a), by_start.get(b)
        lo, hi = a, b
        while lo < hi:
            d = distance(left, lo)
            if not (d <= threshold and d <= distance(right, lo)):
                break
            lo += 1
        while hi > lo and distance(right, hi - 1) <= threshold:
            hi -= 1
        if left is not None:
            spans[left][1] = lo
        if right is not None:
            spans[right][0] = hi
        if steps is not None and (lo > a or hi < b):
            steps.add("absorb", L.beam(a), L.beam(b - 1), value=(lo - a) + (b - hi),
                      reason=f"{(lo - a) + (b - hi)} stranded points joined the neighbouring lines")
    return sorted((a, b) for a, b in spans)


# ---------------------------------------------------------------------------- step 6: the merge
def _similar(r1, a1, c1, r2, a2, c2, merge, merge_dr_m, merge_dalpha, merge_chi2) -> tuple[bool, float]:
    da = math.remainder(a2 - a1, 2 * math.pi)
    dr = r2 - r1
    flipped = abs(da) > math.pi / 2
    if flipped:  # the same line with its normal turned around (both near the origin)
        da = math.remainder(da - math.pi, 2 * math.pi)
        dr = -r2 - r1
    if merge == "thresholds":
        stat = max(abs(dr) / merge_dr_m, abs(da) / merge_dalpha)
        return stat < 1.0, stat
    c2 = np.asarray(c2)
    if flipped:  # (r, alpha) -> (-r, alpha + pi) has Jacobian diag(-1, 1): the r-alpha cross term changes sign
        c2 = c2 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    cov = np.asarray(c1) + c2
    d = np.array([dr, da])
    try:
        stat = float(d @ np.linalg.solve(cov, d))
    except np.linalg.LinAlgError:
        return False, math.inf
    if not math.isfinite(stat):
        return False, math.inf
    return stat < merge_chi2, stat


def lines_similar(a: LineSegment, b: LineSegment, *, merge: str = "thresholds",
                  merge_dr_m: float = SplitMergeParams.merge_dr_m,
                  merge_dalpha_deg: float = SplitMergeParams.merge_dalpha_deg,
                  merge_chi2: float = SplitMergeParams.merge_chi2, **deprecated) -> tuple[bool, float]:
    """Whether two lines are similar enough to merge, and the test statistic.

    The angle difference is taken across the wrap (170 deg vs -170 deg is 20 deg). Two
    lines close to the origin may describe the same line with opposite normals (``r`` near
    0, ``alpha`` differing by about pi); the second line is then compared as
    ``(-r, alpha + pi)``. ``merge="thresholds"`` passes when ``|dr| < merge_dr_m`` and
    ``|dalpha| < merge_dalpha_deg`` (the statistic is the larger of the two ratios, < 1 passes);
    ``merge="chi2"`` when the Mahalanobis distance ``d^T (C_a + C_b)^-1 d`` of
    ``d = (dr, dalpha)`` is under ``merge_chi2`` (default 9.21, the 99% point of chi-square
    with 2 degrees of freedom).

    Parameters
    ----------
    a, b : LineSegment
        The two lines (with covariances for ``merge="chi2"``).
    merge : {"thresholds", "chi2"}, default "thresholds"
        The test.
    merge_dr_m : float, default 0.2
        Largest ``|dr|`` of ``"thresholds"``, metres.
    merge_dalpha_deg : float, default 10.0
        Largest ``|dalpha|`` of ``"thresholds"``, degrees.
    merge_chi2 : float, default 9.21
        Largest Mahalanobis distance of ``"chi2"``.
    **deprecated
        Old names of these keywords (radians without ``_deg``), with a ``DeprecationWarning``.

    Returns
    -------
    similar : bool
        Whether the two lines pass the test.
    statistic : float
        The test statistic (below 1 passes ``"thresholds"``; below ``merge_chi2`` passes ``"chi2"``).

    Examples
    --------
    >>> a = line_segment(np.array([[-1.0, 2.0], [-2.0, 2.01], [-3.0, 2.02]]), [0, 1, 2])
    >>> b = line_segment(np.array([[-4.0, 2.03], [-5.0, 2.04], [-6.0, 2.05]]), [3, 4, 5])
    >>> lines_similar(a, b)[0]
    True
    """
    if deprecated:
        merge_dalpha_deg = _old_merge_dalpha(deprecated, merge_dalpha_deg)
    if merge not in ("thresholds", "chi2"):
        raise ValueError(f'merge must be "thresholds" or "chi2", got {merge!r}')
    return _similar(a.r, a.alpha, a.covariance, b.r, b.alpha, b.covariance, merge, merge_dr_m,
                    math.radians(merge_dalpha_deg), merge_chi2)


def _old_merge_dalpha(deprecated: dict, merge_dalpha_deg: float) -> float:
    """``merge_dalpha`` (radians) of an older release, in degrees, with a ``DeprecationWarning``."""
    unknown = set(deprecated) - {"merge_dalpha"}
    if unknown:
        raise TypeError(f"lines_similar() got an unexpected keyword argument {unknown.pop()!r}")
    warnings.warn("lines_similar(merge_dalpha=...) is deprecated: use merge_dalpha_deg=... (in degrees)",
                  DeprecationWarning, stacklevel=3)
    return math.degrees(deprecated["merge_dalpha"])


class _Merging:
    """Step 6: merge neighbouring similar lines, refitting from the summed weighted sums.

    Neighbours are consecutive lines whose facing ends are at most ``max_gap_m`` apart (with the
    ``"auto"`` split test, or neighbouring beams the breakpoint detector cut only for a grazing
    angle, :func:`~labkit.lines._split_merge_fast.grazing_links`); on a full-circle scan the last
    and first lines are neighbours too. A merge is undone when the refitted line fails the split
    test (:meth:`_SplitTest.line_fails`), or when a beam between the two lines ends more than
    ``max_gap_m`` off the merged line (:func:`_beam_between`): behind it, the beam saw through it
    (a doorway, a window) and the line would cover a hole; in front of it, the beam hid the
    stretch the line would claim (a chair leg).
    """

    def __init__(self, scan: Scan, merge, merge_dr_m: float, merge_dalpha: float, merge_chi2: float,
                 max_gap_m: float, test: _SplitTest, weights, sigma: float, segment_threshold_m, steps):
        self.how = None if merge == "none" else merge  # the merge test
        self.sigma = sigma
        self.dr_m, self.dalpha, self.chi2 = merge_dr_m, merge_dalpha, merge_chi2
        self.max_gap_m, self.test, self.weights, self.steps = max_gap_m, test, weights, steps
        self.floor = SegmentationParams.threshold_m if segment_threshold_m is None else segment_threshold_m
        self.points, self.ranges, self.angles, self.valid = scan.points, scan.ranges, scan.angles, scan.valid
        self.wrap = scan.is_full_circle

    def merge(self, lines: list[Line]) -> list[Line]:
        """``lines`` with every pair of similar neighbours merged, left to right (and across the seam)."""
        if self.how is None or len(lines) < 2:
            return lines
        out = list(lines)
        i = 0
        while i < len(out) - 1:
            merged = self._attempt(out[i], out[i + 1])
            if merged is None:
                i += 1
            else:
                out[i:i + 2] = [merged]
        if self.wrap and len(out) > 1:
            merged = self._attempt(out[-1], out[0])
            if merged is not None:
                out = [merged] + out[1:-1]
        return out

    def _neighbours(self, a: Line, b: Line) -> bool:
        """Whether the facing ends of ``a`` and ``b`` are close enough to merge them (a "keep" step if not)."""
        dx, dy = b.start[0] - a.end[0], b.start[1] - a.end[1]
        gap = math.sqrt(dx * dx + dy * dy)  # (not math.hypot, whose rounding differs between Pythons)
        if gap <= self.max_gap_m or (self.test.noise_sigma and b.first == a.last + 1 and grazing_links(
                self.points, self.ranges, self.angles, np.array([a.last]), self.floor, self.test.noise_sigma).item(0)):
            return True
        if self.steps is not None:
            self.steps.add("keep", a.first, b.last, at=a.last, value=gap, threshold=self.max_gap_m, test="max_gap_m",
                           reason=f"facing ends {gap:.3f} m apart > max_gap_m")
        return False

    def _attempt(self, a: Line, b: Line) -> Line | None:
        """``a`` and ``b`` merged, or None."""
        if not self._neighbours(a, b):
            return None
        if self.how == "chi2":
            for ln in (a, b):
                if ln.cov is None:
                    ln.cov = covariances(ln.idx, np.zeros(1, np.int64), np.array([ln.alpha]),
                                         self.points.take(ln.idx, axis=0), self.ranges, self.weights,
                                         self.sigma)[0][0]
        ok, stat = _similar(a.r, a.alpha, a.cov, b.r, b.alpha, b.cov, self.how, self.dr_m, self.dalpha, self.chi2)
        merged = failed = None
        if ok:
            merged = a.joined(b)
            p = self.points.take(merged.idx, axis=0)
            v = p[:, 0] * math.cos(merged.alpha) + p[:, 1] * math.sin(merged.alpha)
            failed = self.test.line_fails(v, self.ranges.take(merged.idx), merged.r)
            if failed is None:
                failed = _beam_between(merged, a.last, b.first, self.ranges, self.valid, self.angles, self.max_gap_m)
            if failed is not None:
                merged = None
        if self.steps is not None:
            if not ok:
                test, reason = "merge", f"different: statistic {stat:.2f}"
            elif failed is not None:  # (similar, and the merged line failed: merged is None)
                test, reason = failed[0], f"similar ({stat:.2f}) but {failed[1]}"
            else:
                test, reason = "merge", f"similar: statistic {stat:.2f}"
            ln = merged if merged is not None else a
            self.steps.add("merge" if merged is not None else "keep", a.first, b.last, ln.r, ln.alpha, at=a.last,
                           value=stat, threshold=self.chi2 if self.how == "chi2" else 1.0, test=test, reason=reason)
        return merged


def _beam_between(line: Line, after: int, before: int, ranges: np.ndarray, valid: np.ndarray, angles: np.ndarray,
                  margin: float) -> tuple[str, str] | None:
    """Why ``line`` may not cover the beams strictly between beams ``after`` and ``before``
    (across the seam when ``before < after``): the first valid one whose ray meets the line and
    ends more than ``margin`` in front of or behind it; or None. A beam with no valid return is no
    evidence either way; nor is one whose ray does not meet the line."""
    if before == after + 1:  # neighbours in the scan (most merges): no beam between them
        return None
    if before > after:
        js = np.arange(after + 1, before)
    else:
        js = np.concatenate([np.arange(after + 1, len(ranges)), np.arange(0, before)])
    if not len(js):
        return None
    c = np.cos(angles.take(js) - line.alpha)  # the ray meets the line at r / c when c > 0
    rho = ranges.take(js)
    with np.errstate(invalid="ignore", divide="ignore"):
        hit = valid.take(js) & _ends_off(rho, c, line.r, margin)
    k = np.flatnonzero(hit)
    if not len(k):
        return None
    beam, ahead = int(js[k[0]]), float(line.r / c[k[0]] - rho[k[0]])
    where = f"{ahead:.2f} m in front of" if ahead > 0 else f"{-ahead:.2f} m behind"
    return "beam_between", f"beam {beam} ends {where} the merged line (more than max_gap_m)"


def _drop_short(lines: list[Line], min_length_m: float, steps) -> list[Line]:
    """The lines at least ``min_length_m`` long (a ``"reject"`` step for each other)."""
    kept = []
    for line in lines:
        if line.length < min_length_m:
            if steps is not None:
                steps.add("reject", line.first, line.last, line.r, line.alpha, value=line.length,
                          threshold=min_length_m, test="min_length_m",
                          reason=f"length {line.length:.3f} m < min_length_m={min_length_m}")
            continue
        kept.append(line)
    return kept
