"""Angular segmentation of a laser scan into lines (Meglicki 2021, Algorithm 5).

Points on a straight wall share one local direction, whatever their range. The
algorithm therefore clusters in *direction space* first and in *offset space* second,
with DBSCAN on 1-D data both times (:func:`labkit.dbscan.dbscan1d`):

1. **Local direction.** For every beam ``i`` whose neighbours ``i - 1`` and ``i + 1``
   are valid too, fit a line to the three points by total least squares. Its direction,
   taken modulo pi, goes into [0, pi). Walls on opposite sides of the robot then
   reinforce each other (paper, section 3.8). On a full-circle scan the last and first
   beams are neighbours.
2. **Angular clustering.** DBSCAN with wrap-around (period pi) on those directions,
   with ``eps_theta`` and ``min_pts``. Each cluster holds points of one or more
   parallel lines.
3. **Parallel lines.** For each angular cluster, take the circular mean direction
   (period pi). Every point gets a signed offset from the line through the origin in
   that direction. Parallel lines have different offsets, so DBSCAN on the offsets
   (``eps_dist``, ``min_pts``) separates them.
4. **Collinear pieces** (optional, ``split_gap_m``; the paper leaves this open in
   section 3.6). Two walls on one line, e.g. on either side of a door, get the same
   offset. Sort a cluster's points by their position along the line, and split it
   wherever two consecutive points are farther apart than ``split_gap_m``. Pieces left
   with fewer than ``min_pts`` points become noise.

Each final cluster becomes a :class:`labkit.features.LineSegment`, fitted with
:func:`labkit.features.line_segment` to its points in scan order.

Parameters and sensors
----------------------
Noise on the local direction is what limits the method. Three points span about
``2 r dphi`` along the wall (``dphi`` is the angular step). So range noise ``sigma``
tilts the fitted direction by roughly ``sigma / (sqrt(2) r dphi)`` radians. For a
SICK LMS200 (0.5 deg, 5 mm) at 3 m that is about 8 deg. For a Neato XV-11 (1 deg,
15 mm) at 2 m it is about 17 deg. Meglicki's own implementation (ev3dev-mapping-ui,
for the XV-11's 360 beams) used ``eps_theta = 2 deg``, 10 points and
``eps_dist = 1 cm``. These values come from that code: the paper itself gives none.
With DBSCAN a narrow ``eps_theta`` still chains along a wide spread of directions,
but only where enough points are dense. labkit's defaults were tuned on the
simulator's LMS200, LMS111 and XV-11 scans (tests/test_angular.py):

* ``eps_theta = 3 deg``, ``min_pts = 8``: wide enough to chain the noisy directions
  along a wall seen with 20 beams or more. Narrow enough that two walls whose
  directions differ by 30 deg stay apart (an LMS200 at 3 m; 20 deg merge).
  Meglicki's 2 deg and 1 cm found only half the walls of the XV-11 office scans.
* ``eps_dist = 3 cm``: a few times the offset noise of a 5-15 mm sensor. Parallel
  walls closer than that merge.
* For the XV-11 (15 mm noise at 1 deg), noisy directions cost walls points:
  segments hold 78 % of a wall's beams in the office scenario. ``eps_theta = 4 deg``
  and ``eps_dist = 4 cm`` raise that to 82 %. For a dense, precise scanner
  (0.25 deg, 1 mm) the paper's 2 deg and 1 cm work as well as the defaults.

Following the range noise (the default, ``labkit.noise.AUTO_ANGULAR``; the paper is
``labkit.noise.FIXED_ANGULAR``): the three-beam direction is
the method's weak point. A wider window steadies it, and a direction fitted to ``2 h + 1`` beams
at spacing ``s`` tilts by about ``sigma / (s sqrt(h (h + 1) (2 h + 1) / 3))``.
``direction_window="auto"`` takes the narrowest window that keeps this below ``eps_theta`` at
the scan's median range (:func:`auto_direction_window`, with the scan's estimated noise). A wide
window across a corner gives directions between the two walls' directions, which chain the two
clusters together; with ``range_sigma_m`` set, a window whose points are farther from their
line than that noise explains gets no direction (:func:`local_directions`). On the simulated set
of ``benchmarks/evaluation.py`` (722 beams) TruePos / FalsePos go from 0.884 / 0.080 to
0.912 / 0.022 at 5 mm and from 0.445 / 0.647 to 0.736 / 0.143 at 2 cm.

Degenerate input has one policy: a scan with fewer than three valid consecutive beams
(empty, all invalid, too short) has no local directions and gives no segments. It is
not an error.

References
----------
B. Meglicki, "Linear time DBSCAN for sorted 1D data and laser range scan
segmentation", 2021, section 3 (Algorithm 5).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from .._validate import check_int, check_nonneg
from ..dbscan import dbscan1d
from ..features import LineSegment, line_segment
from ..geometry import circular_mean, signed_distance_to_line
from ..noise import chi2_upper_over_dof, noise_sigma, scan_sigma
from ..params import AUTO, Params, checked_by, param
from ..scan import Scan
from ..steps import Step

__all__ = ["AngularSteps", "local_directions", "auto_direction_window", "angular_segmentation", "angular_arrays"]

#: Default DBSCAN radius in direction space: 3 degrees (radians).
EPS_THETA = math.radians(3.0)
#: Default DBSCAN radius in offset space: 3 cm (metres).
EPS_DIST = 0.03
#: Default neighbourhood size for both clusterings (the point itself included).
MIN_PTS = 8
#: The widest ``direction_window="auto"`` chooses (31 beams).
MAX_WINDOW = 15
#: A window is straight when the scatter across its line is below this upper quantile (in
#: standard normal units) of what the range noise gives: one window in 741 of a wall fails.
STRAIGHT_Z = 3.0


@dataclass(frozen=True, eq=False)
class AngularSteps:
    """The intermediate results of :func:`angular_segmentation`, one array per stage.

    :func:`angular_arrays` gives them; ``angular_segmentation(..., trace=True)`` gives the same stages
    as :class:`labkit.Step` records for the step viewers.

    Parameters
    ----------
    local_angles : ndarray of shape (N,), radians in [0, pi)
        Local line direction per beam (step 1). NaN where undefined: the beam or one of
        its two neighbours is invalid.
    angular_labels : ndarray of shape (N,), int64
        Angular cluster per beam (step 2), -1 for noise and undefined directions.
    directions : ndarray of shape (K,), radians in [0, pi)
        Circular mean direction of each angular cluster ``0 .. K-1``.
    distances : ndarray of shape (N,), metres
        Signed offset of each beam's point from the line through the origin along its
        angular cluster's direction (step 3). NaN for beams outside every angular cluster.
    labels : ndarray of shape (N,), int64
        Final label per beam: the index of its segment in the returned list, -1 otherwise.
    """

    local_angles: np.ndarray
    angular_labels: np.ndarray
    directions: np.ndarray
    distances: np.ndarray
    labels: np.ndarray


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def local_directions(scan: Scan, window: int = 1, straight_sigma: float | None = None) -> np.ndarray:
    """Local line direction at every beam, by total least squares through its neighbours.

    The fit runs through beams ``i - window .. i + window`` (the paper's three beams by default).

    Parameters
    ----------
    scan : Scan
        The laser scan.
    window : int, >= 1
        Half-width of the window. Range noise ``sigma`` tilts a direction fitted to ``2 h + 1``
        points at spacing ``s`` by about ``sigma / (s sqrt(h (h + 1) (2 h + 1) / 3))`` radians,
        so wider windows give steadier directions; beams within ``window`` of a corner or an
        edge get none, or a direction between two walls.
    straight_sigma : float, optional, metres
        Range noise: when given, a window whose points are farther from their line than that
        noise explains (the smaller eigenvalue of their scatter beyond ``sigma^2`` times the
        upper z = 3 quantile of chi-square with ``2 h - 1`` degrees of freedom) gets no
        direction. Those are the windows across a corner, a jump edge or a round object.

    Returns
    -------
    ndarray of shape (N,), radians in [0, pi)
        The direction of the line (not its normal). For centred coordinates
        ``dx, dy`` of the window's points it is ``atan2(2 Sxy, Sxx - Syy) / 2 mod pi``,
        the principal axis (paper, section 3.1.3, turned by 90 degrees). NaN where a
        beam of the window is invalid, the points coincide, or (with ``straight_sigma``) they
        are not straight. On a full-circle scan the first and last beams use each other as
        neighbours; otherwise the first and last ``window`` directions are NaN.

    Examples
    --------
    >>> s = Scan(ranges=[1.0, 1.0, 1.0, 1.0], angles=[-0.1, 0.0, 0.1, 0.2])
    >>> np.degrees(local_directions(s)).round(1)
    array([ nan, 90. , 95.7,  nan])

    Five beams on a wall at x = 2 m, 0.5 deg apart, and a 1 cm range error on the second: the
    chord through the three middle points runs 10 mm across over 35 mm along (atan(35 / 10) =
    74 deg from the x axis, 106 deg as a direction), the five-beam window tilts less, and that
    window is not straight for a 2 mm sensor (a 5 sigma error) but is for a 1 cm one:

    >>> angles = np.radians([-1.0, -0.5, 0.0, 0.5, 1.0])
    >>> bumped = Scan(ranges=2.0 / np.cos(angles) + [0, 0.01, 0, 0, 0], angles=angles)
    >>> [round(float(np.degrees(local_directions(bumped, h)[2])), 1) for h in (1, 2)]
    [106.3, 93.4]
    >>> [bool(np.isnan(local_directions(bumped, 2, straight_sigma=s)[2])) for s in (0.002, 0.01)]
    [True, False]
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    h = check_int("window", window, 1)
    n = scan.n_beams
    out = np.full(n, np.nan)
    w = 2 * h + 1
    if n < w:
        return out
    pts, valid = scan.points, scan.valid
    if scan.is_full_circle:  # the window wraps: pad h beams on either side
        pts, valid = np.concatenate([pts[n - h:], pts, pts[:h]]), np.concatenate([valid[n - h:], valid, valid[:h]])
    m = pts.shape[0] - 2 * h  # windows: pts[k:k + m] is the k-th point of every window (views, no copies)
    mid = np.arange(m) + (0 if scan.is_full_circle else h)
    ok = valid[:m].copy()
    total = pts[:m].copy()
    for k in range(1, w):
        ok &= valid[k:k + m]
        total += pts[k:k + m]
    centre = total / w
    with np.errstate(invalid="ignore"):  # invalid beams' points are NaN; their windows are dropped below
        d = pts[:m] - centre
        sxx, syy, sxy = d[:, 0] ** 2, d[:, 1] ** 2, d[:, 0] * d[:, 1]
        for k in range(1, w):
            d = pts[k:k + m] - centre
            sxx += d[:, 0] ** 2
            syy += d[:, 1] ** 2
            sxy += d[:, 0] * d[:, 1]
        spread = sxx + syy
        scale = np.sum(np.abs(centre), axis=1) ** 2 + 1e-300
        good = ok & (spread > 1e-24 * scale)  # coincident points have no direction
        if straight_sigma is not None:
            sigma = check_nonneg("straight_sigma", straight_sigma)
            smallest = 0.5 * spread - np.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)  # the scatter across the line
            dof = w - 2
            good &= smallest <= sigma * sigma * dof * float(chi2_upper_over_dof(dof, STRAIGHT_Z))
    phi = np.mod(0.5 * np.arctan2(2.0 * sxy[good], sxx[good] - syy[good]), np.pi)
    phi[phi >= np.pi] = 0.0
    out[mid[good]] = phi
    return out


