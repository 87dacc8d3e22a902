"""The default path of :func:`labkit.extract_features` with few Python calls per scan (private).

:func:`labkit.extract_features` reads as its stages: each detector called with its section of the
:class:`labkit.Config`, given the segments the stages before left. Called that way, every detector
works out again what the scan already knows -- the labels copied and masked, the segments laid
end to end, their points gathered and split into coordinates, the noise estimate looked up, the
parameters turned into keyword arguments and the tests' records built -- some two hundred Python
calls per scan, which on a 180-beam scan cost more than the compiled work itself.

Here the same stages run on the same arrays with the scan-level quantities worked out once: the
parameters are resolved once per :class:`labkit.Config` (:func:`plan_for`, which also packs their
numbers into the two arrays the passes take: ``labkit._kernels``' layout), the scan's points,
validity, full-circle flag and noise once per scan, and then two compiled passes do the rest:
:func:`labkit._iav_engine.stage_pass` (the segmentation; the legs' tests, occlusion and centres;
the circles' tests, centres and noise test on the segments the legs left) and
:func:`labkit.lines._split_merge_engine.line_pass` (the lines, their covariances and placing, and
their corners). Each hands back one float and one integer array (a call costs a few microseconds
and each array numba hands back to Python about one); the records are made from their rows, the
few floats Python computes itself (a circle's confidence) in the same Python arithmetic. Where
Python computes ``math.hypot``, the passes compute it as CPython does
(:func:`labkit._kernels.py_hypot`: the C library's ``hypot`` differs in the last bit now and
then). So the features are the stages' own, bit for bit: ``tests/test_engine.py`` compares the
two paths on random scans, the simulated worlds and real recordings. Configurations the passes do
not cover (another leg or circle centre, a test of the legs' angles, arc-like circles, the arcs)
run the stages one compiled call or two each (:func:`_staged`), as do the rare scans the passes
hand back (a circle fit that needs numpy's least squares, a placing too close to call).

A configuration the engines do not cover (another line method, the chi-square merge) runs the
stages as :mod:`labkit.pipeline` reads them, and so does ``LABKIT_NO_JIT=1`` (with their readable
code); a leg test of the inscribed angles, arc-like circles and the arcs run their detectors' own
batch code on the segments this path lays out.
"""

from __future__ import annotations

import math
from time import perf_counter
from typing import Any, NamedTuple

import numpy as np

from ._iav_batch import (
    ACCEPTED,
    FIT,
    Angles,
    CircleTest,
    Geometry,
    LegTest,
    Runs,
    circle_engine,
    drop_wider,
    leg_center,
    leg_engine,
    make_circle,
    occluded,
)
from ._iav_engine import COMPLEX_FMA, circle_pass, leg_pass, stage_pass
from ._iav_noise import EARLY_FACTOR, EARLY_STEPS
from ._kernels import (
    CIRCLE_F,
    CIRCLE_I,
    CORNER_F,
    CORNER_I,
    F_C_C_HI,
    F_C_C_LO,
    F_C_HI,
    F_C_LO,
    F_C_MEAN_HI,
    F_C_MEAN_LO,
    F_C_SIGMA,
    F_C_STD,
    F_C_STD_SQ,
    F_EARLY_FACTOR,
    F_INCREMENT,
    F_K_ANGLE,
    F_K_EXT,
    F_K_GAP,
    F_L_ABSORB,
    F_L_FLOOR,
    F_L_GAP,
    F_L_LAM_CUT,
    F_L_LAM_GRAZE,
    F_L_MERGE_DA,
    F_L_MERGE_DR,
    F_L_MIN_LEN,
    F_L_NOISE,
    F_L_PLACE_DA,
    F_L_PLACE_DR,
    F_L_PLACE_P,
    F_L_SIGMA,
    F_L_THRESHOLD,
    F_LAM,
    F_LEG_C_HI,
    F_LEG_C_LO,
    F_LEG_HI,
    F_LEG_LO,
    F_LEG_PAD,
    F_LEG_SIGMA,
    F_SEG_M,
    F_SEG_SIGMA,
    FUSED_DOT,
    I_ADAPTIVE,
    I_C_MIN,
    I_CIRCLES,
    I_CORNERS,
    I_EARLY_STEPS,
    I_FIT,
    I_FULL,
    I_FUSED,
    I_L_MIN,
    I_LEG_MIN,
    I_LEGS,
    I_MERGE,
    I_OCCLUDED,
    I_PLACE,
    I_SEG_MIN,
    I_SKIP_ROUND,
    I_UNIFORM,
    LEG_F,
    LEG_I,
    LINE_F,
    LINE_I,
    MONOTONIC_CLOCK,
    N_F,
    N_H,
    N_I,
    N_S,
    N_T,
    py_hypot_is_pythons,
)
from ._segmentation_engine import beams, runs, without
from ._segmentation_engine import labels as _segment
from .circles.iav_circles import detect_arcs
from .circles.legs import pair_legs
from .features import Circle, Corner, Features, Leg, LineSegment
from .lines._split_merge_engine import (
    PLACING_NODES,
    PLACING_WEIGHTS,
    corners_pass,
    line_pass,
    lines_pass,
    placed_records,
)
from .lines._split_merge_engine import READY as LINES_READY
from .lines._split_merge_fast import GRAZING_DEG
from .noise import AUTO, auto_split_threshold, check_nonneg, scan_sigma
from .segmentation import SegmentationParams

