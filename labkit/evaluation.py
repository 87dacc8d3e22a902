"""Evaluation of extracted features against ground truth and against the scan itself.

Three kinds of score, each a pure function of features and truth:

**Lines against ground-truth walls** (the comparison of Nguyen et al. 2007). An extracted
line *matches* a visible wall when all three hold:

* ``|dr| <= max_dr_m`` (default 5 cm) and ``|dalpha| <= max_dalpha`` (default 3 deg), the
  normal-form parameters compared with the angle difference taken across the wrap;
* the line lies on the wall: the stretch of the line's segment that overlaps the wall's
  visible part (both projected onto the wall) is at least ``min_overlap`` (default 0.5) of the
  segment's length.

Matching is one-to-one: candidate pairs are taken in order of increasing normalised error
``(dr / max_dr)^2 + (dalpha / max_dalpha)^2`` and a pair is kept when neither its line nor its
wall is taken yet (greedy assignment). Then

* true-positive rate = matched walls / walls in the truth ("TruePos" in Nguyen's table),
* false-positive rate = unmatched lines / lines scored ("FalsePos"),
* ``sigma_dr``, ``sigma_dalpha`` = standard deviations of ``dr`` and ``dalpha`` over the matches.

Walls seen by fewer than ``min_beams`` beams (default 10) or shorter than ``min_length_m``
(default 0.3 m) are not in the truth: nobody can ask an extractor to find a wall hit by three
beams. A line on such a wall (it matches it by the rule above) is *not scored*: neither a true
nor a false positive. So is a line whose beams mostly hit a round object (a column, a leg, a
rounded corner), when the truth says what each beam hit (:attr:`labkit.sim.ScanTruth.hits`):
round things are the circle detector's job, and the walls-only truth has nothing to compare
such a line with. Every other line is scored.

**Circles and legs against ground truth.** A detection matches a true circle (or leg) when
their centres are at most ``max_center_m`` apart (default 0.1 m), one-to-one by increasing
distance. Truth objects seen by fewer than ``min_beams`` beams (circles: 4, Xavier et al.'s
``circle_min_pts``; legs: 3, the fewest that have an inscribed angle, which is what the leg
detector's own ``min_points`` allows) or occluded at either end (a neighbouring beam hit something nearer: the
leg detector's own definition of a segment it must not trust) are not in the truth, and a
detection on one of them is not scored. Precision = matched / scored detections, recall =
matched / truth objects; centre errors in metres, radius errors relative.

**Ray-axis error against the scan** (Schaefer et al. 2018): for real scans with no ground
truth, how well do the segments explain the measurements? Each valid beam's ray is intersected
with every segment; the error is the measured range minus the distance to the nearest
intersection, measured along the ray. The RMSE is over the beams whose ray meets a segment;
``coverage`` says which fraction of the valid beams that is -- an extractor that returns fewer
lines covers fewer beams, so report both.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ._validate import check_int, check_nonneg, check_positive
from .geometry import angle_difference
from .scan import Scan

__all__ = [
    "LineMatch",
    "LineScores",
    "DetectionMatch",
    "DetectionScores",
    "RayErrors",
    "match_lines",
    "score_lines",
    "match_circles",
    "match_legs",
    "score_detections",
    "ray_errors",
    "is_occluded_in_truth",
]


# ============================================================================ lines
@dataclass(frozen=True)
class LineMatch:
    """How the lines of one scan match its walls (see the module docstring for the rule).

    Parameters
    ----------
    pairs : tuple of (line index, wall index)
        The matches; wall indices refer to the ``walls`` given (``truth.walls``).
    dr, dalpha : ndarray
        ``r - r_true`` (m) and ``alpha - alpha_true`` wrapped to (-pi, pi] (rad), per pair.
    truth : tuple of int
        The walls in the truth (seen by enough beams and long enough).
    scored : tuple of int
        The lines scored; the others sit on walls too short to be in the truth or on round
        objects.
    """

    pairs: tuple[tuple[int, int], ...]
    dr: np.ndarray = field(repr=False)
    dalpha: np.ndarray = field(repr=False)
    truth: tuple[int, ...]
    scored: tuple[int, ...]

    @property
    def n_matched(self) -> int:
        return len(self.pairs)

    @property
    def false_positives(self) -> tuple[int, ...]:
        """The scored lines that match no wall in the truth."""
        taken = {i for i, _ in self.pairs}
        return tuple(i for i in self.scored if i not in taken)

    @property
    def missed(self) -> tuple[int, ...]:
        """The walls in the truth that no line matches."""
        taken = {j for _, j in self.pairs}
        return tuple(j for j in self.truth if j not in taken)


def _segment_ends(obj) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(obj.start, dtype=float), np.asarray(obj.end, dtype=float)


def _overlap_fraction(line, wall) -> float:
    """Share of the line segment's length that overlaps the wall's visible part, both projected
    onto the wall's direction. A zero-length segment counts as overlapping when its point
    projects inside the wall."""
    w0, w1 = _segment_ends(wall)
    l0, l1 = _segment_ends(line)
    d = w1 - w0
    length = math.hypot(d[0], d[1])
    if length == 0.0:
        return 0.0
    u = d / length
    a, b = sorted((float((l0 - w0) @ u), float((l1 - w0) @ u)))
    inside = max(0.0, min(b, length) - max(a, 0.0))
    span = b - a
    if span == 0.0:
        return 1.0 if 0.0 <= a <= length else 0.0
    return inside / span


def _round_object_ids(truth) -> set[int]:
    ids = set()
    for group in ("circles", "legs", "arcs"):
        ids |= {int(o.object_id) for o in getattr(truth, group, ())}
    return ids


def _check_line_rule(max_dr_m, max_dalpha, min_overlap, min_beams, min_length_m):
    check_positive("max_dr_m", max_dr_m)
    check_positive("max_dalpha", max_dalpha)
    if not 0.0 <= max_dalpha <= math.pi:
        raise ValueError(f"max_dalpha must be in (0, pi] radians, got {max_dalpha}")
    check_nonneg("min_overlap", min_overlap)
    if min_overlap > 1.0:
        raise ValueError(f"min_overlap must be in [0, 1], got {min_overlap}")
    check_int("min_beams", min_beams, 0)
    check_nonneg("min_length_m", min_length_m)


def match_lines(
    lines: Sequence,
    truth,
    *,
    max_dr_m: float = 0.05,
    max_dalpha: float = math.radians(3.0),
    min_overlap: float = 0.5,
    min_beams: int = 10,
    min_length_m: float = 0.3,
) -> LineMatch:
    """Match the extracted ``lines`` of one scan to its ground-truth walls, one-to-one.

    Parameters
    ----------
    lines : sequence of LineSegment
        Anything with ``r``, ``alpha``, ``start``, ``end`` (and ``indices`` for the
        round-object rule).
    truth : ScanTruth or sequence of walls
        A :class:`labkit.sim.ScanTruth` (its ``walls`` and ``hits`` are used), or just the
        walls: objects with ``r``, ``alpha``, ``start``, ``end`` and optionally ``n_beams``.
    max_dr_m, max_dalpha : float
        Largest ``|dr|`` (m) and ``|dalpha|`` (rad) of a match. Defaults 5 cm and 3 deg: ten
        times the LMS200's 5 mm range noise, and the angle a 1 m line turns when one end moves
        by 5 cm.
    min_overlap : float
        Smallest share of the line's length that must lie on the wall's visible part.
    min_beams, min_length_m : int, float
        Walls seen by fewer beams or shorter than this are not in the truth (10 beams, 0.3 m:
        twice the extractors' default ``min_points`` and ``min_length_m``).

    Returns
    -------
    LineMatch
        The matched pairs with their ``dr`` and ``dalpha``, the false positives and the missed walls.

    Examples
    --------
    >>> from types import SimpleNamespace as W
    >>> from labkit import line_segment
    >>> wall = W(r=2.0, alpha=0.0, start=(2.0, -1.0), end=(2.0, 1.0), n_beams=50)
    >>> good = line_segment(np.array([[2.01, -0.9], [2.01, 0.0], [2.01, 0.9]]), [0, 1, 2])
    >>> far = line_segment(np.array([[2.3, -0.5], [2.3, 0.5]]), [3, 4])
    >>> m = match_lines([good, far], [wall])
    >>> m.pairs, m.false_positives, round(float(m.dr[0]), 3)
    (((0, 0),), (1,), 0.01)
    """
    _check_line_rule(max_dr_m, max_dalpha, min_overlap, min_beams, min_length_m)
    walls = list(getattr(truth, "walls", truth))
    hits = getattr(truth, "hits", None)
    round_ids = _round_object_ids(truth)

    def wall_length(w) -> float:
        s, e = _segment_ends(w)
        return float(math.hypot(*(e - s)))

    in_truth = [j for j, w in enumerate(walls)
                if getattr(w, "n_beams", min_beams) >= min_beams and wall_length(w) >= min_length_m]
    truth_set = set(in_truth)
    candidates = []  # (cost, line, wall, dr, dalpha)
    on_other_wall = set()
    for i, ln in enumerate(lines):
        for j, w in enumerate(walls):
            dr = float(ln.r) - float(w.r)
            da = float(angle_difference(float(ln.alpha), float(w.alpha)))
            if abs(dr) > max_dr_m or abs(da) > max_dalpha or _overlap_fraction(ln, w) < min_overlap:
                continue
            if j in truth_set:
                candidates.append(((dr / max_dr_m) ** 2 + (da / max_dalpha) ** 2, i, j, dr, da))
            else:
                on_other_wall.add(i)
    candidates.sort(key=lambda c: c[:3])
    pairs, drs, das, used_l, used_w = [], [], [], set(), set()
    for _, i, j, dr, da in candidates:
        if i in used_l or j in used_w:
            continue
        used_l.add(i)
        used_w.add(j)
        pairs.append((i, j))
        drs.append(dr)
        das.append(da)
    scored = []
    for i, ln in enumerate(lines):
        if i not in used_l:
            if i in on_other_wall:
                continue  # a line on a wall too short to be in the truth
            if hits is not None and round_ids and getattr(ln, "indices", None) is not None and len(ln.indices):
                owners, counts = np.unique(np.asarray(hits)[np.asarray(ln.indices)], return_counts=True)
                if int(owners[np.argmax(counts)]) in round_ids:
                    continue  # a line on a column, leg or rounded corner
        scored.append(i)
    order = sorted(range(len(pairs)), key=lambda k: pairs[k])
    return LineMatch(tuple(pairs[k] for k in order), np.array([drs[k] for k in order]),
                     np.array([das[k] for k in order]), tuple(in_truth), tuple(scored))


@dataclass(frozen=True)
class LineScores:
    """Nguyen et al.'s line metrics pooled over scans.

    ``tp_rate`` = matched walls / walls in the truth; ``fp_rate`` = unmatched lines / lines
    scored; ``sigma_dr`` (m) and ``sigma_dalpha`` (rad) are the standard deviations of the
    errors over all matches (NaN with fewer than two matches).

    Parameters
    ----------
    n_scans : int
        Scans scored.
    n_truth : int
        Walls in the truth.
    n_lines : int
        All lines found.
    n_scored : int
        Lines that count.
    n_matched : int
        Lines matched to a wall.
    dr : ndarray
        The error in ``r`` of every match, metres.
    dalpha : ndarray
        The error in ``alpha`` of every match, radians.
    """

    n_scans: int
    n_truth: int
    n_lines: int
    n_scored: int
    n_matched: int
    dr: np.ndarray = field(repr=False)
    dalpha: np.ndarray = field(repr=False)

    @property
    def tp_rate(self) -> float:
        return self.n_matched / self.n_truth if self.n_truth else math.nan

    @property
    def fp_rate(self) -> float:
        return (self.n_scored - self.n_matched) / self.n_scored if self.n_scored else math.nan

    @property
    def sigma_dr(self) -> float:
        return float(np.std(self.dr, ddof=1)) if len(self.dr) > 1 else math.nan

    @property
    def sigma_dalpha(self) -> float:
        return float(np.std(self.dalpha, ddof=1)) if len(self.dalpha) > 1 else math.nan

    def as_dict(self) -> dict:
        """The counts and rates as plain numbers (``sigma_dalpha_deg`` in degrees)."""
        return {"scans": self.n_scans, "truth": self.n_truth, "lines": self.n_lines, "scored": self.n_scored,
                "matched": self.n_matched, "tp_rate": self.tp_rate, "fp_rate": self.fp_rate,
                "sigma_dr_m": self.sigma_dr, "sigma_dalpha_deg": math.degrees(self.sigma_dalpha)}


def score_lines(results: Iterable[tuple[Sequence, object]], **rule) -> LineScores:
    """Pool :func:`match_lines` over ``(lines, truth)`` pairs, one per scan.

    Pool :func:`match_lines` over ``(lines, truth)`` pairs, one per scan; ``rule``: the keyword
    arguments of :func:`match_lines`.

    Parameters
    ----------
    results : iterable of (lines, truth)
        The extracted lines of each scan and the scan's ground truth.
    **rule
        The keyword arguments of :func:`match_lines` (the matching rule).

    Returns
    -------
    LineScores
        True- and false-positive rates and the spread of ``dr`` and ``dalpha`` over every scan.
    """
    n_scans = n_truth = n_lines = n_scored = n_matched = 0
    dr, da = [], []
    for lines, truth in results:
        m = match_lines(lines, truth, **rule)
        n_scans += 1
        n_truth += len(m.truth)
        n_lines += len(lines)
        n_scored += len(m.scored)
        n_matched += m.n_matched
        dr.append(m.dr)
        da.append(m.dalpha)
    return LineScores(n_scans, n_truth, n_lines, n_scored, n_matched, _cat(dr), _cat(da))


def _cat(arrays: list) -> np.ndarray:
    return np.concatenate(arrays) if arrays else np.empty(0)


# ============================================================================ circles and legs
@dataclass(frozen=True)
class DetectionMatch:
    """How the circle (or leg) detections of one scan match the truth.

    Parameters
    ----------
    pairs : tuple of tuple of (int, int)
        The matches: (detection index, truth index).
    center_errors : ndarray
        The distance between the centres of each pair, metres.
    radius_errors : ndarray
        Each pair's radius error, relative: detected / true - 1.
    truth : tuple of int
        The true objects that count.
    scored : tuple of int
        The detections that count.
    n_detections : int
        All detections of the scan.
    """

    pairs: tuple[tuple[int, int], ...]
    center_errors: np.ndarray = field(repr=False)
    radius_errors: np.ndarray = field(repr=False)
    truth: tuple[int, ...]
    scored: tuple[int, ...]
    n_detections: int = 0


def is_occluded_in_truth(scan: Scan, truth, obj) -> bool:
    """Whether a true object is seen only in part, occluded at one of its ends.

    Whether a neighbouring beam of ``obj`` (a true circle or leg with ``first``/``last`` beams) hit
    something nearer than its end beam: then only part of it can be seen.

    Parameters
    ----------
    scan : Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth (the range each beam hit).
    obj : object
        A true circle or leg with ``first`` and ``last`` beams.

    Returns
    -------
    bool
        True when a neighbouring beam hit something nearer than the object's end beam.
    """
    n = scan.n_beams
    hits = truth.hits
    for end, nb in ((obj.first, obj.first - 1), (obj.last, obj.last + 1)):
        if not 0 <= nb < n:
            if not scan.is_full_circle:
                return True  # cut by the edge of the field of view
            nb %= n
        if hits[nb] >= 0 and hits[nb] != obj.object_id and scan.ranges[nb] < scan.ranges[end]:
            return True
    return False


def _match_detections(detections, objects, scan, truth, radius_of, true_radius_of, *, max_center_m, min_beams,
                      drop_occluded) -> DetectionMatch:
    check_positive("max_center_m", max_center_m)
    check_int("min_beams", min_beams, 0)
    counted = set()
    for j, o in enumerate(objects):
        if o.n_beams >= min_beams and not (drop_occluded and is_occluded_in_truth(scan, truth, o)):
            counted.add(j)
    centres_t = np.array([o.center for o in objects], dtype=float).reshape(-1, 2)
    centres_d = np.array([d.center for d in detections], dtype=float).reshape(-1, 2)
    dist = np.hypot(centres_d[:, None, 0] - centres_t[None, :, 0], centres_d[:, None, 1] - centres_t[None, :, 1])
    i_idx, j_idx = np.nonzero(dist <= max_center_m)
    order = np.lexsort((j_idx, i_idx, dist[i_idx, j_idx]))
    pairs, used_d, used_t, near_uncounted = [], set(), set(), set()
    for k in order.tolist():
        i, j = int(i_idx[k]), int(j_idx[k])
        if j not in counted:
            near_uncounted.add(i)
            continue
        if i in used_d or j in used_t:
            continue
        used_d.add(i)
        used_t.add(j)
        pairs.append((i, j))
    pairs.sort()
    scored = tuple(i for i in range(len(detections)) if i in used_d or i not in near_uncounted)
    ce = np.array([dist[i, j] for i, j in pairs])
    re = np.array([radius_of(detections[i]) / true_radius_of(objects[j]) - 1.0 for i, j in pairs])
    return DetectionMatch(tuple(pairs), ce, re, tuple(sorted(counted)), scored, len(detections))


def match_circles(circles: Sequence, scan: Scan, truth, *, max_center_m: float = 0.1, min_beams: int = 4,
                  drop_occluded: bool = True) -> DetectionMatch:
    """Match detected circles to the ground truth of one scan (the module docstring has the rule).

    Match detected circles (``center``, ``radius``) to ``truth.circles`` of one scan (see the module
    docstring for the rule).

    Parameters
    ----------
    circles : sequence
        The detections of one scan (``center``, ``radius``).
    scan : Scan
        The scan they were detected in.
    truth : labkit.sim.ScanTruth
        The scan's ground truth (one scan of :func:`labkit.sim.read_truth`).
    max_center_m : float, default 0.1
        Largest distance between a detection's centre and the true one, metres.
    min_beams : int, default 4
        True objects hit by fewer beams are not in the truth scored.
    drop_occluded : bool, default True
        Leave out true objects occluded at either end (a neighbouring beam hit something nearer).

    Returns
    -------
    DetectionMatch
        The matched pairs with their centre and radius errors, the true objects and the detections
        that count.
    """
    return _match_detections(circles, list(truth.circles), scan, truth, lambda c: float(c.radius),
                             lambda o: float(o.radius), max_center_m=max_center_m, min_beams=min_beams,
                             drop_occluded=drop_occluded)


def match_legs(legs: Sequence, scan: Scan, truth, *, max_center_m: float = 0.1, min_beams: int = 3,
               drop_occluded: bool = True) -> DetectionMatch:
    """Match detected legs to the ground truth of one scan (the module docstring has the rule).

    Match detected legs (``center``, ``diameter``) to ``truth.legs`` of one scan (see the module
    docstring for the rule).

    Parameters
    ----------
    legs : sequence
        The detections of one scan (``center``, ``diameter``).
    scan : Scan
        The scan they were detected in.
    truth : labkit.sim.ScanTruth
        The scan's ground truth (one scan of :func:`labkit.sim.read_truth`).
    max_center_m : float, default 0.1
        Largest distance between a detection's centre and the true one, metres.
    min_beams : int, default 3
        True objects hit by fewer beams are not in the truth scored.
    drop_occluded : bool, default True
        Leave out true objects occluded at either end (a neighbouring beam hit something nearer).

    Returns
    -------
    DetectionMatch
        The matched pairs with their centre and radius errors, the true objects and the detections
        that count.
    """
    return _match_detections(legs, list(truth.legs), scan, truth, lambda g: float(g.diameter),
                             lambda o: float(o.diameter), max_center_m=max_center_m, min_beams=min_beams,
                             drop_occluded=drop_occluded)


@dataclass(frozen=True)
class DetectionScores:
    """Precision, recall and errors of a detector pooled over scans.

    Parameters
    ----------
    n_scans : int
        Scans scored.
    n_truth : int
        True objects that count.
    n_detected : int
        All detections.
    n_scored : int
        Detections that count.
    n_matched : int
        Detections matched to a true object.
    center_errors : ndarray
        The centre error of every match, metres.
    radius_errors : ndarray
        The relative radius error of every match.
    """

    n_scans: int
    n_truth: int
    n_detected: int
    n_scored: int
    n_matched: int
    center_errors: np.ndarray = field(repr=False)
    radius_errors: np.ndarray = field(repr=False)

    @property
    def precision(self) -> float:
        return self.n_matched / self.n_scored if self.n_scored else math.nan

    @property
    def recall(self) -> float:
        return self.n_matched / self.n_truth if self.n_truth else math.nan

    def as_dict(self) -> dict:
        """Counts, rates and the median and 95th percentile of the errors."""
        def q(x, p):
            return float(np.percentile(np.abs(x), p)) if len(x) else math.nan

        return {"scans": self.n_scans, "truth": self.n_truth, "detected": self.n_detected, "scored": self.n_scored,
                "matched": self.n_matched, "precision": self.precision, "recall": self.recall,
                "center_err_median_m": q(self.center_errors, 50), "center_err_p95_m": q(self.center_errors, 95),
                "radius_err_median": q(self.radius_errors, 50), "radius_err_p95": q(self.radius_errors, 95)}


def score_detections(matches: Iterable[DetectionMatch]) -> DetectionScores:
    """Pool per-scan :class:`DetectionMatch` results (of :func:`match_circles` or :func:`match_legs`).

    Pool per-scan :class:`DetectionMatch` results (from :func:`match_circles` or
    :func:`match_legs`).

    Parameters
    ----------
    matches : iterable of DetectionMatch
        The per-scan matches.

    Returns
    -------
    DetectionScores
        Precision, recall, the centre and radius errors and the counts they come from.
    """
    n_scans = n_truth = n_scored = n_matched = n_det = 0
    ce, re = [], []
    for m in matches:
        n_scans += 1
        n_truth += len(m.truth)
        n_scored += len(m.scored)
        n_matched += len(m.pairs)
        n_det += m.n_detections
        ce.append(m.center_errors)
        re.append(m.radius_errors)
    return DetectionScores(n_scans, n_truth, n_det, n_scored, n_matched, _cat(ce), _cat(re))


# ============================================================================ ray-axis error
@dataclass(frozen=True)
class RayErrors:
    """Per-beam ray-axis errors of segments against one or more scans (Schaefer et al.).

    The RMSE is dominated by a few beams whose ray meets a segment far in front of or behind what
    it hit (a line across a doorway, a piece of clutter): ``median_abs`` and ``share_over`` tell
    those apart from a general misfit. Pooled over scans with ``+`` (concatenated).

    Parameters
    ----------
    errors : ndarray
        Measured range minus the distance along the ray to the nearest segment, metres, for the
        valid beams whose ray meets a segment.
    n_valid : int
        Every valid beam.
    beams : ndarray of int
        The indices of the beams of ``errors``.
    """

    errors: np.ndarray = field(repr=False)
    n_valid: int
    beams: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64), repr=False)

    @property
    def rmse(self) -> float:
        return float(np.sqrt(np.mean(self.errors ** 2))) if len(self.errors) else math.nan

    @property
    def median_abs(self) -> float:
        """Median of ``|errors|``, metres."""
        return float(np.median(np.abs(self.errors))) if len(self.errors) else math.nan

    def share_over(self, limit_m: float = 0.1) -> float:
        """Share of the covered beams whose ``|error|`` exceeds ``limit_m``."""
        return float(np.mean(np.abs(self.errors) > limit_m)) if len(self.errors) else math.nan

    @property
    def coverage(self) -> float:
        """Share of the valid beams whose ray meets a segment."""
        return len(self.errors) / self.n_valid if self.n_valid else math.nan

    def __add__(self, other: RayErrors) -> RayErrors:
        return RayErrors(np.concatenate([self.errors, other.errors]), self.n_valid + other.n_valid,
                         np.concatenate([self.beams, other.beams]))


def ray_errors(scan: Scan, segments: Sequence) -> RayErrors:
    """The ray-axis errors of ``segments`` against ``scan`` (no ground truth needed).

    The ray-axis errors of ``segments`` (anything with ``start``/``end``, sensor frame) against
    ``scan``: for each valid beam, the measured range minus the distance from the sensor to the
    nearest point where the beam's ray crosses a segment (a ray through a segment's end point meets
    it, to within a billionth of its length).

    Parameters
    ----------
    scan : Scan
        The scan the segments were extracted from.
    segments : sequence
        Line segments (anything with ``start`` and ``end``, sensor frame, metres).

    Returns
    -------
    RayErrors
        The error of each valid beam whose ray meets a segment, with its RMSE and robust summaries.

    Examples
    --------
    A wall at x = 2 m seen by three beams, one reading 5 cm long; the segment on the wall
    explains the other two exactly:

    >>> from types import SimpleNamespace as Seg
    >>> angles = np.array([-0.1, 0.0, 0.1])
    >>> scan = Scan(2.0 / np.cos(angles) + [0.0, 0.05, 0.0], angles)
    >>> e = ray_errors(scan, [Seg(start=(2.0, -1.0), end=(2.0, 1.0))])
    >>> np.round(e.errors, 6).tolist(), e.beams.tolist(), e.coverage
    ([0.0, 0.05, 0.0], [0, 1, 2], 1.0)
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    valid = scan.valid
    n_valid = int(valid.sum())
    if n_valid == 0 or len(segments) == 0:
        return RayErrors(np.empty(0), n_valid)
    beams = np.flatnonzero(valid)
    theta = scan.angles[valid]
    rho = scan.ranges[valid]
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)  # (B, 2) ray directions
    p = np.array([np.asarray(s.start, dtype=float) for s in segments])  # (K, 2)
    d = np.array([np.asarray(s.end, dtype=float) for s in segments]) - p
    # s u = p + t d  =>  s = (p x d) / (u x d),  t = (p x u) / (u x d)
    den = u[:, None, 0] * d[None, :, 1] - u[:, None, 1] * d[None, :, 0]  # (B, K)
    pxd = p[:, 0] * d[:, 1] - p[:, 1] * d[:, 0]
    pxu = p[None, :, 0] * u[:, None, 1] - p[None, :, 1] * u[:, None, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = pxd[None, :] / den
        t = pxu / den
    ok = (den != 0) & (s > 0) & (t >= -1e-9) & (t <= 1 + 1e-9)
    s = np.where(ok, s, np.inf)
    nearest = s.min(axis=1)
    hit = np.isfinite(nearest)
    return RayErrors(rho[hit] - nearest[hit], n_valid, beams[hit])
