"""Inscribed Angle Variance (IAV): circles, arcs and lines from the geometry of arcs.

Every point ``P_i`` of an arc sees the arc's extremes ``P_1`` and ``P_n`` under the same
angle (Euclid III.21, the inscribed angle theorem), so the inscribed angles
``angle(P_1, P_i, P_n)`` of a range segment have a small spread when the segment is an
arc, and a mean that tells how much of the circle is visible: 90 deg for a half circle,
180 deg for a straight line (Xavier et al. 2005, Sec. II-B).

* :func:`inscribed_angles`, :func:`iav_stats` -- the angles and their mean and spread
* :func:`middle_point_offset` -- the circle prerequisite of Fig. 5 (Sec. II-D)
* :func:`circle_from_iav` -- centre and radius from the chord and the mean angle (Sec. II-C)
* :func:`is_v_corner` -- the V-corner test that guards the "arc-like" mode (Sec. II-B.3)
* :func:`detect_circles` -- circles (and, optionally, "arc-like" shapes such as tree trunks)
* :func:`labkit.lines.iav.detect_lines_iav` -- lines as segments whose inscribed angles are all near 180 deg
* :func:`detect_arcs` -- arcs embedded in lines, e.g. rounded wall corners (Sec. II-B.2)

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

References
----------
J. Xavier, M. Pacheco, D. Castro, A. Ruano, U. Nunes, "Fast line, arc/circle and leg
detection from laser scan data in a Player driver", IEEE ICRA 2005, Sec. II-B to II-D and
Table II (the defaults here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .._iav import (  # the shared machinery; the public names are documented here
    ARC_LIKE_STD_MAX,
    CIRCLE_MEAN_RANGE,
    CIRCLE_STD_MAX,
    NOISE_Z,
    IAVStats,
    _check_scan,
    _circle_test,
    _Runs,
    _scan_runs,
    _test_runs,
    circle_confidence,
    circle_from_iav,
    iav_stats,
    inscribed_angles,
    is_v_corner,
    middle_point_offset,
)
from ..features import Circle, LineSegment
from ..noise import noise_sigma
from ..params import AUTO, Params, param
from ..scan import Scan
from ..segmentation import RangeSegment
from ..steps import Step
from ._takes_params import old_kwargs, takes_params

__all__ = [
    "CircleParams",
    "ArcParams",
    "IAVStats",
    "inscribed_angles",
    "iav_stats",
    "middle_point_offset",
    "circle_from_iav",
    "is_v_corner",
    "circle_confidence",
    "detect_circles",
    "detect_arcs",
    "ARC_LINE_PARAMS",
    "CIRCLE_STD_MAX",
    "ARC_LIKE_STD_MAX",
    "CIRCLE_MEAN_RANGE",
    "NOISE_Z",
]

#: Line extraction before :func:`detect_arcs` (Sec. II-B.2: "a very low peak error and high distance between
#: line endpoints"): the paper's 0.02 m peak error, and lines shorter than 0.5 m dropped so that arcs are not
#: cut into small polygons.


# ============================================================================ detectors


@dataclass(frozen=True)
class CircleParams(Params):
    """Parameters of :func:`detect_circles` and the ``[circles]`` table of :class:`labkit.Config`
    (Xavier et al. Table II), each default once: lengths in metres, angles in degrees."""

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
    v_corner_neighbours: int = param(4, "arc-like: neighbours whose angles must grow for a V-corner", lo=1)
    range_sigma_m: float = param(AUTO, "range noise the tests allow for, metres (0: the paper's fixed tests); "
                                      "auto: estimated from each scan (labkit.noise)", lo=0, auto=True)


@dataclass(frozen=True)
class ArcParams(Params):
    """Parameters of :func:`detect_arcs` and the ``[arcs]`` table of :class:`labkit.Config`, each
    default once: lengths in metres, angles in degrees. ``split_threshold_m`` and
    ``min_length_m`` are the finer line pass's (:data:`ARC_LINE_PARAMS`)."""

    split_threshold_m: float = param(0.02, "split threshold of the finer line pass, metres", lo=0, strict=True)
    min_length_m: float = param(0.5, "shortest line of the finer line pass, metres", lo=0)
    min_points: int = param(4, "fewest points of an arc", lo=3)
    min_chord_m: float = param(0.15, "shortest chord of an arc, metres", lo=0)
    mean_range_deg: tuple = param((90.0, 155.0), "accepted IAV mean, degrees", lo=0, hi=180)
    std_max_deg: float = param(math.degrees(CIRCLE_STD_MAX), "largest IAV standard deviation, degrees", lo=0,
                               strict=True)
    center_method: str = param("geometric", "centre and radius: geometric, algebraic or iav",
                               choices=("iav", "algebraic", "geometric"))

    def _old_kwargs(self) -> dict:
        kw = old_kwargs(self)
        kw["line_params"] = {"split_threshold_m": kw.pop("split_threshold_m"), "min_length_m": kw.pop("min_length_m")}
        return kw

    def _finish(self, kw: dict, raw: dict) -> dict:
        if kw.get("lines") is not None and "line_params" not in raw:  # given lines, there is no line pass
            kw.pop("line_params")
        return kw