__all__ = ["READY", "plan_for", "extract"]

#: Whether the engines run here (numba on, the BLAS and complex rounding they reproduce).
READY = bool(LINES_READY and COMPLEX_FMA)


# ---------------------------------------------------------------------------- the scan's beams
def _scan_beams(scan) -> tuple[np.ndarray, np.ndarray]:
    """The scan's ``valid`` and ``points``: its cached ones, else worked out by
    :func:`labkit._segmentation_engine.beams` and kept in the scan's cache, read-only, as its cached
    properties keep them."""
    cache = scan.__dict__
    valid, points = cache.get("valid"), cache.get("points")
    if valid is None or points is None:
        v, p = beams(scan.ranges, scan.angles, float(scan.range_min), float(scan.range_max))
        if valid is None:
            v.setflags(write=False)
            cache["valid"] = valid = v
        if points is None:
            p.setflags(write=False)
            cache["points"] = points = p
    return valid, points


# ---------------------------------------------------------------------------- the segments of a stage
def _asruns(idx, xy, starts, ends) -> Runs:
    """The :class:`labkit._iav_batch.Runs` of a stage (its points as one C-ordered (K, 2) array, as
    ``scan.points.take(idx, axis=0)`` gives them)."""
    return Runs(idx, np.ascontiguousarray(xy.T), starts, ends, False)


# ---------------------------------------------------------------------------- the plan of a Config
class Plan(NamedTuple):
    """A :class:`labkit.Config` resolved once: the arguments every stage's engine takes."""

    seg: tuple  # threshold_m, min_points, adaptive, lambda (rad), range_sigma_m (AUTO or metres)
    legs: LegTest | None  # None: legs off
    legs_sigma: Any  # AUTO or metres
    legs_fast: bool  # the compiled leg tests cover the test (no angle mean or spread tested)
    pair_m: float
    circles: CircleTest | None
    circles_sigma: Any
    circles_fast: bool
    lines: tuple | None  # None: no lines; else the engine's arguments but the scan's
    lines_skip_round: bool
    corners: dict | None
    arcs: dict | None
    packed: tuple | None = None  # (floats, integers) of stage_pass and line_pass, where they cover the Config


def _py_hypot_ok() -> bool:
    """Whether the passes' ``math.hypot`` is this Python's (:func:`labkit._kernels.py_hypot_is_pythons`,
    asked once)."""
    if not _PY_HYPOT:
        _PY_HYPOT.append(py_hypot_is_pythons())
    return _PY_HYPOT[0]


_PY_HYPOT: list[bool] = []


