"""Inscribed angle variance: the machinery shared by the IAV detectors (private).

:mod:`labkit.circles.iav` (circles, arcs), :mod:`labkit.circles.legs` and
:mod:`labkit.lines.iav` (IAV lines) all test runs of points by their inscribed angles; this
module holds what they share: the constants of Xavier et al.'s Table II, the trace (as
:class:`labkit.Step` records), the angle statistics, and the batched tests over the runs of a
scan. The public names are documented and re-exported by :mod:`labkit.circles.iav`; see
its docstring for the conventions (angles in radians, signed angles counter-clockwise).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ._cache import remembered
from ._checks import check_int, check_nonneg, check_positive
from .features import Circle
from .fitting import fit_circle, fit_circles
from .noise import chi2_upper_over_dof
from .scan import Scan
from .segmentation import RangeSegment, labels_from, segment_labels, segment_order
from .steps import Step

#: Table II ``circle_std_max``: largest standard deviation of the inscribed angles of a circle (rad, 8.6 deg).
CIRCLE_STD_MAX = 0.15
#: Sec. II-B.3: largest standard deviation of an "arc-like" shape (23 deg).
ARC_LIKE_STD_MAX = math.radians(23.0)
#: Sec. II-B: the mean inscribed angle of a circle lies between 90 and 135 deg.
CIRCLE_MEAN_RANGE = (math.radians(90.0), math.radians(135.0))
_CENTER_METHODS = ("iav", "algebraic", "geometric")


# ============================================================================ records
class IAVStats(NamedTuple):
    """Mean and (population) standard deviation of the inscribed angles of a segment,
    radians, and the number of interior points they come from. Unpacks as
    ``mean, std, n_angles``."""

    mean: float
    std: float
    n_angles: int


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


def _check_scan(scan) -> None:
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")


def _check_range(name: str, value, lo: float, hi: float) -> tuple[float, float]:
    try:
        a, b = map(float, value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (lo <= a < b <= hi):
        raise ValueError(f"{name} must satisfy {lo:g} <= low < high <= {hi:g}, got {value!r}")
    return a, b


def _check_center_method(center_method: str) -> None:
    if center_method not in _CENTER_METHODS:
        raise ValueError(f"center_method must be one of {_CENTER_METHODS}, got {center_method!r}")


def _check_segments(segments) -> list[RangeSegment]:
    segs = list(segments)
    for s in segs:
        if not isinstance(s, RangeSegment):
            raise ValueError(f"segments must be RangeSegment records (labkit.range_segments), got {type(s).__name__}")
    return segs


# ============================================================================ core geometry
def _signed_angles(p: np.ndarray) -> tuple[np.ndarray, bool]:
    """Counter-clockwise angles (M-2,) in [0, 2 pi) and whether all are defined."""
    inner = p[1:-1]
    a = p[0] - inner  # rays P_i -> P_1
    b = p[-1] - inner  # rays P_i -> P_n
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]
    ok = bool(np.all(np.any(a != 0, axis=1) & np.any(b != 0, axis=1)))
    return np.mod(np.arctan2(cross, dot), 2 * np.pi), ok


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
    ndarray of shape (M - 2,), radians

    Raises
    ------
    ValueError
        Fewer than 3 points, non-finite points, or an interior point that coincides
        with ``P_1`` or ``P_M`` (its angle is undefined).

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
    ang, ok = _signed_angles(p)
    if not ok:
        raise ValueError("points has an interior point that coincides with an extreme: "
                         "its inscribed angle is undefined")
    return ang if signed else np.minimum(ang, 2 * np.pi - ang)


def iav_stats(points, *, signed: bool = False) -> IAVStats:
    """Mean and standard deviation of the inscribed angles of ``points``.

    The standard deviation is the population one (``ddof=0``); Xavier et al. do not say
    which they use. Same arguments and degenerate-input policy as :func:`inscribed_angles`.

    Examples
    --------
    >>> t = np.radians(np.linspace(-60, 60, 9))
    >>> mean, std, n = iav_stats(np.c_[-np.cos(t), np.sin(t)])   # 120 deg of a unit circle
    >>> round(float(np.degrees(mean)), 6), round(std, 9), n
    (120.0, 0.0, 7)
    """
    ang = inscribed_angles(points, signed=signed)
    return IAVStats(float(ang.mean()), float(ang.std()), int(ang.size))


def middle_point_offset(points, viewpoint=(0.0, 0.0)) -> float:
    """The circle prerequisite of Xavier et al. Fig. 5: where the middle point lies
    relative to the chord, as a fraction of the chord length.

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
    ratio = _middle_ratio(p, v)
    if math.isnan(ratio):
        raise ValueError("points has identical extremes: the chord is undefined")
    return ratio


