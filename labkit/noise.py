"""How noisy is this scanner? The range noise estimated from the scans themselves.

Every threshold that separates "noise" from "a different wall" -- the split test, the merge
test, the breakpoint gap, the least a line needs to be placed -- depends on the sensor's range
noise sigma, which users rarely know: a SICK LMS ranges to a few millimetres, a cheap 360 deg
scanner (Neato XV-11, RPLIDAR) to a few centimetres. :func:`estimate_range_noise` reads it
off the data.

The residual of one beam
------------------------
Points on a straight line have inverse ranges that are a sinusoid of the beam angle: a line
``x cos(alpha) + y sin(alpha) = d`` is seen at range ``rho(theta) = d / cos(theta - alpha)``,
so ``u = 1 / rho = cos(theta - alpha) / d``. Three values of one sinusoid at the angles
``t0 < t1 < t2`` obey

    u1 sin(t2 - t0) = u0 sin(t2 - t1) + u2 sin(t1 - t0)

whatever the line's distance and incidence. For beam ``i`` and its two neighbours the
residual ``s_i = rho_i^2 (u_i - w0 u_(i-1) - w2 u_(i+1))`` (``w0, w2`` the weights above) is
therefore exactly 0 on any wall, at any incidence, and with range errors ``e`` it is, to first
order, ``-e_i + w0 e_(i-1) (rho_i / rho_(i-1))^2 + w2 e_(i+1) (rho_i / rho_(i+1))^2``: zero mean and
variance ``k_i^2 sigma^2`` with ``k_i^2 = 1 + (w0 rho_i^2 / rho_(i-1)^2)^2 + (w2 rho_i^2 / rho_(i+1)^2)^2``
(1.5 for equal steps and ranges). ``z_i = s_i / k_i`` is the residual in units of range noise.

Corners, jump edges, mixed pixels and round objects give large ``z_i``; they are a few beams
in a scan and the estimate is robust to them: ``sigma_0`` is the normalised median absolute
residual (``1.4826 median |z|``), and the estimate the RMS of the residuals within
``3.5 sigma_0``, corrected for that cut (twice, each round cutting at the newer estimate).

Bias and spread (``benchmarks/noise.py``, ``tests/test_noise.py``; the simulator at known sigma,
50 scans per row): on walls, corners and jump edges the mean is within 5 % of the true sigma
from 2 mm to 5 cm for every preset and world, and one scan's estimate spreads by about
``1 / sqrt(n)`` of its ``n`` residuals (5 % at 361 beams, 7-11 % for the XV-11's 160-300). Round
objects bend the residuals of the beams on them: in the ``hall`` world, where columns, bench
feet and legs fill a fifth of the beams, the estimate is 12-22 % high at 2 mm and up to 10 %
at 5 mm (with those beams removed, 1-2 %). Real sensors add what the model leaves out:
quantisation (the Radish CARMEN logs store whole centimetres: ``1 cm / sqrt(12) = 2.9 mm``;
at fine steps without other noise, equal neighbouring readings make the estimate fall below
that; in aces and infinite-corridor four in five ranges end in 1 or 4 modulo 5 cm, a coarser
grid), range-dependent noise, and surfaces that are not flat at the scale of a beam's
spacing: the Radish logs estimate 6 (intel) to 28 mm (aces). The estimate is then the
effective noise of the data, not the sensor's specification.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from ._jit import ENABLED as _JIT
from ._validate import check_nonneg, check_positive
from .params import AUTO
from .scan import Scan


def _engine_sigma(ranges, angles, valid, full_circle):
    """:func:`_robust_sigma` of :func:`range_noise_residuals` by labkit._noise_engine.robust_sigma, bit for
    bit; imported on the first scan (numba's import alone costs some 0.35 s of CPU, which a process that
    extracts nothing should not pay)."""
    from ._noise_engine import robust_sigma

    return robust_sigma(ranges, angles, valid, full_circle, MIN_RESIDUALS, _MAD_TO_SIGMA, _CUT, _CUT_SD)

__all__ = ["range_noise_residuals", "estimate_range_noise", "scan_sigma", "noise_sigma", "auto_split_threshold",
           "chi2_upper_over_dof", "noise_config", "MIN_RESIDUALS", "AUTO_LINES", "AUTO_RANSAC", "AUTO_HOUGH",
           "AUTO_INCREMENTAL", "AUTO_ANGULAR", "AUTO_CONFIG", "FIXED_LINES", "FIXED_RANSAC", "FIXED_HOUGH",
           "FIXED_INCREMENTAL", "FIXED_ANGULAR", "FIXED_CONFIG", "FIXED", "RANGE_SIGMA_M",
           "MIN_SIGMA_M", "SPLIT_SIGMAS", "MIN_SPLIT_M", "INLIER_SIGMAS", "GROW_SIGMAS"]

#: Fewest usable residuals (beams with two valid neighbours) for an estimate; with fewer,
#: :func:`estimate_range_noise` returns NaN.
MIN_RESIDUALS = 10

#: Range noise of the sensor, metres (an LMS200's 5 mm, doubled), that ``"auto"`` assumes for a
#: scan too small to estimate it (fewer than :data:`MIN_RESIDUALS` usable beams), and the fixed
#: settings' (:data:`FIXED_CONFIG`, the defaults before ``"auto"``).
RANGE_SIGMA_M = 0.01

_MAD_TO_SIGMA = 1.482602218505602  # 1 / Phi^-1(3/4)
_CUT = 3.5  # residuals within this many sigmas are inliers
# the standard deviation of a standard normal cut at +-_CUT: sqrt(1 - 2 c phi(c) / (2 Phi(c) - 1))
_CUT_SD = math.sqrt(1.0 - 2.0 * _CUT * math.exp(-_CUT * _CUT / 2) / math.sqrt(2 * math.pi)
                    / math.erf(_CUT / math.sqrt(2)))


def range_noise_residuals(scan: Scan) -> np.ndarray:
    """The residual ``z_i`` of every beam with two valid neighbours, in metres of range noise.

    It is zero on any straight wall and has standard deviation sigma under Gaussian range noise
    (see the module docstring). Beams in scan order; on a full-circle scan the first and last beam are neighbours.

    Parameters
    ----------
    scan : Scan
        The laser scan.

    Returns
    -------
    ndarray of shape (M,)
        The residual of every beam with two valid neighbours, in scan order, metres.

    Examples
    --------
    A wall at x = 2 m, noise-free: every residual is 0.

    >>> theta = np.radians(np.arange(-40.0, 40.5, 0.5))
    >>> z = range_noise_residuals(Scan(ranges=2.0 / np.cos(theta), angles=theta))
    >>> len(z), bool(np.abs(z).max() < 1e-12)
    (159, True)
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    r, t, ok = scan.ranges, scan.angles, scan.valid
    if scan.is_full_circle and len(r) >= 3:
        r = np.concatenate([r[-1:], r, r[:1]])
        t = np.concatenate([t[-1:] - 2 * np.pi, t, t[:1] + 2 * np.pi])
        ok = np.concatenate([ok[-1:], ok, ok[:1]])
    if len(r) < 3:
        return np.empty(0)
    use = ok[:-2] & ok[1:-1] & ok[2:]
    if not use.all():
        keep = use.nonzero()[0]
        r0, r1, r2 = r.take(keep), r.take(keep + 1), r.take(keep + 2)
        t0, t1, t2 = t.take(keep), t.take(keep + 1), t.take(keep + 2)
    else:
        r0, r1, r2, t0, t1, t2 = r[:-2], r[1:-1], r[2:], t[:-2], t[1:-1], t[2:]
    dt = t[1:] - t[:-1]
    if len(dt) and dt.max() - dt.min() <= 1e-9 * dt.max():  # equal steps (the usual scan): one weight
        w0 = w2 = 0.5 / math.cos(float(dt.mean()))
    else:
        s02 = np.sin(t2 - t0)
        w0, w2 = np.sin(t2 - t1) / s02, np.sin(t1 - t0) / s02
    g0, g2 = r1 / r0, r1 / r2
    s = r1 * (1.0 - w0 * g0 - w2 * g2)  # = r1^2 (1 / r1 - w0 / r0 - w2 / r2)
    q0, q2 = w0 * g0 * g0, w2 * g2 * g2  # the neighbours' errors' weights in s
    return s / np.sqrt(1.0 + q0 * q0 + q2 * q2)


