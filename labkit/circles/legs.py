"""Leg detection and pairing legs into people (Xavier et al. 2005, Sec. II-E).

A leg at knee height is a small, round, fully visible segment. Xavier et al. detect it
as "an extension of the circle prerequisites": a range segment is a leg when

1. it has at least ``min_points`` points (the paper works with at least 3);
2. the distance between its extreme points -- the chord -- lies in the range of leg
   diameters, 0.1 to 0.25 m (see "Chord padding" below for the one change we make);
3. its middle point passes the circle prerequisite of Fig. 5 (it lies towards the sensor
   from the chord, between 0.1 and 0.7 chord lengths, see
   :func:`labkit.circles.iav.middle_point_offset`);
4. it is not partially occluded (below).

The paper applies no inscribed-angle test to legs (Sec. II-E lists only the conditions
above; legs "sometimes get classified as circles also"). :func:`detect_legs` can add
one (``iav_mean_range``, ``iav_std_max``) but does not by default; the IAV statistics
are computed and stored in every :class:`~labkit.features.Leg` either way.

Chord padding (a deviation from the paper, on by default). The extreme beams of a
segment hit the leg up to one beam spacing inside its silhouette on each side, so the
chord underestimates the diameter by one beam spacing ``r * angle_increment`` on
average (about 3 cm for a 0.14 m leg at 3.5 m with 0.5 deg beams). Compared literally,
most legs beyond 3 m seen by 3 or 4 beams fall below 0.1 m, while pieces of larger
objects cut by the segmentation pass. :func:`detect_legs` therefore compares
``chord + chord_padding_beams * r * angle_increment`` (``r`` the middle point's range)
with the diameter range; ``chord_padding_beams=1`` by default, ``0`` is the paper's
literal test. Measured on the simulator's ``hall`` scenario (LMS200, 0.5 deg, 5 mm
noise, seeds 0-3, 300 scans each, a detection matching a true leg within 0.1 m):
precision 0.98-0.99 and recall 0.90-0.93 of the legs seen by at least 3 beams and not
occluded, against 0.82 and 0.64 for the literal test.

Occlusion rule. Let ``first`` and ``last`` be the segment's extreme beams. The segment is
partially occluded when the beam just before ``first`` or just after ``last`` is a valid
return *closer* to the sensor than the segment's end beside it (``range[first - 1] <
range[first]`` or ``range[last + 1] < range[last]``): something in front hides part of
the leg, so its chord underestimates the leg and the middle point is not the leg's
middle. A neighbour that is invalid (no return, dropout) does not occlude. On a scan that
does not cover the full circle, a segment that touches the first or last beam is cut by
the field of view and counts as occluded; on a full-circle scan the neighbours wrap.

Degenerate segments (fewer than 3 points, identical points) are skipped, never raised,
as in :mod:`labkit.circles.iav`.

References
----------
J. Xavier et al., "Fast line, arc/circle and leg detection from laser scan data in a
Player driver", IEEE ICRA 2005, Sec. II-D and II-E.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .._cache import remembered
from .._checks import check_int, check_nonneg, check_positive
from .._iav import (
    _ACCEPTED,
    _DEGENERATE,
    _FEW,
    _FIT,
    _LONG,
    _MEAN,
    _OCCLUDED,
    _PREREQ,
    _SHORT,
    _STD,
    _angle_limits,
    _batch_angles,
    _cheap_tests,
    _check_range,
    _check_scan,
    _geometry,
    _scan_runs,
    _trace,
    circle_from_iav,
)
from ..features import Leg, Person
from ..fitting import fit_circle
from ..noise import noise_sigma
from ..params import AUTO, Params, param
from ..scan import Scan
from ..segmentation import RangeSegment
from ..steps import Step
from ._takes_params import old_kwargs, takes_params

__all__ = ["LegsParams", "detect_legs", "pair_legs", "is_occluded"]

_LEG_CENTER_METHODS = ("ray", "iav", "algebraic", "geometric")


def is_occluded(scan: Scan, first: int, last: int) -> bool:
    """Whether the run of beams ``first..last`` is partially occluded (module notes).

    Examples
    --------
    >>> from labkit import Scan
    >>> s = Scan(ranges=[3.0, 2.0, 2.0, 2.0, 1.5], angles=np.radians([0, 1, 2, 3, 4]))
    >>> is_occluded(s, 1, 3)      # beam 4 (1.5 m) is in front of beam 3 (2.0 m)
    True
    >>> is_occluded(s, 1, 2)      # beam 0 behind, beam 3 at the same range: not occluded
    False
    """
    _check_scan(scan)
    n = scan.n_beams
    for name, beam in (("first", first), ("last", last)):
        if isinstance(beam, bool) or int(beam) != beam or not 0 <= beam < n:
            raise ValueError(f"{name} must be a beam index in 0..{n - 1}, got {beam!r}")
    return _occluded(scan, int(first), int(last))


def _occluded(scan: Scan, first: int, last: int) -> bool:
    """:func:`is_occluded` without the checks."""
    n = scan.n_beams
    r, valid = scan.ranges, scan.valid
    for end, nb in ((first, first - 1), (last, last + 1)):
        if not 0 <= nb < n:
            if not scan.is_full_circle:
                return True  # cut by the edge of the field of view
            nb %= n
        if valid.item(nb) and r.item(nb) < r.item(end):
            return True
    return False


def _leg_center(points: np.ndarray, chord: float, mean: float, side: float,
                method: str) -> tuple[np.ndarray, float]:
    """Centre and diameter of a leg segment."""
    if method == "ray":
        mx, my = points[points.shape[0] // 2].tolist()
        h, k = math.hypot(mx, my), 0.5 * chord
        return np.array([mx + k * mx / h, my + k * my / h]), chord
    if method == "iav":
        center, radius = circle_from_iav(points[0], points[-1], mean, side if side != 0 else 1.0)
        return np.asarray(center, dtype=np.float64), 2.0 * radius
    fit = fit_circle(points, method)
    return np.array(fit.center, dtype=np.float64), 2.0 * fit.radius


@dataclass(frozen=True)
class LegsParams(Params):
    """Parameters of :func:`detect_legs` and :func:`pair_legs`, and the ``[legs]`` table of
    :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    _not_passed = ("pair_max_distance_m",)  # pair_legs's
    min_points: int = param(3, "fewest points of a leg", lo=3)
    chord_range_m: tuple = param((0.1, 0.25), "accepted chord, metres (Xavier et al.)", lo=0)
    chord_padding_beams: float = param(1.0, "widen the chord by this many beam spacings at the leg's range", lo=0)
    middle_range: tuple = param((0.1, 0.7), "prerequisite band: the middle point's distance from the chord, "
                                            "as a fraction of the chord", lo=0)
    iav_mean_range_deg: tuple = param((0.0, 180.0), "accepted IAV mean, degrees ([0, 180]: not tested)", lo=0,
                                      hi=180)
    iav_std_max_deg: float = param(math.inf, "largest IAV standard deviation, degrees (inf: not tested)",
                                   lo=0, strict=True, finite=False)
    reject_occluded: bool = param(True, "drop segments partly hidden behind a nearer object")
    center_method: str = param("ray", "centre: ray (middle point pushed back by the radius), iav, algebraic, "
                                      "geometric", choices=("ray", "iav", "algebraic", "geometric"))
    range_sigma_m: float = param(AUTO, "range noise the tests allow for, metres (0: the paper's fixed tests); "
                                      "auto: estimated from each scan (labkit.noise)", lo=0, auto=True)
    pair_max_distance_m: float = param(0.6, "two legs closer than this are one person, metres (pair_legs)",
                                       lo=0, strict=True)

    @classmethod
    def old_renamed(cls) -> dict:
        return {"chord_range_m": "chord_range"}

    def _old_kwargs(self) -> dict:
        kw = old_kwargs(self)
        if self.iav_mean_range_deg == (0.0, 180.0):
            kw["iav_mean_range"] = None
        if math.isinf(self.iav_std_max_deg):
            kw["iav_std_max"] = None
        return kw


