"""Hidden tests of exercise 12, ``predict(x, P, dt, q)``, ``update(x, P, z, R)`` and
``gate(x, P, z, R, probability=0.99)``: one step of a constant-velocity Kalman filter, and its gate.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.

Two references for every answer: labkit (``labkit.tracking.cv_predict``, ``kalman_update``,
``innovation``, ``mahalanobis2``, ``gate_threshold``) and closed forms built here: the process
noise as the integral of the white acceleration over the interval (``Q = q * integral_0^dt g(s)
g(s)' ds`` with ``g(s) = (s, 1)`` per axis, by Simpson's rule, exact for this quadratic), the
update in information form (``P+ = (P^-1 + H' R^-1 H)^-1``, ``x+ = P+ (P^-1 x + H' R^-1 z)``),
the distance by ``numpy.linalg.solve`` and the chi-square quantile by ``scipy.stats.chi2``. The two
must agree before a student's answer is compared.
"""

import numpy as np
from scipy.stats import chi2

import labkit.tracking as lt

H = np.hstack([np.eye(2), np.zeros((2, 2))])


# ---------------------------------------------------------------------------- references
def q_by_integral(dt, q):
    """The process noise as the integral of g(s) g(s)' (g = (s, 1) per axis), Simpson's rule (exact)."""
    def g(s):
        return np.array([[s, 0.0], [0.0, s], [1.0, 0.0], [0.0, 1.0]])

    a, m, b = g(dt), g(dt / 2), g(0.0)
    return q * dt / 6 * (a @ a.T + 4 * m @ m.T + b @ b.T)


def reference_predict(x, P, dt, q):
    want_x, want_P = lt.cv_predict(x, P, dt, q)
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    closed_x, closed_P = F @ np.asarray(x, float), F @ np.asarray(P, float) @ F.T + q_by_integral(dt, q)
    assert np.allclose(want_x, closed_x, rtol=1e-12, atol=1e-12), "the two references disagree"
    assert np.allclose(want_P, closed_P, rtol=1e-9, atol=1e-12), "the two references disagree"
    return want_x, want_P


def reference_update(x, P, z, R):
    want_x, want_P = lt.kalman_update(x, P, z, R)
    P = np.asarray(P, float)
    Ri = np.linalg.inv(np.asarray(R, float))
    info = np.linalg.inv(P) + H.T @ Ri @ H
    closed_P = np.linalg.inv(info)
    closed_x = closed_P @ (np.linalg.solve(P, np.asarray(x, float)) + H.T @ Ri @ np.asarray(z, float))
    assert np.allclose(want_P, closed_P, rtol=1e-6, atol=1e-9), "the two references disagree"
    assert np.allclose(want_x, closed_x, rtol=1e-6, atol=1e-7), "the two references disagree"
    return want_x, want_P


def reference_gate(x, P, z, R, probability):
    nu, S = lt.innovation(x, P, z, R)
    d2, _ = lt.mahalanobis2(nu, S)
    threshold = lt.gate_threshold(probability)
    closed = float(nu @ np.linalg.solve(S, nu))
    assert np.isclose(float(d2), closed, rtol=1e-9, atol=1e-12), "the two references disagree"
    assert np.isclose(threshold, chi2.ppf(probability, 2), rtol=1e-9), "the two references disagree"
    return float(d2), bool(d2 <= threshold)


# ---------------------------------------------------------------------------- comparisons
def _array(value, shape, where, what):
    try:
        got = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: {what} must be an array of shape {shape}, got {type(value).__name__}") from None
    assert got.shape == shape, f"{where}: {what} must have shape {shape}, got {got.shape}"
    return got


def _pair(got, where):
    try:
        x, P = got
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: return the pair (x, P)") from None
    return _array(x, (4,), where, "x"), _array(P, (4, 4), where, "P")


def assert_state(got, want, where, hint):
    x, P = _pair(got, where)
    scale = max(1.0, float(np.abs(want[1]).max()))
    assert np.allclose(x, want[0], rtol=1e-7, atol=1e-9), f"{where}: the state x is off. {hint}"
    assert np.allclose(P, want[1], rtol=1e-7, atol=1e-9 * scale), f"{where}: the covariance P is off. {hint}"


def assert_gate(got, want, where):
    try:
        d2, inside = got
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: return the pair (d2, inside)") from None
    assert isinstance(inside, (bool, np.bool_)), f"{where}: inside must be True or False, got {type(inside).__name__}"
    try:
        d2 = float(d2)
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: d2 must be a number, got {type(d2).__name__}") from None
    assert np.isclose(d2, want[0], rtol=1e-8, atol=1e-12), (
        f"{where}: d2 is off. nu' S^-1 nu with nu = z - (x, y) and S = P[:2, :2] + R?")
    assert bool(inside) == want[1], f"{where}: inside is wrong. d2 <= the chi-square quantile of 2 dof at p?"


