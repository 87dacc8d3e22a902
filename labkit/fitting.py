"""Fitting lines and circles to points.

Lines are in normal form ``x cos(alpha) + y sin(alpha) = r`` with ``r >= 0`` and ``alpha``
wrapped to (-pi, pi].

* :func:`fit_line_polar` is the weighted least-squares fit of the course slides (Arras &
  Siegwart 1998): it minimises ``S = sum w_i (rho_i cos(theta_i - alpha) - r)^2``, the
  weighted sum of squared *orthogonal* distances, in closed form, and propagates the range
  noise into a 2x2 covariance of ``(r, alpha)``.
* :func:`fit_line_tls` is the same fit for Cartesian points with equal weights
  (orthogonal regression, "total least squares").
* :func:`fit_line_ols` is ordinary least squares ``y = a x + b`` (vertical distances), kept
  for contrast: it depends on the frame and fails on vertical walls.
* :func:`fit_circle` fits a circle algebraically (Kasa) or geometrically (orthogonal
  distances, Gauss-Newton).

Degenerate input, one policy for every fit: fewer points than the model needs (2 for a
line, 3 for a circle), all points identical, or all points collinear for a circle raise
``ValueError`` naming the argument. Non-finite values in ``rho``/``theta`` and ranges
``<= 0`` are invalid beams and are left out, not raised. Extractors never reach this
error: they skip segments with too few points before fitting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .geometry import wrap_angle

__all__ = [
    "LineFit",
    "CircleFit",
    "CircleFits",
    "fit_circles",
    "fit_line_polar",
    "fit_line_tls",
    "fit_line_ols",
    "fit_circle",
    "line_covariance",
    "line_from_sums",
    "line_covariances",
    "line_covariances_rms",
    "placement_probability",
]


@dataclass(frozen=True, eq=False)
class LineFit:
    """A fitted line.

    Parameters
    ----------
    r : float, metres
        Distance of the line from the origin, ``>= 0``.
    alpha : float, radians
        Direction of the line's normal, in (-pi, pi].
    covariance : ndarray (2, 2)
        Covariance of ``(r, alpha)`` (m^2, m rad, rad^2). NaN when it cannot be
        estimated (two points and no noise model; OLS fits).
    rms : float, metres
        Root mean square orthogonal distance of the points to the line (unweighted).
    n_points : int
        Number of points used.
    """

    r: float
    alpha: float
    covariance: np.ndarray
    rms: float
    n_points: int

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Signed orthogonal distances of ``points`` (N, 2) to the line."""
        p = np.asarray(points, dtype=float)
        return p[:, 0] * math.cos(self.alpha) + p[:, 1] * math.sin(self.alpha) - self.r

    def __repr__(self) -> str:
        return (f"LineFit(r={self.r:.4f} m, alpha={math.degrees(self.alpha):.2f} deg, "
                f"rms={self.rms:.4f} m, n={self.n_points})")


@dataclass(frozen=True, eq=False)
class CircleFit:
    """A fitted circle.

    A fitted circle: ``center`` (2,), ``radius``, RMS of the orthogonal distances ``|p - center| -
    radius``, point count, the method and its iteration count.

    Parameters
    ----------
    center : ndarray of shape (2,)
        Centre, metres.
    radius : float
        Radius, metres.
    rms : float
        RMS of the orthogonal distances ``|p - center| - radius``, metres.
    n_points : int
        The number of points fitted.
    method : {"algebraic", "geometric"}
        The fit.
    iterations : int, default 0
        Gauss-Newton iterations of ``"geometric"``.
    """

    center: np.ndarray
    radius: float
    rms: float
    n_points: int
    method: str
    iterations: int = 0

    def __repr__(self) -> str:
        cx, cy = self.center
        return (f"CircleFit(center=({cx:.4f}, {cy:.4f}), radius={self.radius:.4f}, rms={self.rms:.4f}, "
                f"n={self.n_points}, {self.method})")


# ---------------------------------------------------------------------------- validation
def _as_points(points, name: str = "points") -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must be an array of shape (N, 2), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite (drop invalid beams first, e.g. with Scan.xy)")
    return p


def _check_count(n: int, need: int, name: str, what: str) -> None:
    if n < need:
        raise ValueError(f"{name} must hold at least {need} valid points to fit a {what}, got {n}")