@takes_params(LegsParams, segmented=True, own_segmentation=("seg_threshold_m",))
def detect_legs(
    scan: Scan,
    *,
    seg_threshold_m: float = 0.08,
    min_points: int,
    chord_range: tuple[float, float],
    chord_padding_beams: float,
    middle_range: tuple[float, float],
    iav_mean_range: tuple[float, float] | None,
    iav_std_max: float | None,
    reject_occluded: bool,
    center_method: str,
    range_sigma_m: float | str,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[Leg] | tuple[list[Leg], list[Step]]:
    """Leg candidates in a scan (Xavier et al. 2005, Sec. II-E; see the module notes).

    Parameters
    ----------
    scan : Scan
    seg_threshold_m : float, metres
        Range segmentation threshold (Table II, 80 mm). Ignored when ``segments`` is given.
    min_points : int
        Fewest points of a leg: 3 (one inscribed angle).
    chord_range : (float, float), metres
        Distance between the segment's extremes: 0.1 to 0.25 m, the expected leg diameters.
    chord_padding_beams : float
        Beam spacings added to the chord before the range test (module notes): 1.
        0 reproduces the paper's literal test.
    middle_range : (float, float)
        The circle prerequisite (Fig. 5): 0.1 to 0.7 of the chord, towards the sensor.
    iav_mean_range : (float, float) or None, radians
        Optional bound on the mean inscribed angle (e.g. the circles' 90 to 135 deg).
        None (default): no test, as in the paper.
    iav_std_max : float or None, radians
        Optional bound on the spread of the inscribed angles (e.g. 0.15 rad). None: no test.
    reject_occluded : bool
        Apply the occlusion rule (default True).
    center_method : {"ray", "iav", "algebraic", "geometric"}
        ``"ray"`` (default): the middle point moved half a (padded) chord further along
        its beam, i.e. the centre of a circle whose diameter is the padded chord, seen
        straight on; ``diameter`` is the padded chord. ``"iav"``:
        :func:`labkit.circles.iav.circle_from_iav`; ``"algebraic"``/``"geometric"``:
        :func:`labkit.fitting.fit_circle`; with these three, ``diameter`` is twice the
        fitted radius. On the ``hall`` scenario (as above) ``"ray"`` has the larger
        median centre error (1.4 cm against 0.9 cm) but no outliers (largest 4 cm against
        8-11 cm; diameters within 4 cm against up to 20 cm off), since 3 to 5 noisy
        points define a circle poorly.
    range_sigma_m : float or "auto", metres
        Range noise the tests allow for, as :func:`labkit.detect_circles`: the prerequisite
        band (and the IAV bounds, when given) widened by what that noise does to the
        segment's own points. Default ``"auto"``: estimated from the scan; 0: the paper's
        fixed test.
        With 2 cm of noise, the 2 cm on a 10 cm leg's middle point alone moves its
        prerequisite ratio by 0.2, and the fixed test misses a third of the legs (hall,
        300 scans: recall 0.69 fixed, 0.99 with the allowance). The price: 3-7 points of a
        10-25 cm piece cannot tell round from flat at that noise, and with no angle test
        (the paper has none for legs) a flat piece of leg width, such as a box's face,
        passes the widened band about half the time at 2 cm and a fifth at 5 mm (15 % and
        1 % with the fixed band; ``tests/test_noise_aware.py``). Without ``segments``, the
        scan's own segmentation follows this noise too (not 0).
    segments : list of RangeSegment or ndarray of per-beam labels, optional
        Precomputed segments (:func:`labkit.segmentation.labels_from`).
    trace : bool
        Also return one :class:`labkit.Step` per segment (``algorithm="legs"``), as
        :func:`labkit.detect_circles` does (the chord tested is the padded chord; an
        ``"accept"`` step's circle is the leg: its centre and half its diameter; ``test``
        may also be ``"occluded"``).

    Returns
    -------
    list of Leg in scan order (``middle`` is the segment's middle point, the paper's
    record); with ``trace``, ``(legs, steps)``.

    Examples
    --------
    >>> from labkit import sim
    >>> world = sim.World("demo", circles=(sim.Column((2.0, 0.5), 0.07),))
    >>> scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> (leg,) = detect_legs(scan)
    >>> np.round(leg.center, 2).tolist(), round(leg.diameter, 2), leg.n_points
    ([1.99, 0.5], 0.12, 7)
    """
    _check_scan(scan)
    min_points, (chord_lo, chord_hi), middle_range, iav_mean_range, iav_std_max, chord_padding_beams = _leg_params(
        min_points, chord_range, middle_range, iav_mean_range, iav_std_max, center_method, chord_padding_beams)
    runs = _scan_runs(scan, segments, seg_threshold_m)
    if runs.starts.size == 0:
        return ([], []) if trace else []
    geo = _geometry(runs)
    spacing = abs(scan.angle_increment) if scan.n_beams > 1 else 0.0
    chord = geo.chord + chord_padding_beams * spacing * np.hypot(geo.middle[:, 0], geo.middle[:, 1])
    sigma = noise_sigma(scan, range_sigma_m)
    widened: dict = {}
    verdict, ratio = _cheap_tests(geo, chord, min_points, (chord_lo, chord_hi), middle_range, sigma=sigma,
                                  widened=widened)
    widened = {k: {_PREREQ: band} for k, band in widened.items()}
    sel = [k for k, v in enumerate(verdict) if v == _ACCEPTED]
    legs: list[Leg] = []
    ang = None
    if sel:
        ang = _batch_angles(runs, np.array(sel), with_side=center_method == "iav")
        for j, k in enumerate(sel):
            a, b = runs.starts.item(k), runs.ends.item(k)
            first, last = runs.idx.item(a), runs.idx.item(b - 1)
            m, sd = ang.mean.item(j), ang.std.item(j)
            mean_range, std_max = iav_mean_range, iav_std_max
            if sigma > 0.0 and not (mean_range is None and std_max is None):
                mean_range, std_max, _ = _angle_limits(runs.pts[a:b], sigma, mean_range or (0.0, math.pi), std_max)
                widened[k].update({_MEAN: mean_range, _STD: std_max, _ACCEPTED: std_max})
                mean_range = mean_range if iav_mean_range is not None else None
            if ang.degenerate.item(j):
                verdict[k] = _DEGENERATE
            elif mean_range is not None and not mean_range[0] <= m <= mean_range[1]:
                verdict[k] = _MEAN
            elif std_max is not None and sd >= std_max:
                verdict[k] = _STD
            elif reject_occluded and _occluded(scan, first, last):
                verdict[k] = _OCCLUDED
            else:
                side = ang.side.item(j) if center_method == "iav" else 0.0  # (only the iav centre needs it)
                try:
                    center, diameter = _leg_center(runs.pts[a:b], chord.item(k), m, side, center_method)
                except ValueError:
                    verdict[k] = _FIT
                    continue
                middle = np.array(geo.middle[k], dtype=np.float64)
                center.setflags(write=False)
                middle.setflags(write=False)
                legs.append(Leg(center, float(diameter), middle, first, last, b - a, m, sd))
    if not trace:
        return legs
    limits = {_FEW: min_points, _SHORT: chord_lo, _LONG: chord_hi, _PREREQ: middle_range}
    if iav_mean_range is not None:
        limits[_MEAN] = tuple(iav_mean_range)
    if iav_std_max is not None:
        limits[_STD] = limits[_ACCEPTED] = iav_std_max
    return legs, _trace(runs, geo, chord, ratio, verdict, sel, ang, "legs", limits, legs, widened)


@remembered
def _leg_params(min_points, chord_range, middle_range, iav_mean_range, iav_std_max, center_method,
                chord_padding_beams) -> tuple:
    """The parameters of :func:`detect_legs` checked, in its order, and converted."""
    min_points = check_int("min_points", min_points, 3)
    chord_range = _check_range("chord_range", chord_range, 0.0, math.inf)
    middle_range = _check_range("middle_range", middle_range, 0.0, math.inf)
    if iav_mean_range is not None:
        iav_mean_range = _check_range("iav_mean_range", iav_mean_range, 0.0, math.pi)
    if iav_std_max is not None:
        iav_std_max = check_positive("iav_std_max", iav_std_max)
    if center_method not in _LEG_CENTER_METHODS:
        raise ValueError(f"center_method must be one of {_LEG_CENTER_METHODS}, got {center_method!r}")
    chord_padding_beams = check_nonneg("chord_padding_beams", chord_padding_beams)
    return min_points, chord_range, middle_range, iav_mean_range, iav_std_max, chord_padding_beams


def pair_legs(legs: list[Leg], max_distance_m: float = LegsParams.pair_max_distance_m) -> list[Person]:
    """Pair legs into people: greedily, closest pair first, while the two centres are at
    most ``max_distance_m`` apart.

    All pairwise distances between leg centres are sorted; each pair in turn becomes a
    :class:`~labkit.features.Person` unless one of its legs is already taken. Unpaired
    legs are left out. The default 0.6 m covers a walking adult's legs at knee height:
    the simulator's gait (0.4 m steps, legs 0.25 m apart) separates them by at most
    0.47 m, and a person standing still by about a leg's width plus a gap.

    Parameters
    ----------
    legs : list of Leg
    max_distance_m : float, metres

    Returns
    -------
    list of Person, closest pair first; each person's ``legs`` are in scan order
    (by ``first``) and ``center`` is the midpoint of the two leg centres.

    Examples
    --------
    >>> def leg(x, y, first):
    ...     c = np.array([x, y])
    ...     return Leg(c, 0.14, c, first, first + 4, 5, 2.0, 0.1)
    >>> people = pair_legs([leg(2.0, 0.0, 10), leg(2.0, 0.3, 20), leg(4.0, 2.0, 40)])
    >>> len(people), np.round(people[0].center, 3).tolist()
    (1, [2.0, 0.15])
    """
    max_distance_m = check_positive("max_distance_m", max_distance_m)
    legs = list(legs)
    for leg in legs:
        if not isinstance(leg, Leg):
            raise ValueError(f"legs must be Leg records, got {type(leg).__name__}")
    if len(legs) < 2:
        return []
    centers = np.array([leg.center for leg in legs], dtype=np.float64).tolist()
    pairs = list(itertools.combinations(range(len(legs)), 2))  # (0, 1), (0, 2), ..., (1, 2), ...
    dist = np.hypot([centers[i][0] - centers[j][0] for i, j in pairs],
                    [centers[i][1] - centers[j][1] for i, j in pairs])
    order = dist.argsort(kind="stable").tolist()
    dist = dist.tolist()
    used = [False] * len(legs)
    people: list[Person] = []
    for k in order:
        if dist[k] > max_distance_m:
            break
        a, b = pairs[k]
        if used[a] or used[b]:
            continue
        used[a] = used[b] = True
        pair = tuple(sorted((legs[a], legs[b]), key=lambda g: g.first))
        (xa, ya), (xb, yb) = centers[a], centers[b]
        center = np.array([0.5 * (xa + xb), 0.5 * (ya + yb)])
        center.setflags(write=False)
        people.append(Person(center, pair))
    return people
