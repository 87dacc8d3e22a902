"""Range segmentation: split a scan into runs of neighbouring beams.

Consecutive beams ``i`` and ``i + 1`` belong to the same segment while both are valid and
their points are closer than a threshold (Xavier et al. 2005, Sec. II-A: 80 mm). An
invalid beam always ends a segment. Segments with fewer than ``min_points`` points are
rejected (label -1); with the default of 2 that rejects isolated points, as the paper
does. On a full-circle scan the last and first beams are neighbours, so a segment may
cross the seam; its beam indices then wrap (``first > last``).

Labels follow the scikit-learn convention: an int per beam, -1 for "no segment".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scan import Scan

__all__ = ["RangeSegment", "segment_labels", "range_segments"]


@dataclass(frozen=True, eq=False)
class RangeSegment:
    """A run of neighbouring beams.

    Attributes
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


def _validate(threshold_m: float, min_points: int) -> None:
    if not (np.isfinite(threshold_m) and threshold_m > 0):
        raise ValueError(f"threshold_m must be a positive number of metres, got {threshold_m}")
    if int(min_points) != min_points or min_points < 1:
        raise ValueError(f"min_points must be an integer >= 1, got {min_points!r}")


def segment_labels(scan: Scan, threshold_m: float = 0.08, *, min_points: int = 2) -> np.ndarray:
    """Label each beam with its range segment.

    Parameters
    ----------
    scan : Scan
    threshold_m : float, metres
        Largest distance between neighbouring points of one segment. Default 0.08 m
        (Xavier et al. 2005, Table II ``seg_threshold``).
    min_points : int
        Smallest segment kept. Default 2 (isolated points are rejected).

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
    """
    _validate(threshold_m, min_points)
    n = scan.n_beams
    labels = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return labels
    pts = scan.points
    with np.errstate(invalid="ignore"):
        gap = np.hypot(*np.diff(pts, axis=0).T)  # NaN where either beam is invalid
        linked = gap < threshold_m  # (N - 1,)
    valid = scan.valid
    # a new segment starts at every valid beam not linked to its predecessor
    starts = valid & np.concatenate([[True], ~linked])
    raw = np.cumsum(starts) - 1
    raw[~valid] = -1
    wrap = False
    if scan.is_full_circle and n > 2 and valid[0] and valid[-1] and raw[-1] != raw[0]:
        with np.errstate(invalid="ignore"):
            wrap = bool(np.hypot(*(pts[0] - pts[-1])) < threshold_m)
    if wrap:
        raw[raw == raw[-1]] = raw[0]  # the run before the seam continues the first run
    sizes = np.bincount(raw[raw >= 0], minlength=0) if np.any(raw >= 0) else np.zeros(0, dtype=int)
    keep = sizes >= min_points
    new_id = np.cumsum(keep) - 1
    ok = raw >= 0
    ok[ok] = keep[raw[ok]]
    labels[ok] = new_id[raw[ok]]
    return labels


def range_segments(scan: Scan, threshold_m: float = 0.08, *, min_points: int = 2) -> list[RangeSegment]:
    """The segments of :func:`segment_labels` as :class:`RangeSegment` records, in scan
    order (a seam-crossing segment is listed first and its indices run N-k..N-1, 0..m)."""
    labels = segment_labels(scan, threshold_m, min_points=min_points)
    out = []
    n = scan.n_beams
    for k in range(int(labels.max()) + 1 if n and labels.max() >= 0 else 0):
        idx = np.flatnonzero(labels == k)
        if idx[0] == 0 and idx[-1] == n - 1 and idx.size < n:
            # crosses the seam: start after the gap
            gap_at = int(np.argmax(np.diff(idx) > 1)) + 1 if np.any(np.diff(idx) > 1) else 0
            idx = np.concatenate([idx[gap_at:], idx[:gap_at]])
        idx.setflags(write=False)
        pts = scan.points[idx]
        pts.setflags(write=False)
        out.append(RangeSegment(idx, pts))
    return out
