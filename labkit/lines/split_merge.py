"""Split-and-merge line extraction, with the iterative end-point fit (IEPF) variant.

The algorithm of the course slides (after Nguyen et al. 2005):

1. Cut the scan into range segments (:mod:`labkit.segmentation`); each is a list in L.
2. Take the next list and fit a line to it.
3. Find the worst point, the one farthest from the line; it may not be one of the first or
   last ``min_points // 2`` points (``minPointsPerLine`` in the slides).
4. If its distance is under ``split_threshold_m`` accept the line, otherwise split the list
   at that point and go back to 2 with both halves. Points stranded in pieces too short
   for a line (often the beams around a corner) join the neighbouring line when they are
   within three range sigmas of it.
5. When every list is done, merge similar neighbouring lines: ``|r1 - r2|`` and
   ``|alpha1 - alpha2|`` under thresholds (the angle difference taken across the wrap, so
   170 deg and -170 deg are 20 deg apart), or a chi-square test on the covariances, and
   refit the merged line from all its points. Two lines are never merged across a valid beam
   between them that ends more than ``max_gap_m`` off the merged line: behind it, the beam saw
   through it (a doorway, a slot between shelves); in front of it, something else stopped the
   beam (a chair leg, a person), so the stretch of wall behind was never seen.
6. Drop the lines the data cannot place: by its covariance, a line must lie within the
   trusted ``|dr|`` and ``|dalpha|`` of the true line with probability ``place_confidence``.

A line's segment runs between its first and last points projected onto it, but never past the
rays of its first and last beams: a noisy end point seen at a grazing angle projects along the
line over the next beams' rays, and the segment would claim a surface where they saw another.

The thresholds that depend on the sensor's range noise follow it by default (``"auto"``):
``range_sigma_m`` is estimated from each scan (:mod:`labkit.noise`) and the split test measures
each point against its own noise across the line, five times ``sigma |cos(incidence)|`` (at least
2 cm), and the fit's residuals against ``sigma``; lines the data cannot place are dropped
(``place_confidence`` 0.8). :data:`labkit.noise.FIXED_LINES` gives the papers' fixed 5 cm
threshold instead, with every line reported.

``method="fit"`` measures the worst point from the least-squares line (the slides);
``method="endpoints"`` from the chord through the list's first and last points -- the
iterative end-point fit of the lab report and of Xavier et al. (2005) -- which is cheaper
and is refitted by least squares only once a line is accepted. A list is also split at the
widest gap between neighbouring points when that gap exceeds ``max_gap_m``.

Every fit inside the split loop is O(1): prefix sums of ``w``, ``w x``, ``w y``,
``w x^2``, ``w y^2`` and ``w x y`` over a segment give the weighted sums of any run of it
by two subtractions, and the closed form of :func:`labkit.fitting.fit_line_polar` needs
nothing else. Only the worst-point search touches every point.

``split_and_merge(..., trace=True)`` also returns the steps taken, as :class:`labkit.Step`
records, so a notebook, a widget (:func:`labkit.viz.steps.step_viewer`) or the rerun viewer
(:func:`labkit.viz.rr.log_steps`) can replay them.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass

import numpy as np

from .._cache import remembered
from .._checks import check_int, check_nonneg, check_positive
from ..features import LineSegment, line_segment  # noqa: F401 - used in doctests
from ..fitting import _line_covariances, line_from_sums
from ..noise import MIN_SPLIT_M, SPLIT_SIGMAS, auto_split_threshold, chi2_upper_over_dof, scan_sigma
from ..scan import Scan
from ..segmentation import SegmentationParams, _thresholds, labels_from, segment_labels, segment_order
from ..steps import Step
from ._params import AUTO, Params, param, takes_params
from ._runs import _check_placing, _ends_off, _on_rays, _placed

__all__ = ["split_and_merge", "lines_similar"]

_METHODS = ("fit", "endpoints")
_MERGES = ("thresholds", "chi2", None)


class _Steps(list):
    """The steps of one run of :func:`split_and_merge`, as :class:`labkit.Step` records."""

    def __init__(self, algorithm: str):
        super().__init__()
        self.algorithm = algorithm

    def add(self, kind: str, first: int, last: int, r: float = math.nan, alpha: float = math.nan, **fields) -> None:
        self.append(Step(self.algorithm, kind, first, last, r, alpha, **fields))


class _Run:
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
        # python floats: scalar arithmetic on them is fastest (converting only the sums
        # used is much cheaper than converting the whole table)
        return (self.c[b] - self.c[a]).tolist()

    def lines(self, spans: list[tuple[int, int]]) -> list[_Line]:
        """A :class:`_Line` for each run ``a..b-1`` of ``spans``; their sums, end points and
        beams are gathered in one go."""
        if not spans:
            return []
        ab = np.array(spans)
        a, b = ab[:, 0], ab[:, 1]  # (indexing: unpacking an array costs an IndexError)
        sums = (self.c.take(b, axis=0) - self.c.take(a, axis=0)).tolist()
        p_first, p_last = self.xy.take(a, axis=0).tolist(), self.xy.take(b - 1, axis=0).tolist()
        first, last = self.idx.take(a).tolist(), self.idx.take(b - 1).tolist()
        return [_Line(self.idx[i:j], s, f, g, p, q)
                for (i, j), s, f, g, p, q in zip(spans, sums, first, last, p_first, p_last, strict=True)]


class _Line:
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
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])


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


def lines_similar(a: LineSegment, b: LineSegment, *, merge: str = "thresholds", merge_dr_m: float = 0.2,
                  merge_dalpha: float = math.radians(10.0), merge_chi2: float = 9.21) -> tuple[bool, float]:
    """Whether two lines are similar enough to merge, and the test statistic.

    The angle difference is taken across the wrap (170 deg vs -170 deg is 20 deg). Two
    lines close to the origin may describe the same line with opposite normals (``r`` near
    0, ``alpha`` differing by about pi); the second line is then compared as
    ``(-r, alpha + pi)``. ``merge="thresholds"`` passes when ``|dr| < merge_dr_m`` and
    ``|dalpha| < merge_dalpha`` (the statistic is the larger of the two ratios, < 1 passes);
    ``merge="chi2"`` when the Mahalanobis distance ``d^T (C_a + C_b)^-1 d`` of
    ``d = (dr, dalpha)`` is under ``merge_chi2`` (default 9.21, the 99% point of chi-square
    with 2 degrees of freedom).

    Examples
    --------
    >>> a = line_segment(np.array([[-1.0, 2.0], [-2.0, 2.01], [-3.0, 2.02]]), [0, 1, 2])
    >>> b = line_segment(np.array([[-4.0, 2.03], [-5.0, 2.04], [-6.0, 2.05]]), [3, 4, 5])
    >>> lines_similar(a, b)[0]
    True
    """
    if merge not in ("thresholds", "chi2"):
        raise ValueError(f'merge must be "thresholds" or "chi2", got {merge!r}')
    return _similar(a.r, a.alpha, a.covariance, b.r, b.alpha, b.covariance, merge, merge_dr_m, merge_dalpha,
                    merge_chi2)


def _absorb(accepted, leftovers, run: _Run, threshold: float, steps, rho=None,
            noise_sigma: float = 0.0) -> list[tuple[int, int]]:
    """Give the points of runs too short for a line to the neighbouring lines they fit.

    A split can strand a few points between two lines, e.g. the beams just around a corner
    when the worst point is not the corner beam itself; left out, they make the corner look
    hidden. Each stranded point joins the line next to it (within the same range segment)
    when it is within ``threshold`` of that line (the nearer one if both), working outwards
    from the line. With ``noise_sigma`` (``"auto"``) a point's threshold is at most three of its
    own sigmas across the line, ``3 max(noise_sigma |cos(incidence)|, MIN_SPLIT_M / SPLIT_SIGMAS)``
    (``rho``: the points' ranges): a wall seen at a grazing angle is thin.
    """
    if not leftovers or not accepted:
        return sorted(accepted)
    by_end = {b: k for k, (a, b) in enumerate(accepted)}
    by_start = {a: k for k, (a, b) in enumerate(accepted)}
    spans = [list(ab) for ab in accepted]
    x, y = run.x, run.y
    fits: dict[int, tuple[float, float, float]] = {}  # cos(alpha), sin(alpha), r of the lines used

    def distance(k, i):
        if k is None:
            return math.inf
        if k not in fits:
            r, alpha = line_from_sums(*run.sums(*accepted[k]))
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
            steps.add("absorb", int(run.idx[a]), int(run.idx[b - 1]), value=(lo - a) + (b - hi),
                      reason=f"{(lo - a) + (b - hi)} stranded points joined the neighbouring lines")
    return sorted((a, b) for a, b in spans)


def _covariances(idx: np.ndarray, starts: np.ndarray, alpha: np.ndarray, p: np.ndarray, ranges: np.ndarray, weights,
                 sigma: float, r: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Covariances of lines whose beams ``idx[starts[k]:starts[k + 1]]`` have the points ``p``
    (and, given the lines' ``r``, their RMS errors: :func:`labkit.fitting._line_covariances`)."""
    w = np.ones(len(idx)) if weights == "uniform" else 1.0 / ranges.take(idx)
    var = np.full(len(idx), sigma * sigma)
    return _line_covariances(p[:, 0], p[:, 1], w, starts, alpha, var, r=r)


@dataclass(frozen=True)
class SplitMergeParams(Params):
    """Parameters of :func:`split_and_merge` (both ``"iepf"`` and ``"split_and_merge"`` in the
    registry, and the ``[lines]`` table of :class:`labkit.Config`), each default once: lengths
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

    def kwargs(self) -> dict:
        kw = super().kwargs()
        kw["merge"] = None if kw["merge"] == "none" else kw["merge"]
        kw["weights"] = None if kw["weights"] == "inverse_range" else kw["weights"]
        return kw


@takes_params(SplitMergeParams, segmented=True, own_segmentation=("segment_threshold_m", "adaptive_segmentation"))
def split_and_merge(
    scan: Scan,
    *,
    method: str = "endpoints",
    split_threshold_m: float,
    min_points: int,
    min_length_m: float,
    max_gap_m: float,
    merge: str | None,
    merge_dr_m: float,
    merge_dalpha: float,
    merge_chi2: float,
    segment_threshold_m: float = SegmentationParams.threshold_m,
    adaptive_segmentation: bool = SegmentationParams.adaptive,
    range_sigma_m: float,
    weights,
    place_dr_m: float,
    place_dalpha: float,
    place_confidence: float,
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
        breakpoint detector cuts at every beam, is joined again (:func:`_grazing_runs`): lone
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
    merge : {"thresholds", "chi2", None}
        The merge test (see :func:`lines_similar`); ``None`` skips the merge step.
    merge_dr_m, merge_dalpha, merge_chi2 : float
        Thresholds of the merge test: 0.2 m, 10 deg, and 9.21 (chi-square, 2 dof, 99%).
        They can be generous because every merge must also pass the split test: the
        refitted line may miss none of its points by more than ``split_threshold_m``. Tight
        thresholds leave short noisy pieces of long walls unmerged: a few degrees of
        angle error on a piece 3 m away shifts its ``r`` by decimetres.
    segment_threshold_m, adaptive_segmentation : float, bool
        Range segmentation (:func:`labkit.segmentation.segment_labels`): 0.08 m floor with
        the adaptive breakpoint detector on.
    range_sigma_m : float or "auto"
        Range noise, for the adaptive breakpoints, the lines' covariances and the ``"auto"``
        split threshold. Default ``"auto"``: estimated from the scan
        (:func:`labkit.noise.scan_sigma`); a number: that noise (the fixed settings' 0.01 m).
    place_dr_m, place_dalpha, place_confidence : float
        What a user trusts: a line is reported only if, by its covariance (from
        ``range_sigma_m``), it lies within ``place_dr_m`` (default 5 cm) in ``r`` and
        ``place_dalpha`` (default 3 deg, the record's ``place_dalpha_deg``) in ``alpha`` of the
        true line with probability ``place_confidence`` (default 0.8; 0: every line is
        reported, as in the papers):
        :func:`labkit.fitting.placement_probability`. A short piece seen from afar, whose angle
        the data cannot fix to a few degrees, is dropped (a ``"reject"`` step with
        ``test="place_confidence"``). The defaults are Nguyen et al.'s tolerance of a correct
        line; at 0.8 a line matches the wall it belongs to four times in five.
    weights : None or "uniform"
        Point weights of the fits: ``None`` is ``1 / rho`` (the slides).
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
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    min_points, split_threshold_m, min_length_m, max_gap_m, range_sigma_m = _params(
        method, merge, weights, min_points, split_threshold_m, min_length_m, max_gap_m, merge_dr_m, merge_dalpha,
        merge_chi2, range_sigma_m, place_dr_m, place_dalpha, place_confidence)
    if range_sigma_m == AUTO:
        range_sigma_m = scan_sigma(scan)
    noise_sigma = 0.0  # > 0: the "auto" split test, which measures each point against this range noise
    if split_threshold_m == AUTO:
        split_threshold_m = auto_split_threshold(range_sigma_m)
        noise_sigma = range_sigma_m

    steps = _Steps("iepf" if method == "endpoints" else "split_and_merge") if trace else None
    if segments is None:
        labels = segment_labels(scan, segment_threshold_m, min_points=min_points, adaptive=adaptive_segmentation,
                                range_sigma_m=range_sigma_m)
    else:
        labels = labels_from(scan, segments)
    grazing = None
    if noise_sigma:  # "auto": walls seen at a grazing angle, which the breakpoints left as lone points
        labels, grazing = _grazing_runs(scan, labels, segment_threshold_m, min_points, range_sigma_m)
    points = scan.points
    ranges = scan.ranges
    keep = min_points // 2
    order, starts, stops = segment_order(labels)
    order.setflags(write=False)  # so are the lines' beams, slices of it
    # one pass over the whole scan, segments laid end to end: points, weights, prefix sums, gaps
    xy = points.take(order, axis=0)  # = points[order], several times faster
    w = np.ones(len(order)) if weights == "uniform" else 1.0 / ranges.take(order)
    run = _Run(xy, w, order)
    rho = ranges.take(order) if noise_sigma else None
    x, y = run.x, run.y
    # the gaps between neighbours wider than max_gap_m, where a run may have to be cut (ascending);
    # as hypot(dx, dy) <= |dx| + |dy|, only the few neighbours with |dx| + |dy| near max_gap_m are measured
    dx, dy = x[1:] - x[:-1], y[1:] - y[:-1]
    near = (np.abs(dx) + np.abs(dy) > 0.99 * max_gap_m).nonzero()[0]
    gaps = dict(zip(near.tolist(), np.hypot(dx[near], dy[near]).tolist(), strict=True))
    wide = [i for i, gap in gaps.items() if gap > max_gap_m  # (not where a grazing wall was joined again)
            and not (grazing is not None and order[i + 1] == order[i] + 1 and grazing[order[i]])]
    spans: list[tuple[int, int]] = []  # the accepted runs a..b-1, scan order
    normal = np.empty(2)  # (cos alpha, sin alpha) of the line being tested
    fit = method == "fit"
    absorb_m = min(split_threshold_m, 3 * range_sigma_m)
    for seg_a, seg_b in zip(starts.tolist(), stops.tolist(), strict=True):
        if steps is not None:
            joined = grazing is not None and bool(grazing.take(order[seg_a:seg_b - 1]).any())
            graze = " (with beams the breakpoints cut from it: a wall seen at a grazing angle)" if joined else ""
            steps.add("segment", int(order[seg_a]), int(order[seg_b - 1]), value=seg_b - seg_a,
                      reason=f"range segment of {seg_b - seg_a} points{graze}")
        stack = [(seg_a, seg_b)]
        accepted: list[tuple[int, int]] = []
        leftovers: list[tuple[int, int]] = []
        while stack:
            a, b = stack.pop()
            n = b - a
            if steps is not None:
                first, last = int(order[a]), int(order[b - 1])
            if n < min_points:
                if steps is not None:
                    steps.add("reject", first, last, value=n, threshold=min_points, test="min_points",
                              reason=f"{n} points < min_points={min_points}")
                leftovers.append((a, b))
                continue
            k = bisect_left(wide, a) if wide else 0
            if k < len(wide) and wide[k] < b - 1:  # a gap wider than max_gap_m: cut at the widest
                g = max(wide[k:bisect_left(wide, b - 1)], key=gaps.__getitem__)
                if steps is not None:
                    steps.add("gap", first, last, at=int(order[g]), value=gaps[g], threshold=max_gap_m,
                              test="max_gap_m", reason=f"gap {gaps[g]:.3f} m > max_gap_m")
                stack.append((g + 1, b))
                stack.append((a, g + 1))
                continue
            if fit:
                r, alpha = line_from_sums(*run.sums(a, b))
            else:  # the chord: the line through points a and b - 1
                x0, y0, x1, y1 = x.item(a), y.item(a), x.item(b - 1), y.item(b - 1)
                alpha = math.atan2(x1 - x0, -(y1 - y0))
                r = x0 * math.cos(alpha) + y0 * math.sin(alpha)
                if r < 0:
                    r, alpha = -r, alpha + math.pi
                alpha = math.remainder(alpha, 2 * math.pi)
            lo, hi = (a + keep, b - keep) if n > 2 * keep else (a, b)
            # signed distances v - r; the worst point is the farther of the two extremes
            normal[0], normal[1] = math.cos(alpha), math.sin(alpha)
            v = xy[lo:hi].dot(normal)  # xy[lo:hi] @ normal, with less overhead
            k_hi, k_lo = int(v.argmax()), int(v.argmin())
            d_hi, d_lo = v.item(k_hi) - r, r - v.item(k_lo)
            if d_hi > d_lo or (d_hi == d_lo and k_hi < k_lo):
                worst, p = d_hi, lo + k_hi
            else:
                worst, p = d_lo, lo + k_lo
            if steps is not None:
                ref = "fitted line" if fit else "chord"
                steps.add("fit", first, last, r, alpha, at=int(order[p]), value=worst, threshold=split_threshold_m,
                          reason=f"worst point {worst:.3f} m from the {ref}")
            test, threshold = "split_threshold_m", split_threshold_m
            failed = worst > split_threshold_m
            if noise_sigma and not failed and a < p < b - 1:
                # "auto": each point against its own noise across the line, then the fit's residuals
                if worst > MIN_SPLIT_M:
                    q, ratio = _beyond_own_noise(v, rho[lo:hi], r, noise_sigma)
                    if ratio > 1.0:
                        failed, p = True, lo + q
                        worst = abs(v.item(q) - r)
                        threshold = worst / ratio
            misfit = None
            if noise_sigma and not failed and n > 2:  # "auto": the fit's residuals against the noise
                rf, af = (r, alpha) if fit else line_from_sums(*run.sums(a, b))
                normal[0], normal[1] = math.cos(af), math.sin(af)
                misfit = _misfit(xy[a:b].dot(normal), rho[a:b], rf, noise_sigma)
                if misfit is not None and misfit[0] == "residual" and a < p < b - 1:
                    failed, test, threshold = True, "residual", noise_sigma
            if failed and a < p < b - 1:
                if steps is not None:
                    if test == "residual":
                        reason = (f"residuals wider than range noise {noise_sigma:.3f} m allows "
                                  f"(RMS {misfit[1]:.3f} m)")
                    elif threshold < split_threshold_m:
                        reason = (f"{worst:.3f} m > {threshold:.3f} m, {SPLIT_SIGMAS:g} sigma across the line "
                                  "at this point's incidence")
                    else:
                        reason = f"{worst:.3f} m > split_threshold_m={split_threshold_m}"
                    steps.add("split", first, last, r, alpha, at=int(order[p]), value=worst,
                              threshold=threshold, test=test, reason=reason)
                stack.append((p + 1, b))  # right half, processed after the left half
                stack.append((a, p + 1))  # the worst point ends the left half
                continue
            if misfit is not None and misfit[0] == "shift":  # a stretch of points to one side of the fit
                k, width, mean = misfit[1]
                cuts = (a, a + k, a + k + width, b)  # the stretch and what lies either side of it
                if steps is not None:
                    steps.add("split", first, last, rf, af, at=int(order[a + k]), value=abs(mean),
                              threshold=noise_sigma, test="shift",
                              reason=f"beams {int(order[a + k])}..{int(order[a + k + width - 1])} lie "
                                     f"{abs(mean):.3f} m to one side of the fitted line on average")
                for c0, c1 in reversed(list(zip(cuts[:-1], cuts[1:], strict=True))):
                    if c1 > c0:
                        stack.append((c0, c1))
                continue
            if steps is not None:
                steps.add("accept", first, last, r, alpha, at=int(order[p]), value=worst,
                          threshold=split_threshold_m, test="split_threshold_m",
                          reason=f"{worst:.3f} m <= split_threshold_m")
            accepted.append((a, b))
        spans += _absorb(accepted, leftovers, run, absorb_m, steps, rho, noise_sigma) if leftovers else sorted(accepted)
    lines = run.lines(spans)

    merge_args = dict(max_gap_m=max_gap_m, max_error_m=split_threshold_m, merge=merge, merge_dr_m=merge_dr_m,
                      merge_dalpha=merge_dalpha, merge_chi2=merge_chi2, ranges=ranges, angles=scan.angles,
                      valid=scan.valid, weights=weights, sigma=range_sigma_m, noise_sigma=noise_sigma,
                      segment_threshold_m=segment_threshold_m)
    wrap = merge is not None and len(lines) > 1 and scan.is_full_circle
    if merge is not None and len(lines) > 1:
        lines = _merge(lines, points, wrap, steps, **merge_args)
    kept = []
    for line in lines:
        if line.length < min_length_m:
            if steps is not None:
                steps.add("reject", line.first, line.last, line.r, line.alpha, value=line.length,
                          threshold=min_length_m, test="min_length_m",
                          reason=f"length {line.length:.3f} m < min_length_m={min_length_m}")
            continue
        kept.append(line)
    if merge is not None and 1 < len(kept) < len(lines):
        # a short piece dropped from between two parts of one wall (a few noisy points around
        # a dropout) no longer keeps them apart: try merging the new neighbours
        kept = _merge(kept, points, wrap, steps, **merge_args)
    out = _finish(kept, points, ranges, weights, range_sigma_m)
    if place_confidence > 0 and out:
        out = _placed(out, place_dr_m, place_dalpha, place_confidence, steps)
    return (out, list(steps)) if trace else out


#: With ``split_threshold_m="auto"``: neighbouring lone beams that the breakpoint detector cut
#: (its ``incidence_deg``, 10 deg) are joined again when the line between their points makes at
#: least this angle (degrees) with the beams; ``min_points`` or more in a row are a wall seen at a
#: grazing angle (:func:`_grazing_runs`). On the simulated sets 2-5 deg find the same walls to
#: within 0.003 of TruePos.
GRAZING_DEG = 3.0


def _grazing_links(p: np.ndarray, r: np.ndarray, a: np.ndarray, k: np.ndarray, threshold_m: float,
                   sigma: float) -> np.ndarray:
    """Which pairs of neighbouring beams ``(k, k + 1)`` (points ``p``, ranges ``r``, angles ``a``
    of the scan) the breakpoint detector cut (its ``incidence_deg``) though the line between their
    points makes :data:`GRAZING_DEG` or more with the beams: the same surface seen at a grazing
    angle, nothing between them (no beam)."""
    gap = np.hypot(p[k + 1, 0] - p[k, 0], p[k + 1, 1] - p[k, 1])
    dphi = np.abs(a[k + 1] - a[k])
    ra, rb = r[k], r[k + 1]
    return (gap > _thresholds(ra, rb, dphi, threshold_m, SegmentationParams.incidence_deg, sigma)) & (
        gap <= _thresholds(ra, rb, dphi, threshold_m, GRAZING_DEG, sigma))


def _grazing_runs(scan: Scan, labels: np.ndarray, threshold_m: float, min_points: int,
                  sigma: float) -> tuple[np.ndarray, np.ndarray | None]:
    """``labels`` with the walls seen at a grazing angle that the breakpoint detector cut to
    pieces joined again (relabelled in scan order), and at which beams ``k`` the pair
    ``(k, k + 1)`` was joined (None: none).

    The detector (:func:`labkit.segmentation.segment_labels`) cuts between two beams when the
    line joining their points is within ``incidence_deg`` (10 deg) of the beams: there it cannot
    tell a wall from a step in depth. A long wall seen far away at a few degrees is cut at every
    beam, each point alone and up to ``max_gap_m`` or more from the next (0.3-0.7 m for walls of
    the simulated corridor 7-13 m away), and no line was fitted to it. One cut is a step in
    depth; a wall is a chain of them: ``min_points`` or more lone beams in a row, each cut from
    the next at :data:`GRAZING_DEG` or more from the beams, are joined into a segment, and with
    the segment at either end when it was cut from it the same way. The split tests then cut
    what is not one line. (Beams without a label closer than the detector's threshold were not
    cut: the pipeline's beams of circles and legs. They stay out.)"""
    n = len(labels)
    free = scan.valid & (labels < 0)
    k = np.flatnonzero(free[:-1] & free[1:])  # pairs of lone beams
    m = min_points - 1  # pairs in a chain of min_points beams
    if len(k) < m or not (k[m - 1:] - k[:len(k) - m + 1] == m - 1).any():  # (no m of them in a row)
        return labels, None
    link = np.zeros(n - 1, dtype=bool)
    link[k[_grazing_links(scan.points, scan.ranges, scan.angles, k, threshold_m, sigma)]] = True
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
    link[ends[_grazing_links(scan.points, scan.ranges, scan.angles, ends, threshold_m, sigma)]] = True
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


def _misfit(v: np.ndarray, rho: np.ndarray, r: float, sigma: float):
    """How a run of points fails to lie on its fitted line ``r`` within range noise ``sigma``
    (``v``: the points' projections on the line's normal, ``rho``: their ranges), or None.

    Each point's noise across the line is ``sigma |cos(incidence)|``, at least ``MIN_SPLIT_M /
    SPLIT_SIGMAS`` (the split threshold's floor): a wall seen at a grazing angle is thin.
    ``("residual", rms)``: the residuals in those units have a mean square per degree of freedom
    above 1 and above the chi-square quantile at :data:`RESIDUAL_Z` (a bend too gentle for any one
    point to show); ``("shift", (k, w, mean))``: the ``w`` points from the ``k``-th lie to one side
    of the line (:data:`SHIFT_Z`, :data:`SHIFT_MIN_M`).
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
    total = float(z @ z)
    if total > n - 2 and total > (n - 2) * chi2_upper_over_dof(n - 2, RESIDUAL_Z):
        return "residual", math.sqrt(float(res @ res) / n)
    if n < 8 or total <= SHIFT_Z * SHIFT_Z:  # (a shifted stretch's z squared is at most the total)
        return None
    c = np.zeros(n + 1)
    np.add.accumulate(res, out=c[1:])  # (= cumsum, with less overhead)
    # a window of w = 4, 8, ... points is w / 4 windows of 4: if none of those has a mean over
    # SHIFT_MIN_M, no window does (most runs at a few millimetres of noise end here)
    if float(np.abs(c[4:] - c[:-4]).max()) <= SHIFT_MIN_M * 4:
        return None
    v2 = np.zeros(n + 1)
    np.add.accumulate(sd * sd, out=v2[1:])
    best, best_z = None, SHIFT_Z
    w = 4
    while 2 * w <= n:
        s, s2 = c[w:] - c[:-w], v2[w:] - v2[:-w]
        zw = np.abs(s) / np.sqrt(s2)
        k = int(zw.argmax())
        if zw.item(k) > best_z and abs(s.item(k)) > SHIFT_MIN_M * w:
            best, best_z = (k, w, s.item(k) / w), zw.item(k)
        w *= 2
    return None if best is None else ("shift", best)


def _beyond_own_noise(v: np.ndarray, rho: np.ndarray, r: float, sigma: float) -> tuple[int, float]:
    """Which point is farthest from the line ``(r, alpha)`` in units of its own split threshold
    ``max(SPLIT_SIGMAS sigma |cos(incidence)|, MIN_SPLIT_M)``, and that ratio (> 1: it fails);
    ``v`` are the points' projections on the line's normal, ``rho`` their ranges. Range noise
    moves a point across the line by its cosine of incidence, ``|v| / rho``: a wall seen at a
    grazing angle is thin, and a step in it is not noise."""
    ratio = np.abs(v - r) / np.maximum(np.abs(v) * (SPLIT_SIGMAS * sigma) / rho, MIN_SPLIT_M)
    q = int(ratio.argmax())
    return q, ratio.item(q)


@remembered
def _params(method, merge, weights, min_points, split_threshold_m, min_length_m, max_gap_m, merge_dr_m, merge_dalpha,
            merge_chi2, range_sigma_m, place_dr_m, place_dalpha, place_confidence) -> tuple:
    """The parameters of :func:`split_and_merge` checked, in its order; returns those it uses converted."""
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    if merge not in _MERGES:
        raise ValueError(f'merge must be "thresholds", "chi2" or None, got {merge!r}')
    if weights not in (None, "uniform"):
        raise ValueError(f'weights must be None (1/rho) or "uniform", got {weights!r}')
    min_points = check_int("min_points", min_points, 2)
    if split_threshold_m != AUTO:
        split_threshold_m = check_positive("split_threshold_m", split_threshold_m)
    min_length_m = check_nonneg("min_length_m", min_length_m)
    max_gap_m = check_positive("max_gap_m", max_gap_m)
    check_positive("merge_dr_m", merge_dr_m)
    check_positive("merge_dalpha", merge_dalpha)
    check_positive("merge_chi2", merge_chi2)
    if range_sigma_m != AUTO:  # a number or "auto" here (no per-line residual noise)
        range_sigma_m = check_positive("range_sigma_m", range_sigma_m)
    _check_placing(range_sigma_m, place_dr_m, place_dalpha, place_confidence)
    return min_points, split_threshold_m, min_length_m, max_gap_m, range_sigma_m


def _beam_between(line: _Line, after: int, before: int, ranges: np.ndarray, valid: np.ndarray, angles: np.ndarray,
                  margin: float) -> tuple[int, float] | None:
    """The first valid beam strictly between beams ``after`` and ``before`` (across the seam
    when ``before < after``) whose ray meets ``line`` and ends more than ``margin`` off it, and
    how far in front of the line it ends (negative: behind), or None. A beam with no valid
    return is no evidence either way; nor is one whose ray does not meet the line."""
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
    return (int(js[k[0]]), float(line.r / c[k[0]] - rho[k[0]])) if len(k) else None


def _merge(lines: list[_Line], points, wrap: bool, steps, *, max_gap_m, max_error_m, merge, merge_dr_m,
           merge_dalpha, merge_chi2, ranges, angles, valid, weights, sigma, noise_sigma,
           segment_threshold_m) -> list[_Line]:
    """Merge neighbouring similar lines, refitting from the summed weighted sums.

    Neighbours are consecutive lines whose facing ends are at most ``max_gap_m`` apart (with
    ``noise_sigma`` > 0, or neighbouring beams the breakpoint detector cut only for a grazing
    angle, :func:`_grazing_links`; ``segment_threshold_m`` is its floor); on a full-circle scan
    the last and first lines are neighbours too. A merge is undone when the
    refitted line's worst point is farther than ``max_error_m`` from it, when (``noise_sigma``
    > 0, the ``"auto"`` split test) it fails the split loop's noise tests, or when a beam
    between the two lines ends more than ``max_gap_m`` off the merged line: behind it, the beam
    saw through it (a doorway, a window) and the line would cover a hole; in front of it, the
    beam hid the stretch the line would claim (a chair leg).
    """

    def attempt(a: _Line, b: _Line) -> _Line | None:
        first, last = a.first, b.last
        gap = math.hypot(b.start[0] - a.end[0], b.start[1] - a.end[1])
        if gap > max_gap_m and not (noise_sigma and b.first == a.last + 1 and _grazing_links(
                points, ranges, angles, np.array([a.last]), segment_threshold_m, sigma).item(0)):
            if steps is not None:
                steps.add("keep", first, last, at=a.last, value=gap, threshold=max_gap_m, test="max_gap_m",
                          reason=f"facing ends {gap:.3f} m apart > max_gap_m")
            return None
        if merge == "chi2":
            for ln in (a, b):
                if ln.cov is None:
                    ln.cov = _covariances(ln.idx, np.zeros(1, np.int64), np.array([ln.alpha]),
                                          points.take(ln.idx, axis=0), ranges, weights, sigma)[0][0]
        ok, stat = _similar(a.r, a.alpha, a.cov, b.r, b.alpha, b.cov, merge, merge_dr_m, merge_dalpha,
                            merge_chi2)
        merged = worst = None
        if ok:
            idx = np.concatenate([a.idx, b.idx])
            idx.setflags(write=False)
            merged = _Line(idx, [u + v for u, v in zip(a.s, b.s, strict=True)], a.first, b.last, a.p_first,
                           b.p_last)
            p = points.take(idx, axis=0)
            v = p[:, 0] * math.cos(merged.alpha) + p[:, 1] * math.sin(merged.alpha)
            worst = float(np.max(np.abs(v - merged.r)))
            failed = None  # (the test the merged line fails, why)
            if worst > max_error_m:
                failed = "split_threshold_m", f"the merged line misses a point by {worst:.3f} m"
            elif noise_sigma and worst > MIN_SPLIT_M and _beyond_own_noise(v, ranges.take(idx), merged.r,
                                                                          noise_sigma)[1] > 1.0:
                failed = "split_threshold_m", f"a point misses it by more than {SPLIT_SIGMAS:g} of its sigmas"
            elif noise_sigma and (misfit := _misfit(v, ranges.take(idx), merged.r, noise_sigma)) is not None:
                if misfit[0] == "residual":
                    failed = "residual", "the merged line's residuals are wider than the range noise allows"
                else:
                    failed = "shift", (f"{misfit[1][1]} of its points lie {abs(misfit[1][2]):.3f} m to one side "
                                       "of it on average")
            else:
                off = _beam_between(merged, a.last, b.first, ranges, valid, angles, max_gap_m)
                if off is not None:
                    beam, ahead = off
                    where = f"{ahead:.2f} m in front of" if ahead > 0 else f"{-ahead:.2f} m behind"
                    failed = "beam_between", f"beam {beam} ends {where} the merged line (more than max_gap_m)"
            if failed is not None:
                merged = None
        if steps is not None:
            if not ok:
                test, reason = "merge", f"different: statistic {stat:.2f}"
            elif merged is None:
                test, reason = failed[0], f"similar ({stat:.2f}) but {failed[1]}"
            else:
                test, reason = "merge", f"similar: statistic {stat:.2f}"
            ln = merged if merged is not None else a
            steps.add("merge" if merged is not None else "keep", first, last, ln.r, ln.alpha, at=a.last,
                      value=stat, threshold=merge_chi2 if merge == "chi2" else 1.0, test=test, reason=reason)
        return merged

    out = list(lines)
    i = 0
    while i < len(out) - 1:
        merged = attempt(out[i], out[i + 1])
        if merged is None:
            i += 1
        else:
            out[i:i + 2] = [merged]
    if wrap and len(out) > 1:
        merged = attempt(out[-1], out[0])
        if merged is not None:
            out = [merged] + out[1:-1]
    return out


def _finish(lines: list[_Line], points, ranges, weights, sigma: float) -> list[LineSegment]:
    """LineSegment records, with every line's covariance and RMS error in one vectorised pass."""
    if not lines:
        return []
    counts = np.array([len(ln.idx) for ln in lines])
    idx = np.concatenate([ln.idx for ln in lines])
    starts = counts.cumsum() - counts
    p = points.take(idx, axis=0)  # = points[idx]
    alpha, r = np.array([ln.alpha for ln in lines]), np.array([ln.r for ln in lines])
    cov, rms = _covariances(idx, starts, alpha, p, ranges, weights, sigma, r)  # and the RMS distances to the lines
    rms = rms.tolist()
    # read-only records (the beams already are): each covariance, start and end is a view of these
    cov.setflags(write=False)
    ends = np.array([ln.start + ln.end for ln in lines])
    ends.setflags(write=False)
    ends = list(ends.reshape(-1, 2))  # start 0, end 0, start 1, ...
    return [LineSegment(ln.r, ln.alpha, c, start, end, ln.first, ln.last, n, error, ln.idx)
            for ln, c, start, end, n, error in zip(lines, cov, ends[0::2], ends[1::2], counts.tolist(), rms,
                                                   strict=True)]

