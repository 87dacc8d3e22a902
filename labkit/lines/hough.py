"""Hough transform line extraction: lines as the peaks of a vote count over ``(r, alpha)``.

The algorithm as Nguyen et al. (2007) compare it, after Duda & Hart (1972):

1. Every valid point ``(x, y)`` votes, for each discretised normal direction ``alpha_k``,
   for the cell ``(r, alpha_k)`` with ``r = x cos(alpha_k) + y sin(alpha_k)``: the one line of
   that direction through the point. The votes are counted in an accumulator of
   ``(alpha, r)`` cells.
2. The cell with the most votes (the peak) is the line through the most points. If it has
   fewer than ``min_votes`` votes, stop.
3. The peak cell's line is only as good as the grid, so refine it: fit a line by least
   squares to the points that voted for the peak, take every remaining point within
   ``threshold_m`` of the fitted line, fit again to those, and take the points within
   ``threshold_m`` of that line as the line's inliers.
4. Remove the inliers, subtracting their votes from the accumulator, and go back to 2.

As with RANSAC, a Hough line is an infinite line that may gather collinear points of several
walls, so each line's inliers are cut, in scan order, into runs with no gap wider than
``max_gap_m`` and no beam between neighbours that ends more than ``max_gap_m`` off the line
(as :func:`labkit.lines.ransac.ransac_lines`); every run of ``min_points`` points or more and
at least ``min_length_m`` long becomes one :class:`~labkit.features.LineSegment`, fitted to that run's points alone.

The accumulator uses labkit's normal form: ``x cos(alpha) + y sin(alpha) = r`` with ``r >= 0``
and ``alpha`` in (-pi, pi]. Its directions are the full circle in steps of ``alpha_step_deg``, and
a point votes only where ``r >= 0`` (rounded to the nearest cell), so every line has one cell,
for half the directions. Its distances run from 0 to the farthest point in steps of
``r_step_m``. The votes of all points are counted in one ``np.bincount``; the votes of removed
points are taken away the same way, so the accumulator is built only once.

References
----------
Duda, R. O. & Hart, P. E. (1972). Use of the Hough transformation to detect lines and curves
in pictures. Comm. ACM 15(1), 11-15.

Nguyen, V., Gächter, S., Martinelli, A., Tomatis, N. & Siegwart, R. (2007). A comparison of
line extraction algorithms using 2D range data for indoor mobile robotics. Autonomous Robots
23(2), 97-111.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..features import LineSegment
from ..noise import INLIER_SIGMAS
from ..params import AUTO, checked_by, param
from ..scan import Scan
from ..steps import Step
from ._runs import _fit, _noise, _segments, _taking_part, _Trace
from .placing import PlacingParams, placed

__all__ = ["hough_lines"]

#: Accumulators up to this many cells (32 MB of int64 counts) are dense arrays; beyond, only the
#: cells that got votes are counted (points hundreds of metres away, or very fine steps).
_DENSE_CELLS = 1 << 22

#: Points farther than this many ``r_step_m`` (839 km at 0.05 m) do not vote: the cell numbers
#: must fit in 64 bits.
_MAX_R_CELLS = 1 << 24


@dataclass(frozen=True)
class HoughParams(PlacingParams):
    """Parameters of :func:`hough_lines`.

    The ``[lines.hough]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    r_step_m: float = param(0.05, "accumulator cell size in r, metres", lo=0, strict=True)
    alpha_step_deg: float = param(1.0, "accumulator cell size in alpha, degrees", lo=math.degrees(1e-3), hi=90)
    threshold_m: float = param(AUTO, "a point belongs to a peak's line within this distance, metres; auto: "
                                     "max(2.5 sigma, 2 cm) of the scan's range noise", lo=0, strict=True, auto=True)
    min_votes: int = param(8, "fewest votes of a peak", lo=2)
    min_points: int = param(5, "fewest points of a line segment", lo=2)
    min_length_m: float = param(0.15, "shortest line kept, metres", lo=0)
    max_gap_m: float = param(0.3, "no line across a gap wider than this, nor across a beam ending this far off it, m",
                             lo=0, strict=True)


