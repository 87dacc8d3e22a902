"""The range segmentation as one compiled pass over the beams (private: not part of labkit's API).

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

__all__ = ["labels", "threshold"]


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