def assert_raises(call, what):
    try:
        call()
    except ValueError:
        return
    raise AssertionError(f"{what} must raise ValueError")


# ---------------------------------------------------------------------------- random inputs
def random_covariance(rng, n, scale):
    """A random symmetric positive definite n x n matrix, eigenvalues from scale / 30 to scale."""
    Qm, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (Qm * rng.uniform(scale / 30, scale, n)) @ Qm.T


def random_track(rng):
    x = np.array([*rng.uniform(-20.0, 20.0, 2), *rng.uniform(-2.0, 2.0, 2)])
    return x, random_covariance(rng, 4, float(rng.uniform(0.01, 1.0)))


def random_measurement(rng, x, P):
    R = random_covariance(rng, 2, float(rng.uniform(1e-4, 0.05)))
    S = P[:2, :2] + R
    z = x[:2] + np.linalg.cholesky(S) @ rng.normal(size=2) * rng.uniform(0.2, 4.0)
    return z, R


# ---------------------------------------------------------------------------- predict
def test_hidden_random__predict(predict, rng):
    """60 random tracks predicted over random intervals and process noises, against labkit and the integral."""
    for trial in range(60):
        x, P = random_track(rng)
        dt, q = float(rng.uniform(0.001, 2.0)), float(rng.uniform(0.0, 5.0))
        assert_state(predict(x, P, dt, q), reference_predict(x, P, dt, q), f"random track {trial}",
                     "F x and F P F' + Q, Q with dt^3/3, dt^2/2 and dt per axis?")


def test_hidden_edges__predict(predict, rng):
    """dt = 0 (nothing changes), q = 0 (no noise added), lists, integers; negative dt or q, wrong shapes."""
    x, P = random_track(rng)
    q = float(rng.uniform(0.1, 3.0))
    for what, args in [("dt = 0", (x, P, 0.0, q)), ("q = 0", (x, P, float(rng.uniform(0.05, 1.0)), 0.0)),
                       ("lists", (x.tolist(), P.tolist(), float(rng.uniform(0.05, 1.0)), q)),
                       ("integers", (rng.integers(-5, 6, 4).tolist(), (np.eye(4) * int(rng.integers(1, 4))).tolist(),
                                     int(rng.integers(1, 3)), int(rng.integers(1, 3))))]:
        assert_state(predict(*args), reference_predict(*args), f"predict: {what}", "the rule for this case?")
    assert_raises(lambda: predict(x, P, -float(rng.uniform(0.01, 1.0)), q), "a negative dt")
    assert_raises(lambda: predict(x, P, 0.1, -float(rng.uniform(0.01, 1.0))), "a negative q")
    assert_raises(lambda: predict(x[:3], P, 0.1, q), "a state of three numbers")
    assert_raises(lambda: predict(x, P[:3, :3], 0.1, q), "a 3 x 3 covariance")


def test_own_work__predict(predict, rng):
    """Five more tracks: right answers where labkit cannot be imported."""
    for trial in range(5):
        x, P = random_track(rng)
        dt, q = float(rng.uniform(0.01, 1.0)), float(rng.uniform(0.0, 2.0))
        assert_state(predict(x, P, dt, q), reference_predict(x, P, dt, q), f"own-work track {trial}",
                     "F x and F P F' + Q?")


# ---------------------------------------------------------------------------- update
def test_hidden_random__update(update, rng):
    """60 random tracks updated by random measurements with full covariances, against labkit and the
    information form."""
    for trial in range(60):
        x, P = random_track(rng)
        z, R = random_measurement(rng, x, P)
        assert_state(update(x, P, z, R), reference_update(x, P, z, R), f"random update {trial}",
                     "K = P H' S^-1 with S = H P H' + R; x + K (z - H x); (I - K H) P?")


def test_hidden_edges__update(update, rng):
    """A measurement at the prediction (x keeps its place), a very precise and a very vague measurement, lists;
    wrong shapes of z or R (ValueError)."""
    x, P = random_track(rng)
    R = random_covariance(rng, 2, 0.01)
    precise = random_covariance(rng, 2, 1e-8)
    vague = random_covariance(rng, 2, 1e6)
    z = x[:2] + rng.normal(0.0, 0.3, 2)
    for what, args in [("z at the prediction", (x, P, x[:2].copy(), R)), ("a very precise z", (x, P, z, precise)),
                       ("a very vague z", (x, P, z, vague)), ("lists", (x.tolist(), P.tolist(), z.tolist(),
                                                                       R.tolist()))]:
        assert_state(update(*args), reference_update(*args), f"update: {what}", "the rule for this case?")
    assert_raises(lambda: update(x, P, np.append(z, 1.0), R), "a measurement of three numbers")
    assert_raises(lambda: update(x, P, z, np.eye(3)), "a 3 x 3 measurement covariance")


