"""Hidden tests of exercise 3, ``line_covariance(rho, theta, sigma)`` -> the 2 x 2 covariance of ``(r, alpha)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit

RTOL = 1e-4


def assert_covariance(result, expected, where):
    """``result`` is a (2, 2) array within RTOL of ``expected`` (relative to its largest entry); the message names
    the entries that are off and how far, not their values."""
    if not isinstance(result, np.ndarray) or result.shape != (2, 2):
        raise AssertionError(f"{where}: return a numpy array of shape (2, 2), got {type(result).__name__} "
                             f"{getattr(result, 'shape', '')}")
    scale = np.abs(expected).max()
    close = np.isclose(result, expected, rtol=RTOL, atol=RTOL * scale)
    if not close.all():
        names = [name for name, ok in zip(("var r", "cov(r, alpha)", "cov(alpha, r)", "var alpha"), close.ravel(),
                                          strict=True) if not ok]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(result / expected)[~close]
        how = "" if not np.isfinite(ratio).all() else f" (off by a factor of about {_factor(ratio.max())})"
        symmetric = "" if np.allclose(result, result.T) else "; C must be symmetric"
        raise AssertionError(f"{where}: {', '.join(names)} differ from the reference{how}{symmetric}")


def _factor(ratio):
    """A ratio as a power of ten: the size of a mistake, not the answer."""
    return f"1e{int(np.round(np.log10(ratio)))}" if ratio > 0 else "0"


def random_wall(rng, n_max=300, alpha=None):
    alpha = rng.uniform(-np.pi, np.pi) if alpha is None else alpha
    r = rng.uniform(0.3, 10.0)
    half = np.radians(rng.uniform(2.5, 60.0))
    centre = alpha + rng.uniform(-1.0, 1.0) * (np.radians(80.0) - half)
    n = int(rng.integers(2, n_max + 1))
    theta = labkit.wrap_angle(rng.uniform(centre - half, centre + half, n))
    rho = r / np.cos(theta - alpha) + rng.normal(0.0, rng.uniform(0.0, 0.03), n)
    return rho, theta


def random_sigma(rng, rho):
    if rng.random() < 0.5:
        return float(rng.uniform(0.001, 0.05))
    return rng.uniform(0.001, 0.02) * rho ** rng.integers(0, 3)


def _check(line_covariance, rho, theta, sigma, where, as_list=False):
    expected = labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance
    args = (rho.tolist(), theta.tolist(), sigma) if as_list else (rho, theta, sigma)
    kind = "one sigma" if np.ndim(sigma) == 0 else "one sigma per beam"
    assert_covariance(line_covariance(*args), expected,
                      f"{where} ({rho.size} beams{' as lists' if as_list else ''}, {kind})")


def test_hidden_random(line_covariance, rng):
    """60 random noisy walls, 15 per quadrant, against ``labkit.fit_line_polar(..., range_sigma=sigma).covariance``."""
    for trial in range(60):
        rho, theta = random_wall(rng, alpha=rng.uniform(-np.pi, -np.pi / 2) + (trial % 4) * np.pi / 2)
        _check(line_covariance, rho, theta, random_sigma(rng, rho), f"random wall {trial}")


def test_hidden_edges(line_covariance, rng):
    """Two beams, noise-free walls along the axes (the nudges cross where the angle wraps), lists, bad arguments."""
    cases = []
    for _ in range(4):  # two beams
        alpha = rng.uniform(-np.pi, np.pi)
        theta = alpha + rng.uniform(-1.2, 1.2, 2)
        cases.append(("two beams", rng.uniform(0.3, 10.0) / np.cos(theta - alpha), theta,
                      float(rng.uniform(0.005, 0.03))))
    for axis in (0.0, np.pi / 2, np.pi, -np.pi / 2):  # noise-free walls a hair off an axis: where a fit's angle
        alpha = axis + rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 1e-9)  # formula wraps, a nudge crosses it
        theta = alpha + np.radians(rng.uniform(-35.0, 35.0, int(rng.integers(2, 12))))
        cases.append(("a noise-free wall along an axis", rng.uniform(0.5, 8.0) / np.cos(theta - alpha), theta,
                      float(rng.uniform(0.005, 0.03))))
    for where, rho, theta, sigma in cases:
        for as_list in (False, True):
            _check(line_covariance, rho, theta, sigma, where, as_list)
    rho, theta = random_wall(rng, n_max=20)
    bad = [("no beams", [], [], 0.01), ("one beam", rho[:1], theta[:1], 0.01),
           ("rho and theta of different lengths", rho, theta[:-1], 0.01),
           ("a negative sigma", rho, theta, -float(rng.uniform(0.001, 0.1))), ("sigma = 0", rho, theta, 0.0),
           ("one sigma too many", rho, theta, list(rng.uniform(0.001, 0.02, rho.size + 1)))]
    for what, bad_rho, bad_theta, sigma in bad:
        try:
            line_covariance(np.array(bad_rho), np.array(bad_theta), sigma)
        except ValueError:
            pass
        else:
            raise AssertionError(f"line_covariance with {what} must raise ValueError")


def test_own_work(line_covariance, rng):
    """Eight more random walls: right answers where labkit cannot be imported."""
    for trial in range(8):
        rho, theta = random_wall(rng, n_max=80)
        _check(line_covariance, rho, theta, random_sigma(rng, rho), f"own-work wall {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"line_covariance": '''
import labkit


def line_covariance(rho, theta, sigma):
    return labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "sigma instead of its square": ("variance = np.broadcast_to(sigma ** 2, rho.shape)",
                                    "variance = np.broadcast_to(sigma, rho.shape)"),
    "the weights follow the nudged ranges": ("r_up, alpha_up = fit(rho + nudge, w)",
                                             "r_up, alpha_up = fit(rho + nudge, 1.0 / (rho + nudge))"),
    "the alpha difference is not wrapped": ("dalpha = (alpha_up - alpha_down + np.pi) % (2 * np.pi) - np.pi",
                                            "dalpha = alpha_up - alpha_down"),
}
