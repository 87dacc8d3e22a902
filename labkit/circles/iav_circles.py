"""Circles and arcs by the Inscribed Angle Variance (Xavier et al. 2005, Sec. II-B to II-D).

:func:`detect_circles` takes each range segment of a scan through the paper's tests in turn,
cheapest first, and :func:`detect_arcs` the stretches of the segments that lie between the
lines of a wall (rounded corners). The geometry they test with is :mod:`labkit.iav`
(inscribed angles, the prerequisite of Fig. 5, the centre from the chord); its notes give the
conventions and the two corrections to the paper's Sec. II-C.

Read :func:`_test_segment` for the tests, one short function each:

1. enough points (Table II ``circle_min_pts``): :func:`_enough_points`;
2. the chord, the distance between the extremes, within ``[min_chord_m, max_chord_m]`` (Table II
   ``circle_min_len``, ``circle_max_len``): :func:`_chord`;
3. the prerequisite of Fig. 5 (Sec. II-D): the middle point towards the sensor from the chord,
   within ``middle_range`` chords: :func:`_middle_ratio`, :func:`_in_band`;
4. the mean and the spread of the inscribed angles (Sec. II-B): :func:`_angles`, the mean within
   ``mean_range_deg`` and the spread below ``std_max_deg``;
5. with ``arc_like``, a wider spread kept unless the angles grow away from a minimum like those of
   a "V" corner (Sec. II-B.3): :func:`_is_v_corner`;
6. the centre and radius from the chord and the mean angle (Sec. II-C): :func:`_circle`.

The noise allowances (``range_sigma_m``, labkit's own: :mod:`labkit._iav_noise`) are stages of
their own: the band of Fig. 5 widened for the noise (:func:`_prerequisite_band`), the angles'
limits widened (:func:`_angle_limits`), and last the residual test (:func:`_off_one_circle`).

``trace=True`` runs these functions segment by segment and returns their
:class:`labkit.Step` records. Without it the detectors run the batch engine
(:mod:`labkit._iav_batch`), which tests every segment of a scan at once and returns the same
features (``tests/test_iav_reference.py``).

References
----------
J. Xavier, M. Pacheco, D. Castro, A. Ruano, U. Nunes, "Fast line, arc/circle and leg
detection from laser scan data in a Player driver", IEEE ICRA 2005, Sec. II-B to II-D and
Table II (the defaults here).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .._iav_batch import (
    ACCEPTED,
    DEGENERATE,
    FEW,
    FIT,
    LONG,
    MEAN,
    PREREQ,
    RESIDUAL,
    SHORT,
    STD,
    VCORNER,
    CircleTest,
    Runs,
    Seen,
    arc_pieces,
    check_scan,
    circle_engine,
    circle_limits,
    scan_runs,
)
from .._iav_noise import angle_noise, ratio_sd, widen, wider_than_noise
from .._validate import check_int
from ..features import Circle, LineSegment
from ..fitting import fit_circle
from ..iav import (
    ARC_LIKE_STD_MAX,
    CIRCLE_MEAN_RANGE,
    CIRCLE_STD_MAX,
    NOISE_Z,
    IAVStats,
    circle_confidence,
    circle_from_iav,
    inscribed_angles,
    is_v_corner,
    middle_point_offset,
)
from ..lines.split_merge import split_and_merge
from ..noise import noise_sigma
from ..params import AUTO, Params, checked_by, param
from ..scan import Scan
from ..segmentation import RangeSegment, detector_labels
from ..steps import Step

__all__ = ["CircleParams", "ArcParams", "detect_circles", "detect_arcs", "ARC_LINE_PARAMS"]


# ============================================================================ parameters
@dataclass(frozen=True)
class CircleParams(Params):
    """Parameters of :func:`detect_circles` (Xavier et al. Table II).

    The ``[circles]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    min_points: int = param(4, "fewest points (circle_min_pts)", lo=3)
    min_chord_m: float = param(0.15, "shortest chord, metres (circle_min_len)", lo=0)
    max_chord_m: float = param(math.inf, "longest chord, metres (circle_max_len; inf: unlimited)", lo=0, strict=True,
                               finite=False)
    middle_range: tuple = param((0.1, 0.7), "prerequisite band: the middle point's distance from the chord, "
                                            "as a fraction of the chord", lo=0)
    mean_range_deg: tuple = param(tuple(math.degrees(a) for a in CIRCLE_MEAN_RANGE), "accepted IAV mean, degrees",
                                  lo=0, hi=180)
    std_max_deg: float = param(math.degrees(CIRCLE_STD_MAX), "largest IAV standard deviation, degrees "
                                                             "(circle_std_max 0.15 rad)", lo=0, strict=True)
    center_method: str = param("iav", "centre and radius: iav (the paper's construction), algebraic or geometric",
                               choices=("iav", "algebraic", "geometric"))
    arc_like: bool = param(False, "also keep arc-like shapes (tree trunks) with a larger spread, minus V-corners")
    arc_like_std_max_deg: float = param(math.degrees(ARC_LIKE_STD_MAX), "arc-like: largest IAV standard deviation, "
                                                                        "degrees", lo=0, strict=True)
    v_corner_neighbours: int = param(4, "arc-like: neighbours whose angles must grow for a V-corner", lo=2)
    range_sigma_m: float = param(AUTO, "range noise the tests allow for, metres (0: the paper's fixed tests); "
                                      "auto: estimated from each scan (labkit.noise)", lo=0, auto=True)

    @classmethod
    def check_relations(cls, values) -> None:
        _check_chords(cls, values)
        if values["arc_like"] and not values["arc_like_std_max_deg"] > values["std_max_deg"]:
            raise ValueError(f"{cls._where('arc_like_std_max_deg')} must exceed std_max_deg when arc_like is on, "
                             f"got {values['arc_like_std_max_deg']:g} <= {values['std_max_deg']:g}")