def _middle_ratio(p: np.ndarray, viewpoint: np.ndarray | None = None) -> float:
    """Signed middle-point offset over chord (positive towards ``viewpoint``, the origin
    by default); NaN for a zero chord."""
    d = p[-1] - p[0]
    chord = math.hypot(d[0], d[1])
    if chord == 0:
        return math.nan
    m = p[p.shape[0] // 2] - p[0]
    side = (d[0] * m[1] - d[1] * m[0]) / chord  # > 0: left of P_1 -> P_M
    vp = -p[0] if viewpoint is None else viewpoint - p[0]
    sensor_side = d[0] * vp[1] - d[1] * vp[0]
    if sensor_side < 0:
        side = -side
    elif sensor_side == 0:
        side = abs(side)
    return float(side / chord) + 0.0


def circle_from_iav(p_first, p_last, iav_mean: float, side: float) -> tuple[np.ndarray, float]:
    """Centre and radius of the circle through ``p_first`` and ``p_last`` whose points
    between them see the chord under ``iav_mean`` (Xavier et al. 2005, Sec. II-C, corrected).

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
    center : ndarray (2,), radius : float

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
    return _circle_from_iav(float(p1[0]), float(p1[1]), float(pn[0]), float(pn[1]), iav_mean, side)


def _circle_from_iav(x1: float, y1: float, x2: float, y2: float, iav_mean: float,
                     side: float) -> tuple[np.ndarray, float]:
    """:func:`circle_from_iav` for the chord ``(x1, y1) -> (x2, y2)`` given as floats."""
    if not (0 < iav_mean < math.pi):
        raise ValueError(f"iav_mean must be in (0, pi) radians, got {iav_mean!r}")
    if side == 0 or not math.isfinite(side):
        raise ValueError(f"side must be a non-zero number, got {side!r}")
    dx, dy = x2 - x1, y2 - y1
    chord = math.hypot(dx, dy)
    if chord == 0:
        raise ValueError("p_first and p_last coincide: the chord is undefined")
    theta = iav_mean - math.pi / 2
    # the centre's offset from the chord's midpoint along the chord's left normal (-dy, dx) / chord:
    # (chord / 2) tan(theta) away from the points' side
    h = -math.copysign(1.0, side) * 0.5 * math.tan(theta)  # in units of the chord
    return np.array([x1 + 0.5 * dx - h * dy, y1 + 0.5 * dy + h * dx]), 0.5 * chord / math.cos(theta)


def is_v_corner(angles, n_neighbours: int = 4, stride: int = 1) -> bool:
    """The V-corner test of Xavier et al. Sec. II-B.3 (Fig. 4).

    The inscribed angles of a "V" grow on both sides of the apex, so: find the smallest
    angle and check whether its ``n_neighbours`` neighbours (half on each side, taken
    ``stride`` angles apart) grow strictly away from it. True means "V-shaped corner,
    reject". When the minimum has too few neighbours on one side (it is near an end) the
    pattern cannot be checked and the answer is False.

    ``stride=1`` is the paper's literal test. With dense points the range noise breaks
    the strict growth right next to the apex (two angles of 92 deg side by side), so the
    detectors step ``max(1, n_angles // 8)`` angles apart (see :func:`detect_circles`).

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
    """Confidence in [0, 1] of an IAV circle (Xavier et al. Sec. II-B: it grows with the
    number of interior points, with a tighter spread and with a mean near 90 deg).

    ``confidence = f_n * f_std * f_mean`` with

    * ``f_n = 1 - exp(-n_angles / 5)`` (2 interior points: 0.33, 5: 0.63, 15: 0.95),
    * ``f_std = 1 - 0.5 * min(iav_std / std_max, 1)`` (1 for a perfect arc, 0.5 at the threshold),
    * ``f_mean = 1 - 0.5 * min(|iav_mean - 90 deg| / (mean_range[1] - 90 deg), 1)``
      (1 at a half circle, 0.5 at the upper limit of the mean).

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


# ============================================================================ batch analysis
# The detectors test every run of points of a scan at once: a scan's runs are stored back
# to back in one array (``_Runs``), their extreme and middle points and chords are array
# operations over all runs, the cheap tests on them (counts, chords, the middle point) a
# loop on plain floats over the runs (a scan has tens of them), and the inscribed angles of
# the runs that pass them are computed in one go and reduced per run with ``np.bincount``.
# Only the few runs left (the circles themselves) meet more Python code. This is what makes
# a scan cost tens of microseconds rather than a millisecond; ``tests/test_iav.py`` checks it
# against a plain loop over :func:`inscribed_angles` and :func:`middle_point_offset`.
_VERDICTS = ("accepted", "too few points", "chord too short", "chord too long", "prerequisite", "degenerate",
             "iav mean", "iav std", "v-corner", "fit failed", "occluded", "residual")
_ACCEPTED, _FEW, _SHORT, _LONG, _PREREQ, _DEGENERATE, _MEAN, _STD, _VCORNER, _FIT, _OCCLUDED, _RESIDUAL = range(12)


# The internal records below are NamedTuples rather than frozen dataclasses: they are built
# several times per scan, and a NamedTuple is several times cheaper to build.
class _Runs(NamedTuple):
    """Runs of points stored back to back: run ``k`` is rows ``starts[k]:ends[k]``."""

    idx: np.ndarray  # (K,) beam index of each point
    pts: np.ndarray  # (K, 2)
    starts: np.ndarray  # (S,)
    ends: np.ndarray  # (S,), exclusive; every run holds at least one point
    check_finite: bool = True  # False when the points are a scan's valid beams

    @property
    def sizes(self) -> np.ndarray:
        return self.ends - self.starts


_NO_RUNS = _Runs(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64))


def _runs_from_labels(scan: Scan, labels: np.ndarray) -> _Runs:
    """The segments of ``labels`` in label order (:func:`labkit.segmentation.segment_order`)."""
    idx, starts, stops = segment_order(labels)
    if idx.size == 0:
        return _NO_RUNS
    return _Runs(idx, scan.points.take(idx, axis=0), starts, stops, False)  # take: points[idx], faster


def _runs_from_segments(segments) -> _Runs:
    segs = [s for s in _check_segments(segments) if len(s.indices)]
    if not segs:
        return _NO_RUNS
    idx = np.concatenate([np.asarray(s.indices, dtype=np.int64) for s in segs])
    pts = np.concatenate([np.asarray(s.points, dtype=np.float64).reshape(-1, 2) for s in segs])
    if pts.shape[0] != idx.size:
        raise ValueError("segments must hold one point per beam index")
    ends = np.cumsum([len(s.indices) for s in segs])
    return _Runs(idx, pts, ends - np.array([len(s.indices) for s in segs]), ends)


def _scan_runs(scan: Scan, segments, seg_threshold_m: float) -> _Runs:
    if isinstance(segments, np.ndarray):
        return _runs_from_labels(scan, labels_from(scan, segments))
    if segments is not None:
        runs = _runs_from_segments(segments)
        if runs.idx.size and (runs.idx.min() < 0 or runs.idx.max() >= scan.n_beams):
            raise ValueError(f"segments has beam indices outside the scan's 0..{scan.n_beams - 1}")
        return runs
    check_positive("seg_threshold_m", seg_threshold_m)
    return _runs_from_labels(scan, segment_labels(scan, threshold_m=seg_threshold_m, min_points=2, adaptive=False))


class _Geometry(NamedTuple):
    """Per run: size, chord, first, last and middle point (row ``n // 2``), and whether all
    its points are finite (None when not checked: the points of a scan's valid beams)."""

    n: np.ndarray
    chord: np.ndarray
    p_first: np.ndarray
    p_last: np.ndarray
    middle: np.ndarray
    finite: np.ndarray | None


def _geometry(runs: _Runs) -> _Geometry:
    n = runs.ends - runs.starts
    p0 = runs.pts.take(runs.starts, axis=0)  # take(i, axis=0): pts[i], several times faster
    p1 = runs.pts.take(runs.ends - 1, axis=0)
    mid = runs.pts.take(runs.starts + n // 2, axis=0)
    d = p1 - p0
    finite = None
    if runs.check_finite:
        finite = ~(np.add.reduceat(~np.isfinite(runs.pts).all(axis=1), runs.starts) > 0)
    return _Geometry(n, np.hypot(d[:, 0], d[:, 1]), p0, p1, mid, finite)


def _cheap_tests(geo: _Geometry, chord: np.ndarray, min_points: int, chord_range: tuple[float, float],
                 middle_range: tuple[float, float], hollow: bool = False, sigma: float = 0.0,
                 widened: dict | None = None) -> tuple[list[int], list[float]]:
    """The cheap tests of every run in the detectors' order, the first failed deciding: too
    few points, chord too short, chord too long, degenerate (a non-finite point, no chord),
    and the prerequisite on the middle point (``hollow``: on either side of the chord).

    A scan holds tens of runs, not thousands, so a loop on plain floats beats array
    operations here. Returns each run's verdict (``_ACCEPTED`` when it passed them all) and
    its signed middle-point ratio (NaN for the runs that did not get that far). ``chord`` is
    the chord tested; the ratio is taken over ``geo.chord``.

    ``sigma`` > 0 (range noise, metres) widens the prerequisite band of each run by
    ``NOISE_Z`` times the ratio's standard deviation under that noise (:func:`_ratio_sd`);
    the band tested goes to ``widened[k]`` when ``widened`` is a dict.
    """
    n, chords = geo.n.tolist(), geo.chord.tolist()
    tested = chords if chord is geo.chord else chord.tolist()
    p0, p1, mid = geo.p_first.tolist(), geo.p_last.tolist(), geo.middle.tolist()
    finite = [True] * len(n) if geo.finite is None else geo.finite.tolist()
    (c_lo, c_hi), (lo, hi) = chord_range, middle_range
    verdicts, ratios = [], []
    for k in range(len(n)):
        r = math.nan
        if n[k] < min_points:
            v = _FEW
        elif tested[k] < c_lo:
            v = _SHORT
        elif tested[k] > c_hi:
            v = _LONG
        else:
            # the middle point's signed distance from the chord over the chord length,
            # cross(d, m) / chord^2, positive towards the sensor (as _middle_ratio)
            (x0, y0), (x1, y1), (xm, ym), c = p0[k], p1[k], mid[k], chords[k]
            dx, dy = x1 - x0, y1 - y0
            cross_mid = dx * (ym - y0) - dy * (xm - x0)
            cross_origin = dy * x0 - dx * y0  # cross(d, origin - p0)
            side = -cross_mid if cross_origin < 0 else abs(cross_mid) if cross_origin == 0 else cross_mid
            c2 = c * c  # (0 for chords under 1e-162 m: then side / 0 as numpy would give it)
            r = side / c2 if c2 > 0 else side * math.inf if c > 0 else math.nan
            if math.isnan(r) or not finite[k]:
                v = _DEGENERATE
            elif sigma > 0.0:
                w = NOISE_Z * _ratio_sd(p0[k], p1[k], mid[k], c, sigma)
                if widened is not None:
                    widened[k] = (lo - w, hi + w)
                v = _ACCEPTED if lo - w < (abs(r) if hollow else r) < hi + w else _PREREQ
            else:
                v = _ACCEPTED if lo < (abs(r) if hollow else r) < hi else _PREREQ
        verdicts.append(v)
        ratios.append(r)
    return verdicts, ratios


# ---------------------------------------------------------------- noise allowances
# The paper's thresholds are fixed (Table II), which is right for the 5 mm of a SICK LMS200 and
# wrong at 2 cm: a leg seen by 4 beams at 3 m has a chord of 10 cm, and 2 cm of range noise on its
# middle point alone moves the prerequisite ratio by 0.2 -- the whole distance from a half circle's
# 0.35 to the 0.1 limit. Given the range noise sigma, the tests below ask instead whether the data
# *could* come from a shape that passes: each bound is moved out by NOISE_Z standard deviations
# of the statistic under that noise, propagated to first order from the ranges of the very points
# tested (noise along each beam). sigma = 0 is the paper's test.

#: One-sided normal quantile of the noise allowances: from noise alone, a true circle fails one
#: bound 2.3 % of the time.
NOISE_Z = 2.0


#: The widened mean bound stays this many standard deviations of the mean below 180 deg (a
#: straight line), so that a short noisy piece of wall, which could be a line, is not called a circle.
LINE_Z = 3.0


def _ratio_sd(p0, p1, mid, chord: float, sigma: float) -> float:
    """Standard deviation of the middle-point ratio (signed distance from the chord over the
    chord) when the three points' ranges have noise ``sigma``, to first order: the middle
    point's range error moves it by its beam's component across the chord, each extreme's
    moves the chord at the middle by half of its own."""
    (x0, y0), (x1, y1), (xm, ym) = p0, p1, mid
    if chord <= 0.0:
        return math.inf
    ex, ey = (x1 - x0) / chord, (y1 - y0) / chord
    acc = 0.0  # each beam's unit vector's component across the chord, squared and weighted
    for x, y, w in ((xm, ym, 1.0), (x0, y0, 0.25), (x1, y1, 0.25)):
        h2 = x * x + y * y
        if h2 > 0.0:
            across = ex * y - ey * x
            acc += w * across * across / h2
    return sigma * math.sqrt(acc) / chord


def _angle_noise(p: np.ndarray, sigma: float) -> tuple[float, float]:
    """How much range noise ``sigma`` alone spreads the inscribed angles of the run ``p``
    (n, 2), n >= 3: ``(spread_max_sq, mean_sd)`` (:func:`_angle_noise_runs` for one run)."""
    spread_sq, mean_sd = _angle_noise_runs(p, np.array([0]), np.array([len(p)]), sigma)
    return spread_sq.item(0), mean_sd.item(0)


def _angle_noise_runs(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                      sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """How much range noise ``sigma`` alone spreads the inscribed angles of each run
    ``pts[starts[k]:ends[k]]`` (n >= 3 points), all runs at once: ``(spread_max_sq, mean_sd)``.

    With ``J`` the first-order derivatives of the m = n - 2 angles with respect to the n ranges
    (each point moved along its beam) and ``C`` the centring matrix, the population variance
    of the angles has the mean ``E = sigma^2 |C J|_F^2 / m`` and about ``nu`` degrees of freedom
    (Satterthwaite: ``nu = tr(S)^2 / tr(S^2)``, ``S = C J J^T C``); ``spread_max_sq`` is its
    upper ``NOISE_Z`` quantile, ``E chi2(nu) / nu`` (Wilson-Hilferty). ``mean_sd`` is the
    standard deviation of the mean angle, ``sigma |1^T J| / m``.

    Angle i depends on three ranges only: the first point's (``g_i``), its own point's (``d_i``)
    and the last point's (``h_i``). With ``gc, hc`` the centred ``g, h``, ``(C J)^T (C J)`` is
    ``[[gc.gc, d_i gc_i, gc.hc], [., d_i d_j (delta_ij - 1/m), d_i hc_i], [., ., hc.hc]]``, so
    ``tr(S)`` and ``tr(S^2)`` (its trace and squared Frobenius norm) are sums over the angles.
    """
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    m_k = ends - starts - 2
    off = np.concatenate([[0], np.cumsum(m_k)[:-1]])
    run = np.repeat(np.arange(len(starts)), m_k)  # the run of each angle
    mid = np.arange(int(m_k.sum())) + np.repeat(starts + 1 - off, m_k)  # each angle's own point
    h = np.hypot(pts[:, 0], pts[:, 1])
    u = pts / np.where(h > 0, h, 1.0)[:, None]
    p0, p1 = pts[starts][run], pts[ends - 1][run]
    pm, um = pts[mid], u[mid]
    a, b = p0 - pm, p1 - pm  # P_i -> P_1, P_i -> P_n
    na2, nb2 = a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1], b[:, 0] * b[:, 0] + b[:, 1] * b[:, 1]

    def cross(v, w):
        return v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]

    # d arg(v) = cross(v, dv) / |v|^2, and the angle is arg(b) - arg(a); a point on an end point
    # (a degenerate run, which the angle test rejects) gives NaN, not a warning
    with np.errstate(divide="ignore", invalid="ignore"):
        d = cross(a, um) / na2 - cross(b, um) / nb2
        g = -cross(a, u[starts][run]) / na2
        hh_ = cross(b, u[ends - 1][run]) / nb2
    m = m_k.astype(np.float64)

    def per_run(v):
        return np.add.reduceat(v, off)

    g_sum, h_sum = per_run(g), per_run(hh_)
    gc, hc = g - (g_sum / m)[run], hh_ - (h_sum / m)[run]
    gg, hh, gh = per_run(gc * gc), per_run(hc * hc), per_run(gc * hc)
    d2 = d * d
    sd2 = per_run(d2)
    tr = gg + hh + sd2 * (1.0 - 1.0 / m)
    tr2 = (gg * gg + hh * hh + 2.0 * gh * gh + 2.0 * per_run(d2 * (gc * gc + hc * hc))
           + per_run(d2 * d2) * (1.0 - 2.0 / m) + sd2 * sd2 / (m * m))
    mean_sd = sigma * np.sqrt(g_sum * g_sum + sd2 + h_sum * h_sum) / m
    pos = tr > 0.0
    nu = np.where(pos, tr * tr / np.where(pos, tr2, 1.0), 1.0)
    spread_sq = np.where(pos, sigma * sigma * tr / m * chi2_upper_over_dof(nu, NOISE_Z), 0.0)
    return spread_sq, mean_sd


class _Angles(NamedTuple):
    """Signed inscribed angles of selected runs, back to back, and their statistics."""

    angles: np.ndarray  # (T,)
    offsets: np.ndarray  # (R,) start of run j's angles
    counts: np.ndarray  # (R,)
    mean: np.ndarray
    std: np.ndarray
    side: np.ndarray | None  # (R,) sum of cross(chord, P_i - P_1): > 0 when the points lie left of P_1 -> P_n
    degenerate: np.ndarray  # (R,) bool: an interior point on an extreme


def _batch_angles(runs: _Runs, sel: np.ndarray, flip: np.ndarray | None = None, with_side: bool = True) -> _Angles:
    """Inscribed angles of runs ``sel`` (each of 3 points or more); ``flip`` (R,) mirrors a
    run's angles to ``2 pi - a`` (hollow arcs); ``with_side=False`` leaves ``side`` out (None).

    Points are complex numbers here: with ``a = P_1 - P_i`` and ``b = P_n - P_i`` the
    counter-clockwise angle from ``a`` to ``b`` is ``arg(b conj(a))``.
    """
    first, last = runs.starts[sel], runs.ends[sel] - 1
    counts = last - first - 1
    offsets = counts.cumsum() - counts
    r = sel.size
    run_of = np.arange(r).repeat(counts)
    pos = np.arange(run_of.size) + (first + 1 - offsets).repeat(counts)  # the interior points
    z = np.ascontiguousarray(runs.pts).view(np.complex128)[:, 0]  # each row (x, y) read as x + iy
    z0 = z[first]
    d = (z[last] - z0)[run_of]
    a = z0[run_of] - z[pos]  # rays P_i -> P_1
    b = a + d  # rays P_i -> P_n
    ac = a.conj()
    ab = b * ac
    ang = np.arctan2(ab.imag, ab.real) % (2 * np.pi)
    if flip is not None:
        ang = np.where(flip[run_of], 2 * np.pi - ang, ang)
    if a.all() and b.all():  # no interior point on an extreme (the usual case)
        degenerate = np.zeros(r, dtype=bool)
    else:
        degenerate = np.bincount(run_of, (a == 0) | (b == 0), minlength=r) > 0
    mean = np.bincount(run_of, ang, minlength=r) / counts
    var = np.bincount(run_of, (ang - mean[run_of]) ** 2, minlength=r) / counts
    side = np.bincount(run_of, (d * ac).imag, minlength=r) if with_side else None  # sum of cross(d, P_i - P_1)
    return _Angles(ang, offsets, counts, mean, np.sqrt(var), side, degenerate)


def _nearest(value: float, bounds) -> float:
    """The bound of ``bounds`` (a number or a (low, high) pair) that ``value`` is compared with."""
    if not isinstance(bounds, tuple):
        return float(bounds)
    lo, hi = bounds
    return float(lo) if abs(value - lo) <= abs(value - hi) else float(hi)


def _trace(runs: _Runs, geo: _Geometry, chord: np.ndarray, ratio, verdict, sel, ang: _Angles | None,
           algorithm: str, limits: dict, found: list, widened: dict | None = None) -> list[Step]:
    """One :class:`labkit.Step` per run, ``"accept"`` or ``"reject"``, with the values known when
    it was decided (``chord``, ``ratio``: as tested; ``verdict`` per run; ``ang``: the inscribed
    angles of the runs ``sel``, or None). ``limits``: the threshold (or (low, high) range) of
    each verdict's test; ``found``: the features, in the order of the accepted runs;
    ``widened``: per run, the limits (by verdict) that noise allowances changed."""
    mean, std = np.full(len(verdict), np.nan), np.full(len(verdict), np.nan)
    if ang is not None:
        mean[sel], std[sel] = ang.mean, ang.std
    out = []
    first, last = runs.idx[runs.starts], runs.idx[runs.ends - 1]
    features = iter(found)
    for k in range(len(verdict)):
        v = int(verdict[k])
        n = int(geo.n[k])
        c = float(chord[k]) if v != _FEW else math.nan
        r = float(ratio[k]) if v not in (_FEW, _SHORT, _LONG) else math.nan
        m, sd = (float(mean[k]), float(std[k])) if v in (_ACCEPTED, _MEAN, _STD, _VCORNER, _FIT, _OCCLUDED,
                                                         _RESIDUAL) else (
            math.nan, math.nan)
        value = {_FEW: n, _SHORT: c, _LONG: c, _PREREQ: abs(r) if limits.get("hollow") else r, _MEAN: m}.get(v, sd)
        if v == _MEAN and "mean_from" in limits:
            value = abs(m - limits["mean_from"])
        if v in (_DEGENERATE, _FIT, _OCCLUDED, _RESIDUAL):
            value = math.nan
        limit = widened[k].get(v, limits.get(v)) if widened and k in widened else limits.get(v)
        threshold = _nearest(value, limit) if limit is not None and not math.isnan(value) else math.nan
        known = [f"{n} points"] + [text for ok, text in (
            (not math.isnan(c), f"chord {c:.3f} m"), (not math.isnan(r), f"middle ratio {r:.2f}"),
            (not math.isnan(m), f"iav mean {math.degrees(m):.1f} deg, std {math.degrees(sd):.1f} deg")) if ok]
        fields = dict(value=value, threshold=threshold, test=_VERDICTS[v],
                      reason=f"{_VERDICTS[v]}: " + ", ".join(known))
        if v == _ACCEPTED:
            feature = next(features)
            if hasattr(feature, "radius"):  # a circle or an arc
                fields.update(center=tuple(float(x) for x in feature.center), radius=float(feature.radius))
            elif hasattr(feature, "diameter"):  # a leg
                fields.update(center=tuple(float(x) for x in feature.center), radius=float(feature.diameter) / 2)
            else:  # a line
                fields.update(r=float(feature.r), alpha=float(feature.alpha))
        out.append(Step(algorithm, "accept" if v == _ACCEPTED else "reject", int(first[k]), int(last[k]), **fields))
    return out


def _circle_limits(t: _CircleTest) -> dict:
    """The thresholds of the circle test by verdict, for the trace."""
    limits = {_FEW: max(t.min_points, 3), _SHORT: t.chord_range[0], _LONG: t.chord_range[1],
              _PREREQ: t.middle_range, _MEAN: t.mean_range, _STD: t.std_max, _ACCEPTED: t.std_max,
              "hollow": t.hollow}
    if t.arc_like_std_max is not None:
        limits[_STD] = limits[_VCORNER] = t.arc_like_std_max
    return limits


class _CircleTest(NamedTuple):
    """Thresholds of one circle/arc test, validated once at the public boundary."""

    min_points: int
    chord_range: tuple[float, float]
    middle_range: tuple[float, float]
    mean_range: tuple[float, float]
    std_max: float
    arc_like_std_max: float | None  # None: arc-like mode off
    v_corner_neighbours: int
    v_corner_stride: int | None  # None: max(1, n_angles // 8)
    hollow: bool  # True: accept shapes hollow towards the sensor too (arcs of rounded corners)
    center_method: str
    kind: str


def _test_runs(runs: _Runs, t: _CircleTest, want_trace: bool, algorithm: str = "iav_circles",
               sigma: float = 0.0) -> tuple[list[Circle], list[Step]]:
    """The circle test of :func:`detect_circles` on every run (``sigma`` > 0: with the noise
    allowances for that range noise)."""
    s = runs.starts.size
    if s == 0:
        return [], []
    geo = _geometry(runs)
    widened: dict = {}
    verdict, ratio = _cheap_tests(geo, geo.chord, max(t.min_points, 3), t.chord_range, t.middle_range, t.hollow,
                                  sigma, widened)
    widened = {k: {_PREREQ: band} for k, band in widened.items()}
    sel = [k for k, v in enumerate(verdict) if v == _ACCEPTED]
    circles: list[Circle] = []
    ang = None
    if sel:
        ang = _batch_angles(runs, np.array(sel), np.array([ratio[k] < 0 for k in sel]) if t.hollow else None)
        noise = [None] * len(sel)
        if sigma > 0.0:  # the angle allowances of every selected run at once
            spread_sq, mean_sd = _angle_noise_runs(runs.pts, runs.starts[sel], runs.ends[sel], sigma)
            noise = list(zip(spread_sq.tolist(), mean_sd.tolist(), strict=True))
        passed = []  # (j, k, kind, limits) of the runs whose inscribed angles pass
        for j, k in enumerate(sel):
            v, kind, limits = _angle_verdict(ang, j, t, noise[j], widened.get(k))
            verdict[k] = v
            if v == _ACCEPTED:
                passed.append((j, k, kind, limits))
        made = [_make_circle(runs, geo, ang, j, k, t, kind, limits) for j, k, kind, limits in passed]
        if sigma > 0.0 and passed:  # and their points must lie on a circle within the noise
            ks = [k for _, k, _, _ in passed]
            circle_of = [c for c, _ in made]
            centers = np.array([c.center if c is not None else (np.nan, np.nan) for c in circle_of]).reshape(-1, 2)
            radii = np.array([c.radius if c is not None else np.nan for c in circle_of])
            wider = _wider_than_noise(runs.pts, runs.starts[ks], runs.ends[ks], sigma, centers, radii).tolist()
            made = [(None, _RESIDUAL) if w else m for w, m in zip(wider, made, strict=True)]
        for (_, k, _, _), (circle, v) in zip(passed, made, strict=True):
            verdict[k] = v
            if circle is not None:
                circles.append(circle)
    if not want_trace:
        return circles, []
    return circles, _trace(runs, geo, geo.chord, ratio, verdict, sel, ang, algorithm, _circle_limits(t), circles,
                           widened)


def _angle_limits(p: np.ndarray, sigma: float, mean_range: tuple[float, float], std_max: float | None,
                  like_max: float | None = None) -> tuple[tuple[float, float], float | None, float | None]:
    """``mean_range``, ``std_max`` and ``like_max`` (the arc-like bound, or None) of a run of
    points ``p``, widened for range noise ``sigma`` (:func:`_angle_noise`); unchanged when
    ``sigma`` is 0."""
    if sigma <= 0.0:
        return mean_range, std_max, like_max
    return _widen(*_angle_noise(p, sigma), mean_range, std_max, like_max)


def _widen(spread_sq: float, mean_sd: float, mean_range: tuple[float, float], std_max: float | None,
           like_max: float | None) -> tuple[tuple[float, float], float | None, float | None]:
    """The limits of :func:`_angle_limits` for a run whose angles range noise spreads by
    ``spread_sq`` and whose mean angle it moves by ``mean_sd`` (:func:`_angle_noise_runs`)."""
    w = NOISE_Z * mean_sd
    hi = min(mean_range[1] + w, max(math.pi - LINE_Z * mean_sd, mean_range[1]))
    cap = max(ARC_LIKE_STD_MAX, like_max or 0.0)
    return ((mean_range[0] - w, hi), None if std_max is None else min(math.sqrt(std_max ** 2 + spread_sq), cap),
            None if like_max is None else min(math.sqrt(like_max ** 2 + spread_sq), cap))


def _wider_than_noise(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, sigma: float,
                      centers: np.ndarray | None = None, radii: np.ndarray | None = None) -> np.ndarray:
    """Whether the points of each run ``pts[starts[k]:ends[k]]`` lie farther from their best
    circle (orthogonal fit, :func:`labkit.fitting.fit_circles`) than range noise ``sigma``
    allows: the mean square distance per degree of freedom above the upper ``NOISE_Z`` quantile
    of ``sigma^2 chi2(n - 3) / (n - 3)``. The inscribed angles of a room's corner or a chair's
    back can pass the widened tests at a few centimetres of noise; their points do not lie on
    one circle. (A beam's noise moves its point across the circle by at most sigma, so true
    circles fail this less often than the quantile says.) Runs of 3 points, and runs no finite
    circle fits, are not. ``centers`` (K, 2) and ``radii`` (K,), if given, are a circle per run to
    try first (the detector's own; NaN: none)."""
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    out = np.zeros(len(starts), dtype=bool)
    big = np.flatnonzero(ends - starts > 3)
    if not len(big):
        return out
    dof = (ends[big] - starts[big] - 3).astype(np.float64)
    limit = sigma * sigma * chi2_upper_over_dof(dof, NOISE_Z) * dof / (dof + 3)  # on the mean square
    # Any circle whose mean square is under the limit proves a run is not wider (the best circle can
    # only do better): the circle given (or else the algebraic one, Gauss-Newton's start) decides
    # most true circles with no Gauss-Newton step. Gauss-Newton converges slowly on runs far from
    # any circle (a wall's corner, a nearly straight run), and a few steps decide most of the rest:
    # after _EARLY_STEPS steps the mean square was at most about 6 times its minimum on the runs of
    # the simulated hall at 5 mm to 3 cm and of the Radish logs (tests/test_iav.py measures it), so
    # a run _EARLY_FACTOR times over the limit is taken as wider. The few in between are fitted to
    # convergence.
    todo = big
    if centers is not None:
        sizes = ends[big] - starts[big]
        off = np.cumsum(sizes) - sizes
        run = np.repeat(np.arange(len(big)), sizes)
        q = pts[np.arange(sizes.sum()) + np.repeat(starts[big] - off, sizes)]
        c = centers[big][run]
        d = np.hypot(q[:, 0] - c[:, 0], q[:, 1] - c[:, 1]) - radii[big][run]
        with np.errstate(invalid="ignore"):
            todo = big[~(np.add.reduceat(d * d, off) / sizes <= limit)]  # (NaN: no circle given)
        if not len(todo):
            return out
    for steps in (_EARLY_STEPS, None) if centers is not None else (0, _EARLY_STEPS, None):
        fit = fit_circles(pts, starts[todo], ends[todo], "geometric",
                          **({} if steps is None else {"max_iterations": steps}))
        ms, lim = fit.rms ** 2, limit[np.searchsorted(big, todo)]
        with np.errstate(invalid="ignore"):  # (NaN where no circle fits: not wider)
            over = ms > lim
            if steps is None:
                out[todo] = over
                break
            if steps:
                out[todo] = ms > _EARLY_FACTOR * lim
                over &= ms <= _EARLY_FACTOR * lim
        todo = todo[over]
        if not len(todo):
            break
    return out


_EARLY_STEPS = 5
_EARLY_FACTOR = 16.0


def _angle_verdict(ang: _Angles, j: int, t: _CircleTest, noise: tuple | None = None,
                   widened: dict | None = None) -> tuple[int, str, tuple]:
    """The inscribed-angle tests of the ``j``-th selected run: its verdict (``_ACCEPTED`` if it
    passes), its kind, and the limits it was held to ``(mean_range, std_max)``; with a noise
    allowance, ``noise`` is its ``(spread_sq, mean_sd)`` (:func:`_angle_noise_runs`)."""
    mean_range, std_max, like_max = t.mean_range, t.std_max, t.arc_like_std_max
    if ang.degenerate.item(j):
        return _DEGENERATE, t.kind, (mean_range, std_max)
    mean, std = ang.mean.item(j), ang.std.item(j)
    if noise is not None:
        mean_range, std_max, like_max = _widen(noise[0], noise[1], mean_range, std_max, like_max)
        if widened is not None:
            widened.update({_MEAN: mean_range, _STD: std_max if like_max is None else like_max,
                            _VCORNER: like_max, _ACCEPTED: std_max})
    if not (mean_range[0] <= mean <= mean_range[1]):
        return _MEAN, t.kind, (mean_range, std_max)
    kind = t.kind
    if std >= std_max:
        if like_max is None or std >= like_max:
            return _STD, kind, (mean_range, std_max)
        angles = ang.angles[ang.offsets[j]:ang.offsets[j] + ang.counts[j]]
        stride = t.v_corner_stride if t.v_corner_stride is not None else max(1, angles.size // 8)
        if is_v_corner(angles, t.v_corner_neighbours, stride):
            return _VCORNER, kind, (mean_range, std_max)
        kind, std_max = "arc-like", like_max
    return _ACCEPTED, kind, (mean_range, std_max)


def _make_circle(runs: _Runs, geo: _Geometry, ang: _Angles, j: int, k: int, t: _CircleTest, kind: str,
                 limits: tuple) -> tuple[Circle | None, int]:
    """The circle of run ``k`` (``j``-th of the selected), which passed the tests with ``limits``
    (:func:`_angle_verdict`), and its verdict (``_FIT`` when no circle fits it)."""
    mean, std = ang.mean.item(j), ang.std.item(j)
    mean_range, std_max = limits
    try:
        if t.center_method == "iav":
            side = ang.side.item(j)
            (x1, y1), (x2, y2) = geo.p_first[k].tolist(), geo.p_last[k].tolist()
            center, radius = _circle_from_iav(x1, y1, x2, y2, mean, side if side != 0 else 1.0)
        else:
            fit = fit_circle(runs.pts[runs.starts.item(k):runs.ends.item(k)], t.center_method)
            center, radius = np.array(fit.center, dtype=np.float64), fit.radius
    except ValueError:
        return None, _FIT
    center.setflags(write=False)
    n = geo.n.item(k)
    confidence = circle_confidence(n - 2, mean, std, std_max=std_max, mean_range=mean_range)
    first, last = runs.idx.item(runs.starts.item(k)), runs.idx.item(runs.ends.item(k) - 1)
    return Circle(center, float(radius), mean, std, confidence, first, last, n, kind), _ACCEPTED


@remembered
def _circle_test(*, min_points, min_chord_m, max_chord_m, middle_range, mean_range, std_max, arc_like,
                 arc_like_std_max, v_corner_neighbours, v_corner_stride=None, hollow, center_method,
                 kind) -> _CircleTest:
    min_points = check_int("min_points", min_points, 3)
    lo = check_nonneg("min_chord_m", min_chord_m)
    hi = check_positive("max_chord_m", max_chord_m, allow_inf=True)
    if not lo < hi:
        raise ValueError(f"min_chord_m must be < max_chord_m, got {lo:g} >= {hi:g}")
    middle_range = _check_range("middle_range", middle_range, 0.0, math.inf)
    mean_range = _check_range("mean_range", mean_range, 0.0, math.pi)
    std_max = check_positive("std_max", std_max)
    like = None
    if arc_like:
        like = check_positive("arc_like_std_max", arc_like_std_max)
        if like <= std_max:
            raise ValueError(f"arc_like_std_max must exceed std_max, got {like:g} <= {std_max:g}")
    v_corner_neighbours = check_int("v_corner_neighbours", v_corner_neighbours, 2)
    if v_corner_stride is not None:
        v_corner_stride = check_int("v_corner_stride", v_corner_stride, 1)
    _check_center_method(center_method)
    return _CircleTest(min_points, (lo, hi), middle_range, mean_range, std_max, like, v_corner_neighbours,
                       v_corner_stride, hollow, center_method, kind)