def _pack(plan: Plan) -> tuple | None:
    """``plan``'s numbers as the passes take them (``labkit._kernels``' layout; a scan's own left
    NaN or 0, written in a copy per scan), or None where the passes do not cover the plan: an arc
    detector, a leg or circle test or centre the compiled tests do not run, no clock to time the
    stages by."""
    if not (MONOTONIC_CLOCK and _py_hypot_ok()) or plan.lines is None or plan.arcs is not None:
        return None
    t_legs, t_circles = plan.legs, plan.circles
    if t_legs is not None and not (plan.legs_fast and t_legs.center_method == "ray"):
        return None
    if t_circles is not None and not (plan.circles_fast and t_circles.center_method == "iav"
                                      and t_circles.kind == "circle"):
        return None
    fp = np.full(N_F, math.nan)
    ip = np.zeros(N_I, np.int64)
    threshold_m, min_points, adaptive, lam, _ = plan.seg
    fp[F_SEG_M], fp[F_LAM], ip[I_SEG_MIN], ip[I_ADAPTIVE] = threshold_m, lam, min_points, adaptive
    if t_legs is not None:
        ip[I_LEGS], ip[I_LEG_MIN], ip[I_OCCLUDED] = 1, int(t_legs.min_points), bool(t_legs.reject_occluded)
        fp[F_LEG_C_LO], fp[F_LEG_C_HI] = float(t_legs.chord_range[0]), float(t_legs.chord_range[1])
        fp[F_LEG_LO], fp[F_LEG_HI] = float(t_legs.middle_range[0]), float(t_legs.middle_range[1])
    if t_circles is not None:
        ip[I_CIRCLES], ip[I_C_MIN] = 1, int(max(t_circles.min_points, 3))
        fp[F_C_C_LO], fp[F_C_C_HI] = float(t_circles.chord_range[0]), float(t_circles.chord_range[1])
        fp[F_C_LO], fp[F_C_HI] = float(t_circles.middle_range[0]), float(t_circles.middle_range[1])
        fp[F_C_MEAN_LO], fp[F_C_MEAN_HI] = float(t_circles.mean_range[0]), float(t_circles.mean_range[1])
        fp[F_C_STD], fp[F_C_STD_SQ] = float(t_circles.std_max), float(t_circles.std_max) ** 2
    (fit, _, _, min_points, max_gap_m, merge_on, merge_dr_m, merge_dalpha, min_length_m, uniform, _, floor_m, lam_cut,
     lam_graze, place_dr_m, place_dalpha_deg, place_confidence) = plan.lines
    ip[I_FIT], ip[I_L_MIN], ip[I_MERGE], ip[I_UNIFORM] = fit, min_points, merge_on, uniform
    ip[I_SKIP_ROUND], ip[I_PLACE], ip[I_FUSED] = plan.lines_skip_round, place_confidence > 0, bool(FUSED_DOT)
    ip[I_EARLY_STEPS], fp[F_EARLY_FACTOR] = int(EARLY_STEPS), float(EARLY_FACTOR)
    fp[F_L_GAP], fp[F_L_MERGE_DR], fp[F_L_MERGE_DA], fp[F_L_MIN_LEN] = max_gap_m, merge_dr_m, merge_dalpha, min_length_m
    fp[F_L_FLOOR], fp[F_L_LAM_CUT], fp[F_L_LAM_GRAZE] = floor_m, lam_cut, lam_graze
    fp[F_L_PLACE_DR], fp[F_L_PLACE_DA] = float(place_dr_m), math.radians(place_dalpha_deg)
    fp[F_L_PLACE_P] = float(place_confidence)
    if plan.corners is not None:
        p = plan.corners
        ip[I_CORNERS] = 1
        fp[F_K_ANGLE], fp[F_K_GAP] = math.radians(p["min_angle_deg"]), float(p["max_gap_m"])
        fp[F_K_EXT] = float(p["max_extension_m"])
    fp.setflags(write=False)
    ip.setflags(write=False)
    return fp, ip


def plan_for(cfg) -> Plan | None:
    """The plan of ``cfg`` (cached on it: a Config is frozen), or None where the engines do not
    cover it (the stages then run as :func:`labkit.extract_features` reads)."""
    cached = cfg.__dict__.get("_labkit_plan", False)
    if cached is False:
        cached = _plan(cfg) if READY else None
        cfg.__dict__["_labkit_plan"] = cached  # (a frozen dataclass's cache, as Params.kwargs keeps its own)
    return cached


def _sigma_of(value):
    """A detector's ``range_sigma_m`` as :func:`labkit.noise.noise_sigma` resolves it (AUTO: per scan)."""
    return AUTO if value == AUTO else check_nonneg("range_sigma_m", value)