@dataclass(frozen=True)
class ArcParams(Params):
    """Parameters of :func:`detect_arcs`.

    The ``[arcs]`` table of :class:`labkit.Config`, each
    default once: lengths in metres, angles in degrees. ``split_threshold_m`` and
    ``min_length_m`` are the finer line pass's (:data:`ARC_LINE_PARAMS`)."""

    split_threshold_m: float = param(0.02, "split threshold of the finer line pass, metres", lo=0, strict=True)
    min_length_m: float = param(0.5, "shortest line of the finer line pass, metres", lo=0)
    min_points: int = param(4, "fewest points of an arc", lo=3)
    min_chord_m: float = param(0.15, "shortest chord of an arc, metres", lo=0)
    max_chord_m: float = param(math.inf, "longest chord of an arc, metres (inf: unlimited)", lo=0, strict=True,
                               finite=False)
    middle_range: tuple = param((0.1, 0.7), "prerequisite band: the middle point's distance from the chord, on "
                                            "either side, as a fraction of the chord", lo=0)
    mean_range_deg: tuple = param((90.0, 155.0), "accepted IAV mean, degrees", lo=0, hi=180)
    std_max_deg: float = param(math.degrees(CIRCLE_STD_MAX), "largest IAV standard deviation, degrees", lo=0,
                               strict=True)
    center_method: str = param("geometric", "centre and radius: geometric, algebraic or iav",
                               choices=("iav", "algebraic", "geometric"))

    @classmethod
    def check_relations(cls, values) -> None:
        _check_chords(cls, values)


def _check_chords(cls: type[Params], values) -> None:
    if not values["min_chord_m"] < values["max_chord_m"]:
        raise ValueError(f"{cls._where('min_chord_m')} must be < max_chord_m, got {values['min_chord_m']:g} >= "
                         f"{values['max_chord_m']:g}")


#: The finer line pass of :func:`detect_arcs` (Sec. II-B.2: "a very low peak error and high distance between
#: line endpoints"): the paper's 0.02 m peak error, and lines shorter than 0.5 m dropped so that arcs are not
#: cut into small polygons (:class:`ArcParams`' defaults).
ARC_LINE_PARAMS = MappingProxyType({"split_threshold_m": ArcParams.split_threshold_m,
                                    "min_length_m": ArcParams.min_length_m})


