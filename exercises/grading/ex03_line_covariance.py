"""Hidden tests of exercise 3, ``line_covariance(rho, theta, sigma)`` -> the 2 x 2 covariance of ``(r, alpha)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved

FUNCTIONS = ("line_covariance",)
RTOL = 1e-4


def assert_covariance(result, expected, where):
    """``result`` is a (2, 2) array within RTOL of ``expected`` (relative to its largest entry)."""
    if not isinstance(result, np.ndarray) or result.shape != (2, 2):
        raise AssertionError(f"{where}: return a numpy array of shape (2, 2), got {type(result).__name__} "
                             f"{getattr(result, 'shape', '')}")
    scale = np.abs(expected).max()
    if not np.allclose(result, expected, rtol=RTOL, atol=RTOL * scale):
        raise AssertionError(f"{where}: expected {np.array2string(expected, precision=6)}, "
                             f"got {np.array2string(result, precision=6)}")


def random_wall(rng, n_max=300):
    alpha = rng.uniform(-np.pi, np.pi)
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


def test_visible(line_covariance, rng):
    """The visible walls again, turned and scaled (sigma with them): var r and cov(r, alpha) scale with
    the square and the scale, var alpha stays. Earned by a function, not by a table of the answers."""
    moved = Moved(rng, shift=False)
    s = moved.scale
    ahead = np.radians([-40.0, -20.0, 0.0, 20.0, 40.0])
    rho_ahead = np.array([2.6108, 2.1284, 1.9912, 2.1283, 2.6107])
    behind = np.radians([160.0, 170.0, 180.0, 190.0, 200.0])
    walls = [(rho_ahead, ahead, 0.01), (rho_ahead, ahead, 0.005 * rho_ahead),
             (3.0 / np.abs(np.cos(behind)), behind, 0.02)]
    for k, (rho, theta, sigma) in enumerate(walls):
        expected = labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance * np.array([[s * s, s], [s, 1.0]])
        result = line_covariance(s * rho, moved.bearing(theta), s * np.asarray(sigma))
        assert_covariance(result, expected, f"visible wall {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}")


def test_hidden_random(line_covariance, rng):
    """60 random noisy walls against ``labkit.fit_line_polar(..., range_sigma=sigma).covariance``."""
    for trial in range(60):
        rho, theta = random_wall(rng)
        sigma = random_sigma(rng, rho)
        expected = labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance
        kind = "one sigma" if np.ndim(sigma) == 0 else "one sigma per beam"
        assert_covariance(line_covariance(rho, theta, sigma), expected,
                          f"random wall {trial} ({rho.size} beams, {kind})")


def test_hidden_edges(line_covariance, rng):
    """Two beams, noise-free walls at alpha = pi (the nudges cross the wrap), lists, bad arguments."""
    cases = []
    for _ in range(4):  # two beams
        alpha = rng.uniform(-np.pi, np.pi)
        theta = alpha + rng.uniform(-1.2, 1.2, 2)
        cases.append((rng.uniform(0.3, 10.0) / np.cos(theta - alpha), theta, float(rng.uniform(0.005, 0.03))))
    for r in (1.0, 4.0, 7.5):  # symmetric noise-free walls behind the sensor: alpha = pi exactly
        theta = np.pi + np.radians(np.arange(-30.0, 30.1, float(rng.choice([2.0, 5.0]))))
        cases.append((r / np.abs(np.cos(theta)), theta, 0.01))
    for case, (rho, theta, sigma) in enumerate(cases):
        expected = labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance
        for as_list in (False, True):
            args = (rho.tolist(), theta.tolist(), sigma) if as_list else (rho, theta, sigma)
            assert_covariance(line_covariance(*args), expected,
                              f"edge case {case} ({rho.size} beams, {'lists' if as_list else 'arrays'})")
    bad = [([], [], 0.01), ([2.0], [0.3], 0.01), ([1.0, 2.0, 3.0], [0.0, 0.1], 0.01),
           ([1.0, 2.0], [0.0, 0.1], -0.01), ([1.0, 2.0], [0.0, 0.1], 0.0), ([1.0, 2.0], [0.0, 0.1], [0.01] * 3)]
    for rho, theta, sigma in bad:
        try:
            line_covariance(np.array(rho), np.array(theta), sigma)
        except ValueError:
            pass
        else:
            raise AssertionError(f"line_covariance({rho}, {theta}, {sigma}) must raise ValueError")


def test_own_work(line_covariance, rng):
    """Eight more random walls: right answers where labkit cannot be imported."""
    for trial in range(8):
        rho, theta = random_wall(rng, n_max=80)
        sigma = random_sigma(rng, rho)
        expected = labkit.fit_line_polar(rho, theta, range_sigma=sigma).covariance
        assert_covariance(line_covariance(rho, theta, sigma), expected, f"own-work wall {trial}")


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