#: The finer line pass of :func:`detect_arcs` (:class:`ArcParams` ' defaults).
ARC_LINE_PARAMS = MappingProxyType({"split_threshold_m": ArcParams.split_threshold_m,
                                    "min_length_m": ArcParams.min_length_m})


@takes_params(CircleParams, segmented=True, own_segmentation=("seg_threshold_m",))
def detect_circles(
    scan: Scan,
    *,
    seg_threshold_m: float = 0.08,
    min_points: int,
    min_chord_m: float,
    max_chord_m: float,
    middle_range: tuple[float, float],
    mean_range: tuple[float, float],
    std_max: float,
    center_method: str,
    arc_like: bool,
    arc_like_std_max: float,
    v_corner_neighbours: int,
    v_corner_stride: int | None = None,
    range_sigma_m: float | str,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[Circle] | tuple[list[Circle], list[Step]]:
    """Circles in a scan by the Inscribed Angle Variance (Xavier et al. 2005, Sec. II-B to II-D).

    Each range segment is tested in order, cheapest test first:

    1. at least ``min_points`` points (Table II ``circle_min_pts``);
    2. chord -- the distance between the segment's extreme points, which is what
       Table II's ``circle_min_len``/``circle_max_len`` "length" measures, as
       ``line_min_len`` is the "distance between extremes" (Sec. II-F) -- in
       ``[min_chord_m, max_chord_m]``;
    3. the prerequisite of Fig. 5: the middle point lies towards the sensor from the
       chord, between ``middle_range`` times the chord length (see :func:`middle_point_offset`);
    4. the signed inscribed angles (see the module notes) have a mean in ``mean_range``
       and a standard deviation below ``std_max``.

    With ``arc_like=True`` a segment whose standard deviation is in
    ``[std_max, arc_like_std_max)`` is kept as ``kind="arc-like"`` (a tree trunk, a
    not-so-round bin) unless :func:`is_v_corner` says it is a V-shaped corner
    (Sec. II-B.3). The centre comes from :func:`circle_from_iav` (``center_method="iav"``,
    the paper's construction) or from :func:`labkit.fitting.fit_circle` (``"algebraic"``,
    Kasa; ``"geometric"``, orthogonal distances). ``confidence`` is
    :func:`circle_confidence`.

    Parameters
    ----------
    scan : Scan
    seg_threshold_m : float, metres
        Range segmentation threshold (Table II ``seg_threshold``, 80 mm). Ignored when
        ``segments`` is given.
    min_points : int
        Table II ``circle_min_pts``: 4 (at least 3 for an inscribed angle).
    min_chord_m, max_chord_m : float, metres
        Table II ``circle_min_len`` 150 mm, ``circle_max_len`` unlimited (99999 mm).
    middle_range : (float, float)
        Fig. 5 / Eq. (4): 0.1 and 0.7 of the chord.
    mean_range : (float, float), radians
        90 to 135 deg (Sec. II-B).
    std_max : float, radians
        Table II ``circle_std_max``: 0.15 rad (8.6 deg).
    center_method : {"iav", "algebraic", "geometric"}
    arc_like : bool
        Also report "arc-like" shapes (Sec. II-B.3). Default False.
    arc_like_std_max : float, radians
        Upper spread of "arc-like" shapes: 23 deg.
    v_corner_neighbours : int
        Neighbours of the smallest angle checked by the V-corner test: 4.
    v_corner_stride : int or None
        Step between those neighbours (:func:`is_v_corner`). ``None`` (default):
        ``max(1, n_angles // 8)``; 1 is the paper's literal test. Measured with an LMS200
        (0.5 deg, 5 mm) on 60, 90 and 120 deg corners with 0.3-0.6 m arms at 1.5-5 m
        (900 scans): 16 passed as "arc-like" with stride 1, 1 with the default; of 200
        irregular trunks (16-gons, corners 10-15 % off the circle) 22 and 26 were kept
        as "arc-like".
    range_sigma_m : float or "auto", metres
        Range noise the tests allow for (:data:`labkit.circles.iav.NOISE_Z` below). Default
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
        Without ``segments``, the scan's own segmentation follows this noise too (not 0).
    trace : bool
        Also return one :class:`labkit.Step` per segment (``algorithm="iav_circles"``),
        in scan order: ``"accept"`` with the circle's ``center`` and ``radius`` (``value``
        the inscribed angles' standard deviation, ``threshold`` ``std_max``), or
        ``"reject"``; ``test`` is the first test the segment failed (``"too few points"``,
        ``"chord too short"``, ``"chord too long"``, ``"prerequisite"``, ``"degenerate"``,
        ``"iav mean"``, ``"iav std"``, ``"v-corner"``, ``"residual"``, ``"fit failed"``;
        ``"accepted"``),
        ``value`` and ``threshold`` what it compared (points, chord, middle ratio, mean or
        standard deviation of the inscribed angles), ``reason`` every statistic computed.
        Replay: the ``accept`` steps are the returned circles, one for one.

    Returns
    -------
    list of Circle (``kind="circle"`` or ``"arc-like"``), in scan order; with
    ``trace``, ``(circles, steps)``.

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
    _check_scan(scan)
    test = _circle_test(min_points=min_points, min_chord_m=min_chord_m, max_chord_m=max_chord_m,
                        middle_range=middle_range, mean_range=mean_range, std_max=std_max, arc_like=arc_like,
                        arc_like_std_max=arc_like_std_max, v_corner_neighbours=v_corner_neighbours,
                        v_corner_stride=v_corner_stride, hollow=False, center_method=center_method, kind="circle")
    circles, steps = _test_runs(_scan_runs(scan, segments, seg_threshold_m), test, trace,
                                sigma=noise_sigma(scan, range_sigma_m))
    return (circles, steps) if trace else circles


@takes_params(ArcParams, positional=("lines",), segmented=True, own_segmentation=("seg_threshold_m",))
def detect_arcs(
    scan: Scan,
    *,
    lines: list[LineSegment] | None = None,
    seg_threshold_m: float = 0.08,
    min_points: int,
    min_chord_m: float,
    max_chord_m: float = math.inf,
    middle_range: tuple[float, float] = (0.1, 0.7),
    mean_range: tuple[float, float],
    std_max: float,
    center_method: str,
    line_params: dict | None = None,
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
    * ``mean_range`` reaches 155 deg, not 135: the paper gives no separate bound, and a
      quarter-round corner has a mean of exactly 135 deg when all of it is seen and more
      when the line fits take its ends. 155 deg keeps arcs spanning 50 deg or more and
      stays well below a line's 180 deg; the prerequisite's 0.1 ratio already stops
      arcs under 45 deg.

    Returned records have ``kind="arc"``.

    Parameters
    ----------
    scan : Scan
    lines : list of LineSegment, optional
        Lines whose ``indices`` are excluded. ``None``: run
        ``labkit.lines.split_merge.split_and_merge(scan, **ARC_LINE_PARAMS, **line_params)``.
        The paper's advice holds: the line extractor must not cut arcs into small
        polygons (low peak error, long minimum line length). ``split_and_merge``'s own
        defaults (0.05 m split threshold, 0.15 m shortest line) cover a 0.8 m rounded
        corner with short lines and leave no arc; ``ARC_LINE_PARAMS`` (0.02 m, 0.5 m)
        leaves it whole.
    line_params : dict, optional
        Keyword arguments for ``split_and_merge`` when ``lines`` is None, overriding
        ``ARC_LINE_PARAMS``.
    center_method : {"geometric", "algebraic", "iav"}
        Default ``"geometric"``, not the paper's construction: embedded arcs are short
        (90 deg or less) and the lines take their ends, which is where the IAV
        construction is weakest. In rooms with rounded corners of 0.4-1.2 m seen by an
        LMS200 from 2-4 m, the median radius error was 0.5-2 % with the geometric fit
        and 2-5 % with the IAV construction (largest 9 % and 18 %).
    Other parameters
        As :func:`detect_circles`.

    Returns
    -------
    list of Circle in scan order; with ``trace``, ``(arcs, steps)``: one :class:`labkit.Step`
    per run tested (``algorithm="iav_arcs"``), as :func:`detect_circles`.

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
    >>> (arc,) = detect_arcs(scan, lines)
    >>> np.round(arc.center, 2).tolist(), round(arc.radius, 2), arc.kind
    ([2.2, 2.2], 0.8, 'arc')
    """
    _check_scan(scan)
    test = _circle_test(min_points=min_points, min_chord_m=min_chord_m, max_chord_m=max_chord_m,
                        middle_range=middle_range, mean_range=mean_range, std_max=std_max, arc_like=False,
                        arc_like_std_max=None, v_corner_neighbours=4, hollow=True, center_method=center_method,
                        kind="arc")
    if lines is None:
        from ..lines.split_merge import split_and_merge  # lazily: the line extractor is optional here

        lines = split_and_merge(scan, **{**ARC_LINE_PARAMS, **(line_params or {})})
    elif line_params is not None:
        raise ValueError("line_params is only used when lines is None")
    excluded = np.zeros(scan.n_beams, dtype=bool)
    for line in lines:
        idx = getattr(line, "indices", None)
        if idx is None:
            raise ValueError(f"lines must be LineSegment records with beam indices, got {type(line).__name__}")
        idx = np.asarray(idx, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= scan.n_beams):
            raise ValueError(f"lines has beam indices outside the scan's 0..{scan.n_beams - 1}")
        excluded[idx] = True
    runs = _scan_runs(scan, segments, seg_threshold_m)
    if runs.starts.size == 0:
        return ([], []) if trace else []
    # keep the points of segments that hold a line, minus the lines' points, cut into runs
    out = excluded[runs.idx]
    seg_of = np.repeat(np.arange(runs.starts.size), runs.sizes)
    has_line = np.add.reduceat(out, runs.starts) > 0
    keep = ~out & has_line[seg_of]
    continues = np.concatenate([[False], keep[:-1] & (seg_of[1:] == seg_of[:-1])])
    kept = np.flatnonzero(keep)
    if kept.size == 0:
        return ([], []) if trace else []
    starts = np.flatnonzero(~continues[kept])
    sub = _Runs(runs.idx[kept], runs.pts.take(kept, axis=0), starts, np.concatenate([starts[1:], [kept.size]]),
                runs.check_finite)
    arcs, steps = _test_runs(sub, test, trace, "iav_arcs")
    return (arcs, steps) if trace else arcs
