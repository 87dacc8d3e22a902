"""The IAV detectors' compiled kernels (private: not part of labkit's API).

* :func:`fit_circles` -- circle fits to many runs of points as one compiled pass;
* :func:`angle_noise_runs` -- :func:`labkit._iav_noise.angle_noise_runs` (the angle tests' noise
  allowances) as one compiled pass;
* :func:`circle_tests` -- the tests of :func:`labkit._iav_batch.circle_engine` up to the centre, on
  every run of a scan in one pass: the cheap tests, the inscribed angles, their noise allowances
  and the angle tests (what numpy rounds its own way is reproduced: its complex product is two
  fused multiply-adds, ``numpy.bincount`` sums one value after the other);
* :func:`leg_tests` -- the same for :func:`labkit._iav_batch.leg_engine` at its defaults;
* :func:`wider_than_noise` -- the residual test (:func:`labkit._iav_noise.wider_than_noise`).

Both give numpy's results bit for bit (``tests/test_engine.py``); ``LABKIT_NO_JIT=1`` runs numpy's.

:func:`fit_circles` is :func:`labkit.fitting.fit_circles` run run by run in numba instead of as
numpy operations over all runs at once: the same algebraic start and Gauss-Newton steps, the same
IEEE operations in the same order, so the same circles bit for bit (``tests/test_engine.py``
checks it on random runs and the recordings). The sums are numpy's: ``numpy.add.reduceat`` over
several runs (:func:`labkit._kernels.segment_sum`), ``numpy.sum`` over one (pairwise for a column
of values, row after row for the points' mean). A step that numpy takes by least squares (a nearly
straight run) is not in the engine: :func:`fit_circles` returns None and the caller runs numpy's.

The residual test of the IAV detectors (:func:`labkit._iav_noise.wider_than_noise`) fits the few
runs that pass the angle tests, up to 50 Gauss-Newton steps each; as numpy arrays each step is
some forty small array operations, which made that test the largest single cost of a scan.
"""

from __future__ import annotations

import math

import numpy as np

from ._kernels import (
    CIRCLE_F,
    CIRCLE_I,
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
    F_LAM,
    F_LEG_C_HI,
    F_LEG_C_LO,
    F_LEG_HI,
    F_LEG_LO,
    F_LEG_PAD,
    F_LEG_SIGMA,
    F_SEG_M,
    F_SEG_SIGMA,
    I_ADAPTIVE,
    I_C_MIN,
    I_CIRCLES,
    I_EARLY_STEPS,
    I_FULL,
    I_LEG_MIN,
    I_LEGS,
    I_OCCLUDED,
    I_SEG_MIN,
    LEG_F,
    LEG_I,
    N_S,
    N_T,
    S_CIRCLES,
    S_LEGS,
    S_STATUS,
    fma,
    jit,
    jit_inline,
    monotonic_ns,
    py_hypot,
    py_hypot_in_range,
    segment_sum,
    sum_at,
)
from ._segmentation_engine import labels as _labels
from ._segmentation_engine import runs as _runs
from ._segmentation_engine import without as _without

__all__ = ["fit_circles", "angle_noise_runs", "circle_tests", "leg_tests", "wider_than_noise", "COMPLEX_FMA",
           "leg_pass", "circle_pass", "stage_pass"]

NOISE_Z = 2.0  # (= labkit.iav.NOISE_Z, LINE_Z, ARC_LIKE_STD_MAX and labkit._iav_batch's verdicts:
LINE_Z = 3.0  # the engine cannot import the modules it serves; tests/test_engine.py checks they agree)
ARC_LIKE_STD_MAX = math.radians(23.0)
ACCEPTED, FEW, SHORT, LONG, PREREQ, DEGENERATE, MEAN, STD = range(8)
_PI = math.pi
_HALF_PI = math.pi / 2
_TWO_PI = 2 * math.pi


@jit
def _sum(a, n, single):
    """A run's sum of ``a[:n]`` as numpy's ``fit_circles`` takes it: ``numpy.sum`` (one run) or
    ``numpy.add.reduceat`` (several)."""
    if single:
        return sum_at(a, 0, n)
    return segment_sum(a, 0, n)


@jit
def _mean_sum(a, n, single):
    """The sum of a coordinate of the points as ``fit_circles`` takes it for their mean: an
    ``(n, 2)`` array summed over its rows one after the other (one run), or ``reduceat``."""
    if single:
        s = a[0]
        for i in range(1, n):
            s += a[i]
        return s
    return segment_sum(a, 0, n)


