"""Range segmentation: split a scan into runs of neighbouring beams.

Consecutive beams ``i`` and ``i + 1`` belong to the same segment while both are valid and
their points are closer than a threshold (Xavier et al. 2005, Sec. II-A: 80 mm). An
invalid beam always ends a segment. Segments with fewer than ``min_points`` points are
rejected (label -1); with the default of 2 that rejects isolated points, as the paper
does. On a full-circle scan the last and first beams are neighbours, so a segment may
cross the seam; its beam indices then wrap (``first > last``).

With ``adaptive=True`` the threshold grows with range and angular step, as in the
adaptive breakpoint detector of Borges & Aldon (2004): two neighbouring beams at range ``r``
and angular step ``dphi`` are still linked when their points are closer than

    D_max = r sin(dphi) / sin(lambda - dphi) + 3 sigma_r

the gap that a wall seen at the grazing incidence ``lambda`` would leave, plus three
standard deviations of range noise. ``r`` is the smaller of the two ranges. The fixed
``threshold_m`` stays a floor, so near the sensor nothing changes; far away (or at a coarse
angular step) a wall is no longer shattered into isolated points.

Labels follow the scikit-learn convention: an int per beam, -1 for "no segment".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._jit import ENABLED as _JIT
from .noise import RANGE_SIGMA_M, scan_sigma
from .params import AUTO, Params, checked_by, param
from .scan import Scan


def _engine_labels(*args):
    """labkit._segmentation_engine.labels, imported on the first scan (numba's import alone costs
    some 0.35 s of CPU, which a process that extracts nothing should not pay); it then takes this name."""
    global _engine_labels
    from ._segmentation_engine import labels

    _engine_labels = labels
    return labels(*args)

__all__ = ["SegmentationParams", "RANGE_SIGMA_M", "RangeSegment", "segment_labels",
           "range_segments", "breakpoint_thresholds", "segment_order",
           "segments_from_labels", "labels_from", "detector_labels"]


@dataclass(frozen=True)
class SegmentationParams(Params):
    """Parameters of :func:`segment_labels`.

    The ``[segmentation]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees.

    The default is the adaptive detector with Xavier et al.'s 80 mm as its floor, the
    segmentation every detector uses when given no ``segments`` and the pipeline's
    (``adaptive=False`` gives the fixed threshold of the paper)."""

    threshold_m: float = param(0.08, "largest gap between neighbouring points of a segment, metres (Xavier et al. "
                                     "seg_threshold); the floor of the adaptive threshold", lo=0, strict=True)
    adaptive: bool = param(True, "grow the threshold with range and angular step (Borges & Aldon)")
    incidence_deg: float = param(10.0, "grazing angle lambda of the adaptive threshold, degrees",
                                 lo=0, strict=True, hi=89.9)
    range_sigma_m: float = param(AUTO, "range noise of the sensor, metres (adaptive threshold); auto: "
                                       "estimated from each scan (labkit.noise)", lo=0, auto=True)
    min_points: int = param(2, "smallest segment kept; isolated points are dropped", lo=1)


@dataclass(frozen=True, eq=False)
class RangeSegment:
    """A run of neighbouring beams.

    Parameters
    ----------
    indices : ndarray of shape (M,), int
        Beam indices in scan order (wrapping past N - 1 to 0 for a seam-crossing segment).
    points : ndarray of shape (M, 2), metres
        The points of those beams, sensor frame.
    """

    indices: np.ndarray
    points: np.ndarray

    @property
    def first(self) -> int:
        return int(self.indices[0])

    @property
    def last(self) -> int:
        return int(self.indices[-1])

    @property
    def n_points(self) -> int:
        return int(self.indices.size)

    def __len__(self) -> int:
        return self.n_points

    def __repr__(self) -> str:
        return f"RangeSegment(beams {self.first}..{self.last}, {self.n_points} points)"


def breakpoint_thresholds(
    r_a: np.ndarray,
    r_b: np.ndarray,
    dphi: np.ndarray,
    threshold_m: float = SegmentationParams.threshold_m,
    *,
    incidence_deg: float = SegmentationParams.incidence_deg,
    range_sigma_m: float = RANGE_SIGMA_M,
) -> np.ndarray:
    """Adaptive breakpoint distance (Borges & Aldon 2004) between neighbouring beams.

    Two beams of ranges :math:`r_a, r_b` that are :math:`\\Delta\\phi` apart belong to one segment
    when their points are closer than

    .. math::

        D = \\min(r_a, r_b) \\frac{\\sin \\Delta\\phi}{\\sin(\\lambda - \\Delta\\phi)} + 3 \\sigma_r,

    the gap a wall seen at the grazing angle :math:`\\lambda` would leave, plus three times the range
    noise; :math:`D` is floored at ``threshold_m``.

    Parameters
    ----------
    r_a, r_b : ndarray of shape (N,)
        Ranges of the two beams of each pair, metres.
    dphi : ndarray of shape (N,)
        Angle between the two beams of each pair, radians (its absolute value is used).
    threshold_m : float, default 0.08
        The floor of the distance, metres.
    incidence_deg : float, default 10.0
        The grazing angle :math:`\\lambda`, degrees in (0, 90).
    range_sigma_m : float, default 0.01
        The range noise :math:`\\sigma_r` of the sensor, metres.

    Returns
    -------
    ndarray of shape (N,)
        The breakpoint distance of each pair, metres (NaN where a range is NaN).

    Raises
    ------
    ValueError
        For ``incidence_deg`` outside (0, 90) or a negative or infinite ``range_sigma_m``.

    References
    ----------
    G. A. Borges and M.-J. Aldon, "Line extraction in 2D range images for mobile robotics",
    Journal of Intelligent and Robotic Systems 40 (2004).

    Examples
    --------
    >>> t = breakpoint_thresholds(np.array([1.0, 10.0]), np.array([1.0, 10.0]), np.radians([0.5, 0.5]))
    >>> np.round(t, 3).tolist()
    [0.083, 0.559]
    """
    _check_adaptive(incidence_deg, range_sigma_m)
    return _thresholds(r_a, r_b, np.abs(np.asarray(dphi, dtype=float)), threshold_m, incidence_deg, range_sigma_m)


def _check_adaptive(incidence_deg: float, range_sigma_m: float) -> None:
    if not (0 < incidence_deg < 90):
        raise ValueError(f"incidence_deg must be in (0, 90) degrees, got {incidence_deg}")
    if not (np.isfinite(range_sigma_m) and range_sigma_m >= 0):
        raise ValueError(f"range_sigma_m must be a finite number >= 0, got {range_sigma_m}")


def _thresholds(r_a, r_b, dphi: np.ndarray, threshold_m: float, incidence_deg: float,
                range_sigma_m: float) -> np.ndarray:
    """:func:`breakpoint_thresholds` without the checks, for ``dphi >= 0``."""
    lam = math.radians(incidence_deg)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.fmin(r_a, r_b) * np.sin(dphi) / np.sin(np.maximum(lam - dphi, 1e-9)) + 3.0 * range_sigma_m
    return np.fmax(d, threshold_m)


@checked_by(SegmentationParams, positional=("threshold_m",))
def segment_labels(
    scan: Scan,
    *,
    threshold_m: float = SegmentationParams.threshold_m,
    min_points: int = SegmentationParams.min_points,
    adaptive: bool = SegmentationParams.adaptive,
    incidence_deg: float = SegmentationParams.incidence_deg,
    range_sigma_m: float | str = SegmentationParams.range_sigma_m,
) -> np.ndarray:
    """Label each beam with its range segment.

    Parameters
    ----------
    scan : Scan
        Invalid beams are masked: they belong to no segment and end the one before them.
    threshold_m : float, metres
        Largest distance between neighbouring points of one segment. Default 0.08 m
        (Xavier et al. 2005, Table II ``seg_threshold``).
    min_points : int
        Smallest segment kept. Default 2 (isolated points are rejected).
    adaptive : bool
        Grow the threshold with range and angular step (see :func:`breakpoint_thresholds`);
        ``threshold_m`` is then the floor. Default True, as in the pipeline (the function alone
        used to default to False: pass ``adaptive=False`` for the paper's fixed threshold).
    incidence_deg, range_sigma_m : float
        The adaptive detector's grazing angle ``lambda`` (default 10 deg) and range noise
        (default ``"auto"``: estimated from the scan, :func:`labkit.noise.scan_sigma`; the
        fixed settings' 0.01 m before).

    Returns
    -------
    labels : ndarray of shape (N,), int
        Segment number per beam, 0, 1, ... in scan order; -1 for invalid beams and beams
        of rejected segments.

    Examples
    --------
    >>> s = Scan(ranges=[1.0, 1.0, 1.0, 3.0, 3.0, np.nan, 2.0], angles=np.radians(np.arange(7)))
    >>> segment_labels(s).tolist()
    [0, 0, 0, 1, 1, -1, -1]
    >>> segment_labels(s, adaptive=False).tolist()
    [0, 0, 0, 1, 1, -1, -1]
    """
    if adaptive and range_sigma_m == AUTO:
        range_sigma_m = scan_sigma(scan)
    if not _JIT:
        return _segment_labels_reference(scan, threshold_m, min_points, adaptive, incidence_deg, range_sigma_m)
    # one compiled pass over the beams (labkit._segmentation_engine), the labels of
    # _segment_labels_reference below bit for bit
    return _engine_labels(scan.points, scan.ranges, scan.angles, scan.valid, float(threshold_m), int(min_points),
                          bool(adaptive), math.radians(incidence_deg), float(range_sigma_m) if adaptive else 0.0,
                          scan.is_full_circle, scan.angle_increment)


def _segment_labels_reference(scan: Scan, threshold_m: float, min_points: int, adaptive: bool, incidence_deg: float,
                              range_sigma_m) -> np.ndarray:
    """:func:`segment_labels` in numpy, as the paper reads: link neighbouring beams closer than the
    threshold, start a segment at every valid beam not linked to the one before, join the runs
    either side of the seam of a full circle, drop the segments with too few points."""
    n = scan.n_beams
    if n == 0:
        return np.full(n, -1, dtype=np.int64)
    valid = scan.valid
    if not valid.any():
        return np.full(n, -1, dtype=np.int64)
    pts = scan.points
    ranges, angles = scan.ranges, scan.angles
    x, y = pts[:, 0], pts[:, 1]
    with np.errstate(invalid="ignore"):
        gap = np.hypot(x[1:] - x[:-1], y[1:] - y[:-1])  # NaN where either beam is invalid
        linked = gap < threshold_m  # (N - 1,)
        if adaptive:  # the adaptive threshold is never below threshold_m: only wider gaps need it
            k = (gap >= threshold_m).nonzero()[0]
            if k.size:
                if range_sigma_m == AUTO:
                    range_sigma_m = scan_sigma(scan)
                linked[k] = gap[k] < _thresholds(ranges[k], ranges[k + 1], np.abs(angles[k + 1] - angles[k]),
                                                 threshold_m, incidence_deg, range_sigma_m)
    # a new segment starts at every valid beam not linked to its predecessor
    starts = valid.copy()
    starts[1:] &= ~linked
    raw = starts.cumsum() - 1  # the segment of every valid beam (invalid beams: meaningless)
    if n > 2 and valid[0] and valid[-1] and raw[-1] != raw[0] and scan.is_full_circle:
        seam_limit = threshold_m
        if adaptive:
            if range_sigma_m == AUTO:
                range_sigma_m = scan_sigma(scan)
            seam_limit = float(_thresholds(ranges[-1:], ranges[:1], np.abs([scan.angle_increment]), threshold_m,
                                           incidence_deg, range_sigma_m)[0])
        with np.errstate(invalid="ignore"):
            d = pts[0] - pts[-1]
            if np.hypot(d[0], d[1]) < seam_limit:
                raw[raw == raw[-1]] = raw[0]  # the run before the seam continues the first run
    sizes = np.bincount(raw[valid])
    keep = sizes >= min_points
    new_id = np.where(keep, keep.cumsum() - 1, -1)  # per segment: its label, -1 if rejected
    return np.where(valid, new_id[raw], -1)


@checked_by(SegmentationParams, positional=("threshold_m",))
def range_segments(
    scan: Scan,
    *,
    threshold_m: float = SegmentationParams.threshold_m,
    min_points: int = SegmentationParams.min_points,
    adaptive: bool = SegmentationParams.adaptive,
    incidence_deg: float = SegmentationParams.incidence_deg,
    range_sigma_m: float | str = SegmentationParams.range_sigma_m,
) -> list[RangeSegment]:
    """The segments of :func:`segment_labels` as :class:`RangeSegment` records, in scan order.

    A seam-crossing segment is listed first and its indices run N-k..N-1, 0..m.

    Parameters
    ----------
    scan : Scan
        The scan to segment.
    threshold_m : float, default 0.08
        Largest gap between neighbouring points of a segment, metres (the floor of the adaptive threshold).
    min_points : int, default 2
        Smallest segment kept.
    adaptive : bool, default True
        Grow the threshold with range and angular step (:func:`breakpoint_thresholds`).
    incidence_deg : float, default 10.0
        Grazing angle of the adaptive threshold, degrees.
    range_sigma_m : float or "auto", default "auto"
        Range noise of the sensor, metres; ``"auto"`` estimates it from the scan (:mod:`labkit.noise`).

    Returns
    -------
    list of RangeSegment
        One record per kept segment."""
    labels = segment_labels.unchecked(scan, threshold_m=threshold_m, min_points=min_points, adaptive=adaptive,
                                      incidence_deg=incidence_deg, range_sigma_m=range_sigma_m)
    return segments_from_labels(scan, labels)


def detector_labels(scan: Scan, segments, range_sigma_m: float | str | None = None) -> np.ndarray:
    """The range segments a detector works on, as per-beam labels.

    The range segments a detector works on, as per-beam labels: ``segments`` when given (labels or
    :class:`RangeSegment` records, see :func:`labels_from`), else the scan's default segmentation
    (:class:`SegmentationParams`, the pipeline's), whose adaptive breakpoints follow the detector's
    own range noise as its thresholds do: ``"auto"`` (the scan's estimate) or a number of metres; 0,
    a detector's fixed tests (the papers'), the fixed settings' noise
    (:data:`labkit.noise.RANGE_SIGMA_M`); None the segmentation's default.

    Parameters
    ----------
    scan : Scan
        The scan.
    segments : ndarray of shape (N,) or list of RangeSegment or None
        Precomputed segments, or None for the default segmentation.
    range_sigma_m : float, "auto" or None
        The detector's range noise (above).

    Returns
    -------
    ndarray of shape (N,)
        One label per beam, -1 for none.
    """
    if segments is not None:
        return labels_from(scan, segments)
    if range_sigma_m is None:
        return segment_labels.unchecked(scan)
    return segment_labels.unchecked(scan, range_sigma_m=RANGE_SIGMA_M if range_sigma_m == 0 else range_sigma_m)


def segment_order(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The beams of every segment laid end to end, in label order.

    ``labels`` are per beam as :func:`segment_labels` gives them (each segment a run of
    consecutive beams, -1 for none). Returns ``(beams, starts, stops)``: segment ``k`` is
    ``beams[starts[k]:stops[k]]``. A segment crossing the seam of a full-circle scan (the same
    label on the first and the last beam) comes first, its beams running N-k..N-1, 0..m.

    Parameters
    ----------
    labels : ndarray of shape (N,)
        One label per beam, -1 for none.

    Returns
    -------
    beams : ndarray of int
        The beams of every segment, segment after segment.
    starts, stops : ndarray of int
        Where each segment's beams start and stop in ``beams``.

    Examples
    --------
    >>> beams, starts, stops = segment_order(np.array([0, 0, -1, 1, 1, 1, 0]))
    >>> beams.tolist(), starts.tolist(), stops.tolist()
    ([6, 0, 1, 3, 4, 5], [0, 3], [3, 6])
    """
    labels = np.asarray(labels)
    n = labels.size
    if n and labels[0] >= 0 and labels[0] == labels[-1]:
        other = np.flatnonzero(labels != labels[0])
        if other.size:  # a segment crossing the seam: start the beam order where it starts
            t = int(other[-1]) + 1
            rolled = np.concatenate([np.arange(t, n), np.arange(t)])
            beams = rolled[labels[rolled] >= 0]
        else:
            beams = np.arange(n)
    else:
        beams = (labels >= 0).nonzero()[0]
    if beams.size == 0:
        return beams, np.zeros(0, np.int64), np.zeros(0, np.int64)
    lab = labels.take(beams)  # = labels[beams]
    # the segments' bounds in beams: both ends, and wherever the label changes
    edge = np.empty(beams.size + 1, dtype=bool)
    edge[0] = edge[-1] = True
    np.not_equal(lab[1:], lab[:-1], out=edge[1:-1])
    bounds = edge.nonzero()[0]
    return beams, bounds[:-1], bounds[1:]


def segments_from_labels(scan: Scan, labels: np.ndarray) -> list[RangeSegment]:
    """:class:`RangeSegment` records for per-beam labels (-1 skipped), seam-aware.

    :class:`RangeSegment` records for per-beam labels (-1 skipped), seam-aware (see
    :func:`segment_order`).

    Parameters
    ----------
    scan : Scan
        The scan the labels belong to.
    labels : ndarray of shape (N,)
        One label per beam, -1 for none.

    Returns
    -------
    list of RangeSegment
        One record per label, in the order of :func:`segment_order`.
    """
    beams, starts, stops = segment_order(labels)
    out = []
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        idx = beams[a:b].copy()
        idx.setflags(write=False)
        pts = scan.points[idx]
        pts.setflags(write=False)
        out.append(RangeSegment(idx, pts))
    return out


def labels_from(scan: Scan, segments, name: str = "segments") -> np.ndarray:
    """Per-beam segment labels from ``segments``.

    ``segments`` are given either as per-beam labels (an int
    array of shape ``(scan.n_beams,)``, -1 for none, as :func:`segment_labels` returns) or as
    :class:`RangeSegment` records. Labels on invalid beams are set to -1.

    This lets one segmentation be shared by every detector of a pipeline.

    Parameters
    ----------
    scan : Scan
        The scan.
    segments : ndarray of shape (N,) or list of RangeSegment
        Per-beam labels or segment records.
    name : str, default "segments"
        The argument's name in error messages.

    Returns
    -------
    ndarray of shape (N,)
        One label per beam, -1 for none and on invalid beams.

    Examples
    --------
    >>> s = Scan(ranges=[1.0, 1.0, np.nan, 1.0], angles=np.radians(np.arange(4)))
    >>> labels_from(s, np.array([0, 0, 0, 1])).tolist()
    [0, 0, -1, 1]
    """
    n = scan.n_beams
    if isinstance(segments, np.ndarray):
        if segments.shape != (n,) or not (issubclass(segments.dtype.type, np.integer) or segments.size == 0):
            raise ValueError(f"{name} given as labels must be an int array of shape ({n},), one per beam, "
                             f"got {segments.dtype} of shape {segments.shape}")
        if segments.dtype == np.int64:  # the usual case, in short: a copy with -1 on the invalid beams
            labels = segments.copy()
            labels[~scan.valid] = -1
            return labels
        return np.where(scan.valid, segments, -1).astype(np.int64, copy=False)
    labels = np.full(n, -1, dtype=np.int64)
    for k, seg in enumerate(segments):
        if not isinstance(seg, RangeSegment):
            raise ValueError(f"{name} must be per-beam labels or RangeSegment records (labkit.range_segments), "
                             f"got {type(seg).__name__}")
        idx = np.asarray(seg.indices, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            raise ValueError(f"{name} has beam indices outside the scan's 0..{n - 1}")
        labels[idx] = k
    labels[~scan.valid] = -1
    return labels