def _plan(cfg) -> Plan | None:
    seg, lg, cc, lc = cfg.segmentation, cfg.legs, cfg.circles, cfg.lines
    if lc.method not in ("iepf", "split_and_merge", "none") or (lc.method != "none" and lc.merge == "chi2"):
        return None
    legs = None
    if lg.enabled:  # (as labkit.detect_legs builds its test)
        mean_range = std_max = None
        if lg.iav_mean_range_deg is not None and lg.iav_mean_range_deg != (0.0, 180.0):
            low, high = lg.iav_mean_range_deg
            mean_range = (math.radians(low), math.radians(high))
        if lg.iav_std_max_deg is not None and not math.isinf(lg.iav_std_max_deg):
            std_max = math.radians(lg.iav_std_max_deg)
        legs = LegTest(min_points=lg.min_points, chord_range=lg.chord_range_m,
                       chord_padding_beams=lg.chord_padding_beams, middle_range=lg.middle_range,
                       iav_mean_range=mean_range, iav_std_max=std_max, reject_occluded=lg.reject_occluded,
                       center_method=lg.center_method)
    circles = None
    if cc.enabled:  # (as labkit.detect_circles builds its test)
        low, high = cc.mean_range_deg
        circles = CircleTest(min_points=cc.min_points, chord_range=(cc.min_chord_m, cc.max_chord_m),
                             middle_range=cc.middle_range, mean_range=(math.radians(low), math.radians(high)),
                             std_max=math.radians(cc.std_max_deg),
                             arc_like_std_max=math.radians(cc.arc_like_std_max_deg) if cc.arc_like else None,
                             v_corner_neighbours=cc.v_corner_neighbours,
                             v_corner_stride=None, hollow=False,
                             center_method=cc.center_method, kind="circle")
    lines = None
    if lc.method != "none":  # (as labkit.split_and_merge resolves its arguments)
        lines = (lc.method == "split_and_merge", lc.split_threshold_m, _sigma_of(lc.range_sigma_m),
                 int(lc.min_points), float(lc.max_gap_m), lc.merge != "none" and lc.merge is not None,
                 float(lc.merge_dr_m), math.radians(lc.merge_dalpha_deg), float(lc.min_length_m),
                 lc.weights == "uniform", lc.weights, float(SegmentationParams.threshold_m),
                 math.radians(SegmentationParams.incidence_deg), math.radians(GRAZING_DEG), lc.place_dr_m,
                 lc.place_dalpha_deg, lc.place_confidence)
    plan = Plan(
        seg=(float(seg.threshold_m), int(seg.min_points), bool(seg.adaptive), math.radians(seg.incidence_deg),
             seg.range_sigma_m),
        legs=legs, legs_sigma=_sigma_of(lg.range_sigma_m),
        legs_fast=legs is not None and legs.iav_mean_range is None and legs.iav_std_max is None,
        pair_m=lg.pair_max_distance_m,
        circles=circles, circles_sigma=_sigma_of(cc.range_sigma_m),
        circles_fast=circles is not None and circles.arc_like_std_max is None,
        lines=lines, lines_skip_round=bool(lc.skip_round),
        corners=cfg.corners.kwargs() if cfg.corners.enabled else None,
        arcs=cfg.arcs.kwargs() if cfg.arcs.enabled else None)
    return plan._replace(packed=_pack(plan))


# ---------------------------------------------------------------------------- one scan
_NONE = np.zeros(0, np.int64)


def extract(scan, plan: Plan) -> Features:
    """:func:`labkit.extract_features` of ``scan`` with the configuration ``plan`` resolves: in one
    two compiled passes (:func:`stage_pass`, :func:`line_pass`) where they cover the plan and the
    scan, else stage by stage."""
    if plan.packed is not None:
        features = _fused(scan, plan)
        if features is not None:
            return features
    return _staged(scan, plan)


def _scan_geometry(scan):
    """A scan's ranges, angles, validity, points, ``angle_increment`` and ``is_full_circle`` (the last two
    in the Scan's own float arithmetic, without its properties' calls)."""
    ranges, angles = scan.ranges, scan.angles
    valid, points = _scan_beams(scan)
    n = ranges.size
    if n < 2:
        return ranges, angles, valid, points, math.nan, False
    a0, a1 = angles.item(0), angles.item(n - 1)
    increment = (a1 - a0) / (n - 1)
    return ranges, angles, valid, points, increment, n >= 3 and (a1 - a0) + 1.5 * increment >= 2 * math.pi