@jit
def _fit_runs(px, py, starts, ends, geometric, max_iterations, tol):
    """Per run: centre (x, y), radius, rms, iterations, status, and the last Gauss-Newton step
    index; ``ok`` False where a run needs numpy's least-squares step."""
    k_runs = len(starts)
    single = k_runs == 1
    cx_out = np.empty(k_runs)
    cy_out = np.empty(k_runs)
    rad_out = np.empty(k_runs)
    rms_out = np.empty(k_runs)
    iters = np.zeros(k_runs, np.int64)
    status = np.zeros(k_runs, np.int64)
    last_step = 0  # how many steps the whole batch took (a run done earlier still gets + 0.0 each step)
    # per-run state kept for the batch's extra steps
    cxs = np.empty(k_runs)
    cys = np.empty(k_runs)
    rads = np.empty(k_runs)
    scales = np.empty(k_runs)
    mxs = np.empty(k_runs)
    mys = np.empty(k_runs)
    big = 0
    for k in range(k_runs):
        big = max(big, ends[k] - starts[k])
    x = np.empty(big)
    y = np.empty(big)
    qx = np.empty(big)
    qy = np.empty(big)
    z = np.empty(big)
    t1 = np.empty(big)
    t2 = np.empty(big)
    t3 = np.empty(big)
    ux = np.empty(big)
    uy = np.empty(big)
    res = np.empty(big)
    for k in range(k_runs):
        a = starts[k]
        m = ends[k] - a
        n = float(m)
        for i in range(m):
            x[i] = px[a + i]
            y[i] = py[a + i]
        mx = _mean_sum(x, m, single) / n
        my = _mean_sum(y, m, single) / n
        for i in range(m):
            qx[i] = x[i] - mx
            qy[i] = y[i] - my
            t1[i] = qx[i] * qx[i]
            t2[i] = qx[i] * qy[i]
            t3[i] = qy[i] * qy[i]
        sxx = _sum(t1, m, single)
        sxy = _sum(t2, m, single)
        syy = _sum(t3, m, single)
        scale = math.sqrt((sxx + syy) / n)
        st = 0
        if scale == 0:
            st = 1
            scale = 1.0
        for i in range(m):
            qx[i] = qx[i] / scale
            qy[i] = qy[i] / scale
        s2 = scale * scale
        sxx, sxy, syy = sxx / s2, sxy / s2, syy / s2
        half = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
        ch, sh = math.cos(half), math.sin(half)
        for i in range(m):
            across = qy[i] * ch - qx[i] * sh
            t1[i] = across * across
        small = _sum(t1, m, single)
        if st == 0 and small < 1e-18 * n:
            st = 2
        det = small * (n - small)
        if st != 0:
            det = 1.0
        for i in range(m):
            z[i] = qx[i] * qx[i] + qy[i] * qy[i]
            t1[i] = qx[i] * z[i]
            t2[i] = qy[i] * z[i]
        sxz = _sum(t1, m, single)
        syz = _sum(t2, m, single)
        cx = (syy * sxz - sxy * syz) / (2 * det)
        cy = (sxx * syz - sxy * sxz) / (2 * det)
        rad2 = _sum(z, m, single) / n + cx * cx + cy * cy
        if st == 0 and not (rad2 > 0 and math.hypot(cx, cy) <= 1e6):
            st = 2
        radius = math.sqrt(rad2) if st == 0 else 1.0
        if geometric and st == 0:
            for it in range(1, max_iterations + 1):
                for i in range(m):
                    dx = qx[i] - cx
                    dy = qy[i] - cy
                    dist = math.hypot(dx, dy)
                    if dist == 0:
                        dist = 1e-300
                    ux[i] = dx / dist
                    uy[i] = dy / dist
                    res[i] = dist - radius
                for i in range(m):
                    t1[i] = ux[i] * ux[i]
                    t2[i] = ux[i] * uy[i]
                    t3[i] = uy[i] * uy[i]
                a11 = _sum(t1, m, single)
                a12 = _sum(t2, m, single)
                a22 = _sum(t3, m, single)
                a13 = _sum(ux, m, single)
                a23 = _sum(uy, m, single)
                for i in range(m):
                    t1[i] = ux[i] * res[i]
                    t2[i] = uy[i] * res[i]
                b1 = _sum(t1, m, single)
                b2 = _sum(t2, m, single)
                b3 = _sum(res, m, single)
                m11, m12, m13 = a22 * n - a23 * a23, a13 * a23 - a12 * n, a12 * a23 - a13 * a22
                m22, m23, m33 = a11 * n - a13 * a13, a12 * a13 - a11 * a23, a11 * a22 - a12 * a12
                d3 = a11 * m11 + a12 * m12 + a13 * m13
                if not d3 > 1e-8 * a11 * a22 * n:
                    return cx_out, cy_out, rad_out, rms_out, iters, status, False  # numpy's lstsq step
                s1 = (m11 * b1 + m12 * b2 + m13 * b3) / d3
                s2_ = (m12 * b1 + m22 * b2 + m23 * b3) / d3
                s3 = (m13 * b1 + m23 * b2 + m33 * b3) / d3
                cx, cy, radius = cx + s1, cy + s2_, radius + s3
                iters[k] = it
                last_step = max(last_step, it)
                rr = radius * radius
                if not s1 * s1 + s2_ * s2_ + s3 * s3 >= tol * (rr if rr > 1.0 or rr != rr else 1.0):
                    break  # (numpy.maximum: NaN wins)
        cxs[k], cys[k], rads[k], scales[k], mxs[k], mys[k] = cx, cy, radius, scale, mx, my
        status[k] = st
    for k in range(k_runs):
        cx, cy, radius = cxs[k], cys[k], rads[k]
        if geometric:
            for _ in range(iters[k], last_step):  # numpy adds a zero step while other runs go on
                cx, cy, radius = cx + 0.0, cy + 0.0, radius + 0.0
            radius = abs(radius)
        a = starts[k]
        m = ends[k] - a
        ccx = cx * scales[k] + mxs[k]
        ccy = cy * scales[k] + mys[k]
        radius = radius * scales[k]
        for i in range(m):
            d = math.hypot(px[a + i] - ccx, py[a + i] - ccy) - radius
            t1[i] = d * d
        rms = math.sqrt(_sum(t1, m, single) / float(m))
        if status[k] != 0:
            ccx = ccy = radius = rms = math.nan
        cx_out[k], cy_out[k], rad_out[k], rms_out[k] = ccx, ccy, radius, rms
    return cx_out, cy_out, rad_out, rms_out, iters, status, True


