"""Lines by inscribed angle variance (Xavier et al. 2005, Sec. II-B.1): a whole range
segment is a line when its signed inscribed angles are all near 180 deg.

The inscribed angles and their conventions are those of :mod:`labkit.iav`. Read
:func:`_test_segment` for the tests in the paper's order (enough points, the distance between
the extremes, the angles' mean near 180 deg and their spread); ``trace=True`` runs it segment
by segment, and without it :func:`detect_lines_iav` runs the batch engine
(:mod:`labkit._iav_batch`), which gives the same lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._iav_batch import (
    DEGENERATE,
    FEW,
    MEAN,
    SHORT,
    STD,
    LineTest,
    Runs,
    Seen,
    check_scan,
    line_engine,
    line_limits,
    scan_runs,
)
from ..features import LineSegment, line_segment
from ..iav import CIRCLE_STD_MAX, IAVStats, inscribed_angles
from ..params import Params, checked_by, param
from ..scan import Scan
from ..segmentation import RangeSegment, detector_labels
from ..steps import Step

__all__ = ["IAVLineParams", "detect_lines_iav"]


@dataclass(frozen=True)
class IAVLineParams(Params):
    """Parameters of :func:`detect_lines_iav`.

    The ``[lines.iav]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees
    (``std_max_deg``: Table II's 0.15 rad)."""

    min_points: int = param(5, "fewest points of a line (line_min_pts)", lo=3)
    min_length_m: float = param(0.15, "shortest line, metres (line_min_len)", lo=0)
    mean_tolerance_deg: float = param(5.0, "largest |IAV mean - 180|, degrees", lo=0, strict=True)
    std_max_deg: float = param(math.degrees(CIRCLE_STD_MAX), "largest IAV standard deviation, degrees", lo=0,
                               strict=True)


@checked_by(IAVLineParams)
def detect_lines_iav(
    scan: Scan,
    *,
    seg_threshold_m: float | None = None,
    min_points: int = IAVLineParams.min_points,
    min_length_m: float = IAVLineParams.min_length_m,
    mean_tolerance_deg: float = IAVLineParams.mean_tolerance_deg,
    std_max_deg: float = IAVLineParams.std_max_deg,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Lines as range segments whose inscribed angles are all near 180 deg (Sec. II-B.1).

    A whole segment is a line when it has at least ``min_points`` points (Table II
    ``line_min_pts``: 5), its extremes are at least ``min_length_m`` apart
    (``line_min_len``: 150 mm), and its signed inscribed angles have a mean within
    ``mean_tolerance_deg`` of 180 degrees and a standard deviation below ``std_max_deg`` (the
    circles' 0.15 rad: "the same procedure of circles"). The paper gives no tolerance for the
    mean; 5 deg is ours: a circular arc has mean ``180 - phi / 2`` for an arc of ``phi``,
    so 5 deg keeps arcs spanning more than 10 deg out. Unlike split-and-merge, a segment
    is accepted or rejected as a whole, never split. Each accepted segment is fitted by
    :func:`labkit.features.line_segment`.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    seg_threshold_m : float or None, metres
        A fixed range segmentation threshold (Table II ``seg_threshold``, 80 mm). Default None:
        the default segmentation (:func:`labkit.segment_labels`, adaptive with an 80 mm floor),
        as in the pipeline. Ignored when ``segments`` is given.
    min_points : int
        Table II ``line_min_pts``: 5.
    min_length_m : float, metres
        Table II ``line_min_len``: 150 mm between the segment's extremes.
    mean_tolerance_deg : float, degrees
        Largest distance of the mean inscribed angle from 180 degrees: 5 (ours).
    std_max_deg : float, degrees
        0.15 rad (8.6 degrees), as for circles.
    segments : list of RangeSegment or ndarray of per-beam labels, optional
        Precomputed segments.
    trace : bool
        Run the reference, segment by segment, and also return one :class:`labkit.Step` per
        segment (``algorithm="iav_lines"``), as
        :func:`labkit.detect_circles` does; an ``"accept"`` step carries the line ``r, alpha``,
        and the ``"iav mean"`` test compares ``value = |mean - pi|`` (radians) with ``mean_tolerance_deg`` in radians.

    Returns
    -------
    lines : list of LineSegment
        The lines found, in scan order.
    steps : list of Step
        Only with ``trace=True``, which returns ``(lines, steps)``.

    Examples
    --------
    >>> from labkit import sim
    >>> world = sim.World("demo", walls=(sim.Wall((2.0, -1.0), (2.0, 1.0)),))
    >>> scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> (line,) = detect_lines_iav(scan)
    >>> round(line.r, 6), abs(line.alpha) < 1e-6, line.n_points
    (2.0, True, 107)
    """
    check_scan(scan)
    test = LineTest(min_points=min_points, min_length_m=min_length_m, mean_tolerance=math.radians(mean_tolerance_deg),
                    std_max=math.radians(std_max_deg))
    if segments is None and seg_threshold_m is None:
        segments = detector_labels(scan, None)
    runs = scan_runs(scan, segments, seg_threshold_m)
    if not trace:  # the engine: every segment at once, the same lines
        return line_engine(runs, test)[0]
    return _reference(runs, test)


def _reference(runs: Runs, t: LineTest) -> tuple[list[LineSegment], list[Step]]:
    """The line test of Xavier et al. on each segment in turn, and what each test saw."""
    lines, steps = [], []
    limits = line_limits(t)
    for beams, points in runs.segments():
        seen = Seen(len(points))
        line = _test_segment(points, beams, t, seen)
        if line is not None:
            lines.append(line)
        steps.append(seen.step("iav_lines", beams, limits, line))
    return lines, steps


def _test_segment(points: np.ndarray, beams: np.ndarray, t: LineTest, seen: Seen) -> LineSegment | None:
    """The line of one segment, or None; ``seen`` records what the tests saw and the first that
    failed."""
    # Table II line_min_pts: enough points
    if len(points) < t.min_points:
        seen.reject(FEW)
        return None
    # Table II line_min_len: the distance between the extremes
    dx, dy = points[-1] - points[0]
    seen.chord = float(np.hypot(dx, dy))
    if seen.chord < t.min_length_m:
        seen.reject(SHORT)
        return None
    # Sec. II-B.1: "the same procedure of circles", around 180 deg
    try:
        angles = inscribed_angles(points, signed=True)
    except ValueError:  # a point not finite, or an interior point on an extreme
        seen.reject(DEGENERATE)
        return None
    seen.mean, seen.std, _ = IAVStats.from_angles(angles)
    if abs(seen.mean - math.pi) > t.mean_tolerance:
        seen.reject(MEAN)
        return None
    if seen.std >= t.std_max:
        seen.reject(STD)
        return None
    return line_segment(points, beams)