def auto_direction_window(scan: Scan, sigma: float, eps_theta: float = EPS_THETA, largest: int = MAX_WINDOW) -> int:
    """The half-width of the local-direction window that ``direction_window="auto"`` picks.

    It is the narrowest window (half-width, beams) whose local
    directions range noise ``sigma`` tilts by no more than ``eps_theta`` (one standard
    deviation; see :func:`local_directions`), for beams at the scan's median range and at
    normal incidence, at most ``largest``. Then the directions of one wall fall within DBSCAN's
    radius of each other, as the paper's three beams do on a precise, dense scanner.

    Parameters
    ----------
    scan : Scan
        The scan (its median range and angle step).
    sigma : float
        The range noise, metres.
    eps_theta : float
        The largest tilt of a local direction allowed, radians.
    largest : int
        The widest half-width returned, beams.

    Returns
    -------
    int
        The half-width, beams.

    Examples
    --------
    >>> angles = np.radians(np.arange(-90.0, 90.25, 0.5))
    >>> scan = Scan(ranges=np.full(angles.size, 3.0), angles=angles)
    >>> [auto_direction_window(scan, sigma) for sigma in (0.001, 0.005, 0.01, 0.02, 0.03)]
    [1, 3, 4, 7, 9]
    """
    ranges = scan.ranges[scan.valid]
    spacing = float(np.median(ranges)) * abs(scan.angle_increment) if ranges.size else 0.0
    if not spacing > 0:
        return 1
    for h in range(1, largest):
        if sigma <= eps_theta * spacing * math.sqrt(h * (h + 1) * (2 * h + 1) / 3.0):
            return h
    return largest