def _staged(scan, plan: Plan) -> Features:
    """:func:`extract` stage by stage (a compiled call or two each)."""
    timings: dict[str, float] = {}
    t_start = perf_counter()
    ranges, angles, valid, points, increment, full = _scan_geometry(scan)
    n = ranges.size
    threshold_m, min_points, adaptive, lam, seg_sigma = plan.seg
    if adaptive:  # (the scan's noise: worked out once, when a stage asks for it; scan_sigma keeps it on the scan)
        if seg_sigma == AUTO:
            seg_sigma = scan_sigma(scan)
    else:
        seg_sigma = 0.0
    labels = _segment(points, ranges, angles, valid, threshold_m, min_points, adaptive, lam, float(seg_sigma), full,
                      increment)
    t = perf_counter()
    timings["segmentation"] = t - t_start

    legs: list = []
    people: list = []
    rest = labels
    t_legs = plan.legs
    if t_legs is not None:
        s = plan.legs_sigma
        if s == AUTO:
            s = scan_sigma(scan)
        if plan.legs_fast:
            legs = _legs(scan, labels, points, t_legs, s, abs(increment) if n > 1 else 0.0)
        else:
            rest, idx, xy, starts, ends = runs(labels, _NONE, points)
            if starts.size:
                legs = leg_engine(scan, _asruns(idx, xy, starts, ends), t_legs, s)[0]
        people = pair_legs(legs, plan.pair_m) if len(legs) > 1 else []
    now = perf_counter()
    timings["legs"] = now - t
    t = now

    circles: list = []
    t_circles = plan.circles
    if t_circles is not None:
        s = plan.circles_sigma
        if s == AUTO:
            s = scan_sigma(scan)
        if plan.circles_fast:
            rest, circles = _circles(rest, _firsts(legs), points, t_circles, s)
        else:
            rest, idx, xy, starts, ends = runs(rest, _firsts(legs), points)
            if starts.size:
                circles = circle_engine(_asruns(idx, xy, starts, ends), t_circles, s)[0]
    elif legs:
        rest = without(rest, _firsts(legs))
    if circles:
        rest = without(rest, _firsts(circles))
    now = perf_counter()
    timings["circles"] = now - t
    t = now

    lines: list = []
    rows: tuple = ()
    if plan.lines is not None:
        lines, rows = _lines(scan, valid, points, rest if plan.lines_skip_round else labels, plan.lines, full)
    now = perf_counter()
    timings["lines"] = now - t
    t = now

    corners: list = []
    if plan.corners is not None and len(lines) > 1:
        corners = _corners(lines, rows, plan.corners, full)
    now = perf_counter()
    timings["corners"] = now - t
    t = now

    arcs: list = []
    if plan.arcs is not None:
        arcs = detect_arcs.unchecked(scan, **plan.arcs, segments=rest)
    now = perf_counter()
    timings["arcs"] = now - t
    timings["total"] = now - t_start
    features = _new_features(Features)  # (Features(...) as its fields in one update: a frozen dataclass's
    features.__dict__.update(stamp_ns=scan.stamp_ns, n_beams=n, labels=labels, lines=tuple(lines),  # __init__
                             corners=tuple(corners), circles=tuple(circles), arcs=tuple(arcs),  # sets them one
                             legs=tuple(legs), people=tuple(people), timings=timings)  # by one, slowly)
    return features


_new_features = object.__new__