def test_own_work__update(update, rng):
    """Five more updates: right answers where labkit cannot be imported."""
    for trial in range(5):
        x, P = random_track(rng)
        z, R = random_measurement(rng, x, P)
        assert_state(update(x, P, z, R), reference_update(x, P, z, R), f"own-work update {trial}",
                     "K = P H' S^-1?")


# ---------------------------------------------------------------------------- gate
def test_hidden_random__gate(gate, rng):
    """100 random detections (about half inside) at random gate probabilities, against labkit and
    scipy's chi-square quantile."""
    for trial in range(100):
        x, P = random_track(rng)
        z, R = random_measurement(rng, x, P)
        p = float(rng.choice([0.9, 0.95, 0.99, rng.uniform(0.5, 0.999)]))
        assert_gate(gate(x, P, z, R, p), reference_gate(x, P, z, R, p), f"random detection {trial}")


def test_hidden_edges__gate(gate, rng):
    """A detection exactly on the gate's boundary (inside), just beyond it, at the prediction; the default
    probability; lists; a probability of 0 or 1 or beyond (ValueError)."""
    x, P = random_track(rng)
    R = random_covariance(rng, 2, 0.01)
    S = P[:2, :2] + R
    p = float(rng.uniform(0.8, 0.999))
    direction = rng.normal(size=2)
    unit = direction / np.sqrt(direction @ np.linalg.solve(S, direction))  # d2 of x + unit is 1
    edge = x[:2] + np.sqrt(-2.0 * np.log1p(-p)) * unit * (1 - 1e-12)
    beyond = x[:2] + np.sqrt(-2.0 * np.log1p(-p)) * unit * 1.001
    for what, args in [("on the boundary", (x, P, edge, R, p)), ("just beyond it", (x, P, beyond, R, p)),
                       ("at the prediction", (x, P, x[:2].copy(), R, p)),
                       ("lists", (x.tolist(), P.tolist(), beyond.tolist(), R.tolist(), p))]:
        assert_gate(gate(*args), reference_gate(*args), f"gate: {what}")
    far = x[:2] + 2.9 * unit
    assert_gate(gate(x, P, far, R), reference_gate(x, P, far, R, 0.99), "gate: the default probability (0.99)")
    for bad in (0.0, 1.0, 1.0 + float(rng.uniform(0.01, 1.0)), -float(rng.uniform(0.01, 1.0))):
        assert_raises(lambda bad=bad: gate(x, P, x[:2], R, bad), "a probability outside (0, 1)")


def test_own_work__gate(gate, rng):
    """Ten more detections: right answers where labkit cannot be imported."""
    for trial in range(10):
        x, P = random_track(rng)
        z, R = random_measurement(rng, x, P)
        assert_gate(gate(x, P, z, R, 0.99), reference_gate(x, P, z, R, 0.99), f"own-work detection {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {
    "predict": '''
import labkit.tracking


def predict(x, P, dt, q):
    if dt < 0 or q < 0:
        raise ValueError("dt and q must be >= 0")
    return labkit.tracking.cv_predict(x, P, dt, q)
''',
    "update": '''
import labkit.tracking


def update(x, P, z, R):
    return labkit.tracking.kalman_update(x, P, z, R)
''',
    "gate": '''
import labkit.tracking


def gate(x, P, z, R, probability=0.99):
    nu, S = labkit.tracking.innovation(x, P, z, R)
    d2, _ = labkit.tracking.mahalanobis2(nu, S)
    return float(d2), bool(d2 <= labkit.tracking.gate_threshold(probability))
''',
}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "process noise without the dt^3/3 term": ("a, b, c = dt**3 / 3, dt**2 / 2, dt", "a, b, c = 0.0, dt**2 / 2, dt"),
    "process noise of a random walk in position": ("a, b, c = dt**3 / 3, dt**2 / 2, dt", "a, b, c = dt, 0.0, dt"),
    "covariance not carried through F": ("P = F @ P @ F.T + Q", "P = P + Q"),
    "the innovation covariance without R": ("S = P[:2, :2] + R", "S = P[:2, :2]"),
    "the covariance not reduced by the update": ("P = P - K @ S @ K.T", "P = P"),
    "the gate's distance Euclidean": ("d2 = float(nu @ np.linalg.solve(G, nu))", "d2 = float(nu @ nu)"),
    "the quantile of the wrong tail": ("threshold = -2.0 * np.log1p(-probability)",
                                       "threshold = -2.0 * np.log(probability)"),
    "the boundary outside the gate": ("inside = d2 <= threshold", "inside = d2 < threshold * (1 - 1e-9)"),
}