def _split_collinear(beams: np.ndarray, pts: np.ndarray, direction: float, gap: float) -> list[np.ndarray]:
    """Split where consecutive points along the line are more than ``gap`` apart."""
    along = pts[:, 0] * math.cos(direction) + pts[:, 1] * math.sin(direction)
    order = np.argsort(along, kind="stable")
    cuts = np.flatnonzero(np.diff(along[order]) > gap) + 1
    return [np.sort(beams[part]) for part in np.split(order, cuts)]


def _scan_order(beams: np.ndarray, n: int, full_circle: bool) -> np.ndarray:
    """Ascending beam indices; on a full circle, start after the widest gap so that a
    cluster crossing the seam runs N-k .. N-1, 0 .. m (``first > last``)."""
    if not full_circle or beams.size < 2:
        return beams
    gaps = np.diff(np.concatenate([beams, beams[:1] + n]))
    widest = int(np.argmax(gaps))
    return np.roll(beams, -(widest + 1))


@dataclass(frozen=True)
class AngularParams(Params):
    """Parameters of :func:`angular_segmentation`.

    The ``[lines.angular]`` table of :class:`labkit.Config`, each default once: lengths in metres, angles in degrees."""

    eps_theta_deg: float = param(math.degrees(EPS_THETA), "DBSCAN1D radius in line direction, degrees", lo=0,
                                 strict=True, hi=89.9)
    eps_dist_m: float = param(EPS_DIST, "DBSCAN1D radius in line offset, metres", lo=0, strict=True)
    min_points: int = param(MIN_PTS, "DBSCAN1D min_pts of both clusterings", lo=2)
    split_gap_m: float = param(0.3, "split collinear clusters at gaps wider than this, metres (inf: never)", lo=0,
                               strict=True, optional=True, finite=False)
    direction_window: int = param(AUTO, "half-width of the local directions' window, beams (1: the paper's three "
                                     "beams); auto: the narrowest the range noise allows", lo=1, auto=True, kind=int)
    range_sigma_m: float = param(AUTO, "range noise, metres: a local direction only where its window is straight at "
                                      "that noise (0: no test, the paper); auto: estimated from each scan", lo=0,
                                 auto=True)

    @classmethod
    def renamed(cls) -> dict:
        return {"eps_dist": "eps_dist_m", "min_pts": "min_points"}