# ---------------------------------------------------------------------------- line core
def line_from_sums(sw: float, sx: float, sy: float, sxx: float, syy: float, sxy: float) -> tuple[float, float]:
    """``(r, alpha)`` of the weighted orthogonal fit from six weighted sums of the points.

    This is the closed form of :func:`fit_line_polar`. The slides' double sums factor into
    products of single sums, ``sum_i sum_j w_i w_j rho_i rho_j cos(t_i) sin(t_j) =
    (sum w x)(sum w y)`` and ``sum_i sum_j w_i w_j rho_i rho_j cos(t_i + t_j) = (sum w x)^2 -
    (sum w y)^2``, so six sums are all a fit needs: split-and-merge keeps their prefix sums
    and fits any run of a scan in O(1).

    Parameters
    ----------
    sw : float
        ``sum w``.
    sx : float
        ``sum w x``.
    sy : float
        ``sum w y``.
    sxx : float
        ``sum w x^2``.
    syy : float
        ``sum w y^2``.
    sxy : float
        ``sum w x y``.

    Returns
    -------
    r : float
        The line's distance from the origin, metres, ``r >= 0``.
    alpha : float
        Its normal's angle, radians, in (-pi, pi].

    Examples
    --------
    >>> line_from_sums(3.0, 6.0, 0.0, 12.0, 2.0, 0.0)   # (2, -1), (2, 0), (2, 1): the line x = 2
    (2.0, 0.0)
    """
    num = 2.0 * (sxy - sx * sy / sw)
    den = (sxx - syy) - (sx * sx - sy * sy) / sw
    alpha = 0.5 * math.atan2(num, den) + math.pi / 2
    r = (sx * math.cos(alpha) + sy * math.sin(alpha)) / sw
    if r < 0:
        r, alpha = -r, alpha + math.pi
    return r, math.remainder(alpha, 2 * math.pi)  # alpha was in (0, 2 pi]: now in (-pi, pi]


