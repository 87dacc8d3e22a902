"""The noise allowances of the IAV detectors (private: :mod:`labkit.circles.iav_circles`,
:mod:`labkit.circles.legs` and their batch engine :mod:`labkit._iav_batch` share them).

The paper's thresholds are fixed (Table II), which is right for the 5 mm of a SICK LMS200 and
wrong at 2 cm: a leg seen by 4 beams at 3 m has a chord of 10 cm, and 2 cm of range noise on its
middle point alone moves the prerequisite ratio by 0.2 -- the whole distance from a half circle's
0.35 to the 0.1 limit. Given the range noise sigma (``range_sigma_m``), the tests ask instead
whether the data *could* come from a shape that passes: each bound is moved out by
:data:`labkit.iav.NOISE_Z` standard deviations of the statistic under that noise, propagated to
first order from the ranges of the very points tested (noise along each beam). sigma = 0 is the
paper's test.

* :func:`ratio_sd` -- the prerequisite's ratio (Fig. 5);
* :func:`angle_noise`, :func:`angle_noise_runs`, :func:`widen`, :func:`angle_limits` -- the mean
  and the spread of the inscribed angles;
* :func:`wider_than_noise` -- whether the points lie on one circle within the noise (the residual
  test, labkit's own: the widened angle tests alone let corners through at a few centimetres).

``tests/test_noise_aware.py`` checks each allowance against the noise it models, drawn many times.
"""

from __future__ import annotations

import math
from typing import overload

import numpy as np

from ._jit import ENABLED as _JIT
from .fitting import fit_circles
from .iav import ARC_LIKE_STD_MAX, LINE_Z, NOISE_Z
from .noise import chi2_upper_over_dof

__all__ = ["ratio_sd", "angle_noise", "angle_noise_runs", "widen", "angle_limits", "wider_than_noise",
           "EARLY_STEPS", "EARLY_FACTOR"]

#: The residual test (:func:`wider_than_noise`) decides after this many Gauss-Newton steps a run whose
#: mean square is already ``EARLY_FACTOR`` times over its limit (``tests/test_iav.py`` measures how far
#: from the converged fit such a decision can be).
EARLY_STEPS = 5
EARLY_FACTOR = 16.0


def ratio_sd(p0, p1, mid, chord: float, sigma: float) -> float:
    """Standard deviation of the middle-point ratio (signed distance from the chord over the
    chord) when the three points' ranges have noise ``sigma``, to first order: the middle
    point's range error moves it by its beam's component across the chord, each extreme's
    moves the chord at the middle by half of its own."""
    (x0, y0), (x1, y1), (xm, ym) = p0, p1, mid
    if chord <= 0.0:
        return math.inf
    ex, ey = (x1 - x0) / chord, (y1 - y0) / chord
    acc = 0.0  # each beam's unit vector's component across the chord, squared and weighted
    for x, y, w in ((xm, ym, 1.0), (x0, y0, 0.25), (x1, y1, 0.25)):
        h2 = x * x + y * y
        if h2 > 0.0:
            across = ex * y - ey * x
            acc += w * across * across / h2
    return sigma * math.sqrt(acc) / chord


def angle_noise(p: np.ndarray, sigma: float) -> tuple[float, float]:
    """How much range noise ``sigma`` alone spreads the inscribed angles of the run ``p``
    (n, 2), n >= 3: ``(spread_max_sq, mean_sd)`` (:func:`angle_noise_runs` for one run)."""
    spread_sq, mean_sd = angle_noise_runs(p, np.array([0]), np.array([len(p)]), sigma)
    return spread_sq.item(0), mean_sd.item(0)