def _outside(scan: Scan, lines: list[LineSegment], segments) -> list[LineSegment]:
    """Given ``segments`` (labels or RangeSegments), the lines with most of their beams in a
    segment (angular segmentation clusters the whole scan; the pipeline masks the beams that
    legs and circles took)."""
    from ..segmentation import labels_from

    outside = labels_from(scan, segments) < 0
    return [ln for ln in lines if not outside[ln.indices].mean() > 0.5]


@checked_by(AngularParams, positional=("eps_theta", "eps_dist", "min_pts"))
def angular_segmentation(
    scan: Scan,
    *,
    eps_theta_deg: float = AngularParams.eps_theta_deg,
    eps_dist_m: float = AngularParams.eps_dist_m,
    min_points: int = AngularParams.min_points,
    split_gap_m: float | None = AngularParams.split_gap_m,
    direction_window: int | str = AngularParams.direction_window,
    range_sigma_m: float | str = AngularParams.range_sigma_m,
    segments=None,
    trace: bool = False,
) -> list[LineSegment] | tuple[list[LineSegment], list[Step]]:
    """Line segments of a scan by angular segmentation (Meglicki 2021, Algorithm 5).

    Parameters
    ----------
    scan : Scan
        Invalid beams are skipped (they also leave their neighbours without a local
        direction).
    eps_theta_deg : float, degrees
        DBSCAN radius on local directions (circular, period 180 degrees; the paper's
        ``eps_theta``), in (0, 89.9]. Default 3 degrees.
    eps_dist_m : float, metres
        DBSCAN radius on the offsets that separate parallel lines (the paper's ``eps_dist``).
        Default 0.03.
    min_points : int
        DBSCAN neighbourhood size for both clusterings, the point itself included (the
        paper's ``min_pts``), >= 2. Default 8. It is also the smallest segment.
    split_gap_m : float, optional, metres
        Also split collinear pieces wherever consecutive points along the line are
        farther apart than this (e.g. 0.3 for walls on either side of a door). Default
        0.3 m, as in the pipeline; None or inf: no split, as in the paper.
    direction_window : int or "auto"
        Half-width of the window of the local directions, beams. Default ``"auto"``:
        :func:`auto_direction_window` for the range noise (``range_sigma_m``
        when it is set, else the scan's estimate); 1: three beams, the paper.
    range_sigma_m : float or "auto", metres
        When > 0, a beam gets a local direction only if its window is straight at this range
        noise (:func:`local_directions`). Default ``"auto"``: the scan's estimate
        (:func:`labkit.noise.scan_sigma`); 0: no test, the paper.
    segments : labels or list of RangeSegment, optional
        Keep only the lines with most of their beams in a segment (the whole scan is
        clustered all the same).
    trace : bool
        Also return the steps, as :class:`labkit.Step` records (``algorithm="angular"``; ``beams``
        holds each step's beams, spread over the scan): ``"directions"`` (step 1: ``value`` beams
        with a local direction, ``threshold`` the window's half-width), ``"direction"`` (step 2,
        one per angular cluster: ``value`` its mean direction, radians; ``r, alpha`` the line
        through the origin along it), ``"offset"`` (step 3, one per offset cluster: ``value`` its
        offset, ``r, alpha`` its line), ``"reject"`` (a cluster without a common direction,
        ``test="direction"``, or a piece with fewer than ``min_pts`` points, ``test="min_pts"``),
        and ``"accept"`` (one per returned segment, in the order returned, with its fitted line).
        The per-beam arrays of these stages are :func:`angular_arrays`.

    Returns
    -------
    segments : list of LineSegment
        One per final cluster, sorted by first beam. A segment's points are its beams in
        scan order. On a full-circle scan a segment that crosses the seam has
        ``first > last``.
    steps : list of labkit.Step
        Only with ``trace=True``.

    Raises
    ------
    ValueError
        ``scan`` is not a :class:`Scan`, or a parameter is out of range (the message
        names it).

    Examples
    --------
    A wall at x = 2 m seen from the origin, and the end of a parallel one at x = 3 m:

    >>> angles = np.radians(np.arange(-40.0, 40.5, 0.5))
    >>> ranges = np.where(angles < np.radians(30), 2.0 / np.cos(angles), 3.0 / np.cos(angles))
    >>> from labkit.noise import FIXED_ANGULAR
    >>> segs = angular_segmentation(Scan(ranges=ranges, angles=angles), **FIXED_ANGULAR)
    >>> [(round(s.r, 3), abs(round(float(np.degrees(s.alpha)), 1)), s.first, s.last) for s in segs]
    [(2.0, 0.0, 1, 138), (3.0, 0.0, 141, 159)]

    The end beams and the beams next to the jump have no local direction (one of their
    neighbours is missing or on the other wall) and are left out. That is the paper's
    three-beam direction (``FIXED_ANGULAR``); the default fits each direction to as many beams as
    the noise needs (five here, at the 2 mm that a noise-free scan is taken to have), so one more
    beam at each end has none:

    >>> segs = angular_segmentation(Scan(ranges=ranges, angles=angles))
    >>> [(s.first, s.last) for s in segs]
    [(2, 137), (142, 158)]
    """
    lines, _, steps = _angular(scan, eps_theta_deg, eps_dist_m, min_points, split_gap_m, direction_window,
                               range_sigma_m, trace)
    if segments is not None:
        lines = _outside(scan, lines, segments)
    return (lines, list(steps)) if trace else lines