def _line_core(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Weighted orthogonal fit ``(r, alpha)`` of points; ``ValueError`` if they coincide."""
    sw = float(w.sum())
    sx, sy = float(w @ x), float(w @ y)
    sxx, syy = float(w @ (x * x)), float(w @ (y * y))
    if (sxx + syy) - (sx * sx + sy * sy) / sw <= 1e-24 * max(1.0, sxx + syy):
        raise ValueError("points are all identical: a line through them is undefined")
    return line_from_sums(sw, sx, sy, sxx, syy, float(w @ (x * y)))


def line_covariance(x, y, w, alpha: float, sigma_x, sigma_y=None, *, ray_noise: bool = True) -> np.ndarray:
    """Covariance of ``(r, alpha)`` of the weighted orthogonal fit, by first-order error propagation.

    Arras & Siegwart 1998, with the weights held fixed. ``r`` is not needed: the weighted centroid
    fixes it.

    Parameters
    ----------
    x, y : array_like of shape (N,)
        The points, metres.
    w : array_like of shape (N,)
        Their weights.
    alpha : float
        The fitted line's normal angle, radians.
    sigma_x : float or array_like of shape (N,)
        With ``ray_noise``: the range noise of each point, metres (each point moves along its own
        ray); otherwise the noise of its x coordinate.
    sigma_y : float or array_like of shape (N,), or None
        Without ``ray_noise``: the noise of each point's y coordinate; None: ``sigma_x``
        (isotropic point noise).
    ray_noise : bool
        The noise model: along the rays (the polar fit) or per coordinate.

    Returns
    -------
    ndarray of shape (2, 2)
        The covariance of ``(r, alpha)``.
    """
    x = np.asarray(x, dtype=float)
    vx = np.broadcast_to(np.asarray(sigma_x, dtype=float) ** 2, x.shape)
    vy = None if sigma_y is None else np.broadcast_to(np.asarray(sigma_y, dtype=float) ** 2, x.shape)
    return line_covariances(x, np.asarray(y, dtype=float), np.asarray(w, dtype=float), np.array([0]),
                            np.array([alpha]), vx, vy, ray_noise=ray_noise)[0]


def line_covariances(x, y, w, starts, alpha, var_x, var_y=None, *, ray_noise: bool = True) -> np.ndarray:
    """:func:`line_covariance` for many lines at once.

    Parameters
    ----------
    x, y : ndarray of shape (N,)
        The points of every line, metres: line ``k`` has ``x[starts[k]:starts[k + 1]]`` (the last
        runs to the end).
    w : ndarray of shape (N,)
        Their weights.
    starts : ndarray of int, shape (K,)
        Where each line's points start.
    alpha : ndarray of shape (K,)
        Each line's normal angle, radians.
    var_x : ndarray of shape (N,)
        Per-point variances: of the range with ``ray_noise``, else of x.
    var_y : ndarray of shape (N,) or None
        Without ``ray_noise``: per-point variances of y; None: ``var_x``.
    ray_noise : bool
        The noise model, as for :func:`line_covariance`.

    Returns
    -------
    ndarray of shape (K, 2, 2)
        Each line's covariance of ``(r, alpha)``; NaN for a line whose direction is undetermined
        (all points identical, or an isotropic cloud).
    """
    return line_covariances_rms(x, y, w, starts, alpha, var_x, var_y, ray_noise=ray_noise)[0]


def line_covariances_rms(x, y, w, starts, alpha, var_x, var_y=None, *, ray_noise: bool = True,
                         r=None) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`line_covariances`, and the RMS distance of each line's points to the line.

    The distances need the cos and sin of alpha at every point, which the covariances compute anyway.

    Parameters
    ----------
    x, y : ndarray of shape (N,)
        The points of every line, as for :func:`line_covariances`.
    w : ndarray of shape (N,)
        Their weights.
    starts : ndarray of int, shape (K,)
        Where each line's points start.
    alpha : ndarray of shape (K,)
        Each line's normal angle, radians.
    var_x : ndarray of shape (N,)
        Per-point variances, as for :func:`line_covariances`.
    var_y : ndarray of shape (N,) or None
        Per-point variances of y, as for :func:`line_covariances`.
    ray_noise : bool
        The noise model.
    r : ndarray of shape (K,) or None
        Each line's distance from the origin, metres; None: no RMS distances.

    Returns
    -------
    covariances : ndarray of shape (K, 2, 2)
        As :func:`line_covariances` returns them.
    rms : ndarray of shape (K,) or None
        The RMS distance of each line's points to the line ``(r[k], alpha[k])``; None without ``r``.
    """
    starts = np.asarray(starts)
    if len(starts) == 1:  # one line: plain sums and scalars broadcast (reduceat costs more)
        counts = len(x)

        def per_line(v):
            return v.sum(keepdims=True)

        def each(v):
            return v[0]
    else:
        counts = np.concatenate((starts[1:], [len(x)])) - starts

        def per_line(v):
            return np.add.reduceat(v, starts)

        def each(v):
            return v.repeat(counts)  # = v[line of each point]

    sw = per_line(w)
    xm, ym = per_line(w * x) / sw, per_line(w * y) / sw
    dx, dy = x - each(xm), y - each(ym)
    num = 2.0 * per_line(w * dx * dy)
    den = per_line(w * (dx * dx - dy * dy))
    q = num * num + den * den
    num_i, den_i, q_i = each(num), each(den), each(q)
    with np.errstate(divide="ignore", invalid="ignore"):
        # d alpha / d x_i and d alpha / d y_i, from alpha = atan2(num, den) / 2 + pi / 2
        ax = w * (den_i * dy - num_i * dx) / q_i
        ay = w * (den_i * dx + num_i * dy) / q_i
    ca, sa = np.cos(alpha), np.sin(alpha)
    lever = each(-xm * sa + ym * ca)  # d r / d alpha at the centroid
    share = w / each(sw)
    ca_i, sa_i = each(ca), each(sa)
    rx = share * ca_i + lever * ax
    ry = share * sa_i + lever * ay
    cov = np.empty((len(starts), 2, 2))
    if ray_noise:
        rho = np.hypot(x, y)
        c, s = x / rho, y / rho
        jr, ja = rx * c + ry * s, ax * c + ay * s
        var_jr = var_x * jr
        cov[:, 0, 0] = per_line(var_jr * jr)
        cov[:, 0, 1] = cov[:, 1, 0] = per_line(var_jr * ja)
        cov[:, 1, 1] = per_line(var_x * ja * ja)
    else:
        var_y = var_x if var_y is None else var_y
        cov[:, 0, 0] = per_line(var_x * rx * rx + var_y * ry * ry)
        cov[:, 0, 1] = cov[:, 1, 0] = per_line(var_x * rx * ax + var_y * ry * ay)
        cov[:, 1, 1] = per_line(var_x * ax * ax + var_y * ay * ay)
    cov[q == 0] = np.nan
    if r is None:
        return cov, None
    d = x * ca_i + y * sa_i - each(r)
    return cov, np.sqrt(np.add.reduceat(d * d, starts) / counts)


# Gauss-Legendre nodes and weights on [-1, 1] (the integral of placement_probability)
_GL_U, _GL_W = np.polynomial.legendre.leggauss(24)


def _normal_cdf(x: np.ndarray) -> np.ndarray:
    """Phi(x), vectorised, from Abramowitz & Stegun 7.1.26 (absolute error < 1.5e-7)."""
    z = np.abs(x) / math.sqrt(2.0)
    t = 1.0 / (1.0 + 0.3275911 * z)
    poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))))
    erf = 1.0 - poly * np.exp(-z * z)
    return 0.5 * (1.0 + np.copysign(erf, x))


