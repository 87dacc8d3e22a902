"""The range segmentation as one compiled pass over the beams (private: not part of labkit's API).

Also the scan-level passes :func:`labkit.extract_features`' fused path (:mod:`labkit._pipeline_engine`)
and split-and-merge's engine share: :func:`beams` (a scan's valid mask and points), :func:`order`
(:func:`labkit.segmentation.segment_order`) and :func:`runs` (a stage's segments laid end to end).

:func:`labels` is :func:`labkit.segmentation.segment_labels` without its dozen numpy calls: the
same gaps, the same adaptive thresholds (Borges & Aldon), the same seam rule and the same
labels, bit for bit (``tests/test_engine.py`` compares it with the readable
``segmentation._segment_labels_reference``). :func:`threshold` is one adaptive breakpoint
distance, as :func:`labkit.segmentation.breakpoint_thresholds` computes it.
"""

from __future__ import annotations

import math

import numpy as np

from ._kernels import jit, jit_inline

__all__ = ["labels", "threshold", "order", "beams", "runs", "without", "compile_all"]


@jit_inline
def threshold(r_min, dphi, floor_m, lam, range_sigma_m):
    """The adaptive breakpoint distance between two beams ``dphi >= 0`` radians apart, the
    nearer at ``r_min``: ``r_min sin(dphi) / sin(lambda - dphi) + 3 sigma``, at least ``floor_m``."""
    d = r_min * math.sin(dphi) / math.sin(max(lam - dphi, 1e-9)) + 3.0 * range_sigma_m
    return max(d, floor_m)


@jit
def labels(points, ranges, angles, valid, threshold_m, min_points, adaptive, lam, range_sigma_m, full_circle,
           angle_increment):
    """Per-beam segment labels (see :func:`labkit.segmentation.segment_labels`); ``lam`` is
    ``incidence_deg`` in radians, ``angle_increment`` the scan's."""
    n = len(ranges)
    out = np.full(n, -1, np.int64)
    if n == 0:
        return out
    raw = np.empty(n, np.int64)
    count = -1
    any_valid = False
    for i in range(n):
        start = valid[i]
        if start and i > 0:
            gap = math.hypot(points[i, 0] - points[i - 1, 0], points[i, 1] - points[i - 1, 1])
            if gap < threshold_m:
                start = False
            elif adaptive and gap >= threshold_m:
                start = not (gap < threshold(min(ranges[i - 1], ranges[i]), abs(angles[i] - angles[i - 1]),
                                             threshold_m, lam, range_sigma_m))
        if start:
            count += 1
        any_valid = any_valid or valid[i]
        raw[i] = count
    if not any_valid:
        return out
    if n > 2 and valid[0] and valid[n - 1] and raw[n - 1] != raw[0] and full_circle:
        seam_limit = threshold_m
        if adaptive:
            seam_limit = threshold(min(ranges[n - 1], ranges[0]), abs(angle_increment), threshold_m, lam,
                                   range_sigma_m)
        if math.hypot(points[0, 0] - points[n - 1, 0], points[0, 1] - points[n - 1, 1]) < seam_limit:
            last = raw[n - 1]
            for i in range(n):
                if raw[i] == last:
                    raw[i] = raw[0]
    sizes = np.zeros(count + 1, np.int64)
    for i in range(n):
        if valid[i]:
            sizes[raw[i]] += 1
    new_id = np.empty(count + 1, np.int64)
    kept = 0
    for k in range(count + 1):
        if sizes[k] >= min_points:
            new_id[k] = kept
            kept += 1
        else:
            new_id[k] = -1
    for i in range(n):
        if valid[i]:
            out[i] = new_id[raw[i]]
    return out


@jit_inline
def order(labels):
    """:func:`labkit.segmentation.segment_order`: the labelled beams laid end to end, and each
    segment's bounds in that order."""
    n = len(labels)
    beams = np.empty(n, np.int64)
    m = 0
    if n and labels[0] >= 0 and labels[0] == labels[n - 1]:
        t = -1
        for i in range(n - 1, -1, -1):
            if labels[i] != labels[0]:
                t = i + 1
                break
        if t >= 0:  # a segment across the seam: the order starts where it starts
            for u in range(n):
                i = (t + u) % n
                if labels[i] >= 0:
                    beams[m] = i
                    m += 1
        else:
            for i in range(n):
                beams[m] = i
                m += 1
    else:
        for i in range(n):
            if labels[i] >= 0:
                beams[m] = i
                m += 1
    beams = beams[:m]
    bounds = np.empty(m + 1, np.int64)
    nb = 0
    if m:
        bounds[0] = 0
        nb = 1
        for i in range(1, m):
            if labels[beams[i]] != labels[beams[i - 1]]:
                bounds[nb] = i
                nb += 1
        bounds[nb] = m
        nb += 1
    return beams, bounds[:nb]


@jit
def beams(ranges, angles, range_min, range_max):
    """:attr:`labkit.Scan.valid` and :attr:`labkit.Scan.points` in one pass: the same comparisons, and
    ``r cos(theta)``, ``r sin(theta)`` with the C library's ``cos`` and ``sin`` that numpy's float64
    loops call too (``tests/test_engine.py`` checks that on this machine); NaN rows where invalid."""
    n = len(ranges)
    valid = np.empty(n, np.bool_)
    points = np.empty((n, 2))
    for i in range(n):
        r = ranges[i]
        ok = math.isfinite(r) and r > 0 and r >= range_min and r < range_max
        valid[i] = ok
        if ok:
            points[i, 0] = r * math.cos(angles[i])
            points[i, 1] = r * math.sin(angles[i])
        else:
            points[i, 0] = math.nan
            points[i, 1] = math.nan
    return valid, points


@jit
def without(labels, drop):
    """``labels`` less the segments holding a beam of ``drop`` (``labels`` itself when ``drop`` is empty)."""
    n = len(labels)
    rest = labels
    if len(drop):
        top = 0
        for i in range(n):
            top = max(top, labels[i] + 1)
        gone = np.zeros(top + 1, np.bool_)
        for f in drop:
            if labels[f] >= 0:
                gone[labels[f]] = True
        rest = labels.copy()
        for i in range(n):
            if rest[i] >= 0 and gone[rest[i]]:
                rest[i] = -1
    return rest


@jit
def runs(labels, drop, points):
    """The segments of ``labels`` less those holding a beam of ``drop`` (the first beams of the
    features a stage took, as ``labkit.pipeline._mask_segments``), laid end to end in label order as
    :func:`labkit.segmentation.segment_order` lays them: the labels left, each run's beams
    (``idx``), its points as rows ``xy[0]`` (x) and ``xy[1]`` (y), and its bounds ``starts``,
    ``ends``."""
    rest = without(labels, drop)
    idx, bounds = order(rest)
    m = len(idx)
    xy = np.empty((2, m))
    for i in range(m):
        j = idx[i]
        xy[0, i] = points[j, 0]
        xy[1, i] = points[j, 1]
    k = max(len(bounds) - 1, 0)
    return rest, idx, xy, bounds[:k], bounds[1:]


def compile_all() -> None:
    """Compile (or load from numba's cache) :func:`beams` and :func:`runs` as a scan hands them its
    arrays (read-only) and the labels come (writable)."""
    ranges = np.ones(7)
    ranges.setflags(write=False)
    _, points = beams(ranges, ranges, 0.0, 10.0)
    points.setflags(write=False)
    lab = np.array([0, 0, 0, -1, 1, 1, 1], dtype=np.int64)
    runs(lab, np.zeros(0, np.int64), points)
    runs(lab, np.array([0]), points)
    without(lab, np.array([0]))
