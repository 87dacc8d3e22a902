"""Line and circle fits against closed-form geometry, scipy's optimiser and Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from labkit.fitting import fit_circle, fit_circles, fit_line_ols, fit_line_polar, fit_line_tls
from labkit.geometry import angle_difference, normalize_line, rotation_matrix


def wall_beams(r: float, alpha: float, half_width: float = 0.5, n: int = 40):
    """Ranges and bearings of beams hitting the line (r, alpha) around its foot point."""
    theta = alpha + np.linspace(-half_width, half_width, n)
    return r / np.cos(theta - alpha), theta


def assert_same_line(fit, r, alpha, tol=1e-9):
    assert fit.r == pytest.approx(r, abs=tol)
    assert abs(float(angle_difference(fit.alpha, alpha))) < tol


# ---------------------------------------------------------------------------- exact recovery
@pytest.mark.parametrize("alpha_deg", [-179.0, -135.0, -90.0, -45.0, -1.0, 0.0, 30.0, 90.0, 135.0, 180.0])
@pytest.mark.parametrize("r", [0.05, 1.0, 7.5])
def test_noiseless_lines_are_recovered_in_every_quadrant(alpha_deg, r):
    alpha = math.radians(alpha_deg)
    rho, theta = wall_beams(r, alpha)
    assert_same_line(fit_line_polar(rho, theta), r, alpha)
    pts = np.c_[rho * np.cos(theta), rho * np.sin(theta)]
    assert_same_line(fit_line_tls(pts), r, alpha)
    assert fit_line_polar(rho, theta).rms < 1e-9


def test_line_through_the_origin_has_r_zero_and_a_wrapped_alpha():
    pts = np.c_[np.linspace(-1, 1, 11), np.linspace(-1, 1, 11)]  # y = x, through the origin
    fit = fit_line_tls(pts)
    assert fit.r == pytest.approx(0.0, abs=1e-12)
    assert abs(abs(fit.alpha) - 3 * math.pi / 4) < 1e-9  # normal +-(-1, 1)/sqrt 2
    assert -math.pi < fit.alpha <= math.pi


@settings(max_examples=60)
@given(r=st.floats(0.2, 20.0), alpha=st.floats(-math.pi, math.pi), seed=st.integers(0, 2**32 - 1))
def test_r_is_non_negative_and_alpha_wrapped(r, alpha, seed):
    rng = np.random.default_rng(seed)
    rho, theta = wall_beams(r, alpha, half_width=0.4, n=20)
    fit = fit_line_polar(rho + rng.normal(0, 0.01, rho.size), theta, range_sigma=0.01)
    assert fit.r >= 0 and -math.pi < fit.alpha <= math.pi
    # within 6 standard deviations of the fit's own covariance (a 1e-9 chance per draw)
    assert abs(fit.r - r) < 6 * math.sqrt(fit.covariance[0, 0])
    assert abs(float(angle_difference(fit.alpha, alpha))) < 6 * math.sqrt(fit.covariance[1, 1])


@settings(max_examples=50)
@given(phi=st.floats(-math.pi, math.pi), tx=st.floats(-5, 5), ty=st.floats(-5, 5),
       seed=st.integers(0, 2**32 - 1))
def test_fits_are_invariant_under_rotation_and_translation(phi, tx, ty, seed):
    rng = np.random.default_rng(seed)
    pts = np.c_[rng.uniform(1, 4, 30), rng.uniform(-2, 2, 30)]
    pts[:, 0] = 3.0 + 0.1 * pts[:, 1] + rng.normal(0, 0.02, 30)  # a noisy wall near x = 3
    rot = rotation_matrix(phi)
    moved = pts @ rot.T + [tx, ty]

    # orthogonal regression: any rigid motion moves the line with the points. The line
    # (r, alpha) moved by (phi, t) is (r + t . n', alpha + phi) with n' the turned normal.
    a, b = fit_line_tls(pts), fit_line_tls(moved)
    alpha = a.alpha + phi
    want_r, want_alpha = normalize_line(a.r + tx * math.cos(alpha) + ty * math.sin(alpha), alpha)
    # the foot points r n agree, and the directions agree modulo pi (through the origin,
    # r = 0, either normal describes the line)
    np.testing.assert_allclose(b.r * np.array([math.cos(b.alpha), math.sin(b.alpha)]),
                               want_r * np.array([math.cos(want_alpha), math.sin(want_alpha)]), atol=1e-7)
    assert abs(math.sin(b.alpha - want_alpha)) < 1e-7

    # the 1/rho-weighted polar fit depends on the origin, so only rotation about it is free
    rho, theta = np.hypot(*pts.T), np.arctan2(pts[:, 1], pts[:, 0])
    p, q = fit_line_polar(rho, theta), fit_line_polar(rho, theta + phi)
    assert q.r == pytest.approx(p.r, abs=1e-9)
    assert abs(float(angle_difference(q.alpha, p.alpha + phi))) < 1e-9


# ---------------------------------------------------------------------------- optimality
@pytest.mark.parametrize("seed", range(5))
def test_closed_form_minimises_the_weighted_sum(seed):
    rng = np.random.default_rng(seed)
    r0, a0 = rng.uniform(0.5, 6), rng.uniform(-math.pi, math.pi)
    rho, theta = wall_beams(r0, a0, half_width=0.6, n=50)
    rho = rho + rng.normal(0, 0.05, rho.size)
    w = 1 / rho

    def cost(p):
        return float(np.sum(w * (rho * np.cos(theta - p[1]) - p[0]) ** 2))

    fit = fit_line_polar(rho, theta)
    best = min((minimize(cost, [fit.r + dr, fit.alpha + da], method="Nelder-Mead",
                         options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 5000})
                for dr, da in [(0.3, 0.2), (-0.2, -0.3), (0.0, 0.0)]), key=lambda res: res.fun)
    assert cost([fit.r, fit.alpha]) <= best.fun * (1 + 1e-9) + 1e-15
    assert abs(best.x[0] - fit.r) < 1e-5


def test_custom_and_uniform_weights():
    rng = np.random.default_rng(3)
    rho, theta = wall_beams(2.0, 0.3, n=30)
    rho = rho + rng.normal(0, 0.01, rho.size)
    uniform = fit_line_polar(rho, theta, "uniform")
    tls = fit_line_tls(np.c_[rho * np.cos(theta), rho * np.sin(theta)])
    assert uniform.r == pytest.approx(tls.r, abs=1e-12) and uniform.alpha == pytest.approx(tls.alpha, abs=1e-12)
    same = fit_line_polar(rho, theta, np.ones_like(rho))
    assert same.r == pytest.approx(uniform.r, abs=1e-12)


# ---------------------------------------------------------------------------- covariance
@pytest.mark.parametrize("r0, alpha_deg", [(3.0, 40.0), (1.5, -120.0)])
def test_covariance_matches_monte_carlo_within_10_percent(r0, alpha_deg):
    rng = np.random.default_rng(7)
    a0 = math.radians(alpha_deg)
    rho0, theta = wall_beams(r0, a0, half_width=0.6, n=60)
    sigma = 0.01
    fits = [fit_line_polar(rho0 + rng.normal(0, sigma, rho0.size), theta, range_sigma=sigma) for _ in range(3000)]
    samples = np.array([[f.r, f.alpha] for f in fits])
    mc = np.cov(samples.T)
    model = fits[0].covariance
    assert np.allclose(np.diag(model), np.diag(mc), rtol=0.10)
    # the residual-based estimate (no noise model given) is right on average too
    est = np.mean([fit_line_polar(rho0 + rng.normal(0, sigma, rho0.size), theta).covariance for _ in range(500)],
                  axis=0)
    assert np.allclose(np.diag(est), np.diag(mc), rtol=0.10)


def test_inverse_variance_weights_need_sigma():
    rho, theta = wall_beams(2.0, 0.0)
    with pytest.raises(ValueError, match="range_sigma"):
        fit_line_polar(rho, theta, "inverse_variance")
    sig = 0.005 * rho
    fit = fit_line_polar(rho, theta, "inverse_variance", range_sigma=sig)
    assert_same_line(fit, 2.0, 0.0)


# ---------------------------------------------------------------------------- OLS vs TLS
def test_ols_fails_on_a_vertical_wall_and_tls_does_not():
    pts = np.c_[np.full(10, 2.0), np.linspace(-1, 1, 10)]
    with pytest.raises(ValueError, match="vertical"):
        fit_line_ols(pts)
    assert_same_line(fit_line_tls(pts), 2.0, 0.0)


def test_ols_differs_from_tls_on_a_steep_noisy_wall():
    rng = np.random.default_rng(0)
    y = np.linspace(-2, 2, 40)
    pts = np.c_[1.0 + 0.2 * y + rng.normal(0, 0.05, 40), y]  # steep wall, noise in x
    ols, tls = fit_line_ols(pts), fit_line_tls(pts)
    true_alpha = math.atan2(-0.2, 1.0)
    assert abs(float(angle_difference(tls.alpha, true_alpha))) < abs(float(angle_difference(ols.alpha, true_alpha)))
    assert tls.rms <= ols.rms + 1e-12  # TLS minimises exactly the orthogonal RMS


# ---------------------------------------------------------------------------- invalid and degenerate
def test_invalid_beams_are_left_out():
    rho, theta = wall_beams(2.0, 0.5, n=20)
    dirty = rho.copy()
    dirty[[0, 5, 7]] = [np.nan, np.inf, 0.0]
    fit = fit_line_polar(dirty, theta)
    assert fit.n_points == 17
    assert_same_line(fit, 2.0, 0.5)


@pytest.mark.parametrize("rho, theta, match", [
    ([1.0], [0.0], "at least 2"),
    ([np.nan, 1.0], [0.0, 0.1], "at least 2"),
    ([1.0, 1.0, 1.0], [0.2, 0.2, 0.2], "identical"),
])
def test_degenerate_lines_raise_one_clear_error(rho, theta, match):
    with pytest.raises(ValueError, match=match):
        fit_line_polar(np.array(rho), np.array(theta))


@pytest.mark.parametrize("points, match", [
    (np.zeros((0, 2)), "at least 2"),
    (np.ones((3, 2)), "identical"),
    (np.ones((3, 3)), "shape"),
    ([[0.0, np.nan], [1.0, 1.0]], "finite"),
])
def test_tls_rejects_bad_points(points, match):
    with pytest.raises(ValueError, match=match):
        fit_line_tls(points)


def test_mismatched_shapes_are_named():
    with pytest.raises(ValueError, match="rho and theta"):
        fit_line_polar([1.0, 2.0], [0.0])


def test_two_points_give_the_line_through_them_and_nan_covariance():
    fit = fit_line_polar(np.array([2.0, 2.0 / math.cos(0.3)]), np.array([0.0, 0.3]))
    assert_same_line(fit, 2.0, 0.0)
    assert np.all(np.isnan(fit.covariance))


# ---------------------------------------------------------------------------- circles
@pytest.mark.parametrize("method", ["algebraic", "geometric"])
@pytest.mark.parametrize("span", [math.pi / 3, math.pi, 2 * math.pi])
def test_noiseless_circles_are_recovered(method, span):
    t = np.linspace(0.2, 0.2 + span, 12, endpoint=span < 2 * math.pi)
    pts = np.c_[3.0 + 0.4 * np.cos(t), -1.0 + 0.4 * np.sin(t)]
    fit = fit_circle(pts, method)
    assert np.allclose(fit.center, [3.0, -1.0], atol=1e-9) and fit.radius == pytest.approx(0.4, abs=1e-9)


def test_geometric_fit_beats_algebraic_on_short_noisy_arcs():
    rng = np.random.default_rng(11)
    err = {"algebraic": [], "geometric": []}
    for _ in range(200):
        t = np.linspace(-0.6, 0.6, 15)
        pts = np.c_[2.0 + 0.3 * np.cos(t), 0.3 * np.sin(t)] + rng.normal(0, 0.01, (15, 2))
        for method in err:
            err[method].append(abs(fit_circle(pts, method).radius - 0.3))
    # Kasa's fit shrinks the radius of short arcs; the orthogonal fit has no such bias
    assert np.mean(err["geometric"]) < 0.8 * np.mean(err["algebraic"])


def test_geometric_fit_minimises_orthogonal_distances():
    rng = np.random.default_rng(5)
    t = np.linspace(0, 2, 20)
    pts = np.c_[np.cos(t), np.sin(t)] * 0.5 + rng.normal(0, 0.02, (20, 2))
    fit = fit_circle(pts, "geometric")

    def cost(p):
        return float(np.sum((np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1]) - p[2]) ** 2))

    res = minimize(cost, [*fit.center, fit.radius], method="Nelder-Mead",
                   options={"xatol": 1e-12, "fatol": 1e-16, "maxiter": 5000})
    assert cost([*fit.center, fit.radius]) <= res.fun * (1 + 1e-7) + 1e-15


def test_many_circles_at_once_are_each_runs_own_minimum():
    # fit_circles on runs laid back to back: each run's circle minimises its own orthogonal
    # distances (Nelder-Mead as the referee), noiseless arcs give their circles exactly, and a
    # run with no finite circle is marked without spoiling the others
    rng = np.random.default_rng(8)
    runs, truth = [], []
    for k in range(12):
        c, radius = rng.uniform(-5, 5, 2), rng.uniform(0.05, 2.0)
        t = np.sort(rng.uniform(0, rng.uniform(0.5, 6.0), int(rng.integers(4, 40))))
        pts = np.c_[c[0] + radius * np.cos(t), c[1] + radius * np.sin(t)]
        noisy = k % 2 == 1
        runs.append(pts + (rng.normal(0, 0.01, pts.shape) if noisy else 0.0))
        truth.append(None if noisy else (c, radius))
    runs.insert(5, np.c_[np.arange(6.0), 0.5 * np.arange(6.0) - 1.0])  # collinear
    truth.insert(5, "collinear")
    sizes = np.array([len(r) for r in runs])
    ends = np.cumsum(sizes)
    fits = fit_circles(np.concatenate(runs), ends - sizes, ends, "geometric")
    for k, (pts, true) in enumerate(zip(runs, truth, strict=True)):
        if true == "collinear":
            assert fits.status[k] == 2 and np.isnan(fits.radii[k])
            continue
        assert fits.status[k] == 0
        centre, radius = fits.centers[k], fits.radii[k]
        if true is not None:
            assert np.allclose(centre, true[0], atol=1e-8) and radius == pytest.approx(true[1], abs=1e-8)

        def cost(q, pts=pts):
            return float(np.sum((np.hypot(pts[:, 0] - q[0], pts[:, 1] - q[1]) - q[2]) ** 2))

        best = minimize(cost, [*centre, radius], method="Nelder-Mead",
                        options={"xatol": 1e-12, "fatol": 1e-16, "maxiter": 5000}).fun
        assert cost([*centre, radius]) <= best * (1 + 1e-7) + 1e-15
        assert fits.rms[k] == pytest.approx(math.sqrt(cost([*centre, radius]) / len(pts)), rel=1e-9)


@pytest.mark.parametrize("points, match", [
    (np.zeros((2, 2)), "at least 3"),
    (np.ones((4, 2)), "identical"),
    (np.c_[np.arange(5.0), 2 * np.arange(5.0)], "collinear"),
])
def test_degenerate_circles_raise_one_clear_error(points, match):
    with pytest.raises(ValueError, match=match):
        fit_circle(points)


def test_unknown_circle_method_is_named():
    with pytest.raises(ValueError, match="method"):
        fit_circle(np.eye(3)[:, :2], "magic")