def _fused(scan, plan: Plan) -> Features | None:
    """:func:`extract` by two compiled passes (:func:`stage_pass`, :func:`line_pass`), what lies
    between them in Python's own arithmetic, and the records (None where the scan needs the staged
    path). Each stage's time is its part of a pass (the passes read the clock
    :func:`time.perf_counter` reads at the end of each stage) and the building of its records."""
    t_start = perf_counter()
    ranges, angles, valid, points, increment, full = _scan_geometry(scan)
    n = ranges.size
    fp0, ip0 = plan.packed  # type: ignore[misc]
    fp, ip = fp0.copy(), ip0.copy()
    fp[F_INCREMENT], ip[I_FULL] = increment, full
    seg_sigma = plan.seg[4]
    fp[F_SEG_SIGMA] = (scan_sigma(scan) if seg_sigma == AUTO else float(seg_sigma)) if plan.seg[2] else 0.0
    t_legs = plan.legs
    if t_legs is not None:
        s = plan.legs_sigma
        fp[F_LEG_SIGMA] = scan_sigma(scan) if s == AUTO else float(s)
        fp[F_LEG_PAD] = float(t_legs.chord_padding_beams * (abs(increment) if n > 1 else 0.0))
    if plan.circles is not None:
        s = plan.circles_sigma
        fp[F_C_SIGMA] = scan_sigma(scan) if s == AUTO else float(s)
    split_threshold_m, range_sigma_m = plan.lines[1], plan.lines[2]  # type: ignore[index]
    s = scan_sigma(scan) if range_sigma_m == AUTO else range_sigma_m
    if split_threshold_m == AUTO:  # (lines.split_merge._SplitTest)
        noise, threshold = s, auto_split_threshold(s)
    else:
        noise, threshold = 0.0, split_threshold_m
    fp[F_L_THRESHOLD], fp[F_L_NOISE], fp[F_L_ABSORB], fp[F_L_SIGMA] = threshold, noise, min(threshold, 3 * s), s
    labels, rest, fo, io = stage_pass(points, ranges, angles, valid, fp, ip)
    status, n_legs, n_circles = io[:N_S].tolist()
    if status:
        return None
    fo.setflags(write=False)
    clock = [t * 1e-9 for t in fo[:N_T].tolist()]
    timings: dict[str, float] = {"segmentation": clock[0] - t_start}

    t = perf_counter()
    f, i = N_T, N_S
    legs: list = []
    people: list = []
    if n_legs:
        rows = fo[f:f + LEG_F * n_legs].reshape(n_legs, LEG_F)
        ints = io[i:i + LEG_I * n_legs].tolist()
        for j, (_, _, diameter, _, _, m, sd) in enumerate(rows.tolist()):
            legs.append(Leg(rows[j, 0:2], diameter, rows[j, 3:5], ints[3 * j], ints[3 * j + 1], ints[3 * j + 2], m,
                            sd))
        f += LEG_F * n_legs
        i += LEG_I * n_legs
        people = pair_legs(legs, plan.pair_m) if n_legs > 1 else []
    now = perf_counter()
    timings["legs"] = clock[1] - clock[0] + now - t
    t = now

    circles: list = []
    if n_circles:
        rows = fo[f:f + CIRCLE_F * n_circles].reshape(n_circles, CIRCLE_F)
        ints = io[i:i + CIRCLE_I * n_circles].tolist()
        for j, (_, _, radius, m, sd, high, std_max) in enumerate(rows.tolist()):
            size = ints[3 * j + 2]  # (the confidence as labkit.iav.circle_confidence, as _iav_circles)
            f_n = 1.0 - math.exp(-max(size - 2, 0) / 5.0)
            f_std = 1.0 - 0.5 * min(abs(sd) / std_max, 1.0)
            f_mean = 1.0 - 0.5 * min(abs(m - _HALF_PI) / max(high - _HALF_PI, 1e-12), 1.0)
            confidence = float(min(max(f_n * f_std * f_mean, 0.0), 1.0))
            circles.append(Circle(rows[j, 0:2], radius, m, sd, confidence, ints[3 * j], ints[3 * j + 1], size,
                                  "circle"))
    now = perf_counter()
    timings["circles"] = clock[2] - clock[1] + now - t
    t = now

    fo, io = line_pass(points, ranges, angles, valid, rest if plan.lines_skip_round else labels, fp, ip)
    t_back = perf_counter()
    status, n_lines, n_corners, n_beams = io[:N_H].tolist()
    if status:
        return None
    fo.setflags(write=False)
    io.setflags(write=False)
    clock += [t * 1e-9 for t in fo[:2].tolist()]
    f, i = 2, N_H
    lines: list = []
    if n_lines:
        out = fo[f:f + LINE_F * n_lines].reshape(n_lines, LINE_F)
        irows = io[i:i + LINE_I * n_lines].reshape(n_lines, LINE_I).tolist()
        f += LINE_F * n_lines
        i += LINE_I * n_lines
        beams = io[io.size - n_beams:]
        cov = out[:, 7:].reshape(-1, 2, 2)  # (as placed_records builds them)
        starts, ends = out[:, 3:5], out[:, 5:7]
        for k, row in enumerate(out.tolist()):
            g = irows[k]
            lines.append(LineSegment(row[0], row[1], cov[k], starts[k], ends[k], g[0], g[1], g[3] - g[2], row[2],
                                     beams[g[2]:g[3]]))
    now = perf_counter()
    timings["lines"] = t_back - t - (clock[4] - clock[3]) + now - t_back  # (the corners' part of the pass: theirs)
    t = now

    corners: list = []
    if n_corners:
        kf = fo[f:f + CORNER_F * n_corners].reshape(n_corners, CORNER_F)
        ki = io[i:i + CORNER_I * n_corners].reshape(n_corners, CORNER_I).tolist()
        for c, (_, _, angle, concave, extrapolated) in enumerate(kf.tolist()):
            a, b = ki[c]
            corners.append(Corner(kf[c, 0:2], angle, "concave" if concave else "convex", bool(extrapolated), (a, b),
                                  lines[a].last, lines[b].first))
    now = perf_counter()
    timings["corners"] = clock[4] - clock[3] + now - t
    timings["arcs"] = 0.0
    timings["total"] = now - t_start
    features = _new_features(Features)
    features.__dict__.update(stamp_ns=scan.stamp_ns, n_beams=n, labels=labels, lines=tuple(lines),
                             corners=tuple(corners), circles=tuple(circles), arcs=(), legs=tuple(legs),
                             people=tuple(people), timings=timings)
    return features


