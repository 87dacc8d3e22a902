"""The IAV detectors' fast engine: every segment of a scan tested at once (private).

:func:`labkit.detect_circles`, :func:`labkit.detect_arcs` (:mod:`labkit.circles.iav_circles`),
:func:`labkit.detect_legs` (:mod:`labkit.circles.legs`) and :func:`labkit.detect_lines_iav`
(:mod:`labkit.lines.iav_lines`) read as Xavier et al. (2005): their reference, which
``trace=True`` runs, takes one segment at a time through one short function per test of the
paper. Their default path runs the engine here, which gives the same features (the identity
tests of ``tests/test_iav_reference.py``) at a fraction of the cost:

* a scan's segments are stored back to back in one array (:class:`Runs`); their extreme and
  middle points and chords are array operations over all runs (:func:`geometry`);
* the cheap tests on them (counts, chords, the middle point of Fig. 5) are a loop on plain
  floats over the runs, a scan having tens of them (:func:`cheap_tests`);
* the inscribed angles of the runs that pass are computed in one go and reduced per run with
  ``np.bincount`` (:func:`batch_angles`); only the few runs left (the circles themselves) meet
  more Python code.

This is what makes a scan cost tens of microseconds rather than a millisecond. Both faces share
the verdicts (:data:`VERDICTS`) and the one function that writes a segment's
:class:`labkit.Step` (:func:`segment_step`), and the noise allowances (:mod:`labkit._iav_noise`).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from ._iav_noise import angle_limits, angle_noise_runs, ratio_sd, widen, wider_than_noise
from ._jit import ENABLED as _JIT
from ._validate import check_positive
from .features import Circle, Leg, LineSegment, line_segment
from .fitting import fit_circle
from .iav import NOISE_Z, circle_confidence, circle_from_iav, is_v_corner
from .scan import Scan
from .segmentation import RangeSegment, labels_from, segment_labels, segment_order
from .steps import Step

__all__ = ["VERDICTS", "ACCEPTED", "FEW", "SHORT", "LONG", "PREREQ", "DEGENERATE", "MEAN", "STD", "VCORNER", "FIT",
           "OCCLUDED", "RESIDUAL", "Runs", "NO_RUNS", "scan_runs", "check_scan", "geometry", "cheap_tests",
           "batch_angles", "segment_step", "Seen", "trace", "CircleTest", "circle_limits", "circle_engine",
           "arc_pieces", "make_circle", "drop_wider", "LegTest", "leg_limits", "leg_center", "padded_chords",
           "occluded", "leg_engine", "LineTest", "line_limits", "line_engine"]

#: What decided a segment, in the trace's words (``Step.test``); the codes below index it.
VERDICTS = ("accepted", "too few points", "chord too short", "chord too long", "prerequisite", "degenerate",
            "iav mean", "iav std", "v-corner", "fit failed", "occluded", "residual")
ACCEPTED, FEW, SHORT, LONG, PREREQ, DEGENERATE, MEAN, STD, VCORNER, FIT, OCCLUDED, RESIDUAL = range(12)


# ============================================================================ the runs of a scan
# The records below are NamedTuples rather than frozen dataclasses: they are built several times
# per scan, and a NamedTuple is several times cheaper to build.
class Runs(NamedTuple):
    """Runs of points stored back to back: run ``k`` is rows ``starts[k]:ends[k]``."""

    idx: np.ndarray  # (K,) beam index of each point
    pts: np.ndarray  # (K, 2)
    starts: np.ndarray  # (S,)
    ends: np.ndarray  # (S,), exclusive; every run holds at least one point
    check_finite: bool = True  # False when the points are a scan's valid beams

    @property
    def sizes(self) -> np.ndarray:
        return self.ends - self.starts

    def segments(self):
        """Each run in turn as ``(beams, points)``: its beam indices (M,) and points (M, 2)."""
        for a, b in zip(self.starts.tolist(), self.ends.tolist(), strict=True):
            yield self.idx[a:b], self.pts[a:b]


NO_RUNS = Runs(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64))


def check_scan(scan) -> None:
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")


def _check_segments(segments) -> list[RangeSegment]:
    segs = list(segments)
    for s in segs:
        if not isinstance(s, RangeSegment):
            raise ValueError(f"segments must be RangeSegment records (labkit.range_segments), got {type(s).__name__}")
    return segs


def _runs_from_labels(scan: Scan, labels: np.ndarray) -> Runs:
    """The segments of ``labels`` in label order (:func:`labkit.segmentation.segment_order`)."""
    idx, starts, stops = segment_order(labels)
    if idx.size == 0:
        return NO_RUNS
    return Runs(idx, scan.points.take(idx, axis=0), starts, stops, False)  # take: points[idx], faster


def _runs_from_segments(segments) -> Runs:
    segs = [s for s in _check_segments(segments) if len(s.indices)]
    if not segs:
        return NO_RUNS
    idx = np.concatenate([np.asarray(s.indices, dtype=np.int64) for s in segs])
    pts = np.concatenate([np.asarray(s.points, dtype=np.float64).reshape(-1, 2) for s in segs])
    if pts.shape[0] != idx.size:
        raise ValueError("segments must hold one point per beam index")
    ends = np.cumsum([len(s.indices) for s in segs])
    return Runs(idx, pts, ends - np.array([len(s.indices) for s in segs]), ends)


def scan_runs(scan: Scan, segments, seg_threshold_m: float | None) -> Runs:
    """The runs a detector tests: ``segments`` (per-beam labels, or :class:`RangeSegment` records
    with their own points), else the scan cut at the fixed ``seg_threshold_m`` (the paper's
    segmentation)."""
    if isinstance(segments, np.ndarray):
        return _runs_from_labels(scan, labels_from(scan, segments))
    if segments is not None:
        runs = _runs_from_segments(segments)
        if runs.idx.size and (runs.idx.min() < 0 or runs.idx.max() >= scan.n_beams):
            raise ValueError(f"segments has beam indices outside the scan's 0..{scan.n_beams - 1}")
        return runs
    threshold = check_positive("seg_threshold_m", seg_threshold_m)
    return _runs_from_labels(scan, segment_labels.unchecked(scan, threshold_m=threshold, min_points=2, adaptive=False))


class Geometry(NamedTuple):
    """Per run: size, chord, first, last and middle point (row ``n // 2``), and whether all
    its points are finite (None when not checked: the points of a scan's valid beams)."""

    n: np.ndarray
    chord: np.ndarray
    p_first: np.ndarray
    p_last: np.ndarray
    middle: np.ndarray
    finite: np.ndarray | None


def geometry(runs: Runs) -> Geometry:
    n = runs.ends - runs.starts
    p0 = runs.pts.take(runs.starts, axis=0)  # take(i, axis=0): pts[i], several times faster
    p1 = runs.pts.take(runs.ends - 1, axis=0)
    mid = runs.pts.take(runs.starts + n // 2, axis=0)
    d = p1 - p0
    finite = None
    if runs.check_finite:
        finite = ~(np.add.reduceat(~np.isfinite(runs.pts).all(axis=1), runs.starts) > 0)
    return Geometry(n, np.hypot(d[:, 0], d[:, 1]), p0, p1, mid, finite)


def cheap_tests(geo: Geometry, chord: np.ndarray, min_points: int, chord_range: tuple[float, float],
                middle_range: tuple[float, float], hollow: bool = False, sigma: float = 0.0,
                widened: dict | None = None) -> tuple[list[int], list[float]]:
    """The cheap tests of every run in the detectors' order, the first failed deciding: too
    few points, chord too short, chord too long, degenerate (a non-finite point, no chord),
    and the prerequisite on the middle point (``hollow``: on either side of the chord).

    A scan holds tens of runs, not thousands, so a loop on plain floats beats array
    operations here. Returns each run's verdict (``ACCEPTED`` when it passed them all) and
    its signed middle-point ratio (NaN for the runs that did not get that far). ``chord`` is
    the chord tested; the ratio is taken over ``geo.chord``.

    ``sigma`` > 0 (range noise, metres) widens the prerequisite band of each run by
    ``NOISE_Z`` times the ratio's standard deviation under that noise (:func:`labkit._iav_noise.ratio_sd`);
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
            v = FEW
        elif tested[k] < c_lo:
            v = SHORT
        elif tested[k] > c_hi:
            v = LONG
        else:
            # the middle point's signed distance from the chord over the chord length,
            # cross(d, m) / chord^2, positive towards the sensor (as labkit.iav.middle_point_offset)
            (x0, y0), (x1, y1), (xm, ym), c = p0[k], p1[k], mid[k], chords[k]
            dx, dy = x1 - x0, y1 - y0
            cross_mid = dx * (ym - y0) - dy * (xm - x0)
            cross_origin = dy * x0 - dx * y0  # cross(d, origin - p0)
            side = -cross_mid if cross_origin < 0 else abs(cross_mid) if cross_origin == 0 else cross_mid
            c2 = c * c  # (0 for chords under 1e-162 m: then side / 0 as numpy would give it)
            r = side / c2 if c2 > 0 else side * math.inf if c > 0 else math.nan
            if math.isnan(r) or not finite[k]:
                v = DEGENERATE
            elif sigma > 0.0:
                w = NOISE_Z * ratio_sd(p0[k], p1[k], mid[k], c, sigma)
                if widened is not None:
                    widened[k] = (lo - w, hi + w)
                v = ACCEPTED if lo - w < (abs(r) if hollow else r) < hi + w else PREREQ
            else:
                v = ACCEPTED if lo < (abs(r) if hollow else r) < hi else PREREQ
        verdicts.append(v)
        ratios.append(r)
    return verdicts, ratios


class Angles(NamedTuple):
    """Signed inscribed angles of selected runs, back to back, and their statistics."""

    angles: np.ndarray  # (T,)
    offsets: np.ndarray  # (R,) start of run j's angles
    counts: np.ndarray  # (R,)
    mean: np.ndarray
    std: np.ndarray
    side: np.ndarray | None  # (R,) sum of cross(chord, P_i - P_1): > 0 when the points lie left of P_1 -> P_n
    degenerate: np.ndarray  # (R,) bool: an interior point on an extreme

    def side_of(self, j: int) -> float:
        """``side`` of the ``j``-th run (computed unless ``batch_angles(..., with_side=False)``)."""
        assert self.side is not None, "the engine asks batch_angles for the sides wherever it reads one"
        return self.side.item(j)


def batch_angles(runs: Runs, sel: np.ndarray, flip: np.ndarray | None = None, with_side: bool = True) -> Angles:
    """Inscribed angles of runs ``sel`` (each of 3 points or more); ``flip`` (R,) mirrors a
    run's angles to ``2 pi - a`` (hollow arcs); ``with_side=False`` leaves ``side`` out (None).

    Points are complex numbers here, as in :func:`labkit.iav.inscribed_angles`: with
    ``a = P_1 - P_i`` and ``b = P_n - P_i`` the counter-clockwise angle from ``a`` to ``b`` is
    ``arg(b conj(a))``.
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
    return Angles(ang, offsets, counts, mean, np.sqrt(var), side, degenerate)


# ============================================================================ the trace
def _nearest(value: float, bounds) -> float:
    """The bound of ``bounds`` (a number or a (low, high) pair) that ``value`` is compared with."""
    if not isinstance(bounds, tuple):
        return float(bounds)
    lo, hi = bounds
    return float(lo) if abs(value - lo) <= abs(value - hi) else float(hi)


_HAS_ANGLES = (ACCEPTED, MEAN, STD, VCORNER, FIT, OCCLUDED, RESIDUAL)  # verdicts reached after the angles
_NO_VALUE = (DEGENERATE, FIT, OCCLUDED, RESIDUAL)  # verdicts that compare no number


def segment_step(algorithm: str, verdict: int, first: int, last: int, n: int, chord: float, ratio: float,
                 mean: float, std: float, limits: dict, widened: dict | None, feature) -> Step:
    """The :class:`labkit.Step` of one segment, ``"accept"`` or ``"reject"``, with the values known
    when it was decided: ``verdict`` (:data:`VERDICTS`), its beams ``first..last`` and points ``n``,
    the ``chord`` tested, the middle point's ``ratio``, the inscribed angles' ``mean`` and ``std``
    (NaN where not computed). ``limits``: the threshold (or (low, high) range) of each verdict's
    test, ``widened`` those the noise allowances moved (or None); ``feature``: the accepted one."""
    v = verdict
    c = chord if v != FEW else math.nan
    r = ratio if v not in (FEW, SHORT, LONG) else math.nan
    m, sd = (mean, std) if v in _HAS_ANGLES else (math.nan, math.nan)
    value = {FEW: n, SHORT: c, LONG: c, PREREQ: abs(r) if limits.get("hollow") else r, MEAN: m}.get(v, sd)
    if v == MEAN and "mean_from" in limits:
        value = abs(m - limits["mean_from"])
    if v in _NO_VALUE:
        value = math.nan
    limit = widened.get(v, limits.get(v)) if widened else limits.get(v)
    threshold = _nearest(value, limit) if limit is not None and not math.isnan(value) else math.nan
    known = [f"{n} points"] + [text for ok, text in (
        (not math.isnan(c), f"chord {c:.3f} m"), (not math.isnan(r), f"middle ratio {r:.2f}"),
        (not math.isnan(m), f"iav mean {math.degrees(m):.1f} deg, std {math.degrees(sd):.1f} deg")) if ok]
    fields: dict[str, Any] = dict(value=value, threshold=threshold, test=VERDICTS[v],  # (Step's keywords)
                                  reason=f"{VERDICTS[v]}: " + ", ".join(known))
    if v == ACCEPTED:
        if isinstance(feature, Circle):  # a circle or an arc
            fields.update(center=tuple(float(x) for x in feature.center), radius=float(feature.radius))
        elif isinstance(feature, Leg):
            fields.update(center=tuple(float(x) for x in feature.center), radius=float(feature.diameter) / 2)
        else:  # a line
            fields.update(r=float(feature.r), alpha=float(feature.alpha))
    return Step(algorithm, "accept" if v == ACCEPTED else "reject", int(first), int(last), **fields)


class Seen:
    """What the tests of one segment saw, as the detectors' reference takes it through them: its
    points ``n``, the ``chord`` tested, the middle point's ``ratio``, the angles' ``mean`` and
    ``std``, the limits the noise allowances ``widened`` (by verdict), and the ``verdict``.
    :meth:`step` writes its :class:`labkit.Step`, as the engine's :func:`trace` does."""

    __slots__ = ("n", "chord", "ratio", "mean", "std", "widened", "verdict")

    def __init__(self, n: int) -> None:
        self.n = int(n)
        self.chord = self.ratio = self.mean = self.std = math.nan
        self.widened: dict | None = None
        self.verdict = ACCEPTED

    def reject(self, verdict: int) -> None:
        """The segment failed the test ``verdict``: no feature."""
        self.verdict = verdict

    def step(self, algorithm: str, beams: np.ndarray, limits: dict, feature) -> Step:
        return segment_step(algorithm, self.verdict, int(beams[0]), int(beams[-1]), self.n, self.chord, self.ratio,
                            self.mean, self.std, limits, self.widened, feature)


def trace(runs: Runs, geo: Geometry, chord: np.ndarray, ratio, verdict, sel, ang: Angles | None,
          algorithm: str, limits: dict, found: list, widened: dict | None = None) -> list[Step]:
    """One :func:`segment_step` per run, from the engine's arrays (``chord``, ``ratio``: as
    tested; ``verdict`` per run; ``ang``: the inscribed angles of the runs ``sel``, or None;
    ``found``: the features, in the order of the accepted runs; ``widened``: per run, the limits
    (by verdict) that noise allowances changed)."""
    mean, std = np.full(len(verdict), np.nan), np.full(len(verdict), np.nan)
    if ang is not None:
        mean[sel], std[sel] = ang.mean, ang.std
    first, last = runs.idx[runs.starts], runs.idx[runs.ends - 1]
    features = iter(found)
    return [segment_step(algorithm, int(verdict[k]), int(first[k]), int(last[k]), int(geo.n[k]), float(chord[k]),
                         float(ratio[k]), float(mean[k]), float(std[k]), limits,
                         widened.get(k) if widened else None,
                         next(features) if verdict[k] == ACCEPTED else None) for k in range(len(verdict))]


# ============================================================================ circles and arcs
class CircleTest(NamedTuple):
    """The thresholds of the circle test of :func:`labkit.detect_circles` and
    :func:`labkit.detect_arcs` (angles in radians)."""

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


def circle_limits(t: CircleTest) -> dict:
    """The thresholds of the circle test by verdict, for the trace."""
    limits = {FEW: max(t.min_points, 3), SHORT: t.chord_range[0], LONG: t.chord_range[1],
              PREREQ: t.middle_range, MEAN: t.mean_range, STD: t.std_max, ACCEPTED: t.std_max,
              "hollow": t.hollow}
    if t.arc_like_std_max is not None:
        limits[STD] = limits[VCORNER] = t.arc_like_std_max
    return limits


def circle_engine(runs: Runs, t: CircleTest, sigma: float = 0.0, *, want_trace: bool = False,
                  algorithm: str = "iav_circles") -> tuple[list[Circle], list[Step]]:
    """The circle test on every run (``sigma`` > 0: with the noise allowances for that range
    noise): the circles, and with ``want_trace`` the steps."""
    s = runs.starts.size
    if s == 0:
        return [], []
    if not want_trace and not t.hollow and t.arc_like_std_max is None and _engine() is not None:
        return _compiled_circles(runs, t, sigma), []
    geo = geometry(runs)
    widened: dict = {}
    verdict, ratio = cheap_tests(geo, geo.chord, max(t.min_points, 3), t.chord_range, t.middle_range, t.hollow,
                                 sigma, widened)
    widened = {k: {PREREQ: band} for k, band in widened.items()}
    sel = [k for k, v in enumerate(verdict) if v == ACCEPTED]
    circles: list[Circle] = []
    ang = None
    if sel:
        ang = batch_angles(runs, np.array(sel), np.array([ratio[k] < 0 for k in sel]) if t.hollow else None)
        noise: list[tuple[float, float] | None] = [None] * len(sel)
        if sigma > 0.0:  # the angle allowances of every selected run at once
            spread_sq, mean_sd = angle_noise_runs(runs.pts, runs.starts[sel], runs.ends[sel], sigma)
            noise = list(zip(spread_sq.tolist(), mean_sd.tolist(), strict=True))
        passed = []  # (j, k, kind, limits) of the runs whose inscribed angles pass
        for j, k in enumerate(sel):
            v, kind, limits = _angle_verdict(ang, j, t, noise[j], widened.get(k))
            verdict[k] = v
            if v == ACCEPTED:
                passed.append((j, k, kind, limits))
        made = [make_circle(runs, geo, ang, j, k, t, kind, limits) for j, k, kind, limits in passed]
        if sigma > 0.0 and passed:  # and their points must lie on a circle within the noise
            ks = [k for _, k, _, _ in passed]
            circle_of = [c for c, _ in made]
            centers = np.array([c.center if c is not None else (np.nan, np.nan) for c in circle_of]).reshape(-1, 2)
            radii = np.array([c.radius if c is not None else np.nan for c in circle_of])
            wider = wider_than_noise(runs.pts, runs.starts[ks], runs.ends[ks], sigma, centers, radii).tolist()
            made = [(None, RESIDUAL) if w else m for w, m in zip(wider, made, strict=True)]
        for (_, k, _, _), (circle, v) in zip(passed, made, strict=True):
            verdict[k] = v
            if circle is not None:
                circles.append(circle)
    if not want_trace:
        return circles, []
    return circles, trace(runs, geo, geo.chord, ratio, verdict, sel, ang, algorithm, circle_limits(t), circles,
                          widened)


def _engine():
    """labkit._iav_engine, or None where it does not run (LABKIT_NO_JIT=1, or numpy's complex
    product rounds otherwise than it assumes); imported on the first scan."""
    global _ENGINE
    if _ENGINE is False:
        _ENGINE = None
        if _JIT:
            from types import SimpleNamespace

            from ._iav_engine import COMPLEX_FMA, circle_tests, leg_tests

            _ENGINE = SimpleNamespace(circle_tests=circle_tests, leg_tests=leg_tests) if COMPLEX_FMA else None
    return _ENGINE


_ENGINE: Any = False


def _compiled_circles(runs: Runs, t: CircleTest, sigma: float) -> list[Circle]:
    """:func:`circle_engine`'s circles, the tests up to the centre compiled
    (:func:`labkit._iav_engine.circle_tests`)."""
    verdict, _, mean, std, side, lim = _ENGINE.circle_tests(
        runs.pts, runs.starts, runs.ends, runs.check_finite, max(t.min_points, 3), t.chord_range, t.middle_range,
        t.mean_range, t.std_max, sigma)
    passed = np.flatnonzero(verdict == ACCEPTED)
    if not passed.size:
        return []
    geo = Geometry(runs.ends - runs.starts, None, runs.pts.take(runs.starts, axis=0),  # type: ignore[arg-type]
                   runs.pts.take(runs.ends - 1, axis=0), None, None)  # type: ignore[arg-type]
    ang = Angles(None, None, None, mean, std, side, None)  # type: ignore[arg-type]
    made = [make_circle(runs, geo, ang, k, k, t, t.kind, ((lim.item(k, 0), lim.item(k, 1)), lim.item(k, 2)))
            for k in passed.tolist()]
    if sigma > 0.0:  # and their points must lie on a circle within the noise
        made = drop_wider(runs, passed, made, sigma)
    return [c for c, _ in made if c is not None]


def drop_wider(runs: Runs, passed: np.ndarray, made: list, sigma: float) -> list:
    """``made`` (a ``(circle, verdict)`` per run of ``passed``) with ``(None, RESIDUAL)`` where the
    run's points lie wider than noise ``sigma`` allows (:func:`labkit._iav_noise.wider_than_noise`,
    each run's circle tried first)."""
    circle_of = [c for c, _ in made]
    centers = np.array([c.center if c is not None else (np.nan, np.nan) for c in circle_of]).reshape(-1, 2)
    radii = np.array([c.radius if c is not None else np.nan for c in circle_of])
    wider = wider_than_noise(runs.pts, runs.starts[passed], runs.ends[passed], sigma, centers, radii).tolist()
    return [(None, RESIDUAL) if w else m for w, m in zip(wider, made, strict=True)]


def _angle_verdict(ang: Angles, j: int, t: CircleTest, noise: tuple | None = None,
                   widened: dict | None = None) -> tuple[int, str, tuple]:
    """The inscribed-angle tests of the ``j``-th selected run: its verdict (``ACCEPTED`` if it
    passes), its kind, and the limits it was held to ``(mean_range, std_max)``; with a noise
    allowance, ``noise`` is its ``(spread_sq, mean_sd)`` (:func:`labkit._iav_noise.angle_noise_runs`)."""
    mean_range, std_max, like_max = t.mean_range, t.std_max, t.arc_like_std_max
    if ang.degenerate.item(j):
        return DEGENERATE, t.kind, (mean_range, std_max)
    mean, std = ang.mean.item(j), ang.std.item(j)
    if noise is not None:
        mean_range, std_max, like_max = widen(noise[0], noise[1], mean_range, std_max, like_max)
        if widened is not None:
            widened.update({MEAN: mean_range, STD: std_max if like_max is None else like_max,
                            VCORNER: like_max, ACCEPTED: std_max})
    if not (mean_range[0] <= mean <= mean_range[1]):
        return MEAN, t.kind, (mean_range, std_max)
    kind = t.kind
    if std >= std_max:
        if like_max is None or std >= like_max:
            return STD, kind, (mean_range, std_max)
        angles = ang.angles[ang.offsets[j]:ang.offsets[j] + ang.counts[j]]
        stride = t.v_corner_stride if t.v_corner_stride is not None else max(1, angles.size // 8)
        if is_v_corner(angles, t.v_corner_neighbours, stride):
            return VCORNER, kind, (mean_range, std_max)
        kind, std_max = "arc-like", like_max
    return ACCEPTED, kind, (mean_range, std_max)


def make_circle(runs: Runs, geo: Geometry, ang: Angles, j: int, k: int, t: CircleTest, kind: str,
                 limits: tuple) -> tuple[Circle | None, int]:
    """The circle of run ``k`` (``j``-th of the selected), which passed the tests with ``limits``
    (:func:`_angle_verdict`), and its verdict (``FIT`` when no circle fits it)."""
    mean, std = ang.mean.item(j), ang.std.item(j)
    mean_range, std_max = limits
    try:
        if t.center_method == "iav":
            side = ang.side_of(j)
            center, radius = circle_from_iav(geo.p_first[k], geo.p_last[k], mean, side if side != 0 else 1.0)
        else:
            fit = fit_circle(runs.pts[runs.starts.item(k):runs.ends.item(k)], t.center_method)
            center, radius = np.array(fit.center, dtype=np.float64), fit.radius
    except ValueError:
        return None, FIT
    center.setflags(write=False)
    n = geo.n.item(k)
    confidence = circle_confidence(n - 2, mean, std, std_max=std_max, mean_range=mean_range)
    first, last = runs.idx.item(runs.starts.item(k)), runs.idx.item(runs.ends.item(k) - 1)
    return Circle(center, float(radius), mean, std, confidence, first, last, n, kind), ACCEPTED


def arc_pieces(runs: Runs, on_line: np.ndarray) -> Runs:
    """The runs :func:`labkit.detect_arcs` tests: in each run that holds a beam of a line
    (``on_line``, per beam), every stretch of consecutive points off the lines."""
    if runs.starts.size == 0:
        return NO_RUNS
    out = on_line[runs.idx]
    seg_of = np.repeat(np.arange(runs.starts.size), runs.sizes)
    has_line = np.add.reduceat(out, runs.starts) > 0
    keep = ~out & has_line[seg_of]
    continues = np.concatenate([[False], keep[:-1] & (seg_of[1:] == seg_of[:-1])])
    kept = np.flatnonzero(keep)
    if kept.size == 0:
        return NO_RUNS
    starts = np.flatnonzero(~continues[kept])
    return Runs(runs.idx[kept], runs.pts.take(kept, axis=0), starts, np.concatenate([starts[1:], [kept.size]]),
                runs.check_finite)


# ============================================================================ legs
class LegTest(NamedTuple):
    """The thresholds of :func:`labkit.detect_legs` (angles in radians; None: not tested)."""

    min_points: int
    chord_range: tuple[float, float]
    chord_padding_beams: float
    middle_range: tuple[float, float]
    iav_mean_range: tuple[float, float] | None
    iav_std_max: float | None
    reject_occluded: bool
    center_method: str


def leg_limits(t: LegTest) -> dict:
    """The thresholds of the leg test by verdict, for the trace."""
    limits = {FEW: t.min_points, SHORT: t.chord_range[0], LONG: t.chord_range[1], PREREQ: t.middle_range}
    if t.iav_mean_range is not None:
        limits[MEAN] = tuple(t.iav_mean_range)
    if t.iav_std_max is not None:
        limits[STD] = limits[ACCEPTED] = t.iav_std_max
    return limits


def occluded(scan: Scan, first: int, last: int) -> bool:
    """:func:`labkit.circles.legs.is_occluded` without the checks."""
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


def leg_center(points: np.ndarray, chord: float, mean: float, side: float, method: str) -> tuple[np.ndarray, float]:
    """Centre and diameter of a leg segment (:func:`labkit.detect_legs`' ``center_method``):
    ``"ray"`` the middle point pushed back along its beam by half the (padded) ``chord``, whose
    diameter it is; ``"iav"`` :func:`labkit.iav.circle_from_iav` (``side``: the points' side of
    the chord); else :func:`labkit.fit_circle`."""
    if method == "ray":
        mx, my = points[points.shape[0] // 2].tolist()
        h, k = math.hypot(mx, my), 0.5 * chord
        return np.array([mx + k * mx / h, my + k * my / h]), chord
    if method == "iav":
        center, radius = circle_from_iav(points[0], points[-1], mean, side if side != 0 else 1.0)
        return np.asarray(center, dtype=np.float64), 2.0 * radius
    fit = fit_circle(points, method)
    return np.array(fit.center, dtype=np.float64), 2.0 * fit.radius


def padded_chords(scan: Scan, geo: Geometry, chord_padding_beams: float) -> np.ndarray:
    """Each run's chord plus ``chord_padding_beams`` beam spacings at its middle point's range."""
    spacing = abs(scan.angle_increment) if scan.n_beams > 1 else 0.0
    return geo.chord + chord_padding_beams * spacing * np.hypot(geo.middle[:, 0], geo.middle[:, 1])


def leg_engine(scan: Scan, runs: Runs, t: LegTest, sigma: float = 0.0, *,
               want_trace: bool = False) -> tuple[list[Leg], list[Step]]:
    """The leg test on every run (``sigma`` > 0: with the noise allowances for that range noise):
    the legs, and with ``want_trace`` the steps."""
    if runs.starts.size == 0:
        return [], []
    if not want_trace and t.iav_mean_range is None and t.iav_std_max is None and _engine() is not None:
        return _compiled_legs(scan, runs, t, sigma), []
    geo = geometry(runs)
    chord = padded_chords(scan, geo, t.chord_padding_beams)
    widened: dict = {}
    verdict, ratio = cheap_tests(geo, chord, t.min_points, t.chord_range, t.middle_range, sigma=sigma,
                                 widened=widened)
    widened = {k: {PREREQ: band} for k, band in widened.items()}
    sel = [k for k, v in enumerate(verdict) if v == ACCEPTED]
    legs: list[Leg] = []
    ang = None
    if sel:
        ang = batch_angles(runs, np.array(sel), with_side=t.center_method == "iav")
        for j, k in enumerate(sel):
            a, b = runs.starts.item(k), runs.ends.item(k)
            first, last = runs.idx.item(a), runs.idx.item(b - 1)
            m, sd = ang.mean.item(j), ang.std.item(j)
            mean_range, std_max = t.iav_mean_range, t.iav_std_max
            if sigma > 0.0 and not (mean_range is None and std_max is None):
                mean_range, std_max, _ = angle_limits(runs.pts[a:b], sigma, mean_range or (0.0, math.pi), std_max)
                widened[k].update({MEAN: mean_range, STD: std_max, ACCEPTED: std_max})
                mean_range = mean_range if t.iav_mean_range is not None else None
            if ang.degenerate.item(j):
                verdict[k] = DEGENERATE
            elif mean_range is not None and not mean_range[0] <= m <= mean_range[1]:
                verdict[k] = MEAN
            elif std_max is not None and sd >= std_max:
                verdict[k] = STD
            elif t.reject_occluded and occluded(scan, first, last):
                verdict[k] = OCCLUDED
            else:
                side = ang.side_of(j) if t.center_method == "iav" else 0.0  # (only the iav centre needs it)
                try:
                    center, diameter = leg_center(runs.pts[a:b], chord.item(k), m, side, t.center_method)
                except ValueError:
                    verdict[k] = FIT
                    continue
                middle = np.array(geo.middle[k], dtype=np.float64)
                center.setflags(write=False)
                middle.setflags(write=False)
                legs.append(Leg(center, float(diameter), middle, first, last, b - a, m, sd))
    if not want_trace:
        return legs, []
    return legs, trace(runs, geo, chord, ratio, verdict, sel, ang, "legs", leg_limits(t), legs, widened)


def _compiled_legs(scan: Scan, runs: Runs, t: LegTest, sigma: float) -> list[Leg]:
    """:func:`leg_engine`'s legs when neither the angles' mean nor their spread is tested, the tests
    up to the angles compiled (:func:`labkit._iav_engine.leg_tests`)."""
    spacing = abs(scan.angle_increment) if scan.n_beams > 1 else 0.0
    verdict, chord, mean, std, side = _ENGINE.leg_tests(runs.pts, runs.starts, runs.ends, runs.check_finite,
                                                        t.min_points, t.chord_range, t.middle_range,
                                                        t.chord_padding_beams * spacing, sigma)
    legs: list[Leg] = []
    for k in np.flatnonzero(verdict == ACCEPTED).tolist():
        a, b = runs.starts.item(k), runs.ends.item(k)
        first, last = runs.idx.item(a), runs.idx.item(b - 1)
        if t.reject_occluded and occluded(scan, first, last):
            continue
        m, sd = mean.item(k), std.item(k)
        try:
            center, diameter = leg_center(runs.pts[a:b], chord.item(k), m, side.item(k), t.center_method)
        except ValueError:
            continue
        middle = np.array(runs.pts[a + (b - a) // 2], dtype=np.float64)
        center.setflags(write=False)
        middle.setflags(write=False)
        legs.append(Leg(center, float(diameter), middle, first, last, b - a, m, sd))
    return legs


# ============================================================================ lines
class LineTest(NamedTuple):
    """The thresholds of :func:`labkit.detect_lines_iav` (angles in radians)."""

    min_points: int
    min_length_m: float
    mean_tolerance: float
    std_max: float


def line_limits(t: LineTest) -> dict:
    """The thresholds of the line test by verdict, for the trace (the mean test compares
    ``|mean - pi|`` with the tolerance)."""
    return {FEW: t.min_points, SHORT: t.min_length_m, MEAN: t.mean_tolerance, STD: t.std_max, ACCEPTED: t.std_max,
            "mean_from": math.pi}


def line_engine(runs: Runs, t: LineTest, *, want_trace: bool = False) -> tuple[list[LineSegment], list[Step]]:
    """The line test on every run: the lines, and with ``want_trace`` the steps."""
    s = runs.starts.size
    if s == 0:
        return [], []
    geo = geometry(runs)
    verdict = np.full(s, ACCEPTED, dtype=np.int64)
    if geo.finite is not None:
        verdict[~geo.finite] = DEGENERATE
    verdict[geo.chord < t.min_length_m] = SHORT
    verdict[geo.n < t.min_points] = FEW
    sel = np.flatnonzero(verdict == ACCEPTED)
    lines: list[LineSegment] = []
    ang = None
    if sel.size:
        ang = batch_angles(runs, sel)
        verdict[sel[np.abs(ang.mean - math.pi) > t.mean_tolerance]] = MEAN
        verdict[sel[(verdict[sel] == ACCEPTED) & (ang.std >= t.std_max)]] = STD
        verdict[sel[ang.degenerate]] = DEGENERATE
        for k in sel[verdict[sel] == ACCEPTED]:
            a, b = runs.starts[k], runs.ends[k]
            lines.append(line_segment(runs.pts[a:b], runs.idx[a:b]))
    if not want_trace:
        return lines, []
    return lines, trace(runs, geo, geo.chord, np.full(s, np.nan), verdict, sel, ang, "iav_lines", line_limits(t),
                        lines)
