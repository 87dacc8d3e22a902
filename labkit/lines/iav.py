"""Lines by inscribed angle variance (Xavier et al. 2005, Sec. II-B): a whole range
segment is a line when its signed inscribed angles are all near 180 deg.

The inscribed angles and their conventions are those of :mod:`labkit.circles.iav`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._iav import (
    _ACCEPTED,
    _DEGENERATE,
    _FEW,
    _MEAN,
    _SHORT,
    _STD,
    CIRCLE_STD_MAX,
    _batch_angles,
    _check_scan,
    _geometry,
    _scan_runs,
    _trace,
)
from ..features import LineSegment, line_segment
from ..params import Params, checked_by, param
from ..scan import Scan
from ..segmentation import RangeSegment, detector_labels
from ..steps import Step

__all__ = ["detect_lines_iav"]


@dataclass(frozen=True)
class IAVLineParams(Params):
    """Parameters of :func:`detect_lines_iav` and the ``[lines.iav]`` table of
    :class:`labkit.Config`, each default once: lengths in metres, angles in degrees
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
        Also return one :class:`labkit.Step` per segment (``algorithm="iav_lines"``), as
        :func:`labkit.detect_circles` does; an ``"accept"`` step carries the line ``r, alpha``,
        and the ``"iav mean"`` test compares ``value = |mean - pi|`` (radians) with ``mean_tolerance_deg`` in radians.

    Returns
    -------
    list of LineSegment in scan order; with ``trace``, ``(lines, steps)``.

    Examples
    --------
    >>> from labkit import sim
    >>> world = sim.World("demo", walls=(sim.Wall((2.0, -1.0), (2.0, 1.0)),))
    >>> scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> (line,) = detect_lines_iav(scan)
    >>> round(line.r, 6), abs(line.alpha) < 1e-6, line.n_points
    (2.0, True, 107)
    """
    _check_scan(scan)
    mean_tolerance, std_max = math.radians(mean_tolerance_deg), math.radians(std_max_deg)
    if segments is None and seg_threshold_m is None:
        segments = detector_labels(scan, None)
    runs = _scan_runs(scan, segments, seg_threshold_m)
    s = runs.starts.size
    if s == 0:
        return ([], []) if trace else []
    geo = _geometry(runs)
    verdict = np.full(s, _ACCEPTED, dtype=np.int64)
    if geo.finite is not None:
        verdict[~geo.finite] = _DEGENERATE
    verdict[geo.chord < min_length_m] = _SHORT
    verdict[geo.n < min_points] = _FEW
    sel = np.flatnonzero(verdict == _ACCEPTED)
    lines: list[LineSegment] = []
    ang = None
    if sel.size:
        ang = _batch_angles(runs, sel)
        verdict[sel[np.abs(ang.mean - math.pi) > mean_tolerance]] = _MEAN
        verdict[sel[(verdict[sel] == _ACCEPTED) & (ang.std >= std_max)]] = _STD
        verdict[sel[ang.degenerate]] = _DEGENERATE
        for k in sel[verdict[sel] == _ACCEPTED]:
            a, b = runs.starts[k], runs.ends[k]
            lines.append(line_segment(runs.pts[a:b], runs.idx[a:b]))
    if not trace:
        return lines
    limits = {_FEW: min_points, _SHORT: min_length_m, _MEAN: mean_tolerance, _STD: std_max, _ACCEPTED: std_max,
              "mean_from": math.pi}  # the mean test compares |mean - pi| with the tolerance
    return lines, _trace(runs, geo, geo.chord, np.full(s, np.nan), verdict, sel, ang, "iav_lines", limits, lines)
