"""Hidden tests of exercise 2, ``fit_line(rho, theta)`` -> ``(r, alpha)``, the weighted (w = 1/rho) line.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import assert_line_result


def _check(fit_line, rho, theta, what, as_list=False):
    reference = labkit.fit_line_polar(rho, theta)
    args = (rho.tolist(), theta.tolist()) if as_list else (rho, theta)
    try:
        assert_line_result(fit_line(*args), reference.r, reference.alpha, atol=1e-7)
    except AssertionError as error:
        raise AssertionError(f"{what} ({rho.size} beams{' as lists' if as_list else ''}): {error}") from None


def _wall(rng, alpha, n, noise):
    """A wall with normal direction ``alpha`` at a random distance, seen over a random span of bearings."""
    half = np.radians(rng.uniform(2.5, 60.0))  # half the angle the wall covers
    centre = alpha + rng.uniform(-1.0, 1.0) * (np.radians(80.0) - half)
    theta = labkit.wrap_angle(rng.uniform(centre - half, centre + half, n))
    return rng.uniform(0.3, 10.0) / np.cos(theta - alpha) + rng.normal(0.0, noise, n), theta


def test_hidden_random(fit_line, rng):
    """80 random noisy walls, 20 per quadrant of alpha, against ``labkit.fit_line_polar`` to 1e-7."""
    for trial in range(80):
        alpha = rng.uniform(-np.pi, -np.pi / 2) + (trial % 4) * np.pi / 2  # the quadrants in turn
        rho, theta = _wall(rng, alpha, int(rng.integers(2, 501)), rng.uniform(0.0, 0.03))
        _check(fit_line, rho, theta, f"random wall {trial} (quadrant {trial % 4 + 1})")


def test_hidden_edges(fit_line, rng):
    """Two beams, noise-free walls along the axes (alpha on a quadrant's edge), lists, 200 000 beams (O(n)), too
    few or mismatched beams."""
    cases = []
    for _ in range(6):  # two beams
        alpha = rng.uniform(-np.pi, np.pi)
        theta = alpha + rng.uniform(-1.2, 1.2, 2)
        cases.append(("two beams", rng.uniform(0.3, 10.0) / np.cos(theta - alpha) + rng.normal(0.0, 0.01, 2), theta))
    for axis in (0.0, np.pi / 2, np.pi, -np.pi / 2):  # along the axes, a hair either side: across the wrap at pi
        alpha = axis + rng.choice([-1.0, 1.0]) * rng.uniform(1e-9, 1e-6)
        theta = alpha + np.radians(rng.uniform(-40.0, 40.0, int(rng.integers(3, 12))))
        cases.append(("a noise-free wall along an axis", rng.uniform(0.5, 8.0) / np.cos(theta - alpha), theta))
    alpha = rng.uniform(-np.pi, np.pi)  # 200 000 beams: needs O(n)
    theta = labkit.wrap_angle(alpha + np.linspace(-0.9, 0.9, 200_000) + rng.uniform(-0.2, 0.2))
    cases.append(("a long wall", rng.uniform(2.0, 6.0) / np.cos(theta - alpha) + rng.normal(0.0, 0.01, theta.size),
                  theta))
    for what, rho, theta in cases:
        for as_list in (False, True) if rho.size < 100 else (False,):
            _check(fit_line, rho, theta, what, as_list)

    for n_rho, n_theta in [(0, 0), (1, 1), *(tuple(rng.choice(6, 2, replace=False)) for _ in range(2))]:
        try:
            fit_line(rng.uniform(0.5, 5.0, int(n_rho)), rng.uniform(-1.0, 1.0, int(n_theta)))
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError("fewer than two beams, or rho and theta of different lengths, must raise ValueError")


def test_own_work(fit_line, rng):
    """Eight more random walls: right answers where labkit cannot be imported."""
    for trial in range(8):
        alpha = rng.uniform(-np.pi, -np.pi / 2) + (trial % 4) * np.pi / 2
        theta = alpha + rng.uniform(-1.0, 1.0, 50)
        rho = rng.uniform(0.3, 10.0) / np.cos(theta - alpha) + rng.normal(0.0, 0.01, 50)
        _check(fit_line, rho, theta, f"own-work wall {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"fit_line": '''
import labkit


def fit_line(rho, theta):
    fit = labkit.fit_line_polar(rho, theta)
    return fit.r, fit.alpha
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "unweighted fit": ("w = 1.0 / rho", "w = np.ones_like(rho)"),
    "r may come out negative": ("if r < 0:", "if False:"),
    "alpha is not wrapped into (-pi, pi]": ("alpha = np.pi - (np.pi - alpha) % (2 * np.pi)", "pass"),
}