def _firsts(features) -> np.ndarray:
    return np.array([f.first for f in features], dtype=np.int64) if features else _NONE


def _legs(scan, labels, points, t: LegTest, sigma: float, spacing: float) -> list:
    """``_iav_batch._compiled_legs`` on the segments of ``labels`` (:func:`labkit._iav_engine.leg_pass`)."""
    idx, xy, bounds, floats, passed = leg_pass(labels, points, int(t.min_points), float(t.chord_range[0]),
                                               float(t.chord_range[1]), float(t.middle_range[0]),
                                               float(t.middle_range[1]), float(t.chord_padding_beams * spacing),
                                               float(sigma))
    if not passed.size:
        return []
    pts = np.ascontiguousarray(xy.T)
    ray = t.center_method == "ray"
    a_s, b_s = bounds[0].take(passed), bounds[1].take(passed)
    middles = pts.take(a_s + (b_s - a_s) // 2, axis=0)  # (one array: each leg's middle is a row of it)
    middles.setflags(write=False)
    mid_xy = middles.tolist()
    rows = floats.take(passed, axis=0).tolist()
    legs: list = []
    for j in range(len(rows)):
        a, b = a_s.item(j), b_s.item(j)
        first, last = idx.item(a), idx.item(b - 1)
        if t.reject_occluded and occluded(scan, first, last):
            continue
        chord, m, sd, side = rows[j]
        if ray:  # (iav.leg_center's "ray", in the same Python floats)
            mx, my = mid_xy[j]
            h, half = math.hypot(mx, my), 0.5 * chord
            center = np.array([mx + half * mx / h, my + half * my / h])
            diameter = chord
        else:
            try:
                center, diameter = leg_center(pts[a:b], chord, m, side, t.center_method)
            except ValueError:
                continue
        center.setflags(write=False)
        legs.append(Leg(center, float(diameter), middles[j], first, last, b - a, m, sd))
    return legs


def _circles(labels, drop, points, t: CircleTest, sigma: float) -> tuple[np.ndarray, list]:
    """``_iav_batch._compiled_circles`` on the segments of ``labels`` less those holding a beam of
    ``drop`` (:func:`labkit._iav_engine.circle_pass`); and the labels left."""
    rest, idx, xy, bounds, floats, passed = circle_pass(
        labels, drop, points, int(max(t.min_points, 3)), float(t.chord_range[0]), float(t.chord_range[1]),
        float(t.middle_range[0]), float(t.middle_range[1]), float(t.mean_range[0]), float(t.mean_range[1]),
        float(t.std_max), float(t.std_max) ** 2, float(sigma))
    if not passed.size:
        return rest, []
    starts, ends = bounds[0], bounds[1]
    mean, std, side, lim = floats[:, 0], floats[:, 1], floats[:, 2], floats[:, 3:]
    runs = _asruns(idx, xy, starts, ends)
    if t.center_method == "iav":
        made = _iav_circles(runs, passed, mean, std, side, lim, t.kind)
    else:
        geo = Geometry(ends - starts, None, runs.pts.take(starts, axis=0),  # type: ignore[arg-type]
                       runs.pts.take(ends - 1, axis=0), None, None)  # type: ignore[arg-type]
        ang = Angles(None, None, None, mean, std, side, None)  # type: ignore[arg-type]
        made = [make_circle(runs, geo, ang, k, k, t, t.kind,
                                 ((lim.item(k, 0), lim.item(k, 1)), lim.item(k, 2))) for k in passed.tolist()]
    if sigma > 0.0:  # and their points must lie on a circle within the noise
        made = drop_wider(runs, passed, made, sigma)
    return rest, [c for c, _ in made if c is not None]


_HALF_PI = math.pi / 2


def _iav_circles(runs: Runs, passed: np.ndarray, mean: np.ndarray, std: np.ndarray, side: np.ndarray,
                 lim: np.ndarray, kind: str) -> list:
    """``_iav_batch._make_circle`` of the runs ``passed`` with the iav centre, in plain floats gathered
    in bulk: :func:`labkit.iav.circle_from_iav` and :func:`labkit.iav.circle_confidence`'s arithmetic,
    operation for operation (the same Python floats and ``math`` functions)."""
    starts, ends = runs.starts[passed], runs.ends[passed]
    p1, pn = runs.pts.take(starts, axis=0).tolist(), runs.pts.take(ends - 1, axis=0).tolist()
    firsts, lasts = runs.idx.take(starts).tolist(), runs.idx.take(ends - 1).tolist()
    sizes = (ends - starts).tolist()
    means, stds, sides = mean.take(passed).tolist(), std.take(passed).tolist(), side.take(passed).tolist()
    limits = lim.take(passed, axis=0).tolist()
    made: list = []
    for j in range(len(sizes)):
        m, sd, sd_side = means[j], stds[j], sides[j]
        if sd_side == 0:
            sd_side = 1.0
        (x1, y1), (x2, y2) = p1[j], pn[j]
        dx, dy = x2 - x1, y2 - y1
        chord = math.hypot(dx, dy)
        if not (0 < m < math.pi) or not math.isfinite(sd_side) or chord == 0:
            made.append((None, FIT))  # (circle_from_iav raises)
            continue
        theta = m - _HALF_PI
        h = -math.copysign(1.0, sd_side) * 0.5 * math.tan(theta)
        center = np.array([x1 + 0.5 * dx - h * dy, y1 + 0.5 * dy + h * dx])
        radius = 0.5 * chord / math.cos(theta)
        center.setflags(write=False)
        low, high, std_max = limits[j]
        n = sizes[j]
        f_n = 1.0 - math.exp(-max(n - 2, 0) / 5.0)
        f_std = 1.0 - 0.5 * min(abs(sd) / std_max, 1.0)
        f_mean = 1.0 - 0.5 * min(abs(m - _HALF_PI) / max(high - _HALF_PI, 1e-12), 1.0)
        confidence = float(min(max(f_n * f_std * f_mean, 0.0), 1.0))
        made.append((Circle(center, float(radius), m, sd, confidence, firsts[j], lasts[j], n, kind), ACCEPTED))
    return made


def _lines(scan, valid: np.ndarray, points: np.ndarray, labels: np.ndarray, p: tuple, full: bool) -> tuple[list, tuple]:
    """``split_and_merge``'s engine path (``lines._split_merge_engine.split_and_merge``) on ``labels``;
    and the lines' rows (for :func:`_corners`)."""
    (fit, split_threshold_m, range_sigma_m, min_points, max_gap_m, merge_on, merge_dr_m, merge_dalpha, min_length_m,
     uniform, weights, floor_m, lam_cut, lam_graze, place_dr_m, place_dalpha_deg, place_confidence) = p
    s = scan_sigma(scan) if range_sigma_m == AUTO else range_sigma_m
    if split_threshold_m == AUTO:  # (lines.split_merge._SplitTest)
        noise, threshold = s, auto_split_threshold(s)
    else:
        noise, threshold = 0.0, split_threshold_m
    absorb_m = min(threshold, 3 * s)
    out, ints, beams = lines_pass(
        points, scan.ranges, scan.angles, valid, labels, fit, float(threshold), float(noise), float(absorb_m),
        min_points, max_gap_m, merge_on, merge_dr_m, merge_dalpha, min_length_m, uniform, floor_m, lam_cut, lam_graze,
        full, FUSED_DOT, float(s), place_confidence > 0, float(place_dr_m), math.radians(place_dalpha_deg),
        float(place_confidence), PLACING_NODES, PLACING_WEIGHTS)
    lines, keep = placed_records(out, ints, beams, place_dr_m, place_dalpha_deg, place_confidence)
    return lines, (out, ints, keep)


def _corners(lines: list, rows: tuple, p: dict, full: bool) -> list:
    """:func:`labkit.find_corners` of ``lines`` (``p`` its arguments), from the lines' rows of
    :func:`labkit.lines._split_merge_engine.lines_pass` (:func:`corners_pass`)."""
    out, ints, keep = rows
    found = corners_pass(out, ints, np.array(keep, dtype=np.int64), math.radians(p["min_angle_deg"]),
                         float(p["max_gap_m"]), float(p["max_extension_m"]), full)
    if not len(found):
        return []
    found.setflags(write=False)
    points = found[:, :2]
    corners = []
    for c, (_, _, angle, concave, extrapolated, i, j) in enumerate(found.tolist()):
        i, j = int(i), int(j)
        corners.append(Corner(points[c], angle, "concave" if concave else "convex", bool(extrapolated), (i, j),
                              lines[i].last, lines[j].first))
    return corners