def fit_circles(points: np.ndarray, starts: np.ndarray, ends: np.ndarray, method: str = "algebraic", *,
                max_iterations: int = 50, tol: float = 1e-12):
    """:func:`labkit.fitting.fit_circles`' :class:`labkit.fitting.CircleFits`, bit for bit, or None
    where numpy must take a least-squares step (the caller then runs it). The arguments are
    assumed checked (at least 3 points per run, ``method`` algebraic or geometric)."""
    from .fitting import CircleFits  # (fitting imports this module lazily too)

    p = np.asarray(points, dtype=np.float64)
    px, py = np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1])
    starts, ends = np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64)  # (writable: one kind)
    cx, cy, radius, rms, iterations, status, ok = _fit_runs(px, py, starts, ends, method == "geometric",
                                                           int(max_iterations), float(tol))
    if not ok:
        return None
    return CircleFits(np.stack([cx, cy], axis=1), radius, rms, iterations, status)


@jit
def _angle_noise(px, py, starts, ends, sigma):
    """:func:`labkit._iav_noise.angle_noise_runs`, its numpy operations run by run, in order."""
    k_runs = len(starts)
    spread_sq = np.empty(k_runs)
    mean_sd = np.empty(k_runs)
    big = 1
    for k in range(k_runs):
        big = max(big, ends[k] - starts[k] - 2)
    g = np.empty(big)
    hh_ = np.empty(big)
    d = np.empty(big)
    t1 = np.empty(big)
    t2 = np.empty(big)
    t3 = np.empty(big)
    for k in range(k_runs):
        s, e = starts[k], ends[k] - 1
        m_k = ends[k] - starts[k] - 2
        x0, y0, x1, y1 = px[s], py[s], px[e], py[e]
        h0 = math.hypot(x0, y0)
        h1 = math.hypot(x1, y1)
        u0x, u0y = x0 / (h0 if h0 > 0 else 1.0), y0 / (h0 if h0 > 0 else 1.0)
        u1x, u1y = x1 / (h1 if h1 > 0 else 1.0), y1 / (h1 if h1 > 0 else 1.0)
        for i in range(m_k):
            xm, ym = px[s + 1 + i], py[s + 1 + i]
            hm = math.hypot(xm, ym)
            hm = hm if hm > 0 else 1.0
            umx, umy = xm / hm, ym / hm
            ax, ay = x0 - xm, y0 - ym
            bx, by = x1 - xm, y1 - ym
            na2 = ax * ax + ay * ay
            nb2 = bx * bx + by * by
            d[i] = (ax * umy - ay * umx) / na2 - (bx * umy - by * umx) / nb2
            g[i] = -(ax * u0y - ay * u0x) / na2
            hh_[i] = (bx * u1y - by * u1x) / nb2
        m = float(m_k)
        g_sum = segment_sum(g, 0, m_k)
        h_sum = segment_sum(hh_, 0, m_k)
        g_mean, h_mean = g_sum / m, h_sum / m
        for i in range(m_k):
            gc = g[i] - g_mean
            hc = hh_[i] - h_mean
            g[i], hh_[i] = gc, hc
            t1[i] = gc * gc
            t2[i] = hc * hc
            t3[i] = gc * hc
        gg = segment_sum(t1, 0, m_k)
        hh = segment_sum(t2, 0, m_k)
        gh = segment_sum(t3, 0, m_k)
        for i in range(m_k):
            d2 = d[i] * d[i]
            t1[i] = d2
            t2[i] = d2 * (g[i] * g[i] + hh_[i] * hh_[i])
            t3[i] = d2 * d2
        sd2 = segment_sum(t1, 0, m_k)
        tr = gg + hh + sd2 * (1.0 - 1.0 / m)
        tr2 = (gg * gg + hh * hh + 2.0 * gh * gh + 2.0 * segment_sum(t2, 0, m_k)
               + segment_sum(t3, 0, m_k) * (1.0 - 2.0 / m) + sd2 * sd2 / (m * m))
        mean_sd[k] = sigma * math.sqrt(g_sum * g_sum + sd2 + h_sum * h_sum) / m
        if tr > 0.0:
            nu = tr * tr / tr2
            ks = 2.0 / (9.0 * nu)
            base = 1.0 - ks + NOISE_Z * math.sqrt(ks)
            if not base != base:  # (numpy.maximum: NaN wins)
                base = max(base, 0.0)
            spread_sq[k] = sigma * sigma * tr / m * math.pow(base, 3.0)
        else:
            spread_sq[k] = 0.0
    return spread_sq, mean_sd