def _robust_sigma(z: np.ndarray) -> float:
    n = len(z)
    if n < MIN_RESIDUALS:
        return math.nan
    a = np.abs(z)
    sigma = _MAD_TO_SIGMA * float(np.partition(a, n // 2)[n // 2])  # the median (the upper one of an even count)
    for _ in range(2):
        inl = a[a <= _CUT * sigma]
        if len(inl) < MIN_RESIDUALS or sigma == 0.0:
            break
        sigma = math.sqrt(float(np.dot(inl, inl)) / len(inl)) / _CUT_SD
    return sigma


def estimate_range_noise(scans: Scan | Iterable[Scan]) -> float:
    """The standard deviation of the range noise, metres, estimated from one scan or many.

    Many scans (a recording: any iterable of scans) pool their residuals.

    Each beam with two valid neighbours gives a residual that is exactly zero on a straight
    wall at any incidence (:func:`range_noise_residuals`); the estimate is a robust standard
    deviation of those, so corners, jump edges and round objects, a few beams each, barely
    move it. NaN when fewer than :data:`MIN_RESIDUALS` beams have two valid neighbours.

    Parameters
    ----------
    scans : Scan or iterable of Scan
        One scan, or many whose residuals are pooled (a recording).

    Returns
    -------
    float
        The estimated standard deviation of the range noise, metres; NaN when too few beams have two
        valid neighbours.

    Examples
    --------
    A wall 3 m away seen with 1 cm of range noise:

    >>> rng = np.random.default_rng(0)
    >>> theta = np.radians(np.arange(-60.0, 60.25, 0.25))
    >>> ranges = 3.0 / np.cos(theta) + rng.normal(0.0, 0.01, theta.size)
    >>> round(estimate_range_noise(Scan(ranges=ranges, angles=theta)), 3)
    0.01
    """
    if isinstance(scans, Scan):
        if not _JIT:
            return _robust_sigma(range_noise_residuals(scans))
        # the residuals and the start of their robust sigma in one compiled pass, bit for bit
        return _engine_sigma(scans.ranges, scans.angles, scans.valid, scans.is_full_circle)
    if isinstance(scans, (str, bytes)) or not isinstance(scans, Iterable):
        raise ValueError(f"scans must be a labkit.Scan or an iterable of them, got {type(scans).__name__}")
    parts = [range_noise_residuals(s) for s in scans]
    return _robust_sigma(np.concatenate(parts) if parts else np.empty(0))


# ----------------------------------------------------------------------------- "auto" thresholds
#: The least range noise ``"auto"`` assumes, metres: a noise-free (simulated) scan estimates 0,
#: and no real surface is flat to better than this.
MIN_SIGMA_M = 0.002
#: ``split_threshold_m="auto"`` is this many sigmas (across the line: ``sigma |cos(incidence)|``,
#: :func:`labkit.split_and_merge`): the largest of 722 Gaussian residuals
#: passes 4.0 sigma once in 20 scans (722 * 2 (1 - Phi(4.0)) = 0.05), and a residual measured
#: from the chord of two noisy end points has up to 1.5 times the variance (sqrt(1.5) * 4.0 = 4.9).
SPLIT_SIGMAS = 5.0
#: The least ``split_threshold_m="auto"`` gives, metres: walls are not flat to a centimetre,
#: and a split below that would follow the plaster.
MIN_SPLIT_M = 0.02
#: ``threshold_m="auto"`` of RANSAC and the Hough transform is this many sigmas (at least
#: :data:`MIN_SPLIT_M`): an inlier band, not a test every point of a wall must pass -- a wall point
#: outside it is only left out of the line -- so it needs to hold most of a wall's points (98.8 %
#: at 2.5 sigma), and a wider band takes the next wall's first points past a corner and tilts the
#: line. On the 408 simulated scans of ``labkit.app.experiments.nguyen_set`` at 2 cm of noise, RANSAC
#: with 2.5 / 3 / 4 / 5 sigma finds 0.84 / 0.80 / 0.78 / 0.74 of the walls with 0.06 / 0.09 / 0.11 /
#: 0.14 false lines (the Hough transform 0.85 / 0.83 / 0.80 / 0.77 and 0.05 / 0.06 / 0.10 / 0.12).
INLIER_SIGMAS = 2.5
#: ``max_error_m="auto"`` of incremental line extraction is this many sigmas (at least
#: :data:`MIN_SPLIT_M`): as :data:`SPLIT_SIGMAS`, the largest of 722 Gaussian residuals passes 4.0
#: sigma once in 20 scans, but each point is measured from the line refitted with it, not from a
#: chord of two noisy end points, so without the chord's factor sqrt(1.5). Measured as above:
#: 3 / 4 / 5 sigma find 0.86 / 0.84 / 0.82 of the walls with 0.10 / 0.07 / 0.10 false lines.
GROW_SIGMAS = 4.0


#: The noise-following settings below are every record's defaults (issue 16): ``Config()`` is
#: ``Config().updated(AUTO_CONFIG)``, ``split_and_merge(scan)`` is ``split_and_merge(scan,
#: **AUTO_LINES)``. They are kept as names so code that asks for them says so. The fixed
#: thresholds the papers give, the defaults before, are :data:`FIXED_CONFIG` and its parts.
#:
#: Split-and-merge's (``[lines]``; its default segmentation follows the same noise).
AUTO_LINES = {"split_threshold_m": "auto", "range_sigma_m": "auto", "place_confidence": 0.8}

#: RANSAC's (``[lines.ransac]``): inliers within ``max(2.5 sigma, 2 cm)`` of a line
#: (:data:`INLIER_SIGMAS`), and only the lines the data can place, as :data:`AUTO_LINES`
#: (:func:`labkit.lines.ransac.ransac_lines`).
AUTO_RANSAC = {"threshold_m": "auto", "range_sigma_m": "auto", "place_confidence": 0.8}

#: The Hough transform's (``[lines.hough]``), as :data:`AUTO_RANSAC` (:func:`labkit.lines.hough.hough_lines`).
AUTO_HOUGH = {"threshold_m": "auto", "range_sigma_m": "auto", "place_confidence": 0.8}

#: Incremental line extraction's (``[lines.incremental]``): a point joins a line while within
#: ``max(4 sigma, 2 cm)`` of the line refitted with it (:data:`GROW_SIGMAS`), and only the lines
#: the data can place are reported (:func:`labkit.lines.incremental.incremental_lines`).
AUTO_INCREMENTAL = {"max_error_m": "auto", "range_sigma_m": "auto", "place_confidence": 0.8}

#: Angular segmentation's (``[lines.angular]``): local directions over as many beams as the noise
#: needs, and only where those beams are straight (:func:`labkit.angular_segmentation`).
AUTO_ANGULAR = {"direction_window": "auto", "range_sigma_m": "auto"}


def _pipeline(segmentation, lines, angular, incremental, ransac, hough, shapes) -> dict:
    """One setting of every noise-dependent key of a :class:`labkit.Config`."""
    return {"segmentation.range_sigma_m": segmentation, **{f"lines.{k}": v for k, v in lines.items()},
            **{f"lines.{method}.{k}": v for method, setting in (
                ("angular", angular), ("incremental", incremental), ("ransac", ransac), ("hough", hough))
               for k, v in setting.items()},
            "circles.range_sigma_m": shapes, "legs.range_sigma_m": shapes}


#: The whole pipeline's noise-following setting, the default of :class:`labkit.Config`:
#: segmentation, the line extractor ``lines.method`` names (split-and-merge: :data:`AUTO_LINES`;
#: angular segmentation, incremental, RANSAC, Hough: :data:`AUTO_ANGULAR`,
#: :data:`AUTO_INCREMENTAL`, :data:`AUTO_RANSAC`, :data:`AUTO_HOUGH`), and the noise allowances of
#: the IAV circle and leg tests (``range_sigma_m``, :func:`labkit.detect_circles`).
AUTO_CONFIG = _pipeline(AUTO, AUTO_LINES, AUTO_ANGULAR, AUTO_INCREMENTAL, AUTO_RANSAC, AUTO_HOUGH, AUTO)

#: Split-and-merge with the fixed thresholds of the papers, its defaults before ``"auto"``: a
#: 5 cm split threshold, 1 cm of range noise for the breakpoints and covariances, every line
#: reported. ``split_and_merge(scan, **FIXED_LINES)``.
FIXED_LINES = {"split_threshold_m": 0.05, "range_sigma_m": RANGE_SIGMA_M, "place_confidence": 0.0}
#: RANSAC and the Hough transform with a fixed 3 cm inlier band, every line reported.
FIXED_RANSAC = {"threshold_m": 0.03, "range_sigma_m": None, "place_confidence": 0.0}
FIXED_HOUGH = dict(FIXED_RANSAC)
#: Incremental extraction growing within a fixed 5 cm, every line reported.
FIXED_INCREMENTAL = {"max_error_m": 0.05, "range_sigma_m": None, "place_confidence": 0.0}
#: Angular segmentation as the paper has it: three-beam directions, no straightness test.
FIXED_ANGULAR = {"direction_window": 1, "range_sigma_m": 0.0}
#: The whole pipeline with the papers' fixed thresholds, its defaults before ``"auto"``:
#: ``Config().updated(FIXED_CONFIG)``, or ``--range-noise fixed`` on the command line; the IAV
#: circle and leg tests without a noise allowance (the paper's).
FIXED_CONFIG = _pipeline(RANGE_SIGMA_M, FIXED_LINES, FIXED_ANGULAR, FIXED_INCREMENTAL, FIXED_RANSAC, FIXED_HOUGH,
                         0.0)

#: ``--range-noise``'s value for :data:`FIXED_CONFIG`.
FIXED = "fixed"


def noise_config(range_sigma_m: float | str = AUTO) -> dict:
    """The changes to a :class:`labkit.Config` that set how every stage follows the range noise.

    ``labkit extract|view|bench|config --range-noise`` applies it.

    Parameters
    ----------
    range_sigma_m : float or str
        ``"auto"``: :data:`AUTO_CONFIG` (the noise estimated from each scan, the defaults); a
        number of metres (> 0; a datasheet's, or :func:`estimate_range_noise` over a recording):
        the same thresholds derived from that noise, every ``range_sigma_m`` of the config set to
        it; ``"fixed"``: :data:`FIXED_CONFIG` (the papers' fixed thresholds).

    Returns
    -------
    dict
        Dotted config keys (``"lines.range_sigma_m"``) -> values, for :meth:`labkit.Config.updated`.

    Examples
    --------
    >>> noise_config(0.03)["lines.range_sigma_m"], noise_config(0.03)["lines.split_threshold_m"]
    (0.03, 'auto')
    """
    if range_sigma_m == AUTO:
        return dict(AUTO_CONFIG)
    if range_sigma_m == FIXED:
        return dict(FIXED_CONFIG)
    sigma = check_positive("range_sigma_m", range_sigma_m)
    return {k: sigma if k.endswith("range_sigma_m") else v for k, v in AUTO_CONFIG.items()}


def scan_sigma(scan: Scan) -> float:
    """The range noise ``"auto"`` uses for ``scan``, metres.

    The range noise ``"auto"`` uses for ``scan``, metres: :func:`estimate_range_noise`, at least
    :data:`MIN_SIGMA_M`, :data:`RANGE_SIGMA_M` when the scan is too small to tell. Worked out once
    per scan (every detector of a pipeline asks for it).

    Parameters
    ----------
    scan : Scan
        The laser scan.

    Returns
    -------
    float
        The range noise, metres.
    """
    cached = scan.__dict__.get("_labkit_sigma")
    if cached is None:
        sigma = estimate_range_noise(scan)
        cached = RANGE_SIGMA_M if not math.isfinite(sigma) else max(sigma, MIN_SIGMA_M)
        scan.__dict__["_labkit_sigma"] = cached  # (a frozen dataclass's cache, as its cached_property's)
    return cached


def noise_sigma(scan: Scan, range_sigma_m) -> float:
    """The range noise a detector allows for, metres.

    The range noise a detector allows for, metres: ``range_sigma_m`` as given (>= 0), or
    :func:`scan_sigma` of ``scan`` when it is ``"auto"``.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    range_sigma_m : float or "auto"
        A noise in metres (>= 0), or ``"auto"``.

    Returns
    -------
    float
        The range noise, metres.
    """
    if range_sigma_m == AUTO:
        return scan_sigma(scan)
    return check_nonneg("range_sigma_m", range_sigma_m)


def chi2_upper_over_dof(dof, z: float):
    """About the upper quantile of ``chi2(dof) / dof`` that a standard normal reaches at ``z``.

    (Wilson-Hilferty; ``dof`` may be an array and need not be whole). At z = 3 (one in 741) it
    is 10.53 for 1 degree of freedom (exactly 10.27), 4.00 for 5 (3.96) and 2.46 for 15 (2.45).

    Parameters
    ----------
    dof : float or ndarray
        Degrees of freedom.
    z : float
        The standard normal quantile.

    Returns
    -------
    float or ndarray
        The quantile of ``chi2(dof) / dof``, for each ``dof``.

    Examples
    --------
    >>> round(float(chi2_upper_over_dof(15, 3.0)), 2)
    2.46
    """
    if isinstance(dof, (int, float)):  # one value (the split loop's hot path): plain floats
        k = 2.0 / (9.0 * dof)
        return max(1.0 - k + z * math.sqrt(k), 0.0) ** 3
    ks = 2.0 / (9.0 * np.asarray(dof, dtype=float))
    return np.maximum(1.0 - ks + z * np.sqrt(ks), 0.0) ** 3


def auto_split_threshold(sigma: float, sigmas: float = SPLIT_SIGMAS) -> float:
    """The ``split_threshold_m="auto"`` for range noise ``sigma``, at a point seen head-on.

    ``split_threshold_m="auto"`` for range noise ``sigma`` at a point seen head-on: ``max(5 sigma, 2
    cm)``. At incidence ``i`` a point's threshold is ``max(5 sigma cos(i), 2 cm)``
    (:func:`labkit.split_and_merge`), and this is what the trace and the merge report. ``sigmas``:
    the multiple other extractors' ``"auto"`` uses instead (:data:`INLIER_SIGMAS`,
    :data:`GROW_SIGMAS`).

    Parameters
    ----------
    sigma : float
        The range noise, metres.
    sigmas : float, default 5.0
        The multiple of ``sigma``.

    Returns
    -------
    float
        The threshold, metres.
    """
    return max(sigmas * sigma, MIN_SPLIT_M)