# ============================================================================ circles
@checked_by(CircleParams)
def detect_circles(
    scan: Scan,
    *,
    min_points: int = CircleParams.min_points,
    min_chord_m: float = CircleParams.min_chord_m,
    max_chord_m: float = CircleParams.max_chord_m,
    middle_range: tuple[float, float] = CircleParams.middle_range,
    mean_range_deg: tuple[float, float] = CircleParams.mean_range_deg,
    std_max_deg: float = CircleParams.std_max_deg,
    center_method: str = CircleParams.center_method,
    arc_like: bool = CircleParams.arc_like,
    arc_like_std_max_deg: float = CircleParams.arc_like_std_max_deg,
    v_corner_neighbours: int = CircleParams.v_corner_neighbours,
    v_corner_stride: int | None = None,
    range_sigma_m: float | str = CircleParams.range_sigma_m,
    seg_threshold_m: float | None = None,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[Circle] | tuple[list[Circle], list[Step]]:
    """Circles in a scan by the Inscribed Angle Variance (Xavier et al. 2005, Sec. II-B to II-D).

    Each range segment is tested in order, cheapest test first (the module notes name the
    function of each):

    1. at least ``min_points`` points (Table II ``circle_min_pts``);
    2. chord -- the distance between the segment's extreme points, which is what
       Table II's ``circle_min_len``/``circle_max_len`` "length" measures, as
       ``line_min_len`` is the "distance between extremes" (Sec. II-F) -- in
       ``[min_chord_m, max_chord_m]``;
    3. the prerequisite of Fig. 5: the middle point lies towards the sensor from the
       chord, between ``middle_range`` times the chord length (see
       :func:`labkit.iav.middle_point_offset`);
    4. the signed inscribed angles (see :mod:`labkit.iav`) have a mean in ``mean_range_deg``
       and a standard deviation below ``std_max_deg``.

    With ``arc_like=True`` a segment whose standard deviation is in
    ``[std_max_deg, arc_like_std_max_deg)`` is kept as ``kind="arc-like"`` (a tree trunk, a
    not-so-round bin) unless :func:`labkit.iav.is_v_corner` says it is a V-shaped corner
    (Sec. II-B.3). The centre comes from :func:`labkit.iav.circle_from_iav` (``center_method="iav"``,
    the paper's construction) or from :func:`labkit.fitting.fit_circle` (``"algebraic"``,
    Kasa; ``"geometric"``, orthogonal distances). ``confidence`` is
    :func:`labkit.iav.circle_confidence`.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    min_points : int
        Table II ``circle_min_pts``: 4 (at least 3 for an inscribed angle).
    min_chord_m, max_chord_m : float, metres
        Table II ``circle_min_len`` 150 mm, ``circle_max_len`` unlimited (99999 mm).
    middle_range : (float, float)
        Fig. 5 / Eq. (4): 0.1 and 0.7 of the chord.
    mean_range_deg : (float, float), degrees
        90 to 135 (Sec. II-B).
    std_max_deg : float, degrees
        Table II ``circle_std_max``: 0.15 rad (8.6 degrees).
    center_method : {"iav", "algebraic", "geometric"}
    arc_like : bool
        Also report "arc-like" shapes (Sec. II-B.3). Default False.
    arc_like_std_max_deg : float, degrees
        Upper spread of "arc-like" shapes: 23 (it must exceed ``std_max_deg`` when ``arc_like``).
    v_corner_neighbours : int
        Neighbours of the smallest angle checked by the V-corner test: 4.
    v_corner_stride : int or None
        Step between those neighbours (:func:`labkit.iav.is_v_corner`). ``None`` (default):
        ``max(1, n_angles // 8)``; 1 is the paper's literal test. Measured with an LMS200
        (0.5 deg, 5 mm) on 60, 90 and 120 deg corners with 0.3-0.6 m arms at 1.5-5 m
        (900 scans): 16 passed as "arc-like" with stride 1, 1 with the default; of 200
        irregular trunks (16-gons, corners 10-15 % off the circle) 22 and 26 were kept
        as "arc-like".
    range_sigma_m : float or "auto", metres
        Range noise the tests allow for (:data:`labkit.iav.NOISE_Z` below). Default
        ``"auto"``; 0: the paper's fixed thresholds. Given sigma, each test asks whether the segment *could* be
        a circle seen through that noise: the prerequisite band, the mean range and the
        spread limit are widened by what sigma does to the segment's own points (first-order
        propagation along the beams; the spread limit becomes ``sqrt(std_max^2 + q)`` with
        ``q`` the upper ``NOISE_Z`` quantile of the spread noise alone gives). ``"auto"``:
        sigma estimated from the scan (:func:`labkit.noise.scan_sigma`). A column of 0.3 m
        seen by an LMS200 with 2 cm of noise spreads its inscribed angles by 10-20 deg,
        beyond Table II's 8.6 deg, so the fixed test misses about half the circles there.
        Given sigma, a segment that passes must also lie on one circle within that noise
        (the orthogonal fit's mean square distance per degree of freedom, against the upper
        ``NOISE_Z`` quantile of chi-square; ``test="residual"``): at 2 cm and 1 deg steps the
        widened tests alone called 90 % of convex 120 deg corners with 0.6 m arms circles,
        with it about a quarter; on the Radish logs it cuts the circles per scan by 33-71 %.
    seg_threshold_m : float or None, metres
        A fixed range segmentation threshold (Table II ``seg_threshold``, 80 mm). Default None:
        the default segmentation (:func:`labkit.segment_labels`, adaptive with an 80 mm floor),
        its breakpoints following ``range_sigma_m`` too. Ignored when ``segments`` is given.
    segments : list of RangeSegment or ndarray of per-beam labels, optional
        Precomputed segments (shared with other detectors, as the pipeline does).
    trace : bool
        Run the reference, segment by segment, and also return one :class:`labkit.Step` per
        segment (``algorithm="iav_circles"``), in scan order: ``"accept"`` with the circle's
        ``center`` and ``radius`` (``value`` the inscribed angles' standard deviation,
        ``threshold`` ``std_max_deg`` in radians), or ``"reject"``; ``test`` is the first test
        the segment failed (``"too few points"``, ``"chord too short"``, ``"chord too long"``,
        ``"prerequisite"``, ``"degenerate"``, ``"iav mean"``, ``"iav std"``, ``"v-corner"``,
        ``"residual"``, ``"fit failed"``; ``"accepted"``), ``value`` and ``threshold`` what it
        compared (points, chord, middle ratio, mean or standard deviation of the inscribed
        angles, radians; the threshold as the noise allowance widened it), ``reason`` every
        statistic computed. Replay: the ``accept`` steps are the returned circles, one for one.

    Returns
    -------
    circles : list of Circle
        The circles found (``kind="circle"`` or ``"arc-like"``), in scan order.
    steps : list of Step
        Only with ``trace=True``, which returns ``(circles, steps)``: one step per segment.

    Examples
    --------
    A column of radius 0.3 m, 3 m in front of the sensor:

    >>> from labkit import sim
    >>> world = sim.World("demo", circles=(sim.Column((3.0, 0.0), 0.3),))
    >>> scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> (c,) = detect_circles(scan)
    >>> np.round(c.center, 2).tolist(), round(c.radius, 2), c.kind
    ([3.0, 0.0], 0.3, 'circle')
    """
    check_scan(scan)
    if v_corner_stride is not None:
        v_corner_stride = check_int("v_corner_stride", v_corner_stride, 1)
    test = CircleTest(min_points=min_points, chord_range=(min_chord_m, max_chord_m), middle_range=middle_range,
                      mean_range=_radians(mean_range_deg), std_max=math.radians(std_max_deg),
                      arc_like_std_max=math.radians(arc_like_std_max_deg) if arc_like else None,
                      v_corner_neighbours=v_corner_neighbours, v_corner_stride=v_corner_stride, hollow=False,
                      center_method=center_method, kind="circle")
    runs = _segments(scan, segments, seg_threshold_m, range_sigma_m)
    sigma = noise_sigma(scan, range_sigma_m)
    if not trace:  # the engine: every segment at once, the same circles
        return circle_engine(runs, test, sigma)[0]
    return _reference(runs, test, sigma, "iav_circles")


def _radians(pair: tuple[float, float]) -> tuple[float, float]:
    """A pair of angles in degrees, in radians."""
    low, high = pair
    return math.radians(low), math.radians(high)


def _segments(scan: Scan, segments, seg_threshold_m: float | None, range_sigma_m) -> Runs:
    """The segments a detector tests: ``segments`` if given, else the scan cut at
    ``seg_threshold_m``, else the default segmentation following ``range_sigma_m``."""
    if segments is None and seg_threshold_m is None:
        segments = detector_labels(scan, None, range_sigma_m)
    return scan_runs(scan, segments, seg_threshold_m)


def _reference(runs: Runs, t: CircleTest, sigma: float, algorithm: str) -> tuple[list[Circle], list[Step]]:
    """The circle test of Xavier et al. on each segment in turn, and what each test saw."""
    circles, steps = [], []
    limits = circle_limits(t)
    for beams, points in runs.segments():
        seen = Seen(len(points))
        circle = _test_segment(points, beams, t, sigma, seen)
        if circle is not None:
            circles.append(circle)
        steps.append(seen.step(algorithm, beams, limits, circle))
    return circles, steps


def _test_segment(points: np.ndarray, beams: np.ndarray, t: CircleTest, sigma: float, seen: Seen) -> Circle | None:
    """The circle of one segment, or None; ``seen`` records what the tests saw and the first
    that failed."""
    # Table II circle_min_pts: enough points
    if not _enough_points(points, t.min_points):
        seen.reject(FEW)
        return None
    # Table II circle_min_len, circle_max_len: the chord
    seen.chord = _chord(points)
    if seen.chord < t.chord_range[0]:
        seen.reject(SHORT)
        return None
    if seen.chord > t.chord_range[1]:
        seen.reject(LONG)
        return None
    # Sec. II-D, Fig. 5: the prerequisite, the middle point within a band beside the chord
    seen.ratio = _middle_ratio(points)
    if math.isnan(seen.ratio):
        seen.reject(DEGENERATE)
        return None
    band = _prerequisite_band(points, seen.chord, t.middle_range, sigma, seen)
    if not _in_band(seen.ratio, band, either_side=t.hollow):
        seen.reject(PREREQ)
        return None
    # Sec. II-B: the inscribed angles, their mean and spread
    angles = _angles(points, hollow=t.hollow and seen.ratio < 0)
    if angles is None:
        seen.reject(DEGENERATE)
        return None
    seen.mean, seen.std, _ = IAVStats.from_angles(angles)
    mean_range, std_max, like_max = _angle_limits(points, t, sigma, seen)
    if not mean_range[0] <= seen.mean <= mean_range[1]:
        seen.reject(MEAN)
        return None
    kind = t.kind
    if seen.std >= std_max:
        # Sec. II-B.3: "arc-like" shapes, a wider spread, unless a V-shaped corner
        if like_max is None or seen.std >= like_max:
            seen.reject(STD)
            return None
        if _is_v_corner(angles, t):
            seen.reject(VCORNER)
            return None
        kind, std_max = "arc-like", like_max
    # Sec. II-C: the centre and the radius
    circle = _circle(points, beams, seen, t.center_method, kind, mean_range, std_max)
    if circle is None:
        seen.reject(FIT)
        return None
    # the noise allowance's last stage: the points lie on one circle within the noise
    if sigma > 0.0 and _off_one_circle(points, circle, sigma):
        seen.reject(RESIDUAL)
        return None
    return circle


def _enough_points(points: np.ndarray, min_points: int) -> bool:
    """At least ``min_points`` points, and 3 for an inscribed angle."""
    return len(points) >= max(min_points, 3)


def _chord(points: np.ndarray) -> float:
    """The distance between the extreme points."""
    dx, dy = points[-1] - points[0]
    return float(np.hypot(dx, dy))


def _middle_ratio(points: np.ndarray) -> float:
    """The middle point's distance from the chord over the chord, towards the sensor
    (:func:`labkit.iav.middle_point_offset`); NaN where it is undefined (no chord, a point
    not finite)."""
    try:
        return middle_point_offset(points)
    except ValueError:
        return math.nan


def _prerequisite_band(points: np.ndarray, chord: float, middle_range: tuple[float, float], sigma: float,
                       seen: Seen) -> tuple[float, float]:
    """Noise allowance: the band of Fig. 5 widened on both sides by ``NOISE_Z`` standard deviations
    of the ratio under range noise ``sigma`` (:func:`labkit._iav_noise.ratio_sd`; ``chord`` the
    segment's own); the paper's band when ``sigma`` is 0."""
    if sigma <= 0.0:
        return middle_range
    first, last, middle = points[0].tolist(), points[-1].tolist(), points[len(points) // 2].tolist()
    w = NOISE_Z * ratio_sd(first, last, middle, chord, sigma)
    band = (middle_range[0] - w, middle_range[1] + w)
    seen.widened = {PREREQ: band}
    return band


def _in_band(ratio: float, band: tuple[float, float], either_side: bool = False) -> bool:
    """Eq. (4): ``low < ratio < high``; ``either_side``: the ratio's size (an arc hollow towards
    the sensor, as a rounded room corner, lies on the far side of its chord)."""
    return band[0] < (abs(ratio) if either_side else ratio) < band[1]


def _angles(points: np.ndarray, hollow: bool) -> np.ndarray | None:
    """The signed inscribed angles (:func:`labkit.iav.inscribed_angles`), mirrored to
    ``2 pi - a`` for a ``hollow`` arc so that every arc's mean lies below 180 deg; None where
    they are undefined (an interior point on an extreme)."""
    try:
        angles = inscribed_angles(points, signed=True)
    except ValueError:
        return None
    return 2 * np.pi - angles if hollow else angles


def _angle_limits(points: np.ndarray, t: CircleTest, sigma: float,
                  seen: Seen) -> tuple[tuple[float, float], float, float | None]:
    """Noise allowance: the mean range, the spread limit and the arc-like spread limit, widened by
    what range noise ``sigma`` does to this segment's angles (:func:`labkit._iav_noise.angle_noise`);
    the paper's when ``sigma`` is 0."""
    mean_range, std_max, like_max = t.mean_range, t.std_max, t.arc_like_std_max
    if sigma > 0.0:
        mean_range, std_max, like_max = widen(*angle_noise(points, sigma), mean_range, std_max, like_max)
        assert seen.widened is not None, "_prerequisite_band set it (sigma > 0)"
        seen.widened.update({MEAN: mean_range, STD: std_max if like_max is None else like_max, VCORNER: like_max,
                             ACCEPTED: std_max})
    return mean_range, std_max, like_max


def _is_v_corner(angles: np.ndarray, t: CircleTest) -> bool:
    """Fig. 4: the angles grow away from their minimum on both sides (:func:`labkit.iav.is_v_corner`),
    its neighbours taken ``v_corner_stride`` angles apart (default ``max(1, n // 8)``)."""
    stride = t.v_corner_stride if t.v_corner_stride is not None else max(1, angles.size // 8)
    return is_v_corner(angles, t.v_corner_neighbours, stride)


def _circle(points: np.ndarray, beams: np.ndarray, seen: Seen, center_method: str, kind: str,
            mean_range: tuple[float, float], std_max: float) -> Circle | None:
    """The circle of a segment that passed the tests with ``mean_range`` and ``std_max``: centre and
    radius by :func:`labkit.iav.circle_from_iav` (the paper's construction) or a fit; None when none
    fits."""
    try:
        if center_method == "iav":
            side = _side(points)
            center, radius = circle_from_iav(points[0], points[-1], seen.mean, side if side != 0 else 1.0)
        else:
            fit = fit_circle(points, center_method)
            center, radius = np.array(fit.center, dtype=np.float64), fit.radius
    except ValueError:
        return None
    center.setflags(write=False)
    n = len(points)
    confidence = circle_confidence(n - 2, seen.mean, seen.std, std_max=std_max, mean_range=mean_range)
    return Circle(center, float(radius), seen.mean, seen.std, confidence, int(beams[0]), int(beams[-1]), n, kind)


def _side(points: np.ndarray) -> float:
    """Which side of the chord ``P_1 -> P_n`` the interior points lie on: the sum of
    ``cross(P_n - P_1, P_i - P_1)``, > 0 on its left (only its sign is used)."""
    dx, dy = points[-1] - points[0]
    inner = points[1:-1] - points[0]
    return float(np.sum(dx * inner[:, 1] - dy * inner[:, 0]))


def _off_one_circle(points: np.ndarray, circle: Circle, sigma: float) -> bool:
    """Noise allowance, the residual test: the points lie farther from their best circle than range
    noise ``sigma`` allows (:func:`labkit._iav_noise.wider_than_noise`, trying the circle found first).
    A corner's angles can pass the widened tests at a few centimetres of noise; its points do not lie
    on one circle."""
    return bool(wider_than_noise(points, np.array([0]), np.array([len(points)]), sigma,
                                 np.array([circle.center]), np.array([circle.radius]))[0])


# ============================================================================ arcs
@checked_by(ArcParams, positional=("lines",))
def detect_arcs(
    scan: Scan,
    *,
    lines: list[LineSegment] | None = None,
    split_threshold_m: float = ArcParams.split_threshold_m,
    min_length_m: float = ArcParams.min_length_m,
    min_points: int = ArcParams.min_points,
    min_chord_m: float = ArcParams.min_chord_m,
    max_chord_m: float = ArcParams.max_chord_m,
    middle_range: tuple[float, float] = ArcParams.middle_range,
    mean_range_deg: tuple[float, float] = ArcParams.mean_range_deg,
    std_max_deg: float = ArcParams.std_max_deg,
    center_method: str = ArcParams.center_method,
    line_params: dict | None = None,
    seg_threshold_m: float | None = None,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[Circle] | tuple[list[Circle], list[Step]]:
    """Arcs embedded in lines, such as rounded wall corners (Xavier et al. Sec. II-B.2, Fig. 3).

    Lines are found first; their points are excluded, and each remaining run of
    consecutive points of one range segment that borders an excluded point (an arc
    *between* or *after* lines, not a free-standing object -- that is
    :func:`detect_circles`' job) gets the circle test of :func:`detect_circles`, with
    two differences:

    * the arc may bulge towards the sensor (an outside corner) or be hollow towards it
      (a room's rounded corner seen from inside): the prerequisite uses the middle
      point's distance from the chord on either side, and a hollow arc's angles are
      mirrored (``2 pi - a``) before the mean test;
    * ``mean_range_deg`` reaches 155, not 135: the paper gives no separate bound, and a
      quarter-round corner has a mean of exactly 135 deg when all of it is seen and more
      when the line fits take its ends. 155 deg keeps arcs spanning 50 deg or more and
      stays well below a line's 180 deg; the prerequisite's 0.1 ratio already stops
      arcs under 45 deg.

    The paper's fixed tests: no noise allowance. Returned records have ``kind="arc"``.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    lines : list of LineSegment, optional
        Lines whose ``indices`` are excluded. ``None``: run
        :func:`labkit.split_and_merge` with ``split_threshold_m`` and ``min_length_m``.
        The paper's advice holds: the line extractor must not cut arcs into small
        polygons (low peak error, long minimum line length). ``split_and_merge``'s own
        defaults (0.05 m split threshold, 0.15 m shortest line) cover a 0.8 m rounded
        corner with short lines and leave no arc; :data:`ARC_LINE_PARAMS` (0.02 m, 0.5 m)
        leaves it whole. (Passing ``lines`` by position, ``detect_arcs(scan, lines)``, is
        deprecated.)
    split_threshold_m, min_length_m : float, metres
        The finer line pass when ``lines`` is None (:data:`ARC_LINE_PARAMS`); not used otherwise.
    min_points : int, default 4
        Fewest points of an arc.
    min_chord_m, max_chord_m : float, default 0.15 and inf
        Shortest and longest chord of an arc, metres.
    middle_range : tuple of float, default (0.1, 0.7)
        The circle prerequisite's band (:func:`labkit.iav.middle_point_offset`).
    mean_range_deg : tuple of float, default (90.0, 155.0)
        The band of the mean inscribed angle, degrees.
    std_max_deg : float, default 8.59
        Largest standard deviation of the inscribed angles, degrees.
    center_method : {"geometric", "algebraic", "iav"}
        Default ``"geometric"``, not the paper's construction: embedded arcs are short
        (90 deg or less) and the lines take their ends, which is where the IAV
        construction is weakest. In rooms with rounded corners of 0.4-1.2 m seen by an
        LMS200 from 2-4 m, the median radius error was 0.5-2 % with the geometric fit
        and 2-5 % with the IAV construction (largest 9 % and 18 %).
    line_params : dict, optional
        Deprecated: ``split_and_merge``'s keywords for the line pass; use ``split_threshold_m``
        and ``min_length_m``.
    seg_threshold_m : float or None, metres
        A fixed range segmentation threshold; default None: the default segmentation.
    segments : list of RangeSegment or ndarray of per-beam labels, optional
        Precomputed segments, as for :func:`detect_circles`.
    trace : bool, default False
        Also return one :class:`labkit.Step` per run tested (``algorithm="iav_arcs"``), as
        :func:`detect_circles`.

    Returns
    -------
    arcs : list of Circle
        The arcs found (``kind="arc"``), in scan order.
    steps : list of Step
        Only with ``trace=True``, which returns ``(arcs, steps)``.

    Examples
    --------
    A room corner rounded with a radius of 0.8 m, seen from 2 m inside the room; the two
    walls are given as lines:

    >>> from labkit import sim
    >>> from labkit.features import line_segment
    >>> corner = sim.Arc((2.2, 2.2), 0.8, 0.0, np.pi / 2)
    >>> walls = (sim.Wall((3.0, -2.0), (3.0, 2.2)), sim.Wall((2.2, 3.0), (-2.0, 3.0)))
    >>> world = sim.World("demo", walls=walls, arcs=(corner,))
    >>> scan, truth = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> lines = [line_segment(scan.points[w.first:w.last + 1], np.arange(w.first, w.last + 1)) for w in truth.walls]
    >>> (arc,) = detect_arcs(scan, lines=lines)
    >>> np.round(arc.center, 2).tolist(), round(arc.radius, 2), arc.kind
    ([2.2, 2.2], 0.8, 'arc')
    """
    check_scan(scan)
    test = CircleTest(min_points=min_points, chord_range=(min_chord_m, max_chord_m), middle_range=middle_range,
                      mean_range=_radians(mean_range_deg), std_max=math.radians(std_max_deg), arc_like_std_max=None,
                      v_corner_neighbours=4, v_corner_stride=None, hollow=True, center_method=center_method,
                      kind="arc")
    if line_params is not None:
        if lines is not None:
            raise ValueError("line_params is only used when lines is None")
        warnings.warn("detect_arcs(line_params=...) is deprecated: use split_threshold_m=..., min_length_m=...",
                      DeprecationWarning, stacklevel=3)
        lines = split_and_merge(scan, **{"split_threshold_m": split_threshold_m, "min_length_m": min_length_m,
                                         **line_params})
    elif lines is None:  # the finer line pass of Sec. II-B.2
        lines = split_and_merge.unchecked(scan, split_threshold_m=split_threshold_m, min_length_m=min_length_m)
    on_line = _beams_of(lines, scan.n_beams)
    runs = _segments(scan, segments, seg_threshold_m, None)
    if not trace:  # the engine: every stretch at once, the same arcs
        return circle_engine(arc_pieces(runs, on_line), test, 0.0, algorithm="iav_arcs")[0]
    return _arcs_reference(runs, on_line, test)


def _beams_of(lines, n_beams: int) -> np.ndarray:
    """Per beam, whether one of ``lines`` holds it."""
    on_line = np.zeros(n_beams, dtype=bool)
    for line in lines:
        idx = getattr(line, "indices", None)
        if idx is None:
            raise ValueError(f"lines must be LineSegment records with beam indices, got {type(line).__name__}")
        idx = np.asarray(idx, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= n_beams):
            raise ValueError(f"lines has beam indices outside the scan's 0..{n_beams - 1}")
        on_line[idx] = True
    return on_line


def _arcs_reference(runs: Runs, on_line: np.ndarray, t: CircleTest) -> tuple[list[Circle], list[Step]]:
    """Sec. II-B.2 and Fig. 3 on each segment in turn: in a segment that holds a line, each stretch
    of points off the lines gets the circle test."""
    arcs, steps = [], []
    limits = circle_limits(t)
    for beams, points in runs.segments():
        off_line = ~on_line[beams]
        if off_line.all():  # no line here: a free-standing object, detect_circles' job
            continue
        for a, b in _stretches(off_line):
            seen = Seen(b - a)
            arc = _test_segment(points[a:b], beams[a:b], t, 0.0, seen)
            if arc is not None:
                arcs.append(arc)
            steps.append(seen.step("iav_arcs", beams[a:b], limits, arc))
    return arcs, steps


def _stretches(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of consecutive True values of ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))