def angle_noise_runs(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                     sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`labkit._iav_noise.angle_noise_runs` bit for bit (runs of 3 points or more)."""
    p = np.asarray(pts, dtype=np.float64)
    return _angle_noise(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
                        np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64), float(sigma))


def _complex_fma() -> bool:
    """Whether numpy's complex product ``b * a`` is ``(fma(br, ar, -(bi ai)), fma(br, ai, bi ar))`` here
    (each part rounded once), as :func:`circle_tests` computes it; worked out exactly (fractions)."""
    from fractions import Fraction

    rng = np.random.default_rng(20261128)
    for n in (1, 3, 8, 37):
        a = rng.normal(size=n) * 7.0 + 1j * rng.normal(size=n)
        b = rng.normal(size=n) * 3.0 - 1j * rng.normal(size=n)
        for x, y, z in zip(b.tolist(), a.tolist(), (b * a).tolist(), strict=True):
            re = float(Fraction(x.real) * Fraction(y.real) + Fraction(-(x.imag * y.imag)))
            im = float(Fraction(x.real) * Fraction(y.imag) + Fraction(x.imag * y.real))
            if z.real != re or z.imag != im:
                return False
    return True


#: Whether numpy's complex product rounds as :func:`circle_tests` assumes (else the engine stands aside).
COMPLEX_FMA = _complex_fma()


@jit_inline
def _pymin(a, b):
    """Python's ``min(a, b)`` (the first unless the second is smaller: NaN as Python takes it)."""
    return b if b < a else a


@jit_inline
def _pymax(a, b):
    return b if b > a else a


@jit_inline
def _ratio_sd(x0, y0, x1, y1, xm, ym, chord, sigma):
    """:func:`labkit._iav_noise.ratio_sd`."""
    if chord <= 0.0:
        return math.inf
    ex, ey = (x1 - x0) / chord, (y1 - y0) / chord
    acc = 0.0
    for j in range(3):
        x, y, w = (xm, ym, 1.0) if j == 0 else (x0, y0, 0.25) if j == 1 else (x1, y1, 0.25)
        h2 = x * x + y * y
        if h2 > 0.0:
            across = ex * y - ey * x
            acc += w * across * across / h2
    return sigma * math.sqrt(acc) / chord


@jit_inline
def _cheap(px, py, a, e, tested, min_points, c_lo, c_hi, lo, hi, check_finite, sigma):
    """:func:`labkit._iav_batch.cheap_tests` of the run ``a:e`` (its chord tested: ``tested``):
    its verdict and middle ratio (NaN when not reached)."""
    n = e - a
    if n < min_points:
        return FEW, math.nan
    if tested < c_lo:
        return SHORT, math.nan
    if tested > c_hi:
        return LONG, math.nan
    x0, y0, x1, y1 = px[a], py[a], px[e - 1], py[e - 1]
    xm, ym = px[a + n // 2], py[a + n // 2]
    dx, dy = x1 - x0, y1 - y0
    c = math.hypot(dx, dy)
    cross_mid = dx * (ym - y0) - dy * (xm - x0)
    cross_origin = dy * x0 - dx * y0
    sd = -cross_mid if cross_origin < 0 else abs(cross_mid) if cross_origin == 0 else cross_mid
    c2 = c * c
    r = sd / c2 if c2 > 0 else sd * math.inf if c > 0 else math.nan
    finite = True
    if check_finite:
        for i in range(a, e):
            if not (math.isfinite(px[i]) and math.isfinite(py[i])):
                finite = False
    if math.isnan(r) or not finite:
        return DEGENERATE, r
    if sigma > 0.0:
        w = NOISE_Z * _ratio_sd(x0, y0, x1, y1, xm, ym, c, sigma)
        return (ACCEPTED if lo - w < r < hi + w else PREREQ), r
    return (ACCEPTED if lo < r < hi else PREREQ), r


@jit_inline
def _angles(px, py, a, e, ang):
    """:func:`labkit._iav_batch.batch_angles` of the run ``a:e`` (3 points or more): the angles'
    mean, standard deviation, side sum, and whether an interior point is on an extreme. With
    ``z = x + iy``, ``a = z_1 - z_i``, ``b = a + d``: ``b conj(a)`` as numpy multiplies complex
    numbers (each part one fused multiply-add); the sums in order, as ``numpy.bincount``'s."""
    x0, y0 = px[a], py[a]
    dx, dy = px[e - 1] - x0, py[e - 1] - y0
    m = e - a - 2
    degenerate = False
    total = 0.0
    side_sum = 0.0
    for i in range(m):
        ar, ai = x0 - px[a + 1 + i], y0 - py[a + 1 + i]
        br, bi = ar + dx, ai + dy
        if (ar == 0 and ai == 0) or (br == 0 and bi == 0):
            degenerate = True
        re = fma(br, ar, -(bi * -ai))
        im = fma(br, -ai, bi * ar)
        t = math.atan2(im, re) % _TWO_PI
        ang[i] = t
        total += t
        side_sum += fma(dx, -ai, dy * ar)
    mu = total / m
    var = 0.0
    for i in range(m):
        dv = ang[i] - mu
        var += dv * dv
    return mu, math.sqrt(var / m), side_sum, degenerate


@jit
def _circle_tests(px, py, starts, ends, check_finite, min_points, c_lo, c_hi, lo, hi, mean_lo, mean_hi, std_max0,
                  std_max_sq, sigma):
    """Per run: verdict, the middle ratio, the angles' mean, std and side, and the limits held to."""
    k_runs = len(starts)
    verdict = np.empty(k_runs, np.int64)
    ratio = np.full(k_runs, math.nan)
    mean = np.full(k_runs, math.nan)
    std = np.full(k_runs, math.nan)
    side = np.full(k_runs, math.nan)
    lim = np.empty((k_runs, 3))  # mean range, std max
    big = 1
    for k in range(k_runs):
        big = max(big, ends[k] - starts[k])
    ang = np.empty(big)
    sel_s = np.empty(k_runs, np.int64)
    sel_e = np.empty(k_runs, np.int64)
    sel_k = np.empty(k_runs, np.int64)
    n_sel = 0
    for k in range(k_runs):
        a, e = starts[k], ends[k]
        lim[k, 0], lim[k, 1], lim[k, 2] = mean_lo, mean_hi, std_max0
        c = math.hypot(px[e - 1] - px[a], py[e - 1] - py[a])
        verdict[k], ratio[k] = _cheap(px, py, a, e, c, min_points, c_lo, c_hi, lo, hi, check_finite, sigma)
        if verdict[k] != ACCEPTED:
            continue
        mean[k], std[k], side[k], degenerate = _angles(px, py, a, e, ang)
        if degenerate:
            verdict[k] = DEGENERATE
            continue
        sel_s[n_sel], sel_e[n_sel], sel_k[n_sel] = a, e, k
        n_sel += 1
    if n_sel and sigma > 0.0:
        spread_sq, mean_sd = _angle_noise(px, py, sel_s[:n_sel], sel_e[:n_sel], sigma)
        for j in range(n_sel):  # labkit._iav_noise.widen (no arc-like bound)
            k = sel_k[j]
            w = NOISE_Z * mean_sd[j]
            lim[k, 0] = mean_lo - w
            lim[k, 1] = _pymin(mean_hi + w, _pymax(_PI - LINE_Z * mean_sd[j], mean_hi))
            lim[k, 2] = _pymin(math.sqrt(std_max_sq + spread_sq[j]), ARC_LIKE_STD_MAX)
    for j in range(n_sel):
        k = sel_k[j]
        if not (lim[k, 0] <= mean[k] <= lim[k, 1]):
            verdict[k] = MEAN
        elif std[k] >= lim[k, 2]:
            verdict[k] = STD
    return verdict, ratio, mean, std, side, lim


@jit
def _leg_tests(px, py, starts, ends, check_finite, min_points, c_lo, c_hi, lo, hi, padding, sigma):
    """Per run: verdict (up to the angles: no mean or spread test), the padded chord, the angles'
    mean, std and side."""
    k_runs = len(starts)
    verdict = np.empty(k_runs, np.int64)
    chord = np.empty(k_runs)
    mean = np.full(k_runs, math.nan)
    std = np.full(k_runs, math.nan)
    side = np.full(k_runs, math.nan)
    big = 1
    for k in range(k_runs):
        big = max(big, ends[k] - starts[k])
    ang = np.empty(big)
    for k in range(k_runs):
        a, e = starts[k], ends[k]
        mid = a + (e - a) // 2
        chord[k] = (math.hypot(px[e - 1] - px[a], py[e - 1] - py[a])
                    + padding * math.hypot(px[mid], py[mid]))
        verdict[k], _ = _cheap(px, py, a, e, chord[k], min_points, c_lo, c_hi, lo, hi, check_finite, sigma)
        if verdict[k] != ACCEPTED:
            continue
        mean[k], std[k], side[k], degenerate = _angles(px, py, a, e, ang)
        if degenerate:
            verdict[k] = DEGENERATE
    return verdict, chord, mean, std, side


@jit
def _accepted(verdict):
    n = 0
    for k in range(len(verdict)):
        if verdict[k] == ACCEPTED:
            n += 1
    out = np.empty(n, np.int64)
    n = 0
    for k in range(len(verdict)):
        if verdict[k] == ACCEPTED:
            out[n] = k
            n += 1
    return out


@jit
def leg_pass(labels, points, min_points, c_lo, c_hi, lo, hi, padding, sigma):
    """The legs stage of :mod:`labkit._pipeline_engine` up to its records, in one call (each call and
    each array handed back to Python costs about a microsecond): the segments of ``labels`` laid end
    to end (:func:`labkit._segmentation_engine.runs`), :func:`_leg_tests` on them, and the runs
    accepted. Returns the runs' beams and points (``xy``: x row, y row), their bounds ``(2, K)``
    (starts, ends), their floats ``(K, 4)`` (padded chord, mean, std, side) and the accepted runs."""
    _, idx, xy, starts, ends = _runs(labels, np.zeros(0, np.int64), points)
    verdict, chord, mean, std, side = _leg_tests(xy[0], xy[1], starts, ends, False, min_points, c_lo, c_hi, lo, hi,
                                                 padding, sigma)
    k_runs = len(starts)
    bounds = np.empty((2, k_runs), np.int64)
    floats = np.empty((k_runs, 4))
    for k in range(k_runs):
        bounds[0, k], bounds[1, k] = starts[k], ends[k]
        floats[k, 0], floats[k, 1], floats[k, 2], floats[k, 3] = chord[k], mean[k], std[k], side[k]
    return idx, xy, bounds, floats, _accepted(verdict)


@jit
def circle_pass(labels, drop, points, min_points, c_lo, c_hi, lo, hi, mean_lo, mean_hi, std_max0, std_max_sq, sigma):
    """The circles stage of :mod:`labkit._pipeline_engine` up to its centres, in one call: the segments
    of ``labels`` less those holding a beam of ``drop``, laid end to end
    (:func:`labkit._segmentation_engine.runs`), :func:`_circle_tests` on them, and the runs accepted.
    Returns the labels left, the runs' beams and points, their bounds ``(2, K)``, their floats
    ``(K, 6)`` (mean, std, side, the limits held to) and the accepted runs."""
    rest, idx, xy, starts, ends = _runs(labels, drop, points)
    verdict, _, mean, std, side, lim = _circle_tests(xy[0], xy[1], starts, ends, False, min_points, c_lo, c_hi, lo,
                                                     hi, mean_lo, mean_hi, std_max0, std_max_sq, sigma)
    k_runs = len(starts)
    bounds = np.empty((2, k_runs), np.int64)
    floats = np.empty((k_runs, 6))
    for k in range(k_runs):
        bounds[0, k], bounds[1, k] = starts[k], ends[k]
        floats[k, 0], floats[k, 1], floats[k, 2] = mean[k], std[k], side[k]
        floats[k, 3], floats[k, 4], floats[k, 5] = lim[k, 0], lim[k, 1], lim[k, 2]
    return rest, idx, xy, bounds, floats, _accepted(verdict)


@jit
def stage_pass(points, ranges, angles, valid, fp, ip):
    """The segmentation, legs and circles of :func:`labkit._pipeline_engine.extract` up to their
    records, in one compiled call: the labels (:func:`labkit._segmentation_engine.labels`); the
    legs' tests, occlusion and ``"ray"`` centres (as ``labkit._pipeline_engine._legs``); the
    circles' tests on the segments the legs left, their ``"iav"`` centres and the noise test (as
    ``_circles``), with :func:`labkit._kernels.py_hypot` where Python computes ``math.hypot``.
    Returns the labels, the labels the legs and circles left, and one float and one integer
    array: the clock at the end of each stage (ns), then per leg ``cx, cy, diameter, mx, my, mean,
    std`` and per circle ``cx, cy, radius, mean, std, high, std_max`` (the limits held to); the
    integers: a status (0; 1 where only Python can finish the scan: a fit by numpy's least
    squares, a subnormal distance), the counts, per leg and circle ``first, last, n``."""
    n = len(ranges)
    none = np.empty(0, np.int64)
    full = ip[I_FULL] != 0
    lab = _labels(points, ranges, angles, valid, fp[F_SEG_M], ip[I_SEG_MIN], ip[I_ADAPTIVE] != 0, fp[F_LAM],
                  fp[F_SEG_SIGMA], full, fp[F_INCREMENT])
    t_seg = monotonic_ns()
    n_legs = 0
    leg_f = np.empty((0, LEG_F))
    leg_i = np.empty((0, LEG_I), np.int64)
    if ip[I_LEGS]:
        _, idx, xy, starts, ends = _runs(lab, none, points)
        verdict, chord, mean, std, _ = _leg_tests(xy[0], xy[1], starts, ends, False, ip[I_LEG_MIN], fp[F_LEG_C_LO],
                                                  fp[F_LEG_C_HI], fp[F_LEG_LO], fp[F_LEG_HI], fp[F_LEG_PAD],
                                                  fp[F_LEG_SIGMA])
        passed = _accepted(verdict)
        leg_f = np.empty((len(passed), LEG_F))
        leg_i = np.empty((len(passed), LEG_I), np.int64)
        for k in passed:
            a, b = starts[k], ends[k]
            first, last = idx[a], idx[b - 1]
            if ip[I_OCCLUDED] and _occluded(ranges, valid, n, full, first, last):
                continue
            mid = a + (b - a) // 2
            mx, my = xy[0, mid], xy[1, mid]
            if not py_hypot_in_range(mx, my):
                return _refused(lab)
            h, half = py_hypot(mx, my), 0.5 * chord[k]
            leg_f[n_legs, 0], leg_f[n_legs, 1] = mx + half * mx / h, my + half * my / h
            leg_f[n_legs, 2], leg_f[n_legs, 3], leg_f[n_legs, 4] = chord[k], mx, my
            leg_f[n_legs, 5], leg_f[n_legs, 6] = mean[k], std[k]
            leg_i[n_legs, 0], leg_i[n_legs, 1], leg_i[n_legs, 2] = first, last, b - a
            n_legs += 1
    drop = np.empty(n_legs, np.int64)
    for j in range(n_legs):
        drop[j] = leg_i[j, 0]
    t_legs = monotonic_ns()
    rest = lab
    n_circles = 0
    circle_f = np.empty((0, CIRCLE_F))
    circle_i = np.empty((0, CIRCLE_I), np.int64)
    if ip[I_CIRCLES]:
        rest, idx, xy, starts, ends = _runs(lab, drop, points)
        sigma = fp[F_C_SIGMA]
        verdict, _, mean, std, side, lim = _circle_tests(
            xy[0], xy[1], starts, ends, False, ip[I_C_MIN], fp[F_C_C_LO], fp[F_C_C_HI], fp[F_C_LO], fp[F_C_HI],
            fp[F_C_MEAN_LO], fp[F_C_MEAN_HI], fp[F_C_STD], fp[F_C_STD_SQ], sigma)
        passed = _accepted(verdict)
        n_p = len(passed)
        cx, cy, radii = np.full(n_p, math.nan), np.full(n_p, math.nan), np.full(n_p, math.nan)
        for j in range(n_p):  # (labkit.iav.circle_from_iav's arithmetic, as _pipeline_engine._iav_circles)
            k = passed[j]
            m, sd_side = mean[k], side[k]
            if sd_side == 0:
                sd_side = 1.0
            a, e = starts[k], ends[k]
            x1, y1 = xy[0, a], xy[1, a]
            dx, dy = xy[0, e - 1] - x1, xy[1, e - 1] - y1
            if not py_hypot_in_range(dx, dy):
                return _refused(lab)
            c = py_hypot(dx, dy)
            if not (0 < m < _PI) or not math.isfinite(sd_side) or c == 0:
                continue
            theta = m - _HALF_PI
            hh = -math.copysign(1.0, sd_side) * 0.5 * math.tan(theta)
            cx[j], cy[j] = x1 + 0.5 * dx - hh * dy, y1 + 0.5 * dy + hh * dx
            radii[j] = 0.5 * c / math.cos(theta)
        wide = np.zeros(n_p, np.bool_)
        if sigma > 0.0 and n_p:  # and their points must lie on a circle within the noise
            s_p, e_p = np.empty(n_p, np.int64), np.empty(n_p, np.int64)
            for j in range(n_p):
                s_p[j], e_p[j] = starts[passed[j]], ends[passed[j]]
            wide, ok = _wider(xy[0], xy[1], s_p, e_p, sigma, cx, cy, radii, True, ip[I_EARLY_STEPS],
                              fp[F_EARLY_FACTOR])
            if not ok:
                return _refused(lab)
        circle_f = np.empty((n_p, CIRCLE_F))
        circle_i = np.empty((n_p, CIRCLE_I), np.int64)
        for j in range(n_p):
            if math.isnan(radii[j]) or wide[j]:
                continue
            k = passed[j]
            a, e = starts[k], ends[k]
            circle_f[n_circles, 0], circle_f[n_circles, 1], circle_f[n_circles, 2] = cx[j], cy[j], radii[j]
            circle_f[n_circles, 3], circle_f[n_circles, 4] = mean[k], std[k]
            circle_f[n_circles, 5], circle_f[n_circles, 6] = lim[k, 1], lim[k, 2]
            circle_i[n_circles, 0], circle_i[n_circles, 1], circle_i[n_circles, 2] = idx[a], idx[e - 1], e - a
            n_circles += 1
        drop = np.empty(n_circles, np.int64)
        for j in range(n_circles):
            drop[j] = circle_i[j, 0]
    rest = _without(rest, drop)
    t_circles = monotonic_ns()
    fo = np.empty(N_T + LEG_F * n_legs + CIRCLE_F * n_circles)
    io = np.empty(N_S + LEG_I * n_legs + CIRCLE_I * n_circles, np.int64)
    fo[0], fo[1], fo[2] = t_seg, t_legs, t_circles
    io[S_STATUS], io[S_LEGS], io[S_CIRCLES] = 0, n_legs, n_circles
    f, i = _put_rows(fo, io, N_T, N_S, leg_f, leg_i, n_legs)
    _put_rows(fo, io, f, i, circle_f, circle_i, n_circles)
    return lab, rest, fo, io


@jit_inline
def _put_rows(fo, io, f, i, rows_f, rows_i, n):
    """The first ``n`` rows of ``rows_f`` and ``rows_i`` laid end to end into ``fo`` from ``f`` and ``io``
    from ``i``; the places after them."""
    for j in range(n):
        for c in range(rows_f.shape[1]):
            fo[f + c] = rows_f[j, c]
        for c in range(rows_i.shape[1]):
            io[i + c] = rows_i[j, c]
        f += rows_f.shape[1]
        i += rows_i.shape[1]
    return f, i


@jit
def _refused(lab):
    io = np.zeros(N_S, np.int64)
    io[S_STATUS] = 1
    return lab, lab, np.zeros(N_T), io


@jit_inline
def _occluded(ranges, valid, n, full, first, last):
    """:func:`labkit._iav_batch.occluded`."""
    for q in range(2):
        end, nb = (first, first - 1) if q == 0 else (last, last + 1)
        if not 0 <= nb < n:
            if not full:
                return True  # cut by the edge of the field of view
            nb %= n
        if valid[nb] and ranges[nb] < ranges[end]:
            return True
    return False


def circle_tests(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, check_finite: bool, min_points: int,
                 chord_range: tuple[float, float], middle_range: tuple[float, float],
                 mean_range: tuple[float, float], std_max: float, sigma: float):
    """The circle test of :func:`labkit._iav_batch.circle_engine` up to the centre (no arc-like
    shapes, nothing hollow), on every run: per run its verdict (:data:`labkit._iav_batch.VERDICTS`;
    ``ACCEPTED``: passed every angle test), middle ratio, the inscribed angles' mean, standard
    deviation and side sum (NaN where not computed), and the limits ``(mean low, mean high, std max)``
    it was held to (``(K, 3)``)."""
    p = np.asarray(pts, dtype=np.float64)
    return _circle_tests(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
                         np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64), bool(check_finite),
                         int(min_points), float(chord_range[0]), float(chord_range[1]), float(middle_range[0]),
                         float(middle_range[1]), float(mean_range[0]), float(mean_range[1]), float(std_max),
                         float(std_max) ** 2, float(sigma))  # (the square as Python takes it: C's pow)


@jit
def _wider(px, py, starts, ends, sigma, cx, cy, radii, given, early_steps, early_factor):
    """:func:`labkit._iav_noise.wider_than_noise`'s verdicts, and False where a fit needs numpy's
    least-squares step."""
    k_runs = len(starts)
    out = np.zeros(k_runs, np.bool_)
    limit = np.full(k_runs, math.nan)
    todo = np.empty(k_runs, np.int64)
    n_todo = 0
    for k in range(k_runs):
        if ends[k] - starts[k] > 3:
            dof = float(ends[k] - starts[k] - 3)
            ks = 2.0 / (9.0 * dof)
            base = 1.0 - ks + NOISE_Z * math.sqrt(ks)
            if not base != base:
                base = max(base, 0.0)
            limit[k] = sigma * sigma * math.pow(base, 3.0) * dof / (dof + 3)
            todo[n_todo] = k
            n_todo += 1
    if n_todo == 0:
        return out, True
    if given:  # the circle given decides the runs it fits well enough
        big = 1
        for j in range(n_todo):
            big = max(big, ends[todo[j]] - starts[todo[j]])
        dd = np.empty(big)
        kept = 0
        for j in range(n_todo):
            k = todo[j]
            a, m = starts[k], ends[k] - starts[k]
            for i in range(m):
                d = math.hypot(px[a + i] - cx[k], py[a + i] - cy[k]) - radii[k]
                dd[i] = d * d
            if not segment_sum(dd, 0, m) / m <= limit[k]:  # (NaN: no circle given)
                todo[kept] = k
                kept += 1
        n_todo = kept
    stage = 0 if given else -1  # the fits: (EARLY_STEPS, to convergence), after (0, ...) without a circle
    while n_todo:
        steps = 0 if stage == -1 else early_steps if stage == 0 else 50
        sub_s = np.empty(n_todo, np.int64)
        sub_e = np.empty(n_todo, np.int64)
        for j in range(n_todo):
            sub_s[j], sub_e[j] = starts[todo[j]], ends[todo[j]]
        _, _, _, rms, _, _, ok = _fit_runs(px, py, sub_s, sub_e, True, steps, 1e-12)
        if not ok:
            return out, False
        kept = 0
        for j in range(n_todo):
            k = todo[j]
            ms, lim = rms[j] * rms[j], limit[k]
            over = ms > lim
            if stage == 1:
                out[k] = over
            elif stage == 0:
                out[k] = ms > early_factor * lim
                over = over and ms <= early_factor * lim
            if stage != 1 and over:
                todo[kept] = k
                kept += 1
        if stage == 1:
            break
        n_todo = kept
        stage += 1
    return out, True


def wider_than_noise(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, sigma: float, centers: np.ndarray,
                     radii: np.ndarray, early_steps: int, early_factor: float) -> np.ndarray | None:
    """:func:`labkit._iav_noise.wider_than_noise` (with a circle per run to try first), bit for bit,
    or None where a fit needs numpy's least-squares step (the caller then runs numpy's)."""
    p = np.asarray(pts, dtype=np.float64)
    c = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    out, ok = _wider(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]), np.array(starts, dtype=np.int64),
                     np.array(ends, dtype=np.int64), float(sigma), np.ascontiguousarray(c[:, 0]),
                     np.ascontiguousarray(c[:, 1]), np.array(radii, dtype=np.float64), True, int(early_steps),
                     float(early_factor))
    return out if ok else None