@checked_by(AngularParams, positional=("eps_theta", "eps_dist", "min_pts"))
def angular_arrays(
    scan: Scan,
    *,
    eps_theta_deg: float = AngularParams.eps_theta_deg,
    eps_dist_m: float = AngularParams.eps_dist_m,
    min_points: int = AngularParams.min_points,
    split_gap_m: float | None = AngularParams.split_gap_m,
    direction_window: int | str = AngularParams.direction_window,
    range_sigma_m: float | str = AngularParams.range_sigma_m,
) -> AngularSteps:
    """The intermediate arrays of :func:`angular_segmentation`, one per stage, per beam.

    The intermediate arrays of :func:`angular_segmentation` (same parameters), one per stage, per
    beam: local directions, angular labels, the clusters' mean directions, offsets and the final
    labels (:class:`AngularSteps`), for plotting the stages.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    eps_theta_deg : float, default 3.0
        DBSCAN1D radius in line direction, degrees.
    eps_dist_m : float, default 0.03
        DBSCAN1D radius in line offset, metres.
    min_points : int, default 8
        DBSCAN1D min_pts of both clusterings.
    split_gap_m : float, default 0.3
        Split collinear clusters at gaps wider than this, metres (inf: never).
    direction_window : int, default 'auto'
        Half-width of the local directions' window, beams (1: the paper's three beams); auto:
        the narrowest the range noise allows.
    range_sigma_m : float, default 'auto'
        Range noise, metres: a local direction only where its window is straight at that noise
        (0: no test, the paper); auto: estimated from each scan.

    Returns
    -------
    AngularSteps
        The arrays of each stage.

    Examples
    --------
    >>> angles = np.radians(np.arange(-40.0, 40.5, 0.5))
    >>> a = angular_arrays(Scan(ranges=2.0 / np.cos(angles), angles=angles), direction_window=1, range_sigma_m=0)
    >>> np.degrees(a.directions).round(1).tolist(), int((a.labels == 0).sum())
    ([90.0], 159)
    """
    return _angular(scan, eps_theta_deg, eps_dist_m, min_points, split_gap_m, direction_window, range_sigma_m,
                    False)[1]


