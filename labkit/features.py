"""Feature records shared by every extractor, and corner finding.

Every record is a small frozen dataclass that keeps the beam indices it came from
(``first``/``last``, as in the Player "laser feature 2D" record), so a feature can be drawn
back onto its scan. Points are in the sensor frame, metres; angles in radians.

* :class:`LineSegment` -- split-and-merge, IEPF, angular segmentation, IAV lines
* :class:`Corner` -- where two consecutive line segments meet
* :class:`Circle` -- IAV circles and arcs
* :class:`Leg`, :class:`Person` -- leg detection and pairing
* :class:`Features` -- everything :func:`labkit.extract_features` found in one scan
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._fastinit import fast_init
from ._plainfloat import intersect1, wrap1
from .fitting import fit_line_polar
from .geometry import project_onto_line
from .params import Params, checked_by, param

__all__ = ["LineSegment", "Corner", "Circle", "Leg", "Person", "Features", "line_segment", "find_corners"]


def frozen_array(a) -> np.ndarray:
    """``a`` as a read-only float array (the records' arrays never change once built)."""
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


# ``@fast_init`` (labkit._fastinit) only makes building these frozen records faster: it replaces the
# dataclass's ``__init__`` (same fields, order and defaults), which stays for type checkers to read.


@fast_init
@dataclass(frozen=True, eq=False)
class LineSegment:
    """A line fitted to a run of beams.

    Parameters
    ----------
    r, alpha : float
        The line in normal form (``r >= 0`` m, ``alpha`` in (-pi, pi]).
    covariance : ndarray (2, 2)
        Covariance of ``(r, alpha)``.
    start, end : ndarray (2,)
        The first and last points projected onto the line (scan order); split-and-merge,
        incremental and line regression stop a projection that would reach past the ray of
        the first or last beam at that ray.
    first, last : int
        First and last beam index (``first > last`` when the segment crosses the seam of a
        full-circle scan).
    n_points : int
        Number of points fitted.
    error : float, metres
        RMS orthogonal distance of the points to the line.
    indices : ndarray (n_points,), int
        The beams fitted, in scan order.
    """

    r: float
    alpha: float
    covariance: np.ndarray = field(repr=False)
    start: np.ndarray
    end: np.ndarray
    first: int
    last: int
    n_points: int
    error: float
    indices: np.ndarray = field(repr=False)


    @property
    def length(self) -> float:
        """Distance between ``start`` and ``end``, metres."""
        d = self.end - self.start
        return float(math.hypot(d[0], d[1]))

    @property
    def direction(self) -> float:
        """Direction of the line from ``start`` to ``end``, radians."""
        return float(math.atan2(self.end[1] - self.start[1], self.end[0] - self.start[0]))

    def as_dict(self) -> dict:
        """A JSON-ready record (Player laser feature 2D fields)."""
        return {
            "type": "line", "first": self.first, "last": self.last, "r": self.r, "alpha": self.alpha,
            "start": self.start.tolist(), "end": self.end.tolist(), "n_points": self.n_points,
            "error": self.error, "length": self.length,
        }

    def __repr__(self) -> str:
        return (f"LineSegment(r={self.r:.3f}, alpha={math.degrees(self.alpha):.1f} deg, "
                f"beams {self.first}..{self.last}, {self.n_points} pts, length={self.length:.3f} m)")


def line_segment(points: np.ndarray, indices, *, weights=None, range_sigma=None) -> LineSegment:
    """Fit a line to the points of some beams and cut it at their first and last point.

    Fit :func:`labkit.fitting.fit_line_polar` to ``points`` (M, 2, sensor frame) of the beams
    ``indices`` and cut the line at the projections of the first and last point.

    Parameters
    ----------
    points : ndarray of shape (M, 2)
        The points of the beams, metres, sensor frame.
    indices : array_like of shape (M,)
        Their beam indices.
    weights : array_like of shape (M,), optional
        Weights of the polar fit; default ``1 / range`` (:func:`labkit.fitting.fit_line_polar`).
    range_sigma : float, optional
        Range noise for the line's covariance, metres.

    Returns
    -------
    LineSegment
        The fitted line with its end points, beam indices and covariance.

    Examples
    --------
    >>> seg = line_segment(np.array([[1.0, -1.0], [1.0, 0.0], [1.0, 1.0]]), [10, 11, 12])
    >>> round(seg.r, 9), seg.first, seg.last, round(seg.length, 9)
    (1.0, 10, 12, 2.0)
    """
    p = np.asarray(points, dtype=float)
    idx = np.array(indices, dtype=np.int64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) != len(idx):
        raise ValueError(f"points must be (M, 2) with one row per index, got {p.shape} and {idx.shape}")
    rho = np.hypot(p[:, 0], p[:, 1])
    theta = np.arctan2(p[:, 1], p[:, 0])
    fit = fit_line_polar(rho, theta, weights, range_sigma=range_sigma)
    ends = project_onto_line(p[[0, -1]], fit.r, fit.alpha)
    idx.setflags(write=False)
    return LineSegment(fit.r, fit.alpha, frozen_array(fit.covariance), frozen_array(ends[0]), frozen_array(ends[1]),
                       int(idx[0]), int(idx[-1]), len(p), fit.rms, idx)


@fast_init
@dataclass(frozen=True, eq=False)
class Corner:
    """Where two consecutive line segments meet.

    Parameters
    ----------
    point : ndarray (2,)
        Intersection of the two lines.
    angle : float, radians
        Angle between the two lines' directions, in (0, pi/2] (0 would be parallel).
    kind : str
        ``"concave"`` (the sensor sees into the corner, as into a room's corner) or
        ``"convex"`` (the corner points at the sensor, as a box's edge does).
    extrapolated : bool
        True when the corner itself was not observed: the lines had to be extended by more
        than ``max_extension_m`` to meet, and (for lines ending on neighbouring beams) by
        more than the distance between their facing ends, the local beam spacing.
    lines : tuple[int, int]
        Indices of the two segments in the list given to :func:`find_corners`.
    first, last : int
        The beams between which the corner lies: ``last`` of the first line, ``first`` of
        the second.
    """

    point: np.ndarray
    angle: float
    kind: str
    extrapolated: bool
    lines: tuple[int, int]
    first: int
    last: int


    def as_dict(self) -> dict:
        return {"type": "corner", "first": self.first, "last": self.last, "point": self.point.tolist(),
                "angle": self.angle, "kind": self.kind, "extrapolated": self.extrapolated}


def _side(a, b, p) -> float:
    """Twice the signed area of the triangle ``a, b, p``: > 0 when ``p`` lies left of ``a -> b``."""
    return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])