def leg_tests(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, check_finite: bool, min_points: int,
              chord_range: tuple[float, float], middle_range: tuple[float, float], padding: float, sigma: float):
    """The tests of :func:`labkit._iav_batch.leg_engine` up to the angles (its defaults: no test of
    their mean or spread), on every run: per run its verdict (``ACCEPTED``: on to the occlusion
    test), chord padded by ``padding`` metres per metre of the middle point's range, and the
    inscribed angles' mean, standard deviation and side sum (NaN where not computed)."""
    p = np.asarray(pts, dtype=np.float64)
    return _leg_tests(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
                      np.array(starts, dtype=np.int64), np.array(ends, dtype=np.int64), bool(check_finite),
                      int(min_points), float(chord_range[0]), float(chord_range[1]), float(middle_range[0]),
                      float(middle_range[1]), float(padding), float(sigma))


def compile_all() -> None:
    """Compile (or load from the cache) the kernels, for a warm-up."""
    pts = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [0.7, 0.7]])
    fit_circles(pts, np.array([0]), np.array([5]), "geometric")
    angle_noise_runs(pts, np.array([0]), np.array([5]), 0.01)
    circle_tests(pts, np.array([0]), np.array([5]), False, 4, (0.15, math.inf), (0.1, 0.7), (1.6, 2.4), 0.15, 0.01)
    leg_tests(pts, np.array([0]), np.array([5]), False, 3, (0.1, 0.25), (0.1, 0.7), 0.01, 0.01)
    wider_than_noise(pts, np.array([0]), np.array([5]), 0.01, np.array([[0.0, 0.0]]), np.array([1.0]), 5, 16.0)
    # stage_pass as labkit._pipeline_engine hands it a scan's arrays (read-only) and the plan's (copies)
    from ._kernels import N_F, N_I
    from ._segmentation_engine import beams

    angles = np.radians(np.arange(-90.0, 91.0, 10.0))
    ranges = 2.0 + 0.1 * np.cos(3 * angles)
    valid, points = beams(ranges, angles, 0.0, 10.0)
    for a in (angles, ranges, valid, points):
        a.setflags(write=False)
    stage_pass(points, ranges, angles, valid, np.zeros(N_F), np.zeros(N_I, np.int64))
