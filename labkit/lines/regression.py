"""Line regression: sliding-window fits clustered into lines, as compared by Nguyen et al.
(2007) after Arras & Siegwart (1997).

Where split-and-merge works top-down (fit, then split), line regression works bottom-up:

1. Slide a window of ``window`` consecutive points (Nguyen's ``Nf``) along every run of the
   scan.
2. Fit a line to the points of every window.
3. Compute the *fidelity* of every window: how far its line is from the lines of its two
   neighbours (the window one beam before and the one one beam after), as the sum of two
   Mahalanobis distances in ``(r, alpha)``. A window lying on one wall agrees with its
   neighbours (they share all but one point); a window reaching across a corner or onto
   another object does not.
4. Cluster: the windows whose fidelity is under ``fidelity_threshold`` are kept, and each
   run of consecutive kept windows is a cluster; its points are the union of its windows.
   (This is agglomerative clustering of the windows with single linkage, restricted to
   neighbours along the scan and stopped at the threshold: with neighbours only, it cuts the
   chain of windows at every window that disagrees.)
5. Fit one line to each cluster's points; merge neighbouring clusters whose points overlap
   or touch and whose lines agree (the same Mahalanobis distance, under the same threshold);
   the points two clusters still share go to the line they are nearer to.
6. (Ours, not part of the published algorithm.) At a corner the window across it disagrees
   with its neighbours, and so do the windows next to it: the corner point of each wall is
   in no cluster. Points in no cluster join the neighbouring line they lie within three
   ``sigma`` of (the nearer line if both), so that lines end at the corner.
7. Fit every line to its points, stop its segment at the rays of its first and last beams
   (as :func:`labkit.split_and_merge` and :func:`labkit.lines.incremental.incremental_lines`
   do: an end point off the line at a grazing angle would otherwise project over the next
   beams' rays), and drop those shorter than ``min_length_m``.

The distance. Each window's line has a covariance under a simple noise model: every point
is moved across the line by independent noise of standard deviation ``sigma``. For an
orthogonal (total least squares) fit of ``n`` points whose along-line offsets from their
centroid are ``t_i``, that gives ``var(alpha) = sigma^2 / S`` with ``S = sum t_i^2``,
``var(r) = sigma^2 / n + m^2 var(alpha)`` and ``cov(r, alpha) = m var(alpha)``, where ``m``
is the centroid's coordinate along the line (``r`` is measured from the sensor, so a turn of
the line about its centroid moves ``r`` by ``m`` per radian). The distance of two lines is
``d^2 = D^T (C_1 + C_2)^-1 D`` with ``D = (r_2 - r_1, alpha_2 - alpha_1)``, the angle taken
across the wrap (and a line through the origin compared with its normal turned round).
``sigma`` is estimated from the scan itself unless ``range_sigma_m`` is given: the median over
all windows of the RMS residual of the window's fit, corrected for the two parameters
fitted (``* sqrt(window / (window - 2))``). The estimate follows the sensor: 13 mm on the
simulated office (XV-11, 15 mm range noise), 6 mm on the corridor (LMS111, 8 mm), 4 mm in
the hall (LMS200, 5 mm). Neighbouring windows share all but one point, so their lines are
far from independent and ``d^2`` is not chi-square distributed; the threshold is set from
measurement (see :func:`regression_lines`).

Windows and clusters are fitted with equal weights (the noise model above is for that
fit), from prefix sums of ``x, y, x^2, y^2, x y``: every window and every cluster costs
O(1), all windows of a scan are fitted in one vectorised pass. The lines returned are fitted
by :func:`labkit.features.line_segment` (weights ``1 / rho``), as every labkit extractor's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..features import LineSegment
from ..params import Params, checked_by, param
from ..scan import Scan
from ..steps import Step
from ._runs import _fitted, _PrefixSums, _runs, _Trace

__all__ = ["regression_lines"]

#: The smallest noise the estimate may give, metres: a noise-free scan (ranges exact to
#: float32) would otherwise make every rounding difference between windows significant.
_SIGMA_FLOOR_M = 0.001


@dataclass(frozen=True)
class RegressionParams(Params):
    """Parameters of :func:`regression_lines`.

    The ``[lines.regression]`` table of :class:`labkit.Config`, each default once: lengths in metres
    (``range_sigma_m`` none: estimated from the scan, see the function)."""

    window: int = param(7, "points per sliding window (Nguyen's Nf)", lo=3)
    fidelity_threshold: float = param(12.0, "largest fidelity of a window kept (residual over expected noise)",
                                      lo=0, strict=True)
    min_points: int = param(5, "fewest points of a line", lo=2)
    min_length_m: float = param(0.15, "shortest line kept, metres", lo=0)
    max_gap_m: float = param(0.3, "no line across a gap wider than this, metres", lo=0, strict=True)
    range_sigma_m: float = param(None, "range noise, metres (none: estimated from the scan)", lo=0, strict=True,
                                 optional=True, kind=float)

@checked_by(RegressionParams)
def regression_lines(
    scan: Scan,
    *,
    window: int = RegressionParams.window,
    fidelity_threshold: float = RegressionParams.fidelity_threshold,
    min_points: int = RegressionParams.min_points,
    min_length_m: float = RegressionParams.min_length_m,
    max_gap_m: float = RegressionParams.max_gap_m,
    range_sigma_m: float | None = RegressionParams.range_sigma_m,
    segments=None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Extract line segments from a scan by line regression (sliding-window fits, clustered).

    Parameters
    ----------
    scan : Scan
        Invalid beams (NaN, inf, 0, out of range) are masked: skipped, never raised.
    window : int
        Points per window, Nguyen's ``Nf`` (>= 3: a line and a residual). Default 7: a
        wall needs at least ``window`` points (one window) to be found, and over 20 scans
        of the simulated corridor 7 finds 0.96 of the walls, 9 only 0.93 (the 0.3 m deep
        sides of door recesses have few beams), at the same false positive rate.
    fidelity_threshold : float
        A window is kept while the sum of its distances ``d^2`` to its two neighbours is
        under this; two neighbouring clusters are merged when the distance between their
        lines is under it. Dimensionless (``d^2`` is in units of the noise). Default 12.0:
        measured over 20 scans each of the simulated office, corridor and random polygons,
        windows lying on one wall have a median fidelity of 0.9 and a 99th percentile of
        6-9, windows spanning two objects a median of 36-170. Only the product
        ``fidelity_threshold * sigma^2`` matters, so a fixed ``range_sigma_m`` twice as
        large acts as a threshold four times as large.
    min_points : int
        Fewest points of a line. Default 5, as split-and-merge.
    min_length_m : float, metres
        Shorter lines are dropped. Default 0.15 m, as split-and-merge.
    max_gap_m : float, metres
        A line never spans two neighbouring points farther apart than this: runs of the scan
        are cut there. Default 0.3 m, as split-and-merge. An invalid beam is skipped, not a
        cut, when its valid neighbours are within ``max_gap_m``.
    range_sigma_m : float or None, metres
        The noise ``sigma`` of the points across a line, for the lines' covariances.
        Default None: estimated from the scan (see the module's description), never below
        1 mm. A fixed value makes the threshold sensor-specific: 0.005 m gives 0.22 false
        positives on the XV-11 office, 0.02 m loses a third of the corridor's walls.
    segments : ndarray of per-beam labels or list of RangeSegment, optional
        A range segmentation computed elsewhere: lines then never cross a segment boundary
        and never use a beam labelled -1. Default None: the whole scan, cut only at gaps.
    trace : bool
        Also return the steps taken, as :class:`labkit.Step` records
        (``algorithm="regression"``). Distances are in units of the noise (``d^2``, compared
        with ``fidelity_threshold``). Kinds, in this order: ``"reject"`` with
        ``test="fidelity_threshold"`` for every window that disagrees with its neighbours
        (its fit on its beams ``first..last``; ``value`` its fidelity); ``"cluster"`` (a run
        of kept windows: its equal-weight fit; ``value`` the largest fidelity of its
        windows); ``"merge"`` (two neighbouring clusters joined: the joined span with the
        first cluster's line, ``at`` the second's first beam, ``value`` the distance of their
        lines) and ``"keep"`` (touching neighbours not joined); ``"absorb"`` (step 6: a line
        took free points; ``first..last`` its new beams, ``value`` how many it gained);
        then one ``"accept"`` or ``"reject"`` (``test="min_length_m"``) per line, fitted as
        returned (``beams``: its beams). Replay: the ``accept`` steps are the returned lines.

    Returns
    -------
    lines : list of LineSegment
        Sorted by first beam; each fitted by :func:`labkit.features.line_segment` to the
        valid beams it covers (indices ascending). A run needs at least ``window + 1``
        points (two windows to compare). The seam of a full-circle scan ends a run: a
        wall across it gives two lines.
    steps : list of labkit.Step
        Only with ``trace=True``.

    Examples
    --------
    Two walls of a room corner, x = 3 m and y = 2 m, seen from the origin:

    >>> theta = np.radians(np.arange(0.0, 90.5, 0.5))
    >>> ranges = np.minimum(3.0 / np.cos(theta), 2.0 / np.sin(np.maximum(theta, 1e-9)))
    >>> lines = regression_lines(Scan(ranges=ranges, angles=theta))
    >>> [(round(s.r, 6), round(float(np.degrees(s.alpha)), 6) + 0.0, s.first, s.last) for s in lines]  # + 0.0: no -0.0
    [(3.0, 0.0, 0, 67), (2.0, 90.0, 68, 180)]
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    threshold = fidelity_threshold
    # the runs a line may not cross; a run needs two windows, so that they can be compared
    steps = _Trace("regression") if trace else None
    beams, runs = _runs(scan, segments, max_gap_m, max(min_points, window + 1))
    if not runs:
        return ([], []) if trace else []
    xy = scan.points.take(beams, axis=0)
    table = _PrefixSums(xy, np.ones(len(beams))).table  # equal weights: the noise model's fit

    # step 1: the windows, every `window` consecutive points of a run: window k is the
    # points starts[k] .. starts[k] + window - 1 of `xy`
    starts = np.concatenate([np.arange(a, b - window + 1) for a, b in runs])
    run_of = np.repeat(np.arange(len(runs)), [b - a - window + 1 for a, b in runs])

    # step 2: a line through every window, with its covariance in units of sigma^2
    lines = _Lines(table, starts, starts + window)
    if range_sigma_m is None:
        sigma = float(np.median(lines.rms)) * math.sqrt(window / (window - 2))
        range_sigma_m = max(sigma, _SIGMA_FLOOR_M)
    threshold *= range_sigma_m ** 2  # compare d^2 sigma^2 with threshold sigma^2: sigma drops out

    # step 3: the fidelity of every window, the sum of its distances to its two neighbours;
    # a window at the end of a run has one neighbour, whose distance counts twice
    d = lines.distance(slice(None, -1), slice(1, None))  # window k to window k + 1
    d[run_of[1:] != run_of[:-1]] = np.nan  # neighbours in the list, but not along the scan
    before = np.concatenate(([np.nan], d))
    after = np.concatenate((d, [np.nan]))
    fidelity = np.where(np.isnan(before), after, before) + np.where(np.isnan(after), before, after)

    # step 4: clusters, the runs of consecutive kept windows within one run of the scan
    kept = fidelity < threshold
    joined = kept[1:] & kept[:-1] & (run_of[1:] == run_of[:-1])  # window k + 1 continues k's cluster
    first = kept & np.concatenate(([True], ~joined))
    last = kept & np.concatenate((~joined, [True]))
    spans = np.stack([starts[first], starts[last] + window], axis=1)  # each cluster's points [a, b)
    cluster_run = run_of[first]
    if steps is not None:
        _window_steps(steps, beams, lines, starts, window, fidelity, kept, first, last, threshold, range_sigma_m ** 2)

    # step 5: one line per cluster; neighbours that overlap or touch and agree are merged
    clusters = _merge(spans, cluster_run, table, threshold, steps, beams, range_sigma_m ** 2)
    clusters = _share(clusters, table, xy, min_points)

    # step 6: the points between clusters join a neighbouring line they are within 3 sigma of
    grown = _absorb(clusters, runs, table, xy, 3.0 * range_sigma_m)
    if steps is not None:
        for (a0, b0, _), (a, b) in zip(clusters, grown, strict=True):
            if (a, b) != (a0, b0):
                steps.add("absorb", beams[a], beams[b - 1], value=(a0 - a) + (b - b0),
                          reason=f"{(a0 - a) + (b - b0)} free points within 3 sigma = {3.0 * range_sigma_m:.3f} m "
                                 f"join the line")

    # step 7: every line fitted to its points, the short ones dropped
    out = _fitted(xy, beams, grown, min_length_m, steps)
    return (out, list(steps)) if steps is not None else out


def _window_steps(steps: _Trace, beams, lines: _Lines, starts, window: int, fidelity, kept, first, last,
                  threshold: float, s2: float) -> None:
    """The windows that disagree with their neighbours (``reject``), then the clusters of the
    others; ``threshold`` and ``fidelity`` are in ``d^2 sigma^2``, the steps divide by ``s2``."""
    for k in np.flatnonzero(~kept).tolist():
        a = int(starts[k])
        steps.add("reject", beams[a], beams[a + window - 1], lines.r[k], lines.alpha[k], value=fidelity[k] / s2,
                  threshold=threshold / s2, test="fidelity_threshold",
                  reason=f"window {k}: fidelity {fidelity[k] / s2:.1f} >= fidelity_threshold: it disagrees with "
                         f"its neighbours")
    ends = np.flatnonzero(last).tolist()
    for j, (k0, k1) in enumerate(zip(np.flatnonzero(first).tolist(), ends, strict=True)):
        a, b = int(starts[k0]), int(starts[k1]) + window
        n_windows = k1 - k0 + 1
        worst = float(np.max(fidelity[k0:k1 + 1])) / s2
        one = _Lines(lines.table, np.array([a]), np.array([b]))  # the cluster's equal-weight fit
        steps.add("cluster", beams[a], beams[b - 1], one.r[0], one.alpha[0], value=worst, threshold=threshold / s2,
                  test="fidelity_threshold",
                  reason=f"cluster {j}: {n_windows} windows in a row, fidelity at most {worst:.1f}")


class _Lines:
    """Equal-weight orthogonal fits of the point ranges ``a[k] .. b[k] - 1`` (arrays), from
    the prefix sums ``table`` (:class:`labkit.lines._runs._PrefixSums` with unit weights):
    ``r``, ``alpha``, the RMS residual ``rms`` and the covariance of ``(r, alpha)`` divided
    by ``sigma^2`` (``crr``, ``cra``, ``caa``), all arrays."""

    def __init__(self, table: np.ndarray, a: np.ndarray, b: np.ndarray):
        self.table = table
        s = table[b] - table[a]
        n = s[:, 0]
        mx, my = s[:, 1] / n, s[:, 2] / n  # the centroid
        cxx = s[:, 3] / n - mx * mx  # the scatter about it, per point
        cyy = s[:, 4] / n - my * my
        cxy = s[:, 5] / n - mx * my
        # the normal is perpendicular to the direction of largest scatter
        alpha = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy) + math.pi / 2
        r = mx * np.cos(alpha) + my * np.sin(alpha)
        alpha = np.where(r < 0, alpha + math.pi, alpha)  # r >= 0: turn the normal round
        self.r = np.abs(r)
        self.alpha = np.remainder(alpha + math.pi, 2 * math.pi) - math.pi
        half, dev = 0.5 * (cxx + cyy), np.hypot(0.5 * (cxx - cyy), cxy)
        self.rms = np.sqrt(np.maximum(half - dev, 0.0))  # the smaller eigenvalue: the residual
        spread = n * (half + dev)  # the larger one: sum of t_i^2 along the line
        with np.errstate(divide="ignore"):
            self.caa = 1.0 / spread  # var(alpha) / sigma^2
        m = -mx * np.sin(self.alpha) + my * np.cos(self.alpha)  # the centroid along the line
        self.cra = m * self.caa
        self.crr = 1.0 / n + m * m * self.caa

    def distance(self, i, j) -> np.ndarray:
        """``d^2 sigma^2`` between the lines ``i`` and ``j`` (indices, slices or index arrays)."""
        da = np.remainder(self.alpha[j] - self.alpha[i] + math.pi, 2 * math.pi) - math.pi
        dr = self.r[j] - self.r[i]
        # the same line seen with opposite normals (it passes near the sensor): compare
        # (r_j, alpha_j) with (-r_i, alpha_i + pi)
        # (r_j, alpha_j) with (-r_i, alpha_i + pi), whose covariance term cov(r, alpha) changes sign
        turned = np.abs(da) > math.pi / 2
        da = np.where(turned, da - np.copysign(math.pi, da), da)
        dr = np.where(turned, self.r[j] + self.r[i], dr)
        sra = np.where(turned, self.cra[j] - self.cra[i], self.cra[j] + self.cra[i])
        srr, saa = self.crr[i] + self.crr[j], self.caa[i] + self.caa[j]
        with np.errstate(divide="ignore", invalid="ignore"):
            return (saa * dr * dr - 2.0 * sra * dr * da + srr * da * da) / (srr * saa - sra * sra)


def _merge(spans: np.ndarray, run: np.ndarray, table: np.ndarray, threshold: float, steps: _Trace | None = None,
           beams=None, s2: float = 1.0) -> list[list[int]]:
    """Step 5, merging: neighbouring clusters of one run (``run``: the run of each cluster)
    whose points overlap or touch and whose lines are within ``threshold`` (``d^2 sigma^2``)
    are joined; a chain of agreeing neighbours becomes one cluster (single linkage again).
    Returns ``[a, b, run]`` for each cluster, its points ``a..b-1``. Given ``steps``, every
    touching pair is a ``merge`` or a ``keep`` step (distances divided by ``s2``)."""
    if len(spans) < 2:
        return [span + [k] for span, k in zip(spans.tolist(), run.tolist(), strict=True)]
    lines = _Lines(table, spans[:, 0], spans[:, 1])
    # (runs lie end to end in `beams`: the last cluster of a run may end where the next run begins)
    touch = (spans[1:, 0] <= spans[:-1, 1]) & (run[1:] == run[:-1])
    agree = touch & (lines.distance(slice(None, -1), slice(1, None)) < threshold)
    merged = [spans[0].tolist() + [int(run[0])]]
    d = lines.distance(slice(None, -1), slice(1, None)) / s2 if steps is not None else None
    for i, ((a, b), k, join) in enumerate(zip(spans[1:].tolist(), run[1:].tolist(), agree.tolist(), strict=True)):
        if steps is not None and d is not None and touch[i]:
            steps.add("merge" if join else "keep", beams[merged[-1][0]], beams[b - 1], lines.r[i], lines.alpha[i],
                      at=beams[a], value=d[i], threshold=threshold / s2,
                      test="fidelity_threshold",
                      reason=f"neighbouring clusters {d[i]:.1f} apart " + (
                          "< fidelity_threshold: merged" if join else ">= fidelity_threshold: kept apart"))
        if join:
            merged[-1][1] = b
        else:
            merged.append([a, b, k])
    return merged


def _share(spans: list[list[int]], table: np.ndarray, xy: np.ndarray, min_points: int) -> list[list[int]]:
    """Step 5, sharing: where two clusters still overlap (the windows on both sides of a
    corner may hold the corner points), the shared points up to the first one nearer to the
    second line stay with the first line, the rest go to the second. Clusters left with
    fewer than ``min_points`` points are dropped."""
    out: list[list[int]] = []
    for span in spans:  # (starts and ends both increase along the list)
        if out and span[0] < out[-1][1]:
            prev = out[-1]
            # the previous cluster may have lost its first points to the one before it already
            shared = np.arange(max(span[0], prev[0]), prev[1])
            lines = _Lines(table, np.array([prev[0], span[0]]), np.array([prev[1], span[1]]))
            normals = np.stack([np.cos(lines.alpha), np.sin(lines.alpha)])  # (2, 2): one column per line
            dist = np.abs(xy[shared] @ normals - lines.r)  # (shared, 2)
            nearer_next = np.flatnonzero(dist[:, 1] < dist[:, 0])
            cut = int(shared[nearer_next[0]]) if nearer_next.size else int(shared[-1]) + 1
            prev[1] = span[0] = cut
            if prev[1] - prev[0] < min_points:
                out.pop()
        if span[1] - span[0] >= min_points:
            out.append(span)
    return out


def _absorb(spans: list[list[int]], runs: list[tuple[int, int]], table: np.ndarray, xy: np.ndarray,
            reach: float) -> list[tuple[int, int]]:
    """Step 6: give the points no cluster holds to a neighbouring line.

    At a corner, the window that straddles it disagrees with its neighbours, but so do the
    windows next to it, which lie on the walls: the corner point of each wall ends up in no
    cluster. Working outwards from each line, a point between two clusters (or between a
    cluster and the end of its run) joins the line next to it while it is within ``reach``
    of that line, and nearer to it than to the line on its other side. Returns the final
    ``(a, b)`` of every line.
    """
    if not spans:
        return []
    lines = _Lines(table, np.array([s[0] for s in spans]), np.array([s[1] for s in spans]))
    cos, sin, r = np.cos(lines.alpha).tolist(), np.sin(lines.alpha).tolist(), lines.r.tolist()
    x, y = xy[:, 0], xy[:, 1]

    def distance(k: int | None, i: int) -> float:
        """Distance of point ``i`` to the line of cluster ``k`` (none: infinitely far)."""
        return math.inf if k is None else abs(x.item(i) * cos[k] + y.item(i) * sin[k] - r[k])

    out = [[a, b] for a, b, _ in spans]
    for k, (a, b, run) in enumerate(spans):
        # the free points before this cluster: from the end of the previous cluster of the run
        # (or the run's start) to this cluster's start
        before = k - 1 if k > 0 and spans[k - 1][2] == run else None
        lo = out[before][1] if before is not None else runs[run][0]
        i = lo
        while before is not None and i < a and distance(before, i) <= reach and \
                distance(before, i) <= distance(k, i):
            i += 1  # the previous line takes point i
        if before is not None:
            out[before][1] = i
        j = a
        while j > i and distance(k, j - 1) <= reach:
            j -= 1  # this line takes point j - 1
        out[k][0] = j
        # the free points after the last cluster of the run, up to the run's end
        if k + 1 == len(spans) or spans[k + 1][2] != run:
            end = runs[run][1]
            i = b
            while i < end and distance(k, i) <= reach:
                i += 1
            out[k][1] = i
    return [(a, b) for a, b in out]
