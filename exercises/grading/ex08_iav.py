"""Hidden tests of exercise 8, ``inscribed_angles(points)``, ``is_circle(points, std_max, mean_range)`` and
``circle_from_angle(p_first, p_last, mean_angle, side)`` (the centre and radius, with the paper's erratum).

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved

FUNCTIONS = ("inscribed_angles", "is_circle", "circle_from_angle")


def _random_shape(rng, kind, n):
    """``n`` points of a random noisy arc, line or V corner, shifted by up to 5 m."""
    if kind == "arc":
        radius = float(rng.uniform(0.05, 2.0))
        span = np.radians(float(rng.uniform(20.0, 340.0)))
        t = float(rng.uniform(-np.pi, np.pi)) + np.sort(rng.uniform(0.0, span, n))
        t[0], t[-1] = t[0] - 1e-3, t[-1] + 1e-3  # distinct ends
        p = radius * np.column_stack([np.cos(t), np.sin(t)])
        noise = radius * float(rng.choice([0.0, 0.003, 0.01, 0.03, 0.06]))
    elif kind == "line":
        heading = float(rng.uniform(-np.pi, np.pi))
        s = np.sort(rng.uniform(0.0, float(rng.uniform(0.1, 5.0)), n)) + np.arange(n) * 1e-3
        p = np.column_stack([s * np.cos(heading), s * np.sin(heading)])
        noise = float(rng.choice([0.0, 0.0, 0.002, 0.01]))
    else:  # a V corner: two legs of random lengths at a random angle
        opening = np.radians(float(rng.uniform(30.0, 170.0)))
        k = int(rng.integers(1, n - 1))
        left = np.linspace(1.0, 0.0, k + 1)[:-1] * float(rng.uniform(0.2, 2.0))
        right = np.linspace(0.0, 1.0, n - k) * float(rng.uniform(0.2, 2.0))
        p = np.concatenate([left[:, None] * [[1.0, 0.0]], right[:, None] * [[np.cos(opening), np.sin(opening)]]])
        noise = float(rng.choice([0.0, 0.005]))
    p = p + noise * rng.standard_normal(p.shape) + rng.uniform(-5.0, 5.0, 2)
    return p


def _random_arc(rng):
    """The extremes, mean inscribed angle and side of a random arc of a known circle, and the circle:
    closed-form truth (the points of an arc walked counter-clockwise lie right of its chord)."""
    center = rng.uniform(-5.0, 5.0, 2)
    radius = float(rng.uniform(0.05, 3.0))
    start = float(rng.uniform(-np.pi, np.pi))
    span = np.radians(float(rng.uniform(10.0, 350.0)))
    p1 = center + radius * np.array([np.cos(start), np.sin(start)])
    pn = center + radius * np.array([np.cos(start + span), np.sin(start + span)])
    args = (p1, pn, float(np.pi - span / 2), -float(rng.uniform(0.1, 5.0)))
    if rng.random() < 0.5:  # walked the other way: the points lie left
        args = (pn, p1, args[2], -args[3])
    return args, center, radius


def _check_circle(circle_from_angle, args, center, radius, setting, atol=1e-6):
    got = circle_from_angle(*args)
    assert isinstance(got, tuple) and len(got) == 2, f"{setting}: return (center, radius), got {got!r}"
    c, r = got
    assert isinstance(c, np.ndarray) and c.shape == (2,), f"{setting}: center must be an array of shape (2,), got {c!r}"
    scale = max(1.0, radius)
    assert np.allclose(c, center, rtol=0.0, atol=atol * scale) and abs(float(r) - radius) <= atol * scale, (
        f"{setting}: p_first {np.round(args[0], 4)}, p_last {np.round(args[1], 4)}, mean_angle {args[2]:.4f} rad, "
        f"side {args[3]:+.2f}: expected center {np.round(center, 6)} and radius {radius:.6f}, got {np.round(c, 6)} "
        f"and {float(r):.6f}")


def test_visible(inscribed_angles, is_circle, circle_from_angle, rng):
    """The visible shapes again, turned, scaled and shifted: inscribed angles do not change under a
    similarity, so the angles and the verdicts stay. Earned by functions, not by a table of the
    visible answers."""
    moved = Moved(rng)
    t = np.radians([-90.0, -45.0, 0.0, 30.0, 90.0])
    away = np.pi / 2 + np.arctan(0.5)
    shapes = [  # points, angles, tolerance, is_circle with the defaults (None: the half circle's mean is exactly
        # pi/2, the edge of the default range, where rounding in the moved points decides)
        (np.column_stack([np.cos(t), np.sin(t)]), [np.pi / 2] * 3, 1e-9, None),
        ([[0.0, 0.0], [0.1, 0.3], [0.2, 0.6], [0.3, 0.9]], [np.pi, np.pi], 1e-6, False),
        ([[0.0, 1.0], [0.0, 0.5], [0.0, 0.0], [0.5, 0.0], [1.0, 0.0]], [away, np.pi / 2, away], 1e-9, False),
    ]
    where = f"turned by {moved.angle:.3f} rad, scaled by {moved.scale} and shifted"
    for k, (points, angles, atol, circle) in enumerate(shapes):
        points = moved.points(points)
        got = inscribed_angles(points)
        assert isinstance(got, np.ndarray) and got.shape == (len(angles),), (
            f"visible shape {k + 1}, {where}: one angle per interior point, shape ({len(angles)},), got {got!r}")
        assert np.allclose(got, angles, atol=atol, rtol=0), f"visible shape {k + 1}, {where}: angles {got}, " \
            f"expected {np.round(angles, 6)}"
        if circle is None:
            continue
        verdict = is_circle(points)
        assert isinstance(verdict, (bool, np.bool_)), f"is_circle must return a bool, got {type(verdict).__name__}"
        assert verdict == circle, f"visible shape {k + 1}, {where}: is_circle should be {circle}, got {verdict}"
    line = moved.points([[0.0, 0.0], [0.1, 0.3], [0.2, 0.6], [0.3, 0.9]])
    assert is_circle(line, std_max=0.05, mean_range=(3.0, np.pi)), \
        f"visible line, {where}: it passes a test with a line's thresholds (std_max=0.05, mean_range=(3.0, pi))"
    for k, (p1, pn, alpha, side, center, radius) in enumerate([
            ([1.0, 0.0], [0.0, 1.0], np.radians(135.0), -1, [0.0, 0.0], 1.0),
            ([0.0, 1.0], [1.0, 0.0], np.radians(135.0), 1, [0.0, 0.0], 1.0),
            ([3.0, 1.0], [1.0, -1.0], np.radians(45.0), -1, [1.0, 1.0], 2.0)]):
        moved_ends = moved.points([p1, pn])
        _check_circle(circle_from_angle, (moved_ends[0], moved_ends[1], alpha, side), moved.points([center])[0],
                      moved.scale * radius, f"visible circle {k + 1}, {where}", atol=1e-9)


def test_hidden_random(inscribed_angles, is_circle, circle_from_angle, rng):
    """200 random noisy arcs, lines and V-corners: angles and verdicts against ``labkit``'s IAV; 100
    random arcs: the circle from their ends and inscribed angle against the circle they come from."""
    for trial in range(100):
        args, center, radius = _random_arc(rng)
        _check_circle(circle_from_angle, args, center, radius, f"random circle {trial}")
    checked = 0
    for trial in range(200):
        kind = ("arc", "arc", "line", "corner")[trial % 4]
        n = int(rng.integers(3, 61)) if trial % 3 else int(rng.integers(3, 8))
        points = _random_shape(rng, kind, n)
        setting = f"random {kind} {trial} ({n} points)"
        reference = labkit.inscribed_angles(points)
        angles = inscribed_angles(points)
        assert isinstance(angles, np.ndarray), f"{setting}: angles must be a numpy array, got {type(angles).__name__}"
        assert angles.shape == reference.shape, (
            f"{setting}: angles must have shape {reference.shape}, got {angles.shape}"
        )
        assert np.issubdtype(angles.dtype, np.floating), f"{setting}: angles must be floats, got {angles.dtype}"
        if not np.allclose(angles, reference, rtol=0.0, atol=1e-6):
            i = int(np.flatnonzero(~np.isclose(angles, reference, rtol=0.0, atol=1e-6))[0])
            raise AssertionError(f"{setting}: the angle at interior point {i} should be {reference[i]:.9f} rad, "
                                 f"got {angles[i]:.9f}")
        if trial % 2:
            kwargs = {}
            std_max, low, high = 0.15, np.pi / 2, 3 * np.pi / 4
        else:
            std_max = float(rng.uniform(0.02, 0.4))
            low = float(rng.uniform(0.0, 2.5))
            high = float(rng.uniform(low + 0.1, np.pi))
            kwargs = {"std_max": std_max, "mean_range": (low, high)}
        mean, std, _ = labkit.iav_stats(points)
        if min(abs(std - std_max), abs(mean - low), abs(mean - high)) < 1e-6:
            continue  # too close to a threshold to grade fairly
        want = bool(std < std_max and low <= mean <= high)
        verdict = is_circle(points, **kwargs)
        assert isinstance(verdict, (bool, np.bool_)), f"{setting}: is_circle must return a bool, got {type(verdict)}"
        assert verdict == want, (f"{setting} with std_max={std_max:.3f}, mean_range=({low:.3f}, {high:.3f}): "
                                 f"inscribed angles have mean {mean:.4f} and std {std:.4f} rad, so is_circle "
                                 f"should be {want}, got {verdict}")
        checked += 1
    assert checked > 150, "the hidden test skipped too many cases"


def test_hidden_edges(inscribed_angles, is_circle, circle_from_angle, rng):
    """0 to 3 points, identical ends, an interior point on an end, lists of integers, other thresholds;
    circles from integer lists, a half circle, and the undefined ones (no chord, angle 0 or pi, side 0)."""
    _check_circle(circle_from_angle, ([1, 0], [-1, 0], np.pi / 2, -1), np.zeros(2), 1.0, "a half circle, integers")
    _check_circle(circle_from_angle, ((0, 2), (2, 0), 3 * np.pi / 4, 2), np.zeros(2), 2.0, "a quarter, tuples")
    for case, args in enumerate([([1.0, 1.0], [1.0, 1.0], 2.0, 1), ([0, 0], [1, 0], 0.0, 1), ([0, 0], [1, 0], np.pi, 1),
                                 ([0, 0], [1, 0], -1.0, 1), ([0, 0], [1, 0], 2.0, 0), ([0, 0], [1, 0], 2.0, np.nan)]):
        try:
            circle_from_angle(*args)
        except ValueError:
            continue
        raise AssertionError(f"undefined circle {case} (p_first, p_last, mean_angle, side = {args}): raise ValueError")
    undefined = [[], [[1.0, 2.0]], [[0.0, 0.0], [1.0, 1.0]], [[0, 0], [0, 0], [2, 0]], [[0, 0], [1, 1], [2, 0], [2, 0]]]
    for case, points in enumerate(undefined):
        try:
            inscribed_angles(points)
        except ValueError as error:
            assert "points" in str(error), f"undefined case {case} ({points}): name the argument points: {error}"
        else:
            raise AssertionError(f"undefined case {case} ({points}): the angles are undefined, raise ValueError")
        assert not is_circle(points), f"undefined case {case} ({points}): is_circle must return False"
        assert not is_circle(np.array(points, dtype=float).reshape(-1, 2)), f"undefined case {case} as an array"

    t = np.radians(np.linspace(-60.0, 60.0, 9))
    arc_120 = np.column_stack([-np.cos(t), np.sin(t)])  # mean 120 degrees, std 0
    cases = [
        ([[0, 0], [1, 1], [2, 0]], {}),  # 3 points, integers: one angle of 90 degrees
        ([[0, 0], [1, 1], [2, 0]], {"mean_range": (0.5, 1.5)}),
        ([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [0.0, 0.0]], {}),  # identical ends: angles 0
        ([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [0.0, 0.0]], {"mean_range": (0.0, 0.5), "std_max": 0.01}),
        ([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [5, 0]], {}),  # a line of integers
        ([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [5, 0]], {"std_max": 0.05, "mean_range": (3.0, np.pi)}),
        (arc_120.tolist(), {}),
        (arc_120.tolist(), {"mean_range": (np.pi / 2, 2.0)}),  # 120 deg = 2.094 rad: mean too large
        (arc_120 + np.array([[0.0, 0.0]] * 4 + [[0.0, 0.05]] * 5), {"std_max": 0.01}),  # a bent arc: spread too large
        ([[0.0, 1.0], [0.0, 0.0], [1.0, 0.0]], {"mean_range": (1.5, 1.6), "std_max": 1e-3}),
    ]
    for case, (points, kwargs) in enumerate(cases):
        reference = labkit.inscribed_angles(points)
        mean, std, _ = labkit.iav_stats(points)
        std_max = kwargs.get("std_max", 0.15)
        low, high = kwargs.get("mean_range", (np.pi / 2, 3 * np.pi / 4))
        want = bool(std < std_max and low <= mean <= high)
        angles = inscribed_angles(points)
        assert isinstance(angles, np.ndarray) and angles.shape == reference.shape, \
            f"edge case {case}: angles must be an array of shape {reference.shape}, got {angles!r}"
        np.testing.assert_allclose(angles, reference, rtol=0.0, atol=1e-6, err_msg=f"edge case {case} ({points})")
        verdict = is_circle(points, **kwargs)
        assert isinstance(verdict, (bool, np.bool_)), f"edge case {case}: is_circle must return a bool"
        assert verdict == want, f"edge case {case} ({kwargs}): mean {mean:.4f}, std {std:.4f}: should be {want}"


def test_own_work(inscribed_angles, is_circle, circle_from_angle, rng):
    """Six more random arcs: right answers where labkit cannot be imported."""
    for trial in range(6):
        args, center, radius = _random_arc(rng)
        _check_circle(circle_from_angle, args, center, radius, f"own-work circle {trial}")
    for _ in range(6):
        t = float(rng.uniform(-np.pi, np.pi)) + np.sort(rng.uniform(0.0, np.radians(200.0), int(rng.integers(4, 40))))
        points = float(rng.uniform(0.1, 1.0)) * np.column_stack([np.cos(t), np.sin(t)])
        points = points + 0.01 * rng.standard_normal(points.shape)
        np.testing.assert_allclose(inscribed_angles(points), labkit.inscribed_angles(points), rtol=0.0, atol=1e-6)
        mean, std, _ = labkit.iav_stats(points)
        assert is_circle(points) == bool(std < 0.15 and np.pi / 2 <= mean <= 3 * np.pi / 4)


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"iav": '''
import labkit


def inscribed_angles(points):
    return labkit.inscribed_angles(points)


def is_circle(points, std_max=0.15, mean_range=(np.pi / 2, 3 * np.pi / 4)):
    try:
        mean, std, _ = labkit.iav_stats(points)
    except ValueError:
        return False
    return bool(std < std_max and mean_range[0] <= mean <= mean_range[1])
''', "circle": '''
import labkit


def circle_from_angle(p_first, p_last, mean_angle, side):
    return labkit.circle_from_iav(p_first, p_last, mean_angle, side)
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "degrees instead of radians": (
        "return np.arccos(np.clip(cosine, -1.0, 1.0))", "return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))"
    ),
    "arccos without clipping the cosine (nan on straight lines)": ("np.clip(cosine, -1.0, 1.0)", "cosine"),
    "the ray from P_1 to P_i instead of P_i to P_1 (pi minus the angle)": ("a = p[0] - inner", "a = inner - p[0]"),
    "mean and standard deviation swapped": (
        "mean, std = angles.mean(), angles.std()", "std, mean = angles.mean(), angles.std()"
    ),
    "sample standard deviation (ddof=1) instead of the population one": ("angles.std()", "angles.std(ddof=1)"),
    "the paper's slip: height d tan(theta), the whole chord": ("0.5 * chord * np.tan(theta)", "chord * np.tan(theta)"),
    "the paper's slip: arc at the centre 360 - IAV, so theta = IAV / 2 - 90": (
        "theta = mean_angle - np.pi / 2", "theta = mean_angle / 2 - np.pi / 2"),
    "the centre on the points' side of the chord": ("- np.sign(side) * 0.5", "+ np.sign(side) * 0.5"),
    "no ValueError for a mean angle of 0 or pi": ("if not 0.0 < mean_angle < np.pi:", "if mean_angle != mean_angle:"),
}
