"""Hidden tests of exercise 2, ``fit_line(rho, theta)`` -> ``(r, alpha)``, the weighted (w = 1/rho) line.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, assert_line_result

FUNCTIONS = ("fit_line",)


def test_visible(fit_line, rng):
    """The visible walls again, turned and scaled: the fitted line turns and scales with them (the
    weights 1/rho all scale alike, so the minimum of S moves with the plane). Earned by a function,
    not by a table of the visible answers."""
    moved = Moved(rng, shift=False)
    theta = np.radians([-20.0, 0.0, 20.0])
    walls = [
        (2.0 / np.cos(theta), theta, 2.0, 0.0),
        (3.0 / np.cos(np.radians([-60.0, -90.0, -120.0]) + np.pi / 2), np.radians([-60.0, -90.0, -120.0]), 3.0,
         -np.pi / 2),
        (-1.0 / np.cos(np.radians([160.0, 180.0, 200.0])), np.radians([160.0, 180.0, 200.0]), 1.0, np.pi),
        (np.array([1.3354, 1.0442, 1.01, 1.0842, 1.2654]), np.radians([-40.0, -20.0, 0.0, 20.0, 40.0]),
         1.0003793158236751, 0.016346680066035013),
    ]
    for k, (rho, theta, r, alpha) in enumerate(walls):
        s = moved.scale
        result = fit_line(s * rho, moved.bearing(theta))
        try:
            assert_line_result(result, *moved.line(r, alpha), atol=1e-7 * s)
        except AssertionError as error:
            raise AssertionError(f"visible wall {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}: "
                                 f"{error}") from None


def test_hidden_random(fit_line, rng):
    """80 random noisy walls, 20 per quadrant of alpha, against ``labkit.fit_line_polar`` to 1e-7."""
    for trial in range(80):
        alpha = rng.uniform(-np.pi, -np.pi / 2) + (trial % 4) * np.pi / 2  # the quadrants in turn
        r = rng.uniform(0.3, 10.0)
        half = np.radians(rng.uniform(2.5, 60.0))  # half the angle the wall covers
        centre = alpha + rng.uniform(-1.0, 1.0) * (np.radians(80.0) - half)
        n = int(rng.integers(2, 501))
        theta = labkit.wrap_angle(rng.uniform(centre - half, centre + half, n))
        rho = r / np.cos(theta - alpha) + rng.normal(0.0, rng.uniform(0.0, 0.03), n)
        reference = labkit.fit_line_polar(rho, theta)
        result = fit_line(rho, theta)
        try:
            assert_line_result(result, reference.r, reference.alpha, atol=1e-7)
        except AssertionError as error:
            where = f"random wall {trial} ({n} beams, alpha = {np.degrees(alpha):.1f} deg)"
            raise AssertionError(f"{where}: {error}") from None


def test_hidden_edges(fit_line, rng):
    """Two beams, walls along the axes, lists, 200 000 beams (O(n)), too few or mismatched beams."""
    cases = []
    for _ in range(6):  # two beams
        alpha = rng.uniform(-np.pi, np.pi)
        theta = alpha + rng.uniform(-1.2, 1.2, 2)
        cases.append((rng.uniform(0.3, 10.0) / np.cos(theta - alpha) + rng.normal(0.0, 0.01, 2), theta))
    for alpha in (0.0, np.pi / 2, np.pi, -np.pi / 2):  # along the axes: alpha must come out in (-pi, pi]
        theta = alpha + np.radians([-30.0, -10.0, 0.0, 10.0, 30.0])
        cases.append((2.0 / np.cos(theta - alpha), theta))
    theta = np.linspace(-0.9, 0.9, 200_000)  # 200 000 beams: needs O(n)
    cases.append((4.0 / np.cos(theta - 0.2) + rng.normal(0.0, 0.01, theta.size), theta))
    for case, (rho, theta) in enumerate(cases):
        reference = labkit.fit_line_polar(rho, theta)
        for as_list in (False, True):
            if as_list and rho.size > 100:
                continue
            args = (rho.tolist(), theta.tolist()) if as_list else (rho, theta)
            try:
                assert_line_result(fit_line(*args), reference.r, reference.alpha, atol=1e-7)
            except AssertionError as error:
                kind = "lists" if as_list else "arrays"
                raise AssertionError(f"edge case {case} ({rho.size} beams, {kind}): {error}") from None

    for bad_rho, bad_theta in [([], []), ([2.0], [0.3]), ([1.0, 2.0, 3.0], [0.0, 0.1]), ([1.0], [0.0, 0.1])]:
        try:
            fit_line(np.array(bad_rho), np.array(bad_theta))
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError(f"{len(bad_rho)} rho and {len(bad_theta)} theta must raise ValueError")


def test_own_work(fit_line, rng):
    """Eight more random walls: right answers where labkit cannot be imported."""
    for trial in range(8):
        alpha = rng.uniform(-np.pi, -np.pi / 2) + (trial % 4) * np.pi / 2
        theta = alpha + rng.uniform(-1.0, 1.0, 50)
        rho = rng.uniform(0.3, 10.0) / np.cos(theta - alpha) + rng.normal(0.0, 0.01, 50)
        reference = labkit.fit_line_polar(rho, theta)
        result = fit_line(rho, theta)
        assert_line_result(result, reference.r, reference.alpha, atol=1e-7)


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