def placement_probability(cov, max_dr_m: float, max_dalpha: float) -> np.ndarray | float:
    """The probability that a line with covariance ``cov`` lies near the true line.

    The probability that a line whose ``(r, alpha)`` has the covariance ``cov`` lies within
    ``max_dr_m`` in ``r`` and ``max_dalpha`` (radians) in ``alpha`` of the true line: the mass of
    the zero-mean Gaussian ``N(0, cov)`` in the rectangle ``|dr| <= max_dr_m``, ``|dalpha| <=
    max_dalpha``.

    A short or distant line is known worse in ``r`` than its angle error alone says: ``r``
    is measured from the sensor, so a turn of the line about its centroid moves ``r`` too; the
    correlation is kept (the rectangle is integrated over ``alpha`` with the conditional
    distribution of ``r``). ``cov``: one (2, 2) matrix (returns a float) or (K, 2, 2)
    (returns K probabilities). A NaN covariance gives 0.

    Parameters
    ----------
    cov : ndarray of shape (2, 2) or (K, 2, 2)
        Covariance of ``(r, alpha)``, metres and radians.
    max_dr_m : float
        Half-width of the rectangle in ``r``, metres.
    max_dalpha : float
        Half-width of the rectangle in ``alpha``, radians.

    Returns
    -------
    float or ndarray of shape (K,)
        The probability for each covariance (0 for a NaN covariance).

    Examples
    --------
    Uncorrelated, 1 cm and 1 deg of standard deviation, inside +-2 cm and +-2 deg: (2 Phi(2) - 1)^2.

    >>> c = np.diag([0.01 ** 2, np.radians(1.0) ** 2])
    >>> round(float(placement_probability(c, 0.02, np.radians(2.0))), 4)
    0.9111
    """
    c = np.asarray(cov, dtype=float)
    one = c.ndim == 2
    c = c.reshape(-1, 2, 2)
    if not (max_dr_m > 0 and max_dalpha > 0):
        raise ValueError(f"max_dr_m and max_dalpha must be > 0, got {max_dr_m} and {max_dalpha}")
    var_r, var_a, c_ra = c[:, 0, 0], c[:, 1, 1], c[:, 0, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        sd_a = np.sqrt(var_a)
        # alpha in units of its standard deviation, integrated over +-min(max_dalpha / sd, 8)
        half = np.minimum(max_dalpha / sd_a, 8.0)
        slope = c_ra / np.where(var_a > 0, var_a, 1.0) * sd_a  # E[r | alpha = u sd] = slope u
        sd_r = np.sqrt(np.maximum(var_r - c_ra * c_ra / np.where(var_a > 0, var_a, 1.0), 1e-300))
        # With r and alpha strongly correlated (a short wall far away) the probability that r is
        # within max_dr given alpha drops from 1 to 0 within sd_r where |slope u| passes max_dr: a
        # step one set of nodes misses. The interval is cut there, +-b, and each piece integrated.
        b = np.minimum(max_dr_m / np.abs(slope), half)
        lo = np.stack([-half, -b, b], axis=1)  # (K, 3) pieces [lo, hi]
        hi = np.stack([-b, b, half], axis=1)
        mid, rad = (hi + lo) / 2, (hi - lo) / 2
        u = mid[:, :, None] + rad[:, :, None] * _GL_U  # (K, 3, nodes)
        mu = slope[:, None, None] * u
        # Phi((max_dr - mu) / sd_r) - Phi((-max_dr - mu) / sd_r), both in one call
        edges = _normal_cdf((np.array([max_dr_m, -max_dr_m])[:, None, None, None] - mu) / sd_r[:, None, None])
        inside = edges[0] - edges[1]
        dens = np.exp(-0.5 * u * u) / math.sqrt(2 * math.pi)
        p = ((dens * inside) @ _GL_W * rad).sum(axis=1)
    p = np.where(np.isfinite(p), np.clip(p, 0.0, 1.0), 0.0)
    return float(p[0]) if one else p


def _residual_sigma(d: np.ndarray) -> float:
    n = d.size
    return math.sqrt(float(d @ d) / (n - 2)) if n > 2 else math.nan


def fit_line_polar(rho, theta, weights=None, *, range_sigma=None) -> LineFit:
    """Weighted least-squares line through points given in polar form.

    Minimises ``S = sum_i w_i (rho_i cos(theta_i - alpha) - r)^2`` in closed form:

    * ``alpha = 1/2 atan2(sum w rho^2 sin 2theta - 2/W (sum w rho cos theta)(sum w rho sin theta),
      sum w rho^2 cos 2theta - 1/W ((sum w rho cos theta)^2 - (sum w rho sin theta)^2)) + pi/2``
    * ``r = sum w rho cos(theta - alpha) / W`` with ``W = sum w``

    The slides write the second terms as double sums over all pairs (O(n^2)); they factor
    into products of single sums, so the fit is O(n). A negative ``r`` is made positive
    by turning the normal around (``alpha + pi``).

    Parameters
    ----------
    rho, theta : array_like (N,)
        Ranges (m) and bearings (rad). Non-finite values and ranges ``<= 0`` are invalid
        beams and are left out.
    weights : None, "uniform", "inverse_variance" or array_like (N,)
        ``None`` (default): ``w = 1 / rho``, the slides' choice (closer points are more
        certain). ``"inverse_variance"``: ``w = 1 / range_sigma^2`` (a range variance
        model, e.g. noise growing with range). An array: your own non-negative weights.
    range_sigma : float or array_like (N,), metres, optional
        Standard deviation of each range reading, used for the covariance (and for the
        ``"inverse_variance"`` weights). Default: estimated from the orthogonal residuals
        ``d``, ``sqrt(n / (n - 2) * sum d^2 / sum cos^2(theta - alpha))`` (a range error moves
        a point across the line by its cosine), so the covariance is NaN for two points.

    Returns
    -------
    LineFit
        The line ``(r, alpha)`` in normal form, its covariance (with ``range_sigma``), the RMS of the
        orthogonal residuals and the number of points.

    Examples
    --------
    >>> theta = np.radians([-20.0, 0.0, 20.0])
    >>> fit = fit_line_polar(2.0 / np.cos(theta), theta)     # the wall x = 2
    >>> round(fit.r, 9), round(float(np.degrees(fit.alpha)), 9)
    (2.0, 0.0)
    """
    rho = np.asarray(rho, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if rho.ndim != 1 or theta.shape != rho.shape:
        raise ValueError(f"rho and theta must be 1-D arrays of the same length, got shapes {rho.shape} and "
                         f"{theta.shape}")
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(rho) & np.isfinite(theta) & (rho > 0)
    sigma = None
    if range_sigma is not None:
        sigma = np.broadcast_to(np.asarray(range_sigma, dtype=float), rho.shape)
        if not np.all(np.isfinite(sigma[ok]) & (sigma[ok] > 0)):
            raise ValueError("range_sigma must be positive and finite")
    if weights is None:
        w = np.zeros_like(rho)
        w[ok] = 1.0 / rho[ok]
    elif isinstance(weights, str):
        if weights == "uniform":
            w = np.ones_like(rho)
        elif weights == "inverse_variance":
            if sigma is None:
                raise ValueError('weights="inverse_variance" needs range_sigma')
            w = np.zeros_like(rho)
            w[ok] = 1.0 / sigma[ok] ** 2
        else:
            raise ValueError(f'weights must be None, "uniform", "inverse_variance" or an array, got {weights!r}')
    else:
        w = np.asarray(weights, dtype=float)
        if w.shape != rho.shape:
            raise ValueError(f"weights must have the shape of rho {rho.shape}, got {w.shape}")
        if not np.all(np.isfinite(w[ok]) & (w[ok] >= 0)):
            raise ValueError("weights must be finite and >= 0")
        ok = ok & (w > 0)
    _check_count(int(ok.sum()), 2, "rho", "line")
    rho, theta, w = rho[ok], theta[ok], w[ok]
    x, y = rho * np.cos(theta), rho * np.sin(theta)
    r, alpha = _line_core(x, y, w)
    d = x * math.cos(alpha) + y * math.sin(alpha) - r
    if sigma is None:
        # a range error e moves a point by e cos(theta - alpha) across the line, so the
        # orthogonal residuals understate the range noise by that factor
        n, c2 = d.size, float(np.sum(np.cos(theta - alpha) ** 2))
        s = math.sqrt(float(d @ d) * n / ((n - 2) * c2)) if n > 2 and c2 > 0 else math.nan
    else:
        s = sigma[ok]
    cov = line_covariance(x, y, w, alpha, s, ray_noise=True)
    return LineFit(r, alpha, cov, float(np.sqrt(np.mean(d * d))), int(rho.size))


def fit_line_tls(points, *, point_sigma=None) -> LineFit:
    """Orthogonal regression (total least squares), all points weighted equally.

    The line minimising the sum of squared orthogonal distances.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points, metres, at least two distinct.
    point_sigma : float, optional
        Isotropic noise of each coordinate for the covariance, metres; by default estimated from the
        residuals.

    Returns
    -------
    LineFit
        The line ``(r, alpha)`` in normal form, its covariance, the RMS orthogonal residual and the
        number of points.

    Examples
    --------
    >>> fit_line_tls([[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    LineFit(r=1.0000 m, alpha=90.00 deg, rms=0.0000 m, n=3)
    """
    p = _as_points(points)
    _check_count(len(p), 2, "points", "line")
    x, y = p[:, 0], p[:, 1]
    w = np.ones(len(p))
    r, alpha = _line_core(x, y, w)
    d = x * math.cos(alpha) + y * math.sin(alpha) - r
    s = _residual_sigma(d) if point_sigma is None else float(point_sigma)
    cov = line_covariance(x, y, w, alpha, s, ray_noise=False)
    return LineFit(r, alpha, cov, float(np.sqrt(np.mean(d * d))), len(p))


def fit_line_ols(points) -> LineFit:
    """Ordinary least squares ``y = a x + b``, returned in normal form for comparison.

    It minimises *vertical* distances, so the result depends on the frame and it cannot
    represent a vertical line (``ValueError`` when all ``x`` are equal). ``covariance`` is
    NaN: this fit has no range-noise model. ``rms`` is still the orthogonal RMS.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points, metres; not all with the same ``x``.

    Returns
    -------
    LineFit
        The line in normal form, ``covariance`` NaN, ``rms`` the orthogonal RMS.

    Examples
    --------
    >>> fit_line_ols([[0.0, 1.0], [1.0, 2.0], [2.0, 3.0]]).r   # y = x + 1
    0.7071067811865475
    """
    p = _as_points(points)
    _check_count(len(p), 2, "points", "line")
    x, y = p[:, 0], p[:, 1]
    xm, ym = x.mean(), y.mean()
    sxx = float(((x - xm) ** 2).sum())
    if sxx <= 1e-24 * max(1.0, float((x * x).sum())):
        raise ValueError("points all have the same x: ordinary least squares cannot fit a vertical line "
                         "(use fit_line_tls)")
    a = float(((x - xm) * (y - ym)).sum()) / sxx
    b = ym - a * xm
    # a x - y + b = 0  ->  normal (-a, 1) / sqrt(1 + a^2), r = b / sqrt(1 + a^2)
    norm = math.hypot(a, 1.0)
    alpha, r = math.atan2(1.0, -a), b / norm
    if r < 0:
        r, alpha = -r, alpha + math.pi
    alpha = float(wrap_angle(alpha))
    d = x * math.cos(alpha) + y * math.sin(alpha) - r
    return LineFit(float(r), alpha, np.full((2, 2), np.nan), float(np.sqrt(np.mean(d * d))), len(p))


# ---------------------------------------------------------------------------- circles
def fit_circle(points, method: str = "algebraic", *, max_iterations: int = 50, tol: float = 1e-12) -> CircleFit:
    """Fit a circle to points.

    ``method="algebraic"`` (Kasa 1976) minimises ``sum (|p - c|^2 - R^2)^2``, a linear
    least-squares problem: fast, but biased towards small radii on short arcs.
    ``method="geometric"`` minimises ``sum (|p - c| - R)^2``, the orthogonal distances, by
    Gauss-Newton started from the algebraic fit.

    Raises ``ValueError`` for fewer than 3 points or (nearly) collinear points.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        At least 3 points, not collinear, metres.
    method : {"algebraic", "geometric"}, default "algebraic"
        The objective minimised (above).
    max_iterations : int, default 50
        Gauss-Newton iterations at most (``"geometric"``).
    tol : float, default 1e-12
        Stop when the squared length of a Gauss-Newton step falls under ``tol`` times
        ``max(1, radius**2)``.

    Returns
    -------
    CircleFit
        Centre, radius, RMS of the orthogonal residuals, number of points, method and iterations.

    Raises
    ------
    ValueError
        For fewer than 3 points or (nearly) collinear points.

    Examples
    --------
    >>> t = np.linspace(0, np.pi, 7)
    >>> fit = fit_circle(np.c_[1 + 2 * np.cos(t), -1 + 2 * np.sin(t)], "geometric")
    >>> np.round(fit.center, 9).tolist(), round(fit.radius, 9)
    ([1.0, -1.0], 2.0)
    """
    if method not in ("algebraic", "geometric"):
        raise ValueError(f'method must be "algebraic" or "geometric", got {method!r}')
    p = _as_points(points)
    _check_count(len(p), 3, "points", "circle")
    n = len(p)
    fit = fit_circles(p, np.array([0]), np.array([n]), method, max_iterations=max_iterations, tol=tol)
    if fit.status.item(0) == 1:
        raise ValueError("points are all identical: a circle through them is undefined")
    if fit.status.item(0) == 2:
        raise ValueError("points are collinear: no finite circle fits them")
    center = fit.centers[0].copy()
    center.setflags(write=False)
    return CircleFit(center, fit.radii.item(0), fit.rms.item(0), n, method, fit.iterations.item(0))


class CircleFits(NamedTuple):
    """Circles fitted to many runs of points at once (:func:`fit_circles`), one entry per run.

    Parameters
    ----------
    centers : ndarray of shape (K, 2)
        Each run's centre, metres.
    radii : ndarray of shape (K,)
        Each run's radius, metres.
    rms : ndarray of shape (K,)
        Each run's RMS orthogonal distance to its circle, metres.
    iterations : ndarray of shape (K,)
        The Gauss-Newton iterations each run took.
    status : ndarray of shape (K,)
        0: fitted; 1: the points are all identical; 2: collinear, no finite circle (the other
        fields are then NaN).
    """

    centers: np.ndarray  # (K, 2)
    radii: np.ndarray
    rms: np.ndarray
    iterations: np.ndarray
    status: np.ndarray


def fit_circles(points: np.ndarray, starts: np.ndarray, ends: np.ndarray, method: str = "algebraic", *,
                max_iterations: int = 50, tol: float = 1e-12) -> CircleFits:
    """:func:`fit_circle` on many runs of points, all runs at once.

    Every step is a few sums per run, so many small fits cost about what one does.

    Each run is centred and scaled (its mean square distance from its centroid is 1). Then the
    algebraic fit's columns ``(x, y, 1)`` are orthogonal to the last, its normal equations are a
    2 x 2 system, and the smallest singular value of ``[x y 1]`` (collinear points: 0) is the
    root of the points' sum of squares across their major axis. Gauss-Newton solves its 3 x 3
    normal equations in closed form, and a run stops when its step falls under ``tol``; a nearly
    straight run (a huge radius), where the normal equations lose too many digits, takes its
    steps by least squares instead.

    Parameters
    ----------
    points : ndarray of shape (N, 2)
        The points of every run, metres.
    starts : ndarray of int, shape (K,)
        Where each run starts in ``points``.
    ends : ndarray of int, shape (K,)
        Where each run ends (exclusive): run ``k`` is ``points[starts[k]:ends[k]]``, at least 3 points.
    method : {"algebraic", "geometric"}
        The objective minimised, as for :func:`fit_circle`.
    max_iterations : int
        Gauss-Newton iterations at most per run (``"geometric"``).
    tol : float
        A run stops when the squared length of its Gauss-Newton step falls under ``tol`` times
        ``max(1, radius**2)``.

    Returns
    -------
    CircleFits
        Each run's circle, RMS distance, iterations and status.
    """
    p = np.asarray(points, dtype=np.float64)
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    sizes = ends - starts
    k_runs = len(starts)
    if np.any(sizes < 3):
        raise ValueError("every run needs at least 3 points to fit a circle")
    n = sizes.astype(np.float64)
    idx: slice | np.ndarray  # the points of the runs
    if k_runs == 1:  # (one run: plain sums, and its values broadcast over its points)
        idx, off = slice(starts.item(0), ends.item(0)), np.zeros(1, np.int64)

        def per_run(v):
            return v.sum(axis=0, keepdims=True)

        def spread(v):
            return v
    else:  # the runs' points back to back
        off = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        idx = np.arange(sizes.sum()) + np.repeat(starts - off, sizes)
        seg = np.repeat(np.arange(k_runs), sizes)

        def per_run(v):  # the sum of v over each run
            return np.add.reduceat(v, off)

        def spread(v):  # each run's value at each of its points
            return v[seg]

    q = p[idx]
    mean = per_run(q) / n[:, None]
    q = q - spread(mean)
    qx, qy = q[:, 0], q[:, 1]
    sxx, sxy, syy = per_run(qx * qx), per_run(qx * qy), per_run(qy * qy)
    scale = np.sqrt((sxx + syy) / n)
    status = np.where(scale == 0, 1, 0)
    scale[scale == 0] = 1.0
    qx, qy = qx / spread(scale), qy / spread(scale)
    sxx, sxy, syy = sxx / scale ** 2, sxy / scale ** 2, syy / scale ** 2  # sxx + syy = n
    half = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    across = qy * spread(np.cos(half)) - qx * spread(np.sin(half))
    small = per_run(across * across)
    status[(status == 0) & (small < 1e-18 * n)] = 2
    det = small * (n - small)  # the product of the scatter's eigenvalues (they sum to n)
    det[status != 0] = 1.0
    z = qx * qx + qy * qy
    sxz, syz = per_run(qx * z), per_run(qy * z)
    # minimise sum (z - 2 a x - 2 b y - c)^2: c = mean z, and a 2 x 2 system for (a, b)
    cx, cy = (syy * sxz - sxy * syz) / (2 * det), (sxx * syz - sxy * sxz) / (2 * det)
    rad2 = per_run(z) / n + cx * cx + cy * cy
    status[(status == 0) & ~((rad2 > 0) & (np.hypot(cx, cy) <= 1e6))] = 2
    ok = status == 0
    radius = np.sqrt(np.where(ok, rad2, 1.0))
    iterations = np.zeros(k_runs, np.int64)
    if method == "geometric":  # Gauss-Newton on the orthogonal distances
        active = ok.copy()
        for it in range(1, max_iterations + 1):
            dx, dy = qx - spread(cx), qy - spread(cy)
            dist = np.hypot(dx, dy)
            dist[dist == 0] = 1e-300
            ux, uy = dx / dist, dy / dist
            res = dist - spread(radius)
            # J = -(ux, uy, 1); solve (J^T J) step = -J^T res
            a11, a12, a22 = per_run(ux * ux), per_run(ux * uy), per_run(uy * uy)
            a13, a23 = per_run(ux), per_run(uy)
            b1, b2, b3 = per_run(ux * res), per_run(uy * res), per_run(res)
            m11, m12, m13 = a22 * n - a23 * a23, a13 * a23 - a12 * n, a12 * a23 - a13 * a22
            m22, m23, m33 = a11 * n - a13 * a13, a12 * a13 - a11 * a23, a11 * a22 - a12 * a12
            d3 = a11 * m11 + a12 * m12 + a13 * m13
            good = d3 > 1e-8 * a11 * a22 * n
            d3 = np.where(good, d3, 1.0)
            s1 = (m11 * b1 + m12 * b2 + m13 * b3) / d3
            s2 = (m12 * b1 + m22 * b2 + m23 * b3) / d3
            s3 = (m13 * b1 + m23 * b2 + m33 * b3) / d3
            for k in np.flatnonzero(active & ~good).tolist():  # nearly straight: least squares
                o, e = off[k], off[k] + sizes[k]
                s1[k], s2[k], s3[k] = np.linalg.lstsq(np.column_stack([ux[o:e], uy[o:e], np.ones(e - o)]), res[o:e],
                                                      rcond=None)[0].tolist()
            s1, s2, s3 = np.where(active, s1, 0.0), np.where(active, s2, 0.0), np.where(active, s3, 0.0)
            cx, cy, radius = cx + s1, cy + s2, radius + s3
            iterations[active] = it
            active &= s1 * s1 + s2 * s2 + s3 * s3 >= tol * np.maximum(1.0, radius * radius)
            if not active.any():
                break
        radius = np.abs(radius)
    centers = np.stack([cx * scale + mean[:, 0], cy * scale + mean[:, 1]], axis=1)
    radius = radius * scale
    d = np.hypot(p[idx, 0] - spread(centers[:, 0]), p[idx, 1] - spread(centers[:, 1])) - spread(radius)
    rms = np.sqrt(per_run(d * d) / n)
    nan = status != 0
    centers[nan], radius[nan], rms[nan] = np.nan, np.nan, np.nan
    return CircleFits(centers, radius, rms, iterations, status)
