"""Incremental line extraction ("line tracking"), as compared by Nguyen et al. (2007).

The algorithm walks along the scan and grows one line at a time:

1. Start a line with the first ``min_points`` points of a run (the *seed*); a seed whose
   own fit misses one of its points by more than ``max_error_m`` (it lies across a corner
   or a burst of noise) is moved on by one beam.
2. Add the next point to the line and refit it.
3. Test the line condition: the new point lies within ``max_error_m`` of the refitted line.
4. While the condition holds, go back to 2.
5. When it fails, put the point back (the line keeps its previous fit), emit the line,
   and start a new line (step 1) at that point.
6. (Ours, not part of the published algorithm.) Hand corner points back; see below.
7. Fit every line to its points, stop its segment at the rays of its first and last beams
   (below), and drop those shorter than ``min_length_m``.
8. (Opt-in, ``place_confidence`` > 0.) Drop the lines the data cannot place, as
   :func:`labkit.split_and_merge` does.

Why this line condition: it is O(1) per point (no pass over the line's points, unlike the
largest residual of the whole line), it is the same distance that split-and-merge compares
with its ``split_threshold_m`` (a point's orthogonal distance to the fitted line), so the two
extractors share a default of 0.05 m, and measuring the point against the line *refitted with
it* is forgiving while the line is short and its direction still uncertain (the new point
pulls a 5-point line a long way towards itself) and strict once it is long (it barely moves).

A line grown this way keeps the first few points of the next wall: past a corner the points
stay within ``max_error_m`` of the old line for a few beams. Step 6 repairs that: where one
line ends on the beam before the next begins, the end points of the first line are handed to
the second while they are closer to the second line than to their own. Over 20 scans of the
simulated corridor it raises the share of walls found from 0.81 to 0.93 and lowers the false
positives from 0.34 to 0.16 (``tests/test_incremental.py`` scores the defaults).

Step 7 cuts a line's segment at its first and last points projected onto the line, but never
past the rays of its first and last beams, as :func:`labkit.split_and_merge` does. The line
condition measures each new point against the line refitted with it, so the final fit may leave
an end point farther off than ``max_error_m`` (a seed taken across a range jump, a wall that
bends): projected onto the line at a grazing angle, such a point slides along it over the rays
of the next beams, and the segment claims a surface where they saw another. On the Radish logs
(first 100 scans) segments reaching 0.5-4 degrees past their end beams, over beams that saw a
wall up to metres behind, gave 146 beams a ray-axis error over 0.3 m (2 with the ends stopped)
and most of the RMSE: 30/93/42/41/45/64 mm, 27/25/24/28/18/22 mm with the ends stopped (aces,
csail, freiburg, infinite-corridor, intel, orebro); the simulated sets barely change.

Every fit is the weighted least-squares line of :func:`labkit.fitting.fit_line_polar`
(weights ``1 / rho``), computed in O(1) from running sums of ``w, w x, w y, w x^2, w y^2,
w x y`` (:func:`labkit.fitting.line_from_sums`), so the whole scan costs O(N).

Runs: the algorithm never crosses a *break*: a gap wider than ``max_gap_m`` between
neighbouring valid points, or a boundary between range segments when ``segments`` is given.
An invalid beam (NaN, inf, 0, out of range) is skipped, not a break: its neighbours stay in
one run when they are within ``max_gap_m`` of each other, so a single dropout does not cut a
wall in two (on the simulated office, 2 % dropouts, cutting at every invalid beam leaves short
noisy pieces: 0.09 false positives instead of 0.02).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np  # noqa: F401 - used in doctests

from ..features import LineSegment
from ..fitting import line_from_sums
from ..noise import GROW_SIGMAS
from ..params import AUTO, checked_by, param
from ..scan import Scan
from ..steps import Step
from ._runs import _fitted, _noise, _PrefixSums, _runs, _Trace
from .placing import PlacingParams, placed

__all__ = ["incremental_lines"]


@dataclass(frozen=True)
class IncrementalParams(PlacingParams):
    """Parameters of :func:`incremental_lines`.

    The ``[lines.incremental]`` table of :class:`labkit.Config`, each default once: lengths in metres."""

    max_error_m: float = param(AUTO, "a point joins the line while within this distance of the refitted line, "
                                     "metres; auto: max(4 sigma, 2 cm) of the scan's range noise",
                               lo=0, strict=True, auto=True)
    min_points: int = param(5, "points of a seed, and fewest points of a line", lo=2)
    min_length_m: float = param(0.15, "shortest line kept, metres", lo=0)
    max_gap_m: float = param(0.3, "no line across a gap wider than this, metres", lo=0, strict=True)


@checked_by(IncrementalParams)
def incremental_lines(
    scan: Scan,
    *,
    max_error_m: float = IncrementalParams.max_error_m,
    min_points: int = IncrementalParams.min_points,
    min_length_m: float = IncrementalParams.min_length_m,
    max_gap_m: float = IncrementalParams.max_gap_m,
    range_sigma_m: float | str | None = IncrementalParams.range_sigma_m,
    place_dr_m: float = IncrementalParams.place_dr_m,
    place_dalpha_deg: float = IncrementalParams.place_dalpha_deg,
    place_confidence: float = IncrementalParams.place_confidence,
    segments=None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Extract line segments from a scan with the incremental (line-tracking) algorithm.

    Parameters
    ----------
    scan : Scan
        Invalid beams (NaN, inf, 0, out of range) are masked: skipped, never raised.
    max_error_m : float, metres
        The line condition: a new point joins the line while it is within this distance of
        the line refitted with it. Default ``"auto"`` (below). The fixed setting
        (:data:`labkit.noise.FIXED_INCREMENTAL`) has 0.05 m, split-and-merge's fixed
        ``split_threshold_m`` (ten times the LMS200's 5 mm range noise), so that the two
        extractors are compared at the same tolerance. 0.04 m scores about the same on the simulated worlds; 0.06 m
        loses more short walls of the corridor (0.88 found instead of 0.93).
        ``"auto"``: ``max(4 sigma, 2 cm)`` of the scan's range noise sigma
        (:data:`labkit.noise.GROW_SIGMAS`, which says why 4), worked out per scan; a number
        given is used as it is.
    min_points : int
        Points of a seed, and fewest points of a line. Default 5 (Xavier et al.'s
        ``line_min_pts``, split-and-merge's ``min_points``): fewer points fix a line's
        direction too poorly to grow it.
    min_length_m : float, metres
        Shorter lines are dropped. Default 0.15 m, as split-and-merge.
    max_gap_m : float, metres
        A line never spans two neighbouring points farther apart than this. Default 0.3 m,
        as split-and-merge.
    range_sigma_m : float, "auto" or None
        The range noise of the lines' covariances (and of ``max_error_m="auto"``), as for
        :func:`labkit.lines.ransac.ransac_lines`. Default ``"auto"``; ``None``: each line's own
        residuals.
    place_dr_m, place_dalpha_deg, place_confidence : float
        Report only the lines the data can place, as :func:`labkit.split_and_merge` does (default
        ``place_confidence`` 0.8; 0: every line, as in :data:`labkit.noise.FIXED_INCREMENTAL`). On the 408
        simulated scans of :func:`labkit.app.experiments.nguyen_set` at 2 cm of range noise,
        :data:`labkit.noise.AUTO_INCREMENTAL` reports 0.07 false lines instead of the fixed setting's 0.36, and
        finds 0.84 of the walls instead of 0.92.
    segments : ndarray of per-beam labels or list of RangeSegment, optional
        A range segmentation computed elsewhere (e.g. shared by a pipeline, with the beams
        of circles and legs set to -1): lines then never cross a segment boundary nor a
        valid beam labelled -1. Default None: the whole scan, broken only at gaps.
    trace : bool
        Also return the steps taken, as :class:`labkit.Step` records
        (``algorithm="incremental"``), in the order taken. Kinds: ``"reject"`` with
        ``test="max_error_m"`` (a seed that is no line: ``at`` its point farthest from its
        fit, ``value`` that distance; the seed moves on by one beam), ``"seed"`` (a seed
        that is a line, ``value`` its largest residual), ``"grow"`` (the line grown from
        a seed, on the beams ``first..last`` it holds, with the fit it had; ``at`` the point
        that failed the line condition, ``value`` its distance to the line refitted with it,
        ``threshold`` ``max_error_m``; ``at`` -1 when the run ended first), ``"hand_back"``
        (step 6: beam ``at`` moves from the line ending there to the next; ``value`` its
        distance to the next line, ``threshold`` its distance to its own), then one
        ``"accept"`` or ``"reject"`` (``test="min_length_m"``) per line, fitted as returned
        (``beams``: its beams), and with ``place_confidence`` a ``"reject"`` step with
        ``test="place_confidence"`` for every accepted line the data cannot place (``value`` its
        probability). Replay: the ``accept`` steps, less the ``place_confidence`` rejects, are
        the returned lines.

    Returns
    -------
    lines : list of LineSegment
        Sorted by first beam; each fitted by :func:`labkit.features.line_segment` to the
        valid beams it covers (indices ascending), its ends stopped at the rays of its first
        and last beams (step 7). The seam of a full-circle scan is a break: a wall across it
        gives two lines.
    steps : list of labkit.Step
        Only with ``trace=True``.

    Examples
    --------
    A wall at x = 2 m seen from the origin, one beam lost:

    >>> theta = np.radians(np.arange(-40.0, 40.5, 0.5))
    >>> ranges = 2.0 / np.cos(theta)
    >>> ranges[50] = np.nan
    >>> lines = incremental_lines(Scan(ranges=ranges, angles=theta))
    >>> [(round(s.r, 6), round(float(np.degrees(s.alpha)), 6), s.first, s.last, s.n_points) for s in lines]
    [(2.0, 0.0, 0, 160, 160)]
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    max_error_m, sigma = _noise(scan, max_error_m, range_sigma_m, GROW_SIGMAS)  # the numbers for this scan ("auto")
    steps = _Trace("incremental") if trace else None
    beams, runs = _runs(scan, segments, max_gap_m, min_points)
    if not runs:
        return ([], []) if trace else []
    xy = scan.points.take(beams, axis=0)
    w = 1.0 / scan.ranges.take(beams)  # the weights of fit_line_polar: 1 / rho
    sums = _PrefixSums(xy, w)
    # plain Python floats: the growing loop handles one point at a time, where numpy is slow
    xs, ys, ws = xy[:, 0].tolist(), xy[:, 1].tolist(), w.tolist()

    spans: list[list[int]] = []  # every line as [a, b): positions a..b-1 in `beams`
    for a, b in runs:
        run_spans: list[list[int]] = []
        start = a
        while b - start >= min_points:
            # step 1: the seed, the first min_points points; moved on while it is no line
            stop = start + min_points
            s = sums(start, stop)
            r, alpha = line_from_sums(*s)
            c, sn = math.cos(alpha), math.sin(alpha)
            if max(abs(xs[i] * c + ys[i] * sn - r) for i in range(start, stop)) > max_error_m:
                if steps is not None:
                    _seed_step(steps, beams, start, stop, xs, ys, r, alpha, max_error_m, False)
                start += 1
                continue
            if steps is not None:
                _seed_step(steps, beams, start, stop, xs, ys, r, alpha, max_error_m, True)
            # steps 2-4: add the next point, refit, keep it while it lies near the refitted line
            sw, sx, sy, sxx, syy, sxy = s
            while stop < b:
                wi, xi, yi = ws[stop], xs[stop], ys[stop]
                wx, wy = wi * xi, wi * yi
                t = (sw + wi, sx + wx, sy + wy, sxx + wx * xi, syy + wy * yi, sxy + wx * yi)
                r, alpha = line_from_sums(*t)
                if abs(xi * math.cos(alpha) + yi * math.sin(alpha) - r) > max_error_m:
                    break  # step 5: put the point back (its sums t are dropped) and end the line
                sw, sx, sy, sxx, syy, sxy = t
                stop += 1
            if steps is not None:
                _grow_step(steps, beams, start, stop, b, sums, xs, ys, ws, max_error_m)
            run_spans.append([start, stop])
            start = stop  # step 5: the next line starts at the point that failed
        _hand_back_corners(run_spans, sums, xs, ys, min_points, steps, beams)  # step 6
        spans += run_spans

    lines = _fitted(xy, beams, spans, min_length_m, steps, sigma)  # step 7
    lines = placed(lines, place_dr_m, place_dalpha_deg, place_confidence, steps)  # step 8
    return (lines, list(steps)) if steps is not None else lines  # (steps: made when trace is)


def _seed_step(steps: _Trace, beams, start: int, stop: int, xs, ys, r: float, alpha: float, max_error_m: float,
               ok: bool) -> None:
    """The step of a seed, the points ``start..stop-1``: ``seed`` if it is a line, else ``reject``."""
    c, sn = math.cos(alpha), math.sin(alpha)
    d = [abs(xs[i] * c + ys[i] * sn - r) for i in range(start, stop)]
    worst = max(range(len(d)), key=d.__getitem__)
    first, last, at = int(beams[start]), int(beams[stop - 1]), int(beams[start + worst])
    if ok:
        steps.add("seed", first, last, r, alpha, at=at, value=d[worst], threshold=max_error_m, test="max_error_m",
                  reason=f"seed of {stop - start} points: worst {d[worst]:.3f} m <= max_error_m")
    else:
        steps.add("reject", first, last, r, alpha, at=at, value=d[worst], threshold=max_error_m, test="max_error_m",
                  reason=f"seed is no line: beam {at} is {d[worst]:.3f} m off > max_error_m; move on one beam")


def _grow_step(steps: _Trace, beams, start: int, stop: int, end: int, sums, xs, ys, ws, max_error_m: float) -> None:
    """The step of a line grown over the points ``start..stop-1`` of a run ending at ``end``."""
    r, alpha = line_from_sums(*sums(start, stop))
    first, last = int(beams[start]), int(beams[stop - 1])
    if stop == end:
        steps.add("grow", first, last, r, alpha, threshold=max_error_m,
                  reason=f"grown to {stop - start} points, to the end of the run")
        return
    t = [u + v for u, v in zip(sums(start, stop), sums(stop, stop + 1), strict=True)]
    r1, a1 = line_from_sums(*t)  # the line refitted with the point that failed
    d = abs(xs[stop] * math.cos(a1) + ys[stop] * math.sin(a1) - r1)
    at = int(beams[stop])
    steps.add("grow", first, last, r, alpha, at=at, value=d, threshold=max_error_m, test="max_error_m",
              reason=f"grown to {stop - start} points; beam {at} is {d:.3f} m off the refitted line > max_error_m: "
                     f"the line ends")


def _hand_back_corners(spans: list[list[int]], sums, xs, ys, min_points: int, steps: _Trace | None = None,
                       beams=None) -> None:
    """Step 6: where a line ends on the point before the next line starts, move its last
    points to the next line while they are closer to the next line than to their own (at
    least ``min_points`` points stay). Both lines are refitted after every move. ``spans``
    change in place; every move is a ``hand_back`` step in ``steps`` if given."""
    for left, right in zip(spans[:-1], spans[1:], strict=True):
        while left[1] == right[0] and left[1] - left[0] > min_points:
            i = left[1] - 1
            r1, a1 = line_from_sums(*sums(left[0], left[1]))
            r2, a2 = line_from_sums(*sums(right[0], right[1]))
            d1 = abs(xs[i] * math.cos(a1) + ys[i] * math.sin(a1) - r1)
            d2 = abs(xs[i] * math.cos(a2) + ys[i] * math.sin(a2) - r2)
            if d2 >= d1:
                break
            left[1] = right[0] = i
            if steps is not None:
                at = int(beams[i])
                steps.add("hand_back", int(beams[right[0]]), int(beams[right[1] - 1]), r2, a2, at=at, value=d2,
                          threshold=d1, reason=f"corner: beam {at} is {d2:.3f} m from the next line, {d1:.3f} m "
                                               f"from its own: it moves to the next")