def _angular(scan, eps_theta_deg, eps_dist, min_pts, split_gap_m, window, range_sigma_m, trace: bool):
    """(segments, AngularSteps, list of Step or None): :func:`angular_segmentation`, Algorithm 5's
    steps in order."""
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    eps_theta = math.radians(eps_theta_deg)
    if split_gap_m is not None and math.isinf(split_gap_m):
        split_gap_m = None
    sigma = noise_sigma(scan, range_sigma_m)
    if window == AUTO:
        window = auto_direction_window(scan, sigma if sigma > 0 else scan_sigma(scan), eps_theta)
    steps = _Notes() if trace else None
    n, pts = scan.n_beams, scan.points

    # step 1: a local direction at every beam
    theta = local_directions(scan, window, sigma if sigma > 0 else None)
    # step 2: DBSCAN on the directions, wrapping at pi
    angular_labels = _cluster_directions(theta, eps_theta, min_pts, window, sigma, steps)
    directions: list[float] = []
    distances = np.full(n, np.nan)
    clusters: list[np.ndarray] = []
    for k in range(int(angular_labels.max(initial=-1)) + 1):
        members = np.flatnonzero(angular_labels == k)
        direction = _cluster_direction(theta, members, k, steps)
        directions.append(direction)
        if math.isnan(direction):
            continue
        # step 3: parallel lines, by their offsets from the line through the origin
        offset, parallel = _parallel_lines(pts, members, direction, eps_dist, min_pts, steps)
        distances[members] = offset
        for beams in parallel:
            # step 4 (optional): collinear pieces
            clusters += _collinear_pieces(beams, pts, direction, split_gap_m, min_pts, steps)

    segments, labels = _segments(scan, clusters, min_pts, steps)
    arrays = AngularSteps(_frozen(theta), _frozen(angular_labels), _frozen(np.array(directions, dtype=float)),
                          _frozen(distances), _frozen(labels))
    return segments, arrays, steps


class _Notes(list):
    """The :class:`labkit.Step` records of one call (``algorithm="angular"``), each with its beams."""

    def add(self, kind: str, beams: np.ndarray, **fields) -> None:
        b = beams.tolist()
        self.append(Step("angular", kind, min(b, default=-1), max(b, default=-1), beams=tuple(b), **fields))


def _cluster_directions(theta: np.ndarray, eps_theta: float, min_pts: int, window: int, sigma: float,
                        steps) -> np.ndarray:
    """Step 2: the angular cluster of every beam with a local direction (DBSCAN1D with period pi), -1
    for the others."""
    angular_labels = np.full(len(theta), -1, dtype=np.int64)
    defined = np.flatnonzero(np.isfinite(theta))
    if defined.size:
        angular_labels[defined] = dbscan1d(theta[defined], eps_theta, min_pts, period=math.pi)
    if steps is not None:
        over = f" over {2 * window + 1} beams" + (f", straight at {1000 * sigma:.1f} mm" if sigma > 0 else "")
        steps.add("directions", defined, value=defined.size, threshold=window,
                  reason=f"{defined.size} beams have a local direction{over}; DBSCAN on them (eps_theta "
                         f"{math.degrees(eps_theta):.1f} deg) finds {int(angular_labels.max(initial=-1)) + 1} clusters")
    return angular_labels


