"""RANSAC line extraction: lines as the largest consensus sets of random two-point hypotheses.

The algorithm as Nguyen et al. (2007) compare it, after Fischler & Bolles (1981):

1. Draw two of the remaining points at random; the line through them is a hypothesis.
2. Count the remaining points within ``threshold_m`` of that line (its consensus set, or
   inliers). Repeat ``max_trials`` times and keep the hypothesis with the most inliers.
3. If it has fewer than ``min_inliers`` inliers, stop. Otherwise refit the line by least
   squares to its inliers, take the points within ``threshold_m`` of the refitted line as
   the line's inliers, and remove them from the remaining points.
4. Go back to 1 until fewer than ``min_inliers`` points remain.

A RANSAC line is an infinite line: its inliers may lie on several walls that happen to be
collinear, or on a wall and a few points of whatever else crosses the line far away. So each
accepted line's inliers are cut, in scan order, into runs with no gap wider than
``max_gap_m`` between neighbouring inliers and no beam between them that ends more than
``max_gap_m`` in front of or behind the line (it saw through the line, or something hid the
stretch: no beam saw the wall there), and every run of ``min_points`` points or more and at
least ``min_length_m`` long becomes one :class:`~labkit.features.LineSegment`, fitted to that
run's points alone.

The draw (step 1) is *local* by default: the second point is one of the ``draw_window``
remaining points on either side of the first, in scan order. Drawn over the whole scan, both
points lie on the same wall with a probability of about ``sum_k (n_k / N)^2`` (walls of
``n_k`` of the ``N`` points), 0.1 in a room seen as ten walls of equal size; drawn locally they
mostly do, so fewer trials suffice. ``draw_window=None`` draws the second point from all
remaining points, as Nguyen et al. do.

Randomness comes only from the ``rng`` passed in (a :class:`numpy.random.Generator`);
without one, a generator with a fixed seed is used, so the same call gives the same lines.

References
----------
Fischler, M. A. & Bolles, R. C. (1981). Random sample consensus: a paradigm for model fitting
with applications to image analysis and automated cartography. Comm. ACM 24(6), 381-395.

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

__all__ = ["ransac_lines"]

#: The seed of the generator used when no ``rng`` is given.
DEFAULT_SEED = 0


@dataclass(frozen=True)
class RansacParams(PlacingParams):
    """Parameters of :func:`ransac_lines`.

    The ``[lines.ransac]`` table of :class:`labkit.Config`, each default once: lengths in metres
    (the random generator is seeded with ``DEFAULT_SEED``; pass ``rng=`` to the function for another)."""

    threshold_m: float = param(AUTO, "a point is an inlier within this distance of the line, metres; auto: "
                                     "max(2.5 sigma, 2 cm) of the scan's range noise", lo=0, strict=True, auto=True)
    min_inliers: int = param(8, "fewest inliers of a line", lo=2)
    max_trials: int = param(50, "random pairs drawn per line", lo=1)
    draw_window: int = param(20, "the second point of a pair is drawn within this many beams of the first "
                                 "(none: anywhere)", lo=1, optional=True)
    min_points: int = param(5, "fewest points of a line segment", lo=2)
    min_length_m: float = param(0.15, "shortest line kept, metres", lo=0)
    max_gap_m: float = param(0.3, "no line across a gap wider than this, nor across a beam ending this far off it, m",
                             lo=0, strict=True)


@checked_by(RansacParams)
def ransac_lines(
    scan: Scan,
    *,
    threshold_m: float | str = RansacParams.threshold_m,
    min_inliers: int = RansacParams.min_inliers,
    max_trials: int = RansacParams.max_trials,
    draw_window: int | None = RansacParams.draw_window,
    min_points: int = RansacParams.min_points,
    min_length_m: float = RansacParams.min_length_m,
    max_gap_m: float = RansacParams.max_gap_m,
    range_sigma_m: float | str | None = RansacParams.range_sigma_m,
    place_dr_m: float = RansacParams.place_dr_m,
    place_dalpha_deg: float = RansacParams.place_dalpha_deg,
    place_confidence: float = RansacParams.place_confidence,
    segments=None,
    rng: np.random.Generator | None = None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Extract line segments from a scan by RANSAC (random sample consensus).

    Parameters
    ----------
    scan : Scan
        Invalid beams (NaN, inf, 0, out of range) are masked: they take no part.
    threshold_m : float, metres
        A point is an inlier of a line when it is at most this far from it. Default
        ``"auto"`` (below); the fixed setting's 0.03 m (:data:`labkit.noise.FIXED_RANSAC`) is
        2 sigma of the 15 mm range noise of cheap sensors (XV-11), 6 sigma of the LMS200's 5 mm.
        A wider band lets a line take the first points of the next wall past a corner,
        which tilts short walls such as the backs of door recesses: at 0.05 m, 85 % of the
        simulated corridor's walls are found (98 % at 0.03 m). A narrower band leaves noisy
        points out of their wall's line: at 0.02 m the lines of the simulated XV-11 office hold
        87 % of its wall points (96 % at 0.03 m). Measured over 20 scans, seed 0.
        ``"auto"``: ``max(2.5 sigma, 2 cm)`` of the scan's range noise sigma
        (:data:`labkit.noise.INLIER_SIGMAS`, which says why 2.5), worked out per scan; a number
        given is used as it is.
    min_inliers : int
        The best hypothesis is accepted as a line only with at least this many inliers, and
        the search stops when fewer points remain. Default 8: the shortest wall worth a line
        in the simulator's ground truth has 10 beams, and may lose a point at each end to
        its neighbours; at 10, 4 % of the walls of ``random_polygons_2`` are missed.
    max_trials : int
        Hypotheses drawn for each line. Default 50: with the local draw, 25 to 200 trials find
        the same walls to within one in a hundred (20 scans each of five simulated worlds),
        while a 722-beam office scan takes 2.9 ms at 25 or 50 trials, 3.9 ms at 100 and
        4.9 ms at 200.
    draw_window : int or None
        The second point of a hypothesis is drawn among the ``draw_window`` remaining points
        on either side of the first (in scan order): a local draw, so that both points are
        usually on one wall. Default 20 points, 10 degrees at a 0.5 degree step: far enough
        apart that range noise barely tilts the hypothesis, close enough to stay on one wall
        of a room. ``None`` draws it from all remaining points (as Nguyen et al. do), which
        needs more trials: with 5 trials a line, the local draw finds 91 % of the simulated
        office's walls, the global one 56 % (``tests/test_ransac.py``).
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
        The range noise of the lines' covariances, hence of the placing below. Default
        ``"auto"``: the scan's estimate (:func:`labkit.noise.scan_sigma`); ``None``: each line's
        covariance is worked out from its own residuals (:func:`labkit.features.line_segment`); a
        number: that noise. With ``threshold_m="auto"`` it is
        also the noise the threshold follows (the scan's estimate when ``None``).
    place_dr_m, place_dalpha_deg, place_confidence : float
        What a user trusts, as in :func:`labkit.split_and_merge`: a line is reported only if, by its
        covariance, it lies within ``place_dr_m`` (default 5 cm) in ``r`` and ``place_dalpha_deg``
        (default 3 degrees) in ``alpha`` of the true line with
        probability ``place_confidence`` (default 0.8; 0: every line is reported, as in
        :data:`labkit.noise.FIXED_RANSAC`): :func:`labkit.fitting.placement_probability`. A short
        piece whose angle the data cannot fix to a few degrees is dropped (a ``"reject"`` step
        with ``test="place_confidence"``). On the 408 simulated scans of
        :func:`labkit.app.experiments.nguyen_set` at 2 cm of range noise, :data:`labkit.noise.AUTO_RANSAC`
        reports 0.06 false lines instead of the fixed setting's 0.41, and finds 0.84 of the
        walls instead of 0.91.
    segments : ndarray of per-beam labels or list of RangeSegment, optional
        A range segmentation computed elsewhere (for instance with the beams of circles and
        legs set to -1). Beams labelled -1 then take no part, and a segment never spans two
        range segments. Default ``None``: every valid beam takes part, and only ``max_gap_m``
        cuts.
    rng : numpy.random.Generator, optional
        The source of every random draw. Default ``None``: ``np.random.default_rng(0)``, so
        the same call always gives the same lines; pass your own generator to draw anew.
    trace : bool
        Also return the steps taken, as :class:`labkit.Step` records (``algorithm="ransac"``),
        in the order taken; the draws are the same, so are the lines. Every round gives a
        ``"hypothesis"`` step (the best of the round's ``max_trials`` hypotheses: the line
        through the two beams in ``beams``, ``at`` the first drawn; ``value`` its inliers,
        ``threshold`` ``min_inliers``); if it has too few, a ``"reject"`` step
        (``test="min_inliers"``) ends the search; else a ``"consensus"`` step (the refitted
        line, ``beams`` its consensus set, the inliers taken away) and, for every run of the
        consensus set, ``"accept"`` (a segment, ``beams`` its beams) or ``"reject"``
        (``test`` ``"min_points"`` or ``"min_length_m"``); with ``place_confidence``, a
        ``"reject"`` step with ``test="place_confidence"`` for every accepted segment the data
        cannot place (``value`` its probability). Replay: the ``accept`` steps, sorted by first
        beam, less the ``place_confidence`` rejects, are the returned lines.

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
        If a parameter is out of range (the message names it) or ``rng`` is not a
        :class:`numpy.random.Generator`.

    Notes
    -----
    Each round scores all ``max_trials`` hypotheses at once against the remaining points (an
    ``(n, max_trials)`` array of distances), so a round costs ``O(n max_trials)`` and the whole
    extraction ``O(n max_trials L)`` for ``L`` lines. Points removed with a line never come
    back, even those of runs too short to become a segment (as in Nguyen et al.).

    Examples
    --------
    Two walls meeting in the corner (2, 1) m, seen from the origin:

    >>> theta = np.radians(np.arange(-30.0, 60.0, 0.5))
    >>> ranges = np.minimum(2.0 / np.cos(theta), 1.0 / np.sin(np.maximum(theta, 1e-9)))
    >>> lines = ransac_lines(Scan(ranges=ranges, angles=theta))
    >>> [(round(s.r, 6), round(float(np.degrees(s.alpha)), 6), s.first, s.last) for s in lines]
    [(2.0, 0.0, 0, 113), (1.0, 90.0, 114, 179)]
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    if rng is None:
        rng = np.random.default_rng(DEFAULT_SEED)
    elif not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), "
                         f"got {type(rng).__name__}")

    threshold_m, sigma = _noise(scan, threshold_m, range_sigma_m, INLIER_SIGMAS)  # the numbers for this scan ("auto")
    steps = _Trace("ransac") if trace else None
    labels, beams, xy, rho, w = _taking_part(scan, segments)
    if beams.size < max(min_inliers, 2):
        return ([], []) if trace else []
    remaining = np.ones(beams.size, dtype=bool)  # not yet taken by a line
    lines: list[LineSegment] = []

    while True:
        pool = np.flatnonzero(remaining)  # positions of the remaining points, in scan order
        n = pool.size
        if n < min_inliers:  # step 4: too few points left for another line
            break
        p = xy[pool]

        # step 1: max_trials hypotheses, each the line through two of the remaining points
        first = rng.integers(0, n, size=max_trials)
        if draw_window is None:  # anywhere else among the remaining points
            second = (first + rng.integers(1, n, size=max_trials)) % n
        else:  # one of the draw_window neighbours on either side (wrapping at the ends of the pool)
            reach = min(draw_window, n - 1)
            step = rng.integers(1, reach + 1, size=max_trials) * rng.choice(np.array([-1, 1]), size=max_trials)
            second = (first + step) % n
        a, b = p[first], p[second]
        normal = np.stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]], axis=1)  # (b - a) turned by -90 deg
        length = np.hypot(normal[:, 0], normal[:, 1])
        usable = length > 0  # two identical points define no line
        normal[usable] /= length[usable, None]
        offset = np.einsum("ij,ij->i", normal, a)  # x cos(alpha) + y sin(alpha) = offset (any sign)

        # step 2: the consensus of every hypothesis at once, an (n, max_trials) table of distances
        distance = p @ normal.T
        distance -= offset
        votes = np.count_nonzero(np.abs(distance) <= threshold_m, axis=0)
        votes[~usable] = 0
        best = int(np.argmax(votes))  # the first of equals: deterministic
        if steps is not None:
            _hypothesis_steps(steps, beams[pool[[first[best], second[best]]]], normal[best], offset[best],
                              int(votes[best]), min_inliers, max_trials)
        if votes[best] < min_inliers:  # step 3: no hypothesis good enough, stop
            break
        inliers = pool[np.abs(distance[:, best]) <= threshold_m]

        # step 3: refit by weighted least squares, and take the refitted line's consensus set
        r, alpha = _fit(xy[inliers], w[inliers])
        refined = pool[np.abs(p @ np.array([math.cos(alpha), math.sin(alpha)]) - r) <= threshold_m]
        if refined.size >= min_inliers:
            inliers = refined
        remaining[inliers] = False
        if steps is not None:  # the refitted line, whose consensus set is taken
            taken = beams[inliers]
            steps.add("consensus", taken[0], taken[-1], r, alpha, value=inliers.size, threshold=min_inliers,
                      test="threshold_m", beams=tuple(taken.tolist()),
                      reason=f"refitted to its inliers: {inliers.size} points within threshold_m={threshold_m} m, "
                             f"taken away")

        # cut the inliers into runs and make a segment of every run long enough
        lines += _segments(xy, beams, labels, inliers, min_points, min_length_m, max_gap_m, steps, sigma)

    lines.sort(key=lambda s: s.first)
    lines = placed(lines, place_dr_m, place_dalpha_deg, place_confidence, steps)
    return (lines, list(steps)) if steps is not None else lines  # (steps: made when trace is)


def _hypothesis_steps(steps: _Trace, pair: np.ndarray, normal: np.ndarray, offset: float, votes: int,
                      min_inliers: int, max_trials: int) -> None:
    """The best hypothesis of a round (the line through the beams ``pair``), and the stop if
    it has fewer than ``min_inliers`` inliers."""
    if normal[0] == 0.0 and normal[1] == 0.0:  # every draw was two identical points
        r = alpha = math.nan
    else:
        if offset < 0:  # labkit's normal form: r >= 0
            normal, offset = -normal, -offset
        r, alpha = float(offset), math.atan2(normal[1], normal[0])
    a, b = (int(k) for k in pair)
    steps.add("hypothesis", min(a, b), max(a, b), r, alpha, at=a, value=votes, threshold=min_inliers,
              test="min_inliers", beams=(a, b),
              reason=f"best of {max_trials} hypotheses: the line through beams {a} and {b}, {votes} inliers")
    if votes < min_inliers:
        steps.add("reject", min(a, b), max(a, b), r, alpha, at=a, value=votes, threshold=min_inliers,
                  test="min_inliers", beams=(a, b),
                  reason=f"{votes} inliers < min_inliers={min_inliers}: no more lines")
