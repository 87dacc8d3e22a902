"""Leg detection and pairing legs into people (Xavier et al. 2005, Sec. II-E).

A leg at knee height is a small, round, fully visible segment. Xavier et al. detect it
as "an extension of the circle prerequisites": a range segment is a leg when

1. it has at least ``min_points`` points (the paper works with at least 3);
2. the distance between its extreme points -- the chord -- lies in the range of leg
   diameters, 0.1 to 0.25 m (see "Chord padding" below for the one change we make);
3. its middle point passes the circle prerequisite of Fig. 5 (it lies towards the sensor
   from the chord, between 0.1 and 0.7 chord lengths, see
   :func:`labkit.iav.middle_point_offset`);
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
as in :mod:`labkit.circles.iav_circles`.

Read :func:`_test_segment` for the tests in the paper's order, one short function each:
enough points, the (padded) chord within the leg diameters, the prerequisite of Fig. 5
(shared with :mod:`labkit.circles.iav_circles`), the optional angle tests, the occlusion rule,
and the centre. The noise allowances (``range_sigma_m``) are stages of their own: the band of
Fig. 5 and the optional angle limits widened for the noise (:mod:`labkit._iav_noise`).
``trace=True`` runs these functions segment by segment; without it :func:`detect_legs` runs
the batch engine (:mod:`labkit._iav_batch`), which gives the same legs.

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

from .._iav_batch import (
    ACCEPTED,
    DEGENERATE,
    FEW,
    FIT,
    LONG,
    MEAN,
    OCCLUDED,
    PREREQ,
    SHORT,
    STD,
    LegTest,
    Runs,
    Seen,
    check_scan,
    leg_center,
    leg_engine,
    leg_limits,
    occluded,
)
from .._iav_noise import angle_limits
from .._validate import check_positive
from ..features import Leg, Person
from ..iav import IAVStats
from ..noise import noise_sigma
from ..params import AUTO, Params, checked_by, param
from ..scan import Scan
from ..segmentation import RangeSegment
from ..steps import Step
from .iav_circles import _angles, _chord, _in_band, _middle_ratio, _prerequisite_band, _segments, _side

__all__ = ["LegsParams", "detect_legs", "pair_legs", "is_occluded"]


def is_occluded(scan: Scan, first: int, last: int) -> bool:
    """Whether the run of beams ``first..last`` is partially occluded (module notes).

    Parameters
    ----------
    scan : Scan
        The scan.
    first : int
        The run's first beam.
    last : int
        Its last beam.

    Returns
    -------
    bool
        True when the beam just before or after the run is a valid return closer than the run's
        end beside it, or when the run touches the edge of a field of view that is not a full circle.

    Examples
    --------
    >>> from labkit import Scan
    >>> s = Scan(ranges=[3.0, 2.0, 2.0, 2.0, 1.5], angles=np.radians([0, 1, 2, 3, 4]))
    >>> is_occluded(s, 1, 3)      # beam 4 (1.5 m) is in front of beam 3 (2.0 m)
    True
    >>> is_occluded(s, 1, 2)      # beam 0 behind, beam 3 at the same range: not occluded
    False
    """
    check_scan(scan)
    n = scan.n_beams
    for name, beam in (("first", first), ("last", last)):
        if isinstance(beam, bool) or int(beam) != beam or not 0 <= beam < n:
            raise ValueError(f"{name} must be a beam index in 0..{n - 1}, got {beam!r}")
    return occluded(scan, int(first), int(last))


@dataclass(frozen=True)
class LegsParams(Params):
    """Parameters of :func:`detect_legs` and :func:`pair_legs`.

    The ``[legs]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    _not_passed = ("pair_max_distance_m",)  # pair_legs's
    min_points: int = param(3, "fewest points of a leg", lo=3)
    chord_range_m: tuple = param((0.1, 0.25), "accepted chord, metres (Xavier et al.)", lo=0)
    chord_padding_beams: float = param(1.0, "widen the chord by this many beam spacings at the leg's range", lo=0)
    middle_range: tuple = param((0.1, 0.7), "prerequisite band: the middle point's distance from the chord, "
                                            "as a fraction of the chord", lo=0)
    iav_mean_range_deg: tuple = param((0.0, 180.0), "accepted IAV mean, degrees ([0, 180] or none: not tested)",
                                      lo=0, hi=180, optional=True)
    iav_std_max_deg: float = param(math.inf, "largest IAV standard deviation, degrees (inf or none: not tested)",
                                   lo=0, strict=True, finite=False, optional=True)
    reject_occluded: bool = param(True, "drop segments partly hidden behind a nearer object")
    center_method: str = param("ray", "centre: ray (middle point pushed back by the radius), iav, algebraic, "
                                      "geometric", choices=("ray", "iav", "algebraic", "geometric"))
    range_sigma_m: float = param(AUTO, "range noise the tests allow for, metres (0: the paper's fixed tests); "
                                      "auto: estimated from each scan (labkit.noise)", lo=0, auto=True)
    pair_max_distance_m: float = param(0.6, "two legs closer than this are one person, metres (pair_legs)",
                                       lo=0, strict=True)

    @classmethod
    def renamed(cls) -> dict:
        return {"chord_range": "chord_range_m"}


