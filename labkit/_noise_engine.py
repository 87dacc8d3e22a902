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

__all__ = ["residuals"]


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
