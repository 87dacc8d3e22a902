"""Inscribed Angle Variance (IAV): the geometry of arcs that Xavier et al. detect circles,
arcs, lines and legs with.

Every point ``P_i`` of an arc sees the arc's extremes ``P_1`` and ``P_n`` under the same
angle (Euclid III.21, the inscribed angle theorem), so the inscribed angles
``angle(P_1, P_i, P_n)`` of a range segment have a small spread when the segment is an arc,
and a mean that tells how much of the circle is visible: 90 deg for a half circle, 180 deg
for a straight line (Xavier et al. 2005, Sec. II-B).

* :func:`inscribed_angles`, :func:`iav_stats` (:class:`IAVStats`) -- the angles, their mean
  and spread
* :func:`middle_point_offset` -- the circle prerequisite of Fig. 5 (Sec. II-D)
* :func:`circle_from_iav` -- centre and radius from the chord and the mean angle (Sec. II-C)
* :func:`is_v_corner` -- the V-corner test that guards the "arc-like" mode (Sec. II-B.3)
* :func:`circle_confidence` -- how sure a circle is (Sec. II-B)
* the constants of Table II and Sec. II-B (:data:`CIRCLE_STD_MAX`, :data:`CIRCLE_MEAN_RANGE`,
  :data:`ARC_LIKE_STD_MAX`) and of the noise allowances (:data:`NOISE_Z`, :data:`LINE_Z`)

The detectors built on them: :func:`labkit.detect_circles` and :func:`labkit.detect_arcs`
(:mod:`labkit.circles.iav_circles`), :func:`labkit.detect_legs` (:mod:`labkit.circles.legs`)
and :func:`labkit.detect_lines_iav` (:mod:`labkit.lines.iav_lines`).

Conventions
-----------
Angles are radians. Points of a scan segment are in scan order, which is counter-clockwise
around the sensor (``Scan.angles`` increase). The *signed* inscribed angle at ``P_i`` is
measured counter-clockwise from the ray ``P_i -> P_1`` to the ray ``P_i -> P_n``, in
[0, 2 pi). For points in scan order a shape that bulges towards the sensor (a column, a
leg, a box's edge) gives angles below pi, a straight line pi, and a shape that is hollow
towards the sensor (a room's rounded corner seen from inside) angles above pi. This is
the paper's "measured counter-clockwise". The *unsigned* angle is the plain geometric
angle in [0, pi].

Degenerate input, one policy (the one of :mod:`labkit.fitting`): the functions that take
points raise ``ValueError`` naming ``points`` when there are fewer than 3 points (no
interior point, no inscribed angle), when the points are not finite, or when an interior
point coincides with an extreme (its angle is undefined). The detectors never raise on
data: they skip such segments, and the skipped segment's trace record says why.

Corrections to the paper (Sec. II-C), derived in :func:`circle_from_iav`: the central
angle ``P_1 O P_n`` is ``360 - 2 IAV`` (the paper prints ``360 - IAV``; its own next step,
``theta = IAV - 90``, follows only from ``360 - 2 IAV``); the centre's height above the
chord is ``(chord / 2) tan(theta)`` (the paper prints ``P_4 tan(theta)``, the whole
chord, which doubles it); and the side of the chord the centre lies on is the side away
from the segment's points when ``IAV > 90 deg`` (the paper leaves the sign implicit).

The functions compute as the detectors' batch engine (:mod:`labkit._iav_batch`) does for
all the segments of a scan at once, operation for operation (the rays as complex numbers,
the sums taken in order), so that the detectors' readable reference, which calls them one
segment at a time, gives the engine's numbers to the last bit.

References
----------
J. Xavier, M. Pacheco, D. Castro, A. Ruano, U. Nunes, "Fast line, arc/circle and leg
detection from laser scan data in a Player driver", IEEE ICRA 2005, Sec. II-B to II-D and
Table II (the defaults here).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ._validate import check_int

__all__ = [
    "IAVStats",
    "inscribed_angles",
    "iav_stats",
    "middle_point_offset",
    "circle_from_iav",
    "is_v_corner",
    "circle_confidence",
    "CIRCLE_STD_MAX",
    "ARC_LIKE_STD_MAX",
    "CIRCLE_MEAN_RANGE",
    "NOISE_Z",
    "LINE_Z",
]

#: Table II ``circle_std_max``: largest standard deviation of the inscribed angles of a circle (rad, 8.6 deg).
CIRCLE_STD_MAX = 0.15
#: Sec. II-B.3: largest standard deviation of an "arc-like" shape (23 deg).
ARC_LIKE_STD_MAX = math.radians(23.0)
#: Sec. II-B: the mean inscribed angle of a circle lies between 90 and 135 deg.
CIRCLE_MEAN_RANGE = (math.radians(90.0), math.radians(135.0))

#: The noise allowances of the detectors (``range_sigma_m``): each bound moves out by this many
#: standard deviations of its statistic under the range noise (one-sided normal quantile: from
#: noise alone, a true circle fails one bound 2.3 % of the time).
NOISE_Z = 2.0
#: The widened upper bound of the mean inscribed angle stays this many standard deviations of the
#: mean below 180 deg (a straight line), so that a short noisy piece of wall is not called a circle.
LINE_Z = 3.0


class IAVStats(NamedTuple):
    """Mean and (population) standard deviation of the inscribed angles of a segment.

    Mean and (population) standard deviation of the inscribed angles of a segment, radians, and the
    number of interior points they come from. Unpacks as ``mean, std, n_angles``.

    Parameters
    ----------
    mean : float
        Mean inscribed angle, radians.
    std : float
        Population standard deviation of the inscribed angles, radians.
    n_angles : int
        The number of interior points they come from.
    """

    mean: float
    std: float
    n_angles: int

    @classmethod
    def from_angles(cls, angles) -> IAVStats:
        """The statistics of given inscribed angles (radians; one or more).

        Each sum is taken angle by angle in order (``np.cumsum``), as the detectors' batch
        engine takes it for every segment of a scan at once (``np.bincount``); numpy's own
        ``mean`` adds in another order, which can change the last bit.

        >>> mean, std, n = IAVStats.from_angles(np.radians([80.0, 100.0]))
        >>> round(float(np.degrees(mean)), 9), round(float(np.degrees(std)), 9), n
        (90.0, 10.0, 2)
        """
        a = np.asarray(angles, dtype=np.float64)
        if a.ndim != 1 or a.size == 0:
            raise ValueError(f"angles must be a non-empty one-dimensional array, got shape {a.shape}")
        n = a.size
        mean = np.cumsum(a)[-1] / n
        variance = np.cumsum((a - mean) ** 2)[-1] / n
        return cls(float(mean), float(np.sqrt(variance)), n)


# ============================================================================ validation
def _as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must be an array of shape (M, 2), got shape {p.shape}")
    if p.shape[0] < 3:
        raise ValueError(f"points must hold at least 3 points (an interior point and two extremes), got {p.shape[0]}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite (drop invalid beams first, e.g. with Scan.xy)")
    return p


# ============================================================================ the angles
def inscribed_angles(points, *, signed: bool = False) -> np.ndarray:
    """Inscribed angles ``angle(P_1, P_i, P_n)`` at the interior points of a polyline.

    Parameters
    ----------
    points : array_like of shape (M, 2), metres
        ``P_1 .. P_M`` in order (for a scan segment: scan order). ``M >= 3``.
    signed : bool
        ``False`` (default): the geometric angle in [0, pi]. ``True``: measured
        counter-clockwise from the ray ``P_i -> P_1`` to the ray ``P_i -> P_M``, in
        [0, 2 pi); for points in scan order, below pi where the shape bulges towards
        the sensor and above pi where it is hollow towards it.

    Returns
    -------
    ndarray of shape (M - 2,)
        The angle at each interior point, radians.

    Raises
    ------
    ValueError
        Fewer than 3 points, non-finite points, or an interior point that coincides
        with ``P_1`` or ``P_M`` (its angle is undefined).

    Notes
    -----
    The points are complex numbers here, ``x + iy``: with ``a = P_1 - P_i`` and ``b = P_M - P_i``
    the counter-clockwise angle from ``a`` to ``b`` is the argument of ``b conj(a)``, whose real
    part is their dot product and whose imaginary part their cross product.

    Examples
    --------
    Points on a circle see the chord under one angle (here a half circle: 90 deg), and
    points on a line under 180 deg:

    >>> t = np.radians([-90, -45, 0, 30, 90])
    >>> np.degrees(inscribed_angles(np.c_[np.cos(t), np.sin(t)])).round(6)
    array([90., 90., 90.])
    >>> np.degrees(inscribed_angles([[0, 0], [1, 0], [2, 0], [3, 0]])).round(6)
    array([180., 180.])
    """
    p = _as_points(points)
    z = np.ascontiguousarray(p).view(np.complex128)[:, 0]  # each row (x, y) read as x + iy
    to_first = z[0] - z[1:-1]  # the rays P_i -> P_1
    to_last = to_first + (z[-1] - z[0])  # the rays P_i -> P_M: P_i -> P_1, then along the chord
    if not (to_first.all() and to_last.all()):
        raise ValueError("points has an interior point that coincides with an extreme: "
                         "its inscribed angle is undefined")
    turn = to_last * to_first.conj()
    angles = np.arctan2(turn.imag, turn.real) % (2 * np.pi)  # counter-clockwise, in [0, 2 pi)
    return angles if signed else np.minimum(angles, 2 * np.pi - angles)


def iav_stats(points, *, signed: bool = False) -> IAVStats:
    """Mean and standard deviation of the inscribed angles of ``points``.

    Mean and standard deviation of the inscribed angles of ``points`` (:meth:`IAVStats.from_angles`
    of :func:`inscribed_angles`).

    The standard deviation is the population one (``ddof=0``); Xavier et al. do not say
    which they use. Same arguments and degenerate-input policy as :func:`inscribed_angles`.

    Parameters
    ----------
    points : array_like of shape (M, 2)
        The points of a segment, M >= 3.
    signed : bool, default False
        Measure the angles counter-clockwise, in [0, 2 pi), instead of in [0, pi] (:func:`inscribed_angles`).

    Returns
    -------
    IAVStats
        ``mean, std, n_angles``: radians, radians, the number of interior points.

    Examples
    --------
    >>> t = np.radians(np.linspace(-60, 60, 9))
    >>> mean, std, n = iav_stats(np.c_[-np.cos(t), np.sin(t)])   # 120 deg of a unit circle
    >>> round(float(np.degrees(mean)), 6), round(std, 9), n
    (120.0, 0.0, 7)
    """
    return IAVStats.from_angles(inscribed_angles(points, signed=signed))


# ============================================================================ the prerequisite
def middle_point_offset(points, viewpoint=(0.0, 0.0)) -> float:
    """The circle prerequisite of Xavier et al. Fig. 5: the middle point's offset from the chord.

    The circle prerequisite of Xavier et al. Fig. 5: where the middle point lies relative to the
    chord, as a fraction of the chord length.

    The chord joins the extremes ``P_1`` and ``P_M``; the middle point is
    ``P_(M // 2)`` (0-based row ``M // 2``). Returns its distance from the chord's line
    divided by the chord length, positive when it lies on the side of ``viewpoint`` (the
    sensor, at the origin of the scan frame). A column, a leg or any arc seen from
    outside bulges towards the sensor and gives a positive value; a half circle gives
    0.5, a straight segment 0, a hollow (a rounded room corner seen from inside) a
    negative value. The paper's equations (2)-(4) rotate the chord onto an axis and test
    ``0.1 d < x_2 < 0.7 d``; this is the same test without choosing an axis, and with
    the side fixed by the sensor (the paper's sign depends on its axis conventions).

    When the viewpoint lies on the chord's line, the side is taken as the middle
    point's own (the value is then the absolute offset). Degenerate input as
    :func:`inscribed_angles`, plus ``P_1 == P_M`` (no chord).

    Parameters
    ----------
    points : array_like of shape (M, 2)
        The points of a segment, metres.
    viewpoint : array_like of shape (2,), default (0, 0)
        Where the sensor is, in the frame of ``points``.

    Returns
    -------
    float
        The middle point's distance from the chord's line over the chord length, positive on the
        viewpoint's side.

    Examples
    --------
    >>> t = np.radians([-90, -45, 0, 45, 90])
    >>> round(middle_point_offset(np.c_[3 - np.cos(t), np.sin(t)]), 9)   # half circle, seen from the origin
    0.5
    >>> middle_point_offset([[1, 0], [1, 1], [1, 2]])
    0.0
    """
    p = _as_points(points)
    v = np.asarray(viewpoint, dtype=np.float64)
    if v.shape != (2,) or not np.all(np.isfinite(v)):
        raise ValueError(f"viewpoint must be two finite numbers, got {viewpoint!r}")
    (x0, y0), (x1, y1), (xm, ym) = p[0].tolist(), p[-1].tolist(), p[p.shape[0] // 2].tolist()
    dx, dy = x1 - x0, y1 - y0
    chord = float(np.hypot(dx, dy))
    if chord == 0:
        raise ValueError("points has identical extremes: the chord is undefined")
    offset = dx * (ym - y0) - dy * (xm - x0)  # cross(P_M - P_1, middle - P_1): > 0 left of the chord
    vx, vy = v.tolist()
    sensor_side = dx * (vy - y0) - dy * (vx - x0)  # the viewpoint's side, the same way
    if sensor_side < 0:
        offset = -offset
    elif sensor_side == 0:
        offset = abs(offset)
    square = chord * chord  # (0 for chords under 1e-162 m: the offset over 0, as numpy would give it)
    return offset / square if square > 0 else offset * math.inf


# ============================================================================ the centre
def circle_from_iav(p_first, p_last, iav_mean: float, side: float) -> tuple[np.ndarray, float]:
    """Centre and radius of a circle from its chord and the mean inscribed angle.

    Centre and radius of the circle through ``p_first`` and ``p_last`` whose points between them see
    the chord under ``iav_mean`` (Xavier et al. 2005, Sec. II-C, corrected).

    Derivation. An interior point sees the chord under half the central angle of the
    *other* arc, so the arc that holds the points spans ``360 - 2 IAV`` at the centre
    (the paper prints ``360 - IAV``). The triangle ``P_1 O P_n`` is isosceles, so its
    base angle is ``theta = (180 - (360 - 2 IAV)) / 2 = IAV - 90`` (the paper's result).
    With ``P_1`` at the origin and ``P_n`` on the x axis at ``(c, 0)``, the centre is at
    ``(c / 2, (c / 2) tan(theta))`` -- half the chord, not the whole chord as the paper
    prints -- and the radius is ``(c / 2) / cos(theta)``. For ``IAV > 90 deg`` (less than
    half the circle seen) the centre lies on the far side of the chord from the points;
    below 90 deg ``tan(theta) < 0`` puts it on their side. ``side`` says on which side of
    ``P_1 -> P_n`` the points lie (> 0: left, < 0: right).

    Parameters
    ----------
    p_first, p_last : array_like (2,), metres
        The extremes of the arc.
    iav_mean : float, radians
        Mean (unsigned) inscribed angle, in (0, pi).
    side : float
        Sign of the points' side of the directed chord (any non-zero number).

    Returns
    -------
    center : ndarray of shape (2,)
        The circle's centre, metres.
    radius : float
        Its radius, metres.

    Examples
    --------
    A quarter of the unit circle around (0, 0), from (1, 0) to (0, 1): its points lie
    right of that chord and see it under 135 deg:

    >>> c, r = circle_from_iav([1.0, 0.0], [0.0, 1.0], np.radians(135.0), side=-1)
    >>> np.round(c, 9).tolist(), round(r, 9)
    ([0.0, 0.0], 1.0)
    """
    p1 = np.asarray(p_first, dtype=np.float64)
    pn = np.asarray(p_last, dtype=np.float64)
    if p1.shape != (2,) or pn.shape != (2,):
        raise ValueError(f"p_first and p_last must be points (x, y), got shapes {p1.shape} and {pn.shape}")
    if not (0 < iav_mean < math.pi):
        raise ValueError(f"iav_mean must be in (0, pi) radians, got {iav_mean!r}")
    if side == 0 or not math.isfinite(side):
        raise ValueError(f"side must be a non-zero number, got {side!r}")
    (x1, y1), (x2, y2) = p1.tolist(), pn.tolist()
    dx, dy = x2 - x1, y2 - y1
    chord = math.hypot(dx, dy)
    if chord == 0:
        raise ValueError("p_first and p_last coincide: the chord is undefined")
    theta = iav_mean - math.pi / 2
    # the centre's offset from the chord's midpoint along the chord's left normal (-dy, dx) / chord:
    # (chord / 2) tan(theta) away from the points' side
    h = -math.copysign(1.0, side) * 0.5 * math.tan(theta)  # in units of the chord
    return np.array([x1 + 0.5 * dx - h * dy, y1 + 0.5 * dy + h * dx]), 0.5 * chord / math.cos(theta)


# ============================================================================ V corners, confidence
def is_v_corner(angles, n_neighbours: int = 4, stride: int = 1) -> bool:
    """The V-corner test of Xavier et al. Sec. II-B.3 (Fig. 4).

    The inscribed angles of a "V" grow on both sides of the apex, so: find the smallest
    angle and check whether its ``n_neighbours`` neighbours (half on each side, taken
    ``stride`` angles apart) grow strictly away from it. When the minimum has too few
    neighbours on one side (it is near an end) the pattern cannot be checked and the answer is
    False.

    ``stride=1`` is the paper's literal test. With dense points the range noise breaks
    the strict growth right next to the apex (two angles of 92 deg side by side), so the
    detectors step ``max(1, n_angles // 8)`` angles apart (see :func:`labkit.detect_circles`).

    Parameters
    ----------
    angles : array_like of shape (M,)
        The inscribed angles along the run, radians.
    n_neighbours : int
        How many neighbours of the smallest angle must grow away from it (half on each side).
    stride : int
        How many angles apart the neighbours are taken.

    Returns
    -------
    bool
        True means "V-shaped corner, reject".

    Examples
    --------
    >>> is_v_corner(np.radians([170, 150, 120, 90, 120, 150, 170]))
    True
    >>> is_v_corner(np.radians([120, 118, 121, 117, 122, 119, 120]))
    False
    >>> v = np.radians([150, 140, 130, 121, 112, 112, 100, 103, 111, 120, 131, 140, 150])
    >>> is_v_corner(v), is_v_corner(v, stride=2)
    (False, True)
    """
    a = np.asarray(angles, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"angles must be one-dimensional, got shape {a.shape}")
    k = check_int("n_neighbours", n_neighbours, 2) // 2
    s = check_int("stride", stride, 1)
    if a.size == 0:
        return False
    m = int(np.argmin(a))
    if m < k * s or m + k * s >= a.size:
        return False
    left, right = a[m - k * s:m + 1:s], a[m:m + k * s + 1:s]
    return bool(np.all(np.diff(left) < 0) and np.all(np.diff(right) > 0))


def circle_confidence(n_angles: int, iav_mean: float, iav_std: float, *, std_max: float = CIRCLE_STD_MAX,
                      mean_range: tuple[float, float] = CIRCLE_MEAN_RANGE) -> float:
    """Confidence in [0, 1] of an IAV circle.

    Xavier et al. Sec. II-B: it grows with the number of interior points, with a tighter spread
    and with a mean near 90 deg. ``confidence = f_n * f_std * f_mean`` with

    * ``f_n = 1 - exp(-n_angles / 5)`` (2 interior points: 0.33, 5: 0.63, 15: 0.95),
    * ``f_std = 1 - 0.5 * min(iav_std / std_max, 1)`` (1 for a perfect arc, 0.5 at the threshold),
    * ``f_mean = 1 - 0.5 * min(|iav_mean - 90 deg| / (mean_range[1] - 90 deg), 1)``
      (1 at a half circle, 0.5 at the upper limit of the mean).

    Parameters
    ----------
    n_angles : int
        The number of inscribed angles (interior points).
    iav_mean : float
        Their mean, radians.
    iav_std : float
        Their standard deviation, radians.
    std_max : float
        The detector's limit on the standard deviation, radians.
    mean_range : tuple of (float, float)
        The detector's limits on the mean, radians.

    Returns
    -------
    float
        The confidence.

    Examples
    --------
    >>> round(circle_confidence(20, np.radians(90), 0.0), 3)
    0.982
    >>> round(circle_confidence(2, np.radians(135), 0.15), 3)
    0.082
    """
    f_n = 1.0 - math.exp(-max(int(n_angles), 0) / 5.0)
    f_std = 1.0 - 0.5 * min(abs(iav_std) / std_max, 1.0)
    span = max(mean_range[1] - math.pi / 2, 1e-12)
    f_mean = 1.0 - 0.5 * min(abs(iav_mean - math.pi / 2) / span, 1.0)
    return float(min(max(f_n * f_std * f_mean, 0.0), 1.0))