@checked_by(LegsParams)
def detect_legs(
    scan: Scan,
    *,
    min_points: int = LegsParams.min_points,
    chord_range_m: tuple[float, float] = LegsParams.chord_range_m,
    chord_padding_beams: float = LegsParams.chord_padding_beams,
    middle_range: tuple[float, float] = LegsParams.middle_range,
    iav_mean_range_deg: tuple[float, float] | None = LegsParams.iav_mean_range_deg,
    iav_std_max_deg: float | None = LegsParams.iav_std_max_deg,
    reject_occluded: bool = LegsParams.reject_occluded,
    center_method: str = LegsParams.center_method,
    range_sigma_m: float | str = LegsParams.range_sigma_m,
    seg_threshold_m: float | None = None,
    segments: list[RangeSegment] | np.ndarray | None = None,
    trace: bool = False,
) -> list[Leg] | tuple[list[Leg], list[Step]]:
    """Leg candidates in a scan (Xavier et al. 2005, Sec. II-E; see the module notes).

    Parameters
    ----------
    scan : Scan
        The laser scan.
    min_points : int
        Fewest points of a leg: 3 (one inscribed angle).
    chord_range_m : (float, float), metres
        Distance between the segment's extremes: 0.1 to 0.25 m, the expected leg diameters
        (``chord_range``, its old name, is deprecated).
    chord_padding_beams : float
        Beam spacings added to the chord before the range test (module notes): 1.
        0 reproduces the paper's literal test.
    middle_range : (float, float)
        The circle prerequisite (Fig. 5): 0.1 to 0.7 of the chord, towards the sensor.
    iav_mean_range_deg : (float, float) or None, degrees
        Optional bound on the mean inscribed angle (e.g. the circles' 90 to 135).
        Default (0, 180), or None: no test, as in the paper.
    iav_std_max_deg : float or None, degrees
        Optional bound on the spread of the inscribed angles (e.g. 8.6). Default inf, or None:
        no test.
    reject_occluded : bool
        Apply the occlusion rule (default True).
    center_method : {"ray", "iav", "algebraic", "geometric"}
        ``"ray"`` (default): the middle point moved half a (padded) chord further along
        its beam, i.e. the centre of a circle whose diameter is the padded chord, seen
        straight on; ``diameter`` is the padded chord. ``"iav"``:
        :func:`labkit.iav.circle_from_iav`; ``"algebraic"``/``"geometric"``:
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
        1 % with the fixed band; ``tests/test_noise_aware.py``).
    seg_threshold_m : float or None, metres
        A fixed range segmentation threshold (Table II, 80 mm). Default None: the default
        segmentation, its breakpoints following ``range_sigma_m`` too. Ignored when
        ``segments`` is given.
    segments : list of RangeSegment or ndarray of per-beam labels, optional
        Precomputed segments (:func:`labkit.segmentation.labels_from`).
    trace : bool
        Run the reference, segment by segment, and also return one :class:`labkit.Step` per
        segment (``algorithm="legs"``), as :func:`labkit.detect_circles` does (the chord tested
        is the padded chord; an ``"accept"`` step's circle is the leg: its centre and half its
        diameter; ``test`` may also be ``"occluded"``).

    Returns
    -------
    legs : list of Leg
        The legs found, in scan order (``middle`` is the segment's middle point, the paper's record).
    steps : list of Step
        Only with ``trace=True``, which returns ``(legs, steps)``: one step per segment.

    Examples
    --------
    >>> from labkit import sim
    >>> world = sim.World("demo", circles=(sim.Column((2.0, 0.5), 0.07),))
    >>> scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
    >>> (leg,) = detect_legs(scan)
    >>> np.round(leg.center, 2).tolist(), round(leg.diameter, 2), leg.n_points
    ([1.99, 0.5], 0.12, 7)
    """
    check_scan(scan)
    mean_range = std_max = None  # None: not tested
    if iav_mean_range_deg is not None and iav_mean_range_deg != (0.0, 180.0):
        low, high = iav_mean_range_deg
        mean_range = (math.radians(low), math.radians(high))
    if iav_std_max_deg is not None and not math.isinf(iav_std_max_deg):
        std_max = math.radians(iav_std_max_deg)
    test = LegTest(min_points=min_points, chord_range=chord_range_m, chord_padding_beams=chord_padding_beams,
                   middle_range=middle_range, iav_mean_range=mean_range, iav_std_max=std_max,
                   reject_occluded=reject_occluded, center_method=center_method)
    runs = _segments(scan, segments, seg_threshold_m, range_sigma_m)
    sigma = noise_sigma(scan, range_sigma_m)
    if not trace:  # the engine: every segment at once, the same legs
        return leg_engine(scan, runs, test, sigma)[0]
    return _reference(scan, runs, test, sigma)