def angle_noise_runs(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                     sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """How much range noise ``sigma`` alone spreads the inscribed angles of each run
    ``pts[starts[k]:ends[k]]`` (n >= 3 points), all runs at once: ``(spread_max_sq, mean_sd)``.

    With ``J`` the first-order derivatives of the m = n - 2 angles with respect to the n ranges
    (each point moved along its beam) and ``C`` the centring matrix, the population variance
    of the angles has the mean ``E = sigma^2 |C J|_F^2 / m`` and about ``nu`` degrees of freedom
    (Satterthwaite: ``nu = tr(S)^2 / tr(S^2)``, ``S = C J J^T C``); ``spread_max_sq`` is its
    upper ``NOISE_Z`` quantile, ``E chi2(nu) / nu`` (Wilson-Hilferty). ``mean_sd`` is the
    standard deviation of the mean angle, ``sigma |1^T J| / m``.

    Angle i depends on three ranges only: the first point's (``g_i``), its own point's (``d_i``)
    and the last point's (``h_i``). With ``gc, hc`` the centred ``g, h``, ``(C J)^T (C J)`` is
    ``[[gc.gc, d_i gc_i, gc.hc], [., d_i d_j (delta_ij - 1/m), d_i hc_i], [., ., hc.hc]]``, so
    ``tr(S)`` and ``tr(S^2)`` (its trace and squared Frobenius norm) are sums over the angles.

    The compiled engine (:mod:`labkit._iav_engine`) computes the same, bit for bit, unless
    ``LABKIT_NO_JIT`` is set; :func:`angle_noise_reference` is the numpy code below.
    """
    if _JIT:
        from ._iav_engine import angle_noise_runs as engine  # (numba imported on the first call)

        return engine(pts, starts, ends, sigma)
    return angle_noise_reference(pts, starts, ends, sigma)


def angle_noise_reference(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                          sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`angle_noise_runs` as numpy operations over every angle of every run at once."""
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    m_k = ends - starts - 2
    off = np.concatenate([[0], np.cumsum(m_k)[:-1]])
    run = np.repeat(np.arange(len(starts)), m_k)  # the run of each angle
    mid = np.arange(int(m_k.sum())) + np.repeat(starts + 1 - off, m_k)  # each angle's own point
    h = np.hypot(pts[:, 0], pts[:, 1])
    u = pts / np.where(h > 0, h, 1.0)[:, None]
    p0, p1 = pts[starts][run], pts[ends - 1][run]
    pm, um = pts[mid], u[mid]
    a, b = p0 - pm, p1 - pm  # P_i -> P_1, P_i -> P_n
    na2, nb2 = a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1], b[:, 0] * b[:, 0] + b[:, 1] * b[:, 1]

    def cross(v, w):
        return v[:, 0] * w[:, 1] - v[:, 1] * w[:, 0]

    # d arg(v) = cross(v, dv) / |v|^2, and the angle is arg(b) - arg(a); a point on an end point
    # (a degenerate run, which the angle test rejects) gives NaN, not a warning
    with np.errstate(divide="ignore", invalid="ignore"):
        d = cross(a, um) / na2 - cross(b, um) / nb2
        g = -cross(a, u[starts][run]) / na2
        hh_ = cross(b, u[ends - 1][run]) / nb2
    m = m_k.astype(np.float64)

    def per_run(v):
        return np.add.reduceat(v, off)

    g_sum, h_sum = per_run(g), per_run(hh_)
    gc, hc = g - (g_sum / m)[run], hh_ - (h_sum / m)[run]
    gg, hh, gh = per_run(gc * gc), per_run(hc * hc), per_run(gc * hc)
    d2 = d * d
    sd2 = per_run(d2)
    tr = gg + hh + sd2 * (1.0 - 1.0 / m)
    tr2 = (gg * gg + hh * hh + 2.0 * gh * gh + 2.0 * per_run(d2 * (gc * gc + hc * hc))
           + per_run(d2 * d2) * (1.0 - 2.0 / m) + sd2 * sd2 / (m * m))
    mean_sd = sigma * np.sqrt(g_sum * g_sum + sd2 + h_sum * h_sum) / m
    pos = tr > 0.0
    nu = np.where(pos, tr * tr / np.where(pos, tr2, 1.0), 1.0)
    spread_sq = np.where(pos, sigma * sigma * tr / m * chi2_upper_over_dof(nu, NOISE_Z), 0.0)
    return spread_sq, mean_sd


def _fit_circles(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, **kwargs):
    """Geometric :func:`labkit.fitting.fit_circles`: the compiled one (:mod:`labkit._iav_engine`,
    the same circles bit for bit) unless ``LABKIT_NO_JIT`` is set or a run needs numpy's
    least-squares step."""
    if _JIT:
        from ._iav_engine import fit_circles as engine  # (numba imported on the first fit)

        fit = engine(pts, starts, ends, "geometric", **kwargs)
        if fit is not None:
            return fit
    return fit_circles(pts, starts, ends, "geometric", **kwargs)


def angle_limits(p: np.ndarray, sigma: float, mean_range: tuple[float, float], std_max: float | None,
                 like_max: float | None = None) -> tuple[tuple[float, float], float | None, float | None]:
    """``mean_range``, ``std_max`` and ``like_max`` (the arc-like bound, or None) of a run of
    points ``p``, widened for range noise ``sigma`` (:func:`angle_noise`); unchanged when
    ``sigma`` is 0."""
    if sigma <= 0.0:
        return mean_range, std_max, like_max
    return widen(*angle_noise(p, sigma), mean_range, std_max, like_max)


@overload  # a spread limit given is widened, never dropped
def widen(spread_sq: float, mean_sd: float, mean_range: tuple[float, float], std_max: float,
          like_max: float | None) -> tuple[tuple[float, float], float, float | None]: ...


@overload
def widen(spread_sq: float, mean_sd: float, mean_range: tuple[float, float], std_max: float | None,
          like_max: float | None) -> tuple[tuple[float, float], float | None, float | None]: ...


def widen(spread_sq: float, mean_sd: float, mean_range: tuple[float, float], std_max: float | None,
          like_max: float | None) -> tuple[tuple[float, float], float | None, float | None]:
    """The limits of :func:`angle_limits` for a run whose angles range noise spreads by
    ``spread_sq`` and whose mean angle it moves by ``mean_sd`` (:func:`angle_noise_runs`)."""
    w = NOISE_Z * mean_sd
    hi = min(mean_range[1] + w, max(math.pi - LINE_Z * mean_sd, mean_range[1]))
    cap = max(ARC_LIKE_STD_MAX, like_max or 0.0)
    return ((mean_range[0] - w, hi), None if std_max is None else min(math.sqrt(std_max ** 2 + spread_sq), cap),
            None if like_max is None else min(math.sqrt(like_max ** 2 + spread_sq), cap))


def wider_than_noise(pts: np.ndarray, starts: np.ndarray, ends: np.ndarray, sigma: float,
                     centers: np.ndarray | None = None, radii: np.ndarray | None = None) -> np.ndarray:
    """Whether the points of each run ``pts[starts[k]:ends[k]]`` lie farther from their best
    circle (orthogonal fit, :func:`labkit.fitting.fit_circles`) than range noise ``sigma``
    allows: the mean square distance per degree of freedom above the upper ``NOISE_Z`` quantile
    of ``sigma^2 chi2(n - 3) / (n - 3)``. The inscribed angles of a room's corner or a chair's
    back can pass the widened tests at a few centimetres of noise; their points do not lie on
    one circle. (A beam's noise moves its point across the circle by at most sigma, so true
    circles fail this less often than the quantile says.) Runs of 3 points, and runs no finite
    circle fits, are not. ``centers`` (K, 2) and ``radii`` (K,), if given, are a circle per run to
    try first (the detector's own; NaN: none). With them, the compiled engine decides
    (:mod:`labkit._iav_engine`, the same verdicts bit for bit) unless ``LABKIT_NO_JIT`` is set or a
    fit needs numpy's least-squares step."""
    if _JIT and centers is not None and radii is not None:
        from ._iav_engine import wider_than_noise as engine  # (numba imported on the first call)

        decided = engine(pts, starts, ends, sigma, centers, radii, EARLY_STEPS, EARLY_FACTOR)
        if decided is not None:
            return decided
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    out = np.zeros(len(starts), dtype=bool)
    big = np.flatnonzero(ends - starts > 3)
    if not len(big):
        return out
    dof = (ends[big] - starts[big] - 3).astype(np.float64)
    limit = sigma * sigma * chi2_upper_over_dof(dof, NOISE_Z) * dof / (dof + 3)  # on the mean square
    # Any circle whose mean square is under the limit proves a run is not wider (the best circle can
    # only do better): the circle given (or else the algebraic one, Gauss-Newton's start) decides
    # most true circles with no Gauss-Newton step. Gauss-Newton converges slowly on runs far from
    # any circle (a wall's corner, a nearly straight run), and a few steps decide most of the rest:
    # after EARLY_STEPS steps the mean square was at most about 6 times its minimum on the runs of
    # the simulated hall at 5 mm to 3 cm and of the Radish logs (tests/test_iav.py measures it), so
    # a run EARLY_FACTOR times over the limit is taken as wider. The few in between are fitted to
    # convergence.
    todo = big
    if centers is not None:
        if radii is None:  # (the TypeError indexing None raised before, with a message)
            raise TypeError("wider_than_noise: centers need their radii")
        sizes = ends[big] - starts[big]
        off = np.cumsum(sizes) - sizes
        run = np.repeat(np.arange(len(big)), sizes)
        q = pts[np.arange(sizes.sum()) + np.repeat(starts[big] - off, sizes)]
        c = centers[big][run]
        d = np.hypot(q[:, 0] - c[:, 0], q[:, 1] - c[:, 1]) - radii[big][run]
        with np.errstate(invalid="ignore"):
            todo = big[~(np.add.reduceat(d * d, off) / sizes <= limit)]  # (NaN: no circle given)
        if not len(todo):
            return out
    for steps in (EARLY_STEPS, None) if centers is not None else (0, EARLY_STEPS, None):
        fit = _fit_circles(pts, starts[todo], ends[todo], **({} if steps is None else {"max_iterations": steps}))
        ms, lim = fit.rms ** 2, limit[np.searchsorted(big, todo)]
        with np.errstate(invalid="ignore"):  # (NaN where no circle fits: not wider)
            over = ms > lim
            if steps is None:
                out[todo] = over
                break
            if steps:
                out[todo] = ms > EARLY_FACTOR * lim
                over &= ms <= EARLY_FACTOR * lim
        todo = todo[over]
        if not len(todo):
            break
    return out


