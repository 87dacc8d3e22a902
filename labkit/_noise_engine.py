"""The range-noise residuals as one compiled pass over the beams (private: not part of labkit's API).

:func:`residuals` is :func:`labkit.noise.range_noise_residuals` without its temporary arrays: the
same three-beam residuals, the same operations in the same order, bit for bit
(``tests/test_engine.py``). The robust standard deviation of them stays numpy's
(:func:`labkit.noise._robust_sigma`: a median and two dot products, whose BLAS summation order
a loop would not reproduce).
"""

from __future__ import annotations

import math

import numpy as np

from ._kernels import TWO_PI, jit, pairwise_sum

__all__ = ["residuals", "kth_smallest", "robust_start", "robust_sigma"]


@jit
def residuals(ranges, angles, valid, full_circle):
    """The residual of every beam with two valid neighbours (see
    :func:`labkit.noise.range_noise_residuals`), in scan order."""
    n = len(ranges)
    wrap = full_circle and n >= 3  # the first and last beams are neighbours
    m = n + 2 if wrap else n
    r = np.empty(m)
    t = np.empty(m)
    ok = np.empty(m, np.bool_)
    at = 1 if wrap else 0
    for i in range(n):
        r[at + i], t[at + i], ok[at + i] = ranges[i], angles[i], valid[i]
    if wrap:
        r[0], t[0], ok[0] = ranges[n - 1], angles[n - 1] - TWO_PI, valid[n - 1]
        r[m - 1], t[m - 1], ok[m - 1] = ranges[0], angles[0] + TWO_PI, valid[0]
    if m < 3:
        return np.empty(0)
    dt = np.empty(m - 1)
    lo = math.inf
    hi = -math.inf
    for i in range(m - 1):
        dt[i] = t[i + 1] - t[i]
        lo = min(lo, dt[i])
        hi = max(hi, dt[i])
    equal = hi - lo <= 1e-9 * hi  # equal steps (the usual scan): one weight for every beam
    w = 0.0
    if equal:
        w = 0.5 / math.cos(pairwise_sum(dt, m - 1) / (m - 1))
    out = np.empty(m - 2)
    k = 0
    for i in range(m - 2):
        if not (ok[i] and ok[i + 1] and ok[i + 2]):
            continue
        r0, r1, r2 = r[i], r[i + 1], r[i + 2]
        if equal:
            w0 = w2 = w
        else:
            t0, t1, t2 = t[i], t[i + 1], t[i + 2]
            s02 = math.sin(t2 - t0)
            w0 = math.sin(t2 - t1) / s02
            w2 = math.sin(t1 - t0) / s02
        g0 = r1 / r0
        g2 = r1 / r2
        s = r1 * (1.0 - w0 * g0 - w2 * g2)
        q0 = w0 * g0 * g0
        q2 = w2 * g2 * g2
        out[k] = s / math.sqrt(1.0 + q0 * q0 + q2 * q2)
        k += 1
    return out[:k]  # (a view: no copy)


@jit
def kth_smallest(values, k):
    """The ``k``-th smallest of ``values`` (no NaN), as ``numpy.partition(values, k)[k]`` gives it: a
    quickselect on a copy (a value is a value, whichever way it is found)."""
    a = values.copy()
    lo, hi = 0, len(a) - 1
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return a[k]


@jit
def robust_start(ranges, angles, valid, full_circle, min_residuals, mad_to_sigma, cut):
    """The start of ``noise._robust_sigma`` on the scan's :func:`residuals`: their absolute values,
    the median's sigma (``numpy.partition``'s value), the first inliers (within ``cut`` of it, in
    order; empty where the residuals are too few), and False where a residual is NaN."""
    z = residuals(ranges, angles, valid, full_circle)
    n = len(z)
    a = np.empty(n)
    ok = True
    for i in range(n):
        a[i] = abs(z[i])
        ok = ok and not math.isnan(a[i])
    if n < min_residuals or not ok:
        return a, math.nan, a[:0], ok
    sigma = mad_to_sigma * kth_smallest(a, n // 2)
    limit = cut * sigma
    m = 0
    for i in range(n):
        if a[i] <= limit:
            m += 1
    inl = np.empty(m)
    m = 0
    for i in range(n):
        if a[i] <= limit:
            inl[m] = a[i]
            m += 1
    return a, sigma, inl, ok


def robust_sigma(ranges, angles, valid, full_circle, min_residuals: int, mad_to_sigma: float, cut: float,
                 cut_sd: float) -> float:
    """``noise._robust_sigma(range_noise_residuals(scan))`` (its constants given), bit for bit: the
    start in one compiled call (:func:`robust_start`; numpy's where a residual is NaN), then its
    loop's dot products as numpy computes them (BLAS)."""
    a, sigma, inl, ok = robust_start(ranges, angles, valid, full_circle, min_residuals, mad_to_sigma, cut)
    n = len(a)
    if not ok:
        if n < min_residuals:
            return math.nan
        sigma = mad_to_sigma * float(np.partition(a, n // 2)[n // 2])
        inl = a[a <= cut * sigma]
    for step in range(2):
        if step:
            inl = a[a <= cut * sigma]
        if len(inl) < min_residuals or sigma == 0.0:
            break
        sigma = math.sqrt(float(np.dot(inl, inl)) / len(inl)) / cut_sd
    return sigma