def _reference(scan: Scan, runs: Runs, t: LegTest, sigma: float) -> tuple[list[Leg], list[Step]]:
    """The leg test of Xavier et al. on each segment in turn, and what each test saw."""
    legs, steps = [], []
    limits = leg_limits(t)
    spacing = abs(scan.angle_increment) if scan.n_beams > 1 else 0.0
    for beams, points in runs.segments():
        seen = Seen(len(points))
        leg = _test_segment(scan, points, beams, t, sigma, spacing, seen)
        if leg is not None:
            legs.append(leg)
        steps.append(seen.step("legs", beams, limits, leg))
    return legs, steps


def _test_segment(scan: Scan, points: np.ndarray, beams: np.ndarray, t: LegTest, sigma: float, spacing: float,
                  seen: Seen) -> Leg | None:
    """The leg of one segment, or None; ``seen`` records what the tests saw and the first that
    failed."""
    # enough points (3: one inscribed angle)
    if len(points) < t.min_points:
        seen.reject(FEW)
        return None
    # Sec. II-E: the distance between the end points within the leg diameters (the chord padded)
    chord = _chord(points)
    seen.chord = _padded(chord, points, t.chord_padding_beams, spacing)
    if seen.chord < t.chord_range[0]:
        seen.reject(SHORT)
        return None
    if seen.chord > t.chord_range[1]:
        seen.reject(LONG)
        return None
    # Sec. II-D, Fig. 5: the circle prerequisite, as for circles
    seen.ratio = _middle_ratio(points)
    if math.isnan(seen.ratio):
        seen.reject(DEGENERATE)
        return None
    band = _prerequisite_band(points, chord, t.middle_range, sigma, seen)
    if not _in_band(seen.ratio, band):
        seen.reject(PREREQ)
        return None
    # the inscribed angles: kept in the record; tested only when asked (the paper does not)
    angles = _angles(points, hollow=False)
    if angles is None:
        seen.reject(DEGENERATE)
        return None
    seen.mean, seen.std, _ = IAVStats.from_angles(angles)
    mean_range, std_max = _angle_limits(points, t, sigma, seen)
    if mean_range is not None and not mean_range[0] <= seen.mean <= mean_range[1]:
        seen.reject(MEAN)
        return None
    if std_max is not None and seen.std >= std_max:
        seen.reject(STD)
        return None
    # Sec. II-E: not partially occluded
    first, last = int(beams[0]), int(beams[-1])
    if t.reject_occluded and is_occluded(scan, first, last):
        seen.reject(OCCLUDED)
        return None
    # the centre and the diameter
    side = _side(points) if t.center_method == "iav" else 0.0
    try:
        center, diameter = leg_center(points, seen.chord, seen.mean, side, t.center_method)
    except ValueError:
        seen.reject(FIT)
        return None
    middle = np.array(points[len(points) // 2], dtype=np.float64)
    center.setflags(write=False)
    middle.setflags(write=False)
    return Leg(center, float(diameter), middle, first, last, len(points), seen.mean, seen.std)


def _padded(chord: float, points: np.ndarray, padding_beams: float, spacing: float) -> float:
    """The chord plus ``padding_beams`` beam spacings at the middle point's range: the extreme
    beams hit a leg up to one spacing inside its silhouette (module notes)."""
    mx, my = points[len(points) // 2]
    return chord + padding_beams * spacing * float(np.hypot(mx, my))


def _angle_limits(points: np.ndarray, t: LegTest, sigma: float,
                  seen: Seen) -> tuple[tuple[float, float] | None, float | None]:
    """Noise allowance: the optional mean range and spread limit, widened by what range noise
    ``sigma`` does to this segment's angles (:func:`labkit._iav_noise.angle_limits`); as given
    when ``sigma`` is 0; None: not tested."""
    mean_range, std_max = t.iav_mean_range, t.iav_std_max
    if sigma > 0.0 and not (mean_range is None and std_max is None):
        wide, std_max, _ = angle_limits(points, sigma, mean_range or (0.0, math.pi), std_max)
        assert seen.widened is not None, "_prerequisite_band set it (sigma > 0)"
        seen.widened.update({MEAN: wide, STD: std_max, ACCEPTED: std_max})
        mean_range = wide if mean_range is not None else None
    return mean_range, std_max


def pair_legs(legs: list[Leg], max_distance_m: float = LegsParams.pair_max_distance_m) -> list[Person]:
    """Pair legs into people, greedily, closest pair first.

    Two legs pair while their centres are at most ``max_distance_m`` apart.

    All pairwise distances between leg centres are sorted; each pair in turn becomes a
    :class:`~labkit.features.Person` unless one of its legs is already taken. Unpaired
    legs are left out. The default 0.6 m covers a walking adult's legs at knee height:
    the simulator's gait (0.4 m steps, legs 0.25 m apart) separates them by at most
    0.47 m, and a person standing still by about a leg's width plus a gap.

    Parameters
    ----------
    legs : list of Leg
        The legs of one scan (:func:`detect_legs`).
    max_distance_m : float, default 0.6
        The farthest two leg centres of one person can be, metres.

    Returns
    -------
    list of Person
        Closest pair first; each person's ``legs`` are in scan order (by ``first``) and ``center``
        is the midpoint of the two leg centres.

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