@dataclass(frozen=True)
class CornerParams(Params):
    """Parameters of :func:`find_corners`.

    The ``[corners]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    min_angle_deg: float = param(30.0, "smallest angle between the two lines, degrees", lo=0, strict=True, hi=90)
    max_gap_m: float = param(0.3, "largest gap between the lines' facing ends, metres", lo=0)
    max_extension_m: float = param(0.1, "how far a line may be extended to reach the corner, metres", lo=0)


@checked_by(CornerParams)
def find_corners(
    lines: list[LineSegment],
    *,
    min_angle_deg: float = CornerParams.min_angle_deg,
    max_gap_m: float = CornerParams.max_gap_m,
    max_extension_m: float = CornerParams.max_extension_m,
    wrap: bool = False,
) -> list[Corner]:
    """Corners between consecutive line segments, in the order given (usually scan order).

    Corners between consecutive line segments (in the order given, usually scan order).

    Two consecutive segments make a corner when their lines differ in direction by more
    than ``min_angle_deg`` (degrees, default 30) and the end of the first is within ``max_gap_m`` of the start of the
    second. The corner is the intersection of the two lines. It is ``"extrapolated"`` when
    the lines must be extended further than ``max_extension_m`` to meet it -- or, when the
    lines end on neighbouring beams, further than the gap between those two beams, which
    grows with range. It is ``"concave"`` when it
    lies beyond the chord joining the two segments' far ends (seen from the sensor at the
    origin) and ``"convex"`` when it lies on the sensor's side. ``wrap=True`` also pairs the
    last segment with the first (a full-circle scan).

    Parameters
    ----------
    lines : list of LineSegment
        The segments, usually in scan order.
    min_angle_deg : float, default 30.0
        Smallest change of direction between two segments that makes a corner, degrees.
    max_gap_m : float, default 0.3
        Largest distance from the end of one segment to the start of the next, metres.
    max_extension_m : float, default 0.1
        How far the lines may be extended to meet before the corner is ``"extrapolated"``, metres.
    wrap : bool, default False
        Also pair the last segment with the first (a full-circle scan).

    Returns
    -------
    list of Corner
        The corners, in the order of ``lines``.

    Examples
    --------
    >>> a = line_segment(np.array([[3.0, -2.0], [3.0, -1.0], [3.0, 0.0]]), [0, 1, 2])
    >>> b = line_segment(np.array([[2.9, 0.1], [2.0, 0.1], [1.0, 0.1]]), [3, 4, 5])
    >>> [(c.kind, np.round(c.point, 6).tolist()) for c in find_corners([a, b])]
    [('concave', [3.0, 0.1])]
    """
    min_angle = math.radians(min_angle_deg)
    out: list[Corner] = []
    n = len(lines)
    pairs = [(i, i + 1) for i in range(n - 1)]
    if wrap and n > 2:
        pairs.append((n - 1, 0))
    if not pairs:
        return out
    # Plain floats throughout: for 2-vectors, math is several times faster than numpy.
    alphas = [float(ln.alpha) for ln in lines]
    for i, j in pairs:
        # angle between undirected lines, in [0, pi/2]
        d = abs(wrap1(alphas[i] - alphas[j]))
        angle = min(d, math.pi - d)
        if angle < min_angle:
            continue
        a, b = lines[i], lines[j]
        a_start, a_end = a.start.tolist(), a.end.tolist()
        b_start, b_end = b.start.tolist(), b.end.tolist()
        gap = math.hypot(b_start[0] - a_end[0], b_start[1] - a_end[1])
        if gap > max_gap_m:
            continue
        p = intersect1(float(a.r), alphas[i], float(b.r), alphas[j])
        if p is None:
            continue
        extension = max(math.hypot(p[0] - a_end[0], p[1] - a_end[1]), math.hypot(p[0] - b_start[0], p[1] - b_start[1]))
        allowed = max_extension_m
        if b.first - a.last == 1:  # neighbouring beams: the corner lies between two readings
            allowed = max(allowed, gap)
        side_origin = _side(a_start, b_end, (0.0, 0.0))
        side_corner = _side(a_start, b_end, p)
        kind = "concave" if side_origin * side_corner < 0 else "convex"
        out.append(Corner(frozen_array(p), angle, kind, extension > allowed, (i, j), a.last, b.first))
    return out


@fast_init
@dataclass(frozen=True, eq=False)
class Circle:
    """A circle (or arc) found in a scan.

    ``center`` (2,) and ``radius`` in metres; ``iav_mean``/``iav_std`` the inscribed-angle
    statistics in radians; ``confidence`` in [0, 1]; ``first``/``last`` beam indices;
    ``n_points``; ``kind`` is ``"circle"``, ``"arc"`` (embedded in a wall) or ``"arc-like"``.

    Parameters
    ----------
    center : ndarray of shape (2,)
        Centre, metres, sensor frame.
    radius : float
        Radius, metres.
    iav_mean, iav_std : float
        Mean and standard deviation of the inscribed angles, radians.
    confidence : float
        In [0, 1].
    first, last : int
        The first and last beam index of the segment.
    n_points : int
        Its number of points.
    kind : {"circle", "arc", "arc-like"}, default "circle"
        ``"arc"``: embedded in a wall.
    """

    center: np.ndarray
    radius: float
    iav_mean: float
    iav_std: float
    confidence: float
    first: int
    last: int
    n_points: int
    kind: str = "circle"


    def as_dict(self) -> dict:
        return {"type": self.kind, "first": self.first, "last": self.last, "center": self.center.tolist(),
                "radius": self.radius, "iav_mean": self.iav_mean, "iav_std": self.iav_std,
                "confidence": self.confidence, "n_points": self.n_points}


@fast_init
@dataclass(frozen=True, eq=False)
class Leg:
    """A leg candidate found in a scan.

    A leg candidate: ``center`` (2,) and ``diameter`` in metres, ``middle`` the segment's middle
    point (Xavier et al. Table I), beam indices, IAV statistics.

    Parameters
    ----------
    center : ndarray of shape (2,)
        Centre of the leg, metres, sensor frame.
    diameter : float
        Diameter, metres.
    middle : ndarray of shape (2,)
        The segment's middle point (Xavier et al. Table I).
    first, last : int
        The first and last beam index of the segment.
    n_points : int
        Its number of points.
    iav_mean, iav_std : float
        Mean and standard deviation of the inscribed angles, radians.
    """

    center: np.ndarray
    diameter: float
    middle: np.ndarray
    first: int
    last: int
    n_points: int
    iav_mean: float
    iav_std: float


    def as_dict(self) -> dict:
        return {"type": "leg", "first": self.first, "last": self.last, "center": self.center.tolist(),
                "diameter": self.diameter, "middle": self.middle.tolist(), "n_points": self.n_points,
                "iav_mean": self.iav_mean, "iav_std": self.iav_std}


@dataclass(frozen=True, eq=False)
class Person:
    """Two legs closer than the pairing distance; ``center`` is their midpoint.

    Parameters
    ----------
    center : ndarray of shape (2,)
        The midpoint of the two legs' centres, metres.
    legs : tuple of Leg
        The two legs, in scan order.
    """

    center: np.ndarray
    legs: tuple[Leg, Leg]

    def as_dict(self) -> dict:
        return {"type": "person", "center": self.center.tolist(), "legs": [leg.as_dict() for leg in self.legs]}


@dataclass(frozen=True, eq=False)
class Features:
    """Every feature found in one scan, with the time each stage took.

    Parameters
    ----------
    stamp_ns : int
        The scan's time stamp.
    n_beams : int
        Beams in the scan.
    labels : ndarray (n_beams,), int
        The range segment of each beam (-1: invalid or in no segment), shared by every
        detector.
    lines, corners, circles, arcs, legs, people : tuple
        :class:`LineSegment`, :class:`Corner`, :class:`Circle` (``kind`` ``"circle"`` or
        ``"arc-like"``), :class:`Circle` (``kind="arc"``, arcs embedded in walls),
        :class:`Leg`, :class:`Person`. A stage that is switched off gives an empty tuple.
    timings : dict of str to float
        Seconds spent per stage (``segmentation``, ``legs``, ``circles``, ``lines``,
        ``corners``, ``arcs``) and in all (``total``).
    """

    stamp_ns: int
    n_beams: int
    labels: np.ndarray = field(repr=False)
    lines: tuple = ()
    corners: tuple = ()
    circles: tuple = ()
    arcs: tuple = ()
    legs: tuple = ()
    people: tuple = ()
    timings: dict = field(default_factory=dict, repr=False)

    LAYERS = ("lines", "corners", "circles", "arcs", "legs", "people")

    @property
    def n_segments(self) -> int:
        """Number of range segments."""
        return int(self.labels.max()) + 1 if self.labels.size else 0

    def counts(self) -> dict[str, int]:
        """How many of each feature: ``{"segments": .., "lines": .., ...}``."""
        return {"segments": self.n_segments, **{k: len(getattr(self, k)) for k in self.LAYERS}}

    def as_record(self) -> dict:
        """One JSON-ready record for the scan: time stamp, beam count, counts, stage times
        in milliseconds, and every feature as its ``as_dict()`` (the Player "laser feature
        2D" fields: ``type``, ``first``/``last`` beam, endpoints or centre, radius, IAV mean
        and std, point count, fit error). People are listed after the legs they pair."""
        items = [f.as_dict() for k in self.LAYERS for f in getattr(self, k)]
        return {
            "stamp_ns": int(self.stamp_ns),
            "n_beams": int(self.n_beams),
            "counts": self.counts(),
            "timings_ms": {k: round(v * 1e3, 4) for k, v in self.timings.items()},
            "features": items,
        }

    def __repr__(self) -> str:
        c = self.counts()
        return "Features(" + ", ".join(f"{v} {k}" for k, v in c.items()) + f", stamp_ns={self.stamp_ns})"