@checked_by(HoughParams)
def hough_lines(
    scan: Scan,
    *,
    r_step_m: float = HoughParams.r_step_m,
    alpha_step_deg: float = HoughParams.alpha_step_deg,
    threshold_m: float = HoughParams.threshold_m,
    min_votes: int = HoughParams.min_votes,
    min_points: int = HoughParams.min_points,
    min_length_m: float = HoughParams.min_length_m,
    max_gap_m: float = HoughParams.max_gap_m,
    range_sigma_m: float | str | None = HoughParams.range_sigma_m,
    place_dr_m: float = HoughParams.place_dr_m,
    place_dalpha_deg: float = HoughParams.place_dalpha_deg,
    place_confidence: float = HoughParams.place_confidence,
    segments=None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Extract line segments from a scan by the Hough transform.

    Parameters
    ----------
    scan : Scan
        Invalid beams (NaN, inf, 0, out of range) are masked: they do not vote.
    r_step_m : float, metres
        Size of the accumulator's cells in ``r``. Default 0.05 m.
    alpha_step_deg : float, degrees
        Size of the accumulator's cells in ``alpha``, between 0.001 rad (0.057 degrees) and 90
        degrees. Default 1 degree (360 directions). With the 0.05 m step the cells are coarse enough that the
        points of a wall a few metres long, with centimetres of noise, vote mostly for one
        cell or two neighbours, and fine enough that two walls meeting at a corner, or a wall
        and the back of a door recess, fall in different cells; the refinement (step 3) then
        makes the line exact. Over 20 scans each of five simulated worlds, halving both steps
        finds about the same walls at over twice the cost.
        The accumulator holds ``n_alpha x n_r`` counts, ``n_alpha = 360 / alpha_step_deg`` and
        ``n_r = r_max / r_step_m + 2`` for the farthest point ``r_max``: with a 722-beam scan
        reaching 32 m, 360 x 642 = 231,120 counts (1.8 MB as int64), plus the 722 x 360 table
        of the cell each point voted for (2.1 MB as int64), kept to take votes back.
    threshold_m : float, metres
        A point is an inlier of a refined line when it is at most this far from it.
        Default ``"auto"``, as for :func:`labkit.lines.ransac.ransac_lines`; the fixed setting's
        0.03 m (see there why) is 2 sigma
        of the 15 mm noise of cheap sensors, 6 sigma of the LMS200's 5 mm; at 0.05 m, 86 %
        of the simulated corridor's walls are found (99 % at 0.03 m).
        ``"auto"``: ``max(2.5 sigma, 2 cm)`` of the scan's range noise sigma
        (:data:`labkit.noise.INLIER_SIGMAS`, which says why 2.5), worked out per scan; a number
        given is used as it is.
    min_votes : int
        The peak is accepted as a line only with at least this many votes. Default 8, as
        ``min_inliers`` of :func:`labkit.lines.ransac.ransac_lines`: the shortest wall worth a line
        in the simulator's ground truth has 10 beams, and its votes may be shared with a
        neighbouring cell. At 10, 2 % of the simulated office's walls are missed; at 5, 12 %
        of the corridor's lines are false (3 % at 8).
    min_points : int
        Runs of inliers with fewer points make no segment. Default 5, as for
        :func:`labkit.split_and_merge` (Xavier et al., ``line_min_pts``).
    min_length_m : float, metres
        Shorter segments (between the projections of their first and last points) are
        dropped. Default 0.15 m, as for :func:`labkit.split_and_merge`.
    max_gap_m : float, metres
        A segment never spans two neighbouring inliers (in scan order) farther apart than this,
        nor a beam between them that ends more than this in front of or behind the line: the
        inliers of a line are cut there into separate segments. Default 0.3 m, as for
        :func:`labkit.split_and_merge`.
    range_sigma_m : float, "auto" or None
        The range noise of the lines' covariances (and of ``threshold_m="auto"``), as for
        :func:`labkit.lines.ransac.ransac_lines`. Default ``"auto"``; ``None``: each line's own
        residuals.
    place_dr_m, place_dalpha_deg, place_confidence : float
        Report only the lines the data can place, as :func:`labkit.split_and_merge` does (default
        ``place_confidence`` 0.8; 0: every line, as in :data:`labkit.noise.FIXED_HOUGH`). On the 408
        simulated scans of :func:`labkit.app.experiments.nguyen_set` at 2 cm of range noise,
        :data:`labkit.noise.AUTO_HOUGH` reports 0.05 false lines instead of the fixed setting's 0.37, and
        finds 0.85 of the walls instead of 0.90.
    segments : ndarray of per-beam labels or list of RangeSegment, optional
        A range segmentation computed elsewhere (for instance with the beams of circles and
        legs set to -1). Beams labelled -1 then do not vote, and a segment never spans two
        range segments. Default ``None``: every valid beam votes, and only ``max_gap_m`` cuts.
    trace : bool
        Also return the steps taken, as :class:`labkit.Step` records (``algorithm="hough"``),
        in the order taken. Every round gives a ``"peak"`` step (the peak cell's line, at the
        cell's centre; ``value`` its votes, ``threshold`` ``min_votes``, ``beams`` the
        remaining points that voted for it); if it has too few votes, a ``"reject"`` step
        (``test="min_votes"``) ends the search; else a ``"consensus"`` step (the refined
        line, ``beams`` its inliers, taken away with their votes) and, for every run of the
        inliers, ``"accept"`` (a segment, ``beams`` its beams) or ``"reject"`` (``test``
        ``"min_points"`` or ``"min_length_m"``); with ``place_confidence``, a ``"reject"`` step
        with ``test="place_confidence"`` for every accepted segment the data cannot place
        (``value`` its probability). Replay: the ``accept`` steps, sorted by first beam, less
        the ``place_confidence`` rejects, are the returned lines.

    Returns
    -------
    lines : list of LineSegment
        Sorted by first beam; each fitted by :func:`labkit.features.line_segment` to the points
        of its run (beam indices ascending). The seam of a full-circle scan is ignored: a wall
        seen across it gives two segments, one ending at the last beam and one starting at
        beam 0. A scan without valid beams gives ``[]``.
    steps : list of labkit.Step
        Only with ``trace=True``.

    Raises
    ------
    ValueError
        If a parameter is out of range; the message names it.

    Examples
    --------
    Two walls meeting in the corner (2, 1) m, seen from the origin:

    >>> theta = np.radians(np.arange(-30.0, 60.0, 0.5))
    >>> ranges = np.minimum(2.0 / np.cos(theta), 1.0 / np.sin(np.maximum(theta, 1e-9)))
    >>> lines = hough_lines(Scan(ranges=ranges, angles=theta))
    >>> [(round(s.r, 6), round(float(np.degrees(s.alpha)), 6), s.first, s.last) for s in lines]
    [(2.0, 0.0, 0, 113), (1.0, 90.0, 114, 179)]
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    alpha_step = math.radians(alpha_step_deg)
    threshold_m, sigma = _noise(scan, threshold_m, range_sigma_m, INLIER_SIGMAS)  # the numbers for this scan ("auto")

    # the beams that vote: valid ones (given a segmentation, those in a segment) within the accumulator
    steps = _Trace("hough") if trace else None
    labels, beams, xy, rho, w = _taking_part(scan, segments, _MAX_R_CELLS * r_step_m)
    if beams.size < max(min_votes, 2):
        return ([], []) if trace else []

    # step 1: the accumulator. Directions alpha_k = -pi + (k + 1) d_alpha, k = 0..n_alpha-1 (the
    # last one is pi); distances r_j = j r_step_m, j = 0..n_r-1, to beyond the farthest point
    n_alpha = round(2 * math.pi / alpha_step)
    alphas = -math.pi + (2 * math.pi / n_alpha) * np.arange(1, n_alpha + 1)
    n_r = int(rho.max() / r_step_m) + 2
    # every point's vote in every direction: r / r_step_m rounded to the nearest cell, an
    # (M, n_alpha) table of flat cell numbers k n_r + j, or -1 where r < 0 (no vote)
    normals = np.stack([np.cos(alphas), np.sin(alphas)]) / r_step_m
    j = np.rint(xy @ normals)
    cells = j.astype(np.int64)
    cells += np.arange(n_alpha) * n_r
    cells[j < 0] = -1
    voted = cells >= 0
    if n_alpha * n_r <= _DENSE_CELLS:  # the usual case: a count for every cell
        votes = np.bincount(cells[voted], minlength=n_alpha * n_r)
        cell_number = None
    else:  # a point very far away: count only the cells that got votes, renumbered 0, 1, ...
        cell_number, cells[voted] = np.unique(cells[voted], return_inverse=True)
        votes = np.bincount(cells[voted])

    remaining = np.ones(beams.size, dtype=bool)  # not yet taken by a line
    lines: list[LineSegment] = []
    while True:
        # step 2: the peak (the first of equals: deterministic)
        peak = int(np.argmax(votes))
        if votes[peak] < min_votes:
            if steps is not None:
                _peak_steps(steps, peak, cell_number, n_r, alphas, r_step_m, int(votes[peak]), min_votes, None)
            break
        k = (peak if cell_number is None else int(cell_number[peak])) // n_r  # its direction
        voters = np.flatnonzero(remaining & (cells[:, k] == peak))
        if steps is not None:
            _peak_steps(steps, peak, cell_number, n_r, alphas, r_step_m, int(votes[peak]), min_votes, beams[voters])

        # step 3: refine the peak's line by least squares, twice over the points near it
        pool = np.flatnonzero(remaining)
        p = xy[pool]
        inliers = voters
        for _ in range(2):
            r_fit, alpha_fit = _fit(xy[inliers], w[inliers])
            near = pool[np.abs(p @ np.array([math.cos(alpha_fit), math.sin(alpha_fit)]) - r_fit) <= threshold_m]
            if near.size == 0:
                break
            inliers = near

        # step 4: take the inliers away, with their votes. (The voters that are not inliers stay:
        # near a corner they are the other wall's points. There is always an inlier to take, as
        # the voters themselves are kept when no point is near the fitted line.)
        remaining[inliers] = False
        gone = cells[inliers]
        np.subtract.at(votes, gone[gone >= 0], 1)
        if steps is not None:  # the line whose inliers were taken
            taken = beams[inliers]
            steps.add("consensus", taken[0], taken[-1], r_fit, alpha_fit, value=inliers.size, test="threshold_m",
                      beams=tuple(taken.tolist()),
                      reason=f"refined by least squares: {inliers.size} points within threshold_m={threshold_m} m, "
                             f"taken away with their votes")

        # cut the inliers into runs and make a segment of every run long enough
        lines += _segments(xy, beams, labels, inliers, min_points, min_length_m, max_gap_m, steps, sigma)

    lines.sort(key=lambda s: s.first)
    lines = placed(lines, place_dr_m, place_dalpha_deg, place_confidence, steps)
    return (lines, list(steps)) if steps is not None else lines  # (steps: made when trace is)


def _peak_steps(steps: _Trace, peak: int, cell_number, n_r: int, alphas: np.ndarray, r_step_m: float, votes: int,
                min_votes: int, voters: np.ndarray | None) -> None:
    """The step of a peak cell (its line at the cell's centre), and the stop when it has fewer
    than ``min_votes`` votes (``voters`` None)."""
    cell = peak if cell_number is None else int(cell_number[peak])
    r, alpha = (cell % n_r) * r_step_m, float(alphas[cell // n_r])
    where = f"cell r={r:.2f} m, alpha={math.degrees(alpha):.0f} deg"
    if voters is None:
        steps.add("reject", r=r, alpha=alpha, value=votes, threshold=min_votes, test="min_votes",
                  reason=f"the peak, {where}, has {votes} votes < min_votes={min_votes}: no more lines")
        return
    steps.add("peak", voters[0], voters[-1], r, alpha, value=votes, threshold=min_votes, test="min_votes",
              beams=tuple(voters.tolist()), reason=f"the peak: {where}, {votes} votes")