def _cluster_direction(theta: np.ndarray, members: np.ndarray, k: int, steps) -> float:
    """The circular mean (period pi) of angular cluster ``k``'s directions; NaN when they spread
    evenly round the circle and have no common direction."""
    try:
        direction = circular_mean(theta[members], period=math.pi)
    except ValueError:
        if steps is not None:
            steps.add("reject", members, test="direction", reason=f"angular cluster {k}: no common direction")
        return math.nan
    if steps is not None:
        steps.add("direction", members, r=0.0, alpha=math.remainder(direction + math.pi / 2, 2 * math.pi),
                  value=direction,
                  reason=f"angular cluster {k}: {members.size} beams, direction {math.degrees(direction):.1f} deg")
    return direction


def _parallel_lines(pts: np.ndarray, members: np.ndarray, direction: float, eps_dist: float, min_pts: int,
                    steps) -> tuple[np.ndarray, Iterator[np.ndarray]]:
    """Step 3: the signed offsets of an angular cluster's points from the line through the origin
    along its direction, and its beams split into parallel lines by DBSCAN1D on those offsets (one
    by one, each noted as it is taken)."""
    offset = signed_distance_to_line(pts[members], 0.0, direction + math.pi / 2)
    offset_labels = dbscan1d(offset, eps_dist, min_pts)

    def lines() -> Iterator[np.ndarray]:
        normal = math.remainder(direction + math.pi / 2, 2 * math.pi)
        for j in range(int(offset_labels.max(initial=-1)) + 1):
            beams = members[offset_labels == j]
            if steps is not None:
                d = float(np.median(offset[offset_labels == j]))
                alpha = normal if d >= 0 else math.remainder(normal + math.pi, 2 * math.pi)
                steps.add("offset", beams, r=abs(d), alpha=alpha, value=d,
                          reason=f"direction {math.degrees(direction):.1f} deg, offset cluster {j}: "
                                 f"{beams.size} beams {d:.3f} m from the origin")
            yield beams

    return offset, lines()


def _collinear_pieces(beams: np.ndarray, pts: np.ndarray, direction: float, split_gap_m: float | None,
                      min_pts: int, steps) -> list[np.ndarray]:
    """Step 4: a line's beams cut where consecutive points along it are more than ``split_gap_m``
    apart (none: not cut, the paper); pieces with fewer than ``min_pts`` points are noise."""
    pieces = [beams] if split_gap_m is None else _split_collinear(beams, pts[beams], direction, split_gap_m)
    if steps is not None:
        for p in pieces:
            if p.size < min_pts:
                steps.add("reject", p, value=p.size, threshold=min_pts, test="min_pts",
                          reason=f"a collinear piece of {p.size} points < min_pts={min_pts}")
    return [p for p in pieces if p.size >= min_pts]


def _segments(scan: Scan, clusters: list[np.ndarray], min_pts: int, steps) -> tuple[list[LineSegment], np.ndarray]:
    """A :class:`LineSegment` fitted to each final cluster, sorted by first beam (a cluster across the
    seam of a full-circle scan starts where it starts), and every beam's segment (-1: none)."""
    n = scan.n_beams
    ordered = sorted((_scan_order(c, n, scan.is_full_circle) for c in clusters), key=lambda c: int(c[0]))
    pts = scan.points
    segments = [line_segment(pts[c], c) for c in ordered]
    labels = np.full(n, -1, dtype=np.int64)
    for i, c in enumerate(ordered):
        labels[c] = i
    if steps is not None:
        for s, c in zip(segments, ordered, strict=True):
            steps.add("accept", c, r=s.r, alpha=s.alpha, value=s.n_points, threshold=min_pts,
                      reason=f"segment of {s.n_points} beams, r {s.r:.3f} m, alpha {math.degrees(s.alpha):.1f} deg")
    return segments, labels


#: The registry's name for it (it takes ``segments`` and gives the lines of the whole scan's
#: clusters that lie mostly in them).
angular_lines = angular_segmentation
