"""Hidden tests of exercise 8, ``inscribed_angles(points)``, ``is_circle(points, std_max, mean_range)``,
``circle_from_angle(p_first, p_last, mean_angle, side)`` (the centre and radius, with the paper's erratum),
``in_band(points, low, high)`` (the circle prerequisite of Fig. 5) and ``is_leg(points, angle_increment,
chord_range, middle_range, padding_beams)`` (the leg criteria of Sec. II-E as ``labkit.detect_legs``
applies them with ``range_sigma_m=0``, the paper's test).

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit import sim
from labkit.grading import Moved

FUNCTIONS = ("inscribed_angles", "is_circle", "circle_from_angle", "in_band", "is_leg")


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


def _band_shape(rng, ratio=None, chord=None):
    """Points of a random segment whose middle point (row ``M // 2``) lies ``ratio`` chord lengths from the
    chord, towards the sensor at the origin (negative: away from it): closed-form truth for the band.
    Returns the points and the ratio."""
    n = int(rng.integers(3, 31))
    bearing = float(rng.uniform(-np.pi, np.pi))
    center = float(rng.uniform(1.0, 6.0)) * np.array([np.cos(bearing), np.sin(bearing)])
    if chord is None:
        chord = float(rng.choice([0.05, 0.2, 1.0])) * float(rng.uniform(0.5, 2.0))
    heading = float(rng.uniform(-np.pi, np.pi))
    d = chord * np.array([np.cos(heading), np.sin(heading)])
    p1 = center - d / 2
    normal = np.array([-d[1], d[0]]) / chord
    towards = normal if normal @ (-p1) > 0 else -normal  # the unit normal pointing to the sensor's side
    if ratio is None:
        ratio = float(rng.uniform(-0.5, 1.0))
    t = np.sort(rng.uniform(0.05, 0.95, n - 2))
    inner = p1 + t[:, None] * d + (chord * rng.uniform(-0.3, 0.6, n - 2))[:, None] * towards
    points = np.concatenate([[p1], inner, [p1 + d]])
    points[n // 2] = p1 + float(rng.uniform(0.05, 0.95)) * d + ratio * chord * towards
    if rng.random() < 0.5:  # the same segment walked the other way round, the middle point kept in row n // 2
        points = points[::-1].copy()
        other = (n - 1) - n // 2
        points[[n // 2, other]] = points[[other, n // 2]]
    return points, ratio


def _leg_world(rng):
    """A random world around the sensor: circles the size of legs and larger, short walls and V corners."""
    def somewhere(lo, hi):
        bearing = float(rng.uniform(-np.pi, np.pi))
        return float(rng.uniform(lo, hi)) * np.array([np.cos(bearing), np.sin(bearing)])

    circles = tuple(sim.Column(tuple(somewhere(0.5, 5.0)), float(rng.uniform(0.02, 0.2))) for _ in range(10))
    walls = []
    for _ in range(4):
        a = somewhere(0.7, 5.0)
        heading = float(rng.uniform(-np.pi, np.pi))
        b = a + float(rng.uniform(0.05, 0.4)) * np.array([np.cos(heading), np.sin(heading)])
        walls.append(sim.Wall(tuple(a), tuple(b)))
        if rng.random() < 0.7:  # a V corner at b
            turn = heading + float(rng.choice([-1.0, 1.0])) * np.radians(float(rng.uniform(60.0, 150.0)))
            walls.append(sim.Wall(tuple(b), tuple(b + float(rng.uniform(0.05, 0.3)) * np.array([np.cos(turn),
                                                                                               np.sin(turn)]))))
    return sim.World("legs", walls=tuple(walls), circles=circles)


def _near(value, edges, tol=1e-9):
    return any(abs(value - e) < tol * max(1.0, abs(e)) for e in edges)


def _check_band(in_band, points, args, want, setting):
    got = in_band(points, *args)
    assert isinstance(got, (bool, np.bool_)), f"{setting}: in_band must return a bool, got {type(got).__name__}"
    assert got == want, f"{setting}: in_band{'' if not args else ' with (low, high) = ' + str(args)} should be " \
        f"{want}, got {got}"


def _check_leg(is_leg, points, args, kwargs, want, setting):
    got = is_leg(points, *args, **kwargs)
    assert isinstance(got, (bool, np.bool_)), f"{setting}: is_leg must return a bool, got {type(got).__name__}"
    assert got == want, f"{setting}: is_leg(points, {', '.join(map(repr, args))}, {kwargs}) should be {want}, got {got}"


def _leg_kwargs(rng):
    """The defaults half of the time, else random leg criteria (and the paper's literal test, no padding)."""
    if rng.random() < 0.5:
        return {}, ((0.1, 0.25), (0.1, 0.7), 1.0)
    c_lo = float(rng.uniform(0.03, 0.15))
    m_lo = float(rng.uniform(0.0, 0.3))
    kw = {"chord_range": (c_lo, c_lo + float(rng.uniform(0.05, 0.3))),
          "middle_range": (m_lo, m_lo + float(rng.uniform(0.2, 0.8))),
          "padding_beams": float(rng.choice([0.0, 0.5, 1.0, 2.0]))}
    return kw, (kw["chord_range"], kw["middle_range"], kw["padding_beams"])


def _check_sim_legs(is_leg, rng, scans, setting):
    """Every segment of random simulated scans: is_leg against labkit.detect_legs's verdict on its points
    (accepted, or rejected only by the occlusion rule, which needs the neighbouring beams)."""
    checked = 0
    for s in range(scans):
        lidar = sim.LIDARS[str(rng.choice(["lms200", "lms200", "lms111", "xv11"]))]
        scan, _ = sim.scan_at(_leg_world(rng), lidar, (0.0, 0.0, 0.0), rng=rng)
        kwargs, (chord_range, middle_range, padding) = _leg_kwargs(rng)
        # the paper's fixed test, the one the exercise asks for (labkit's default widens it for the noise)
        _, steps = labkit.detect_legs(scan, chord_range_m=chord_range, middle_range=middle_range,
                                      chord_padding_beams=padding, range_sigma_m=0, trace=True)
        xy, n = scan.points, scan.n_beams
        for check in steps:
            beams = np.arange(check.first, check.last + (n if check.last < check.first else 0) + 1) % n
            points = xy[beams]
            if check.test == "degenerate" or len(points) < 3:
                continue
            # the padded chord and the band ratio, in closed form from the points, to skip cases on an edge
            chord = float(np.hypot(*(points[-1] - points[0])))
            middle = points[len(points) // 2]
            width = chord + padding * abs(float(scan.angle_increment)) * float(np.hypot(*middle))
            if _near(width, chord_range):
                continue
            if chord > 0:
                d = points[-1] - points[0]
                offset = ((middle[0] - points[0][0]) * d[1] - (middle[1] - points[0][1]) * d[0]) / chord
                if _near(abs(offset) / chord, middle_range):  # either side: a ratio on an edge is skipped
                    continue
            want = check.test in ("accepted", "occluded")
            _check_leg(is_leg, points, (float(scan.angle_increment),), kwargs, want,
                       f"{setting} scan {s} ({lidar.name}), beams {check.first}..{check.last} ({len(points)} points, "
                       f"labkit.detect_legs: {check.test})")
            checked += 1
    return checked


def _check_built_legs(is_leg, rng, count, setting):
    """Segments built with a known chord and middle point: the leg verdict in closed form."""
    for trial in range(count):
        chord = float(rng.uniform(0.03, 0.45))
        points, ratio = _band_shape(rng, float(rng.uniform(-0.3, 0.9)), chord)
        increment = float(rng.choice([-1.0, 1.0]) * np.radians(rng.choice([0.25, 0.5, 1.0])))
        kwargs, (chord_range, middle_range, padding) = _leg_kwargs(rng)
        width = chord + padding * abs(increment) * float(np.hypot(*points[len(points) // 2]))
        if _near(width, chord_range, 1e-7) or _near(ratio, middle_range, 1e-7):
            continue
        want = bool(chord_range[0] <= width <= chord_range[1] and middle_range[0] < ratio < middle_range[1])
        _check_leg(is_leg, points, (increment,), kwargs, want, f"{setting} {trial} (chord {chord:.4f} m, middle "
                   f"point {ratio:.3f} chords towards the sensor, {len(points)} points)")

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


def test_visible(inscribed_angles, is_circle, circle_from_angle, in_band, is_leg, rng):
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
    # the band and the legs are measured from the sensor at the origin: turned and scaled about it, not shifted
    turned = Moved(rng, shift=False)
    where = f"turned by {turned.angle:.3f} rad and scaled by {turned.scale} about the sensor"
    t = np.radians([-90.0, -45.0, 0.0, 45.0, 90.0])
    half = np.column_stack([np.cos(t), np.sin(t)])
    for k, (points, args, want) in enumerate([
            ([3.0, 0.0] - half, (), True), ([3.0, 0.0] - half, (0.1, 0.4), False), ([3.0, 0.0] + half, (), False),
            ([[3.0, -1.0], [3.0, 0.0], [3.0, 1.0]], (), False)]):
        _check_band(in_band, turned.points(points), args, want, f"visible band {k + 1}, {where}")
    increment = float(np.radians(0.5))
    chords = (0.1 * turned.scale, 0.25 * turned.scale)
    for k, (points, kwargs, want) in enumerate([
            ([2.0, 0.0] - 0.06 * half, {}, True), ([2.0, 0.0] - 0.045 * half, {}, True),
            ([2.0, 0.0] - 0.045 * half, {"padding_beams": 0.0}, False), ([2.0, 0.0] - 0.15 * half, {}, False),
            ([[2.0, -0.07], [2.0, 0.0], [2.0, 0.07]], {}, False)]):
        _check_leg(is_leg, turned.points(points), (increment,), {"chord_range": chords, **kwargs}, want,
                   f"visible leg {k + 1}, {where}")


def test_hidden_random(inscribed_angles, is_circle, circle_from_angle, in_band, is_leg, rng):
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
    for trial in range(150):
        points, ratio = _band_shape(rng)
        low, high = 0.1, 0.7
        args = ()
        if trial % 2:
            low = float(rng.uniform(-0.3, 0.5))
            high = low + float(rng.uniform(0.1, 0.6))
            args = (low, high)
        if _near(ratio, (low, high), 1e-7):
            continue
        _check_band(in_band, points, args, bool(low < ratio < high),
                    f"random band {trial} ({len(points)} points, chord {np.hypot(*(points[-1] - points[0])):.3f} m, "
                    f"middle point {ratio:.4f} chords towards the sensor)")
    assert _check_sim_legs(is_leg, rng, 8, "random") > 40, "the hidden test skipped too many segments"
    _check_built_legs(is_leg, rng, 80, "random leg")


def test_hidden_edges(inscribed_angles, is_circle, circle_from_angle, in_band, is_leg, rng):
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
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
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

    # the band: exact edges (the paper's 0.1 d < x < 0.7 d is strict), the side from the sensor, row M // 2
    quarter = [[4, -2], [3, 0], [4, 2]]  # integers; the middle point 1/4 of the chord towards the sensor, exactly
    for case, (points, args, want) in enumerate([
            (quarter, (), True), (quarter, (0.25, 0.5), False), (quarter, (0.125, 0.25), False),
            (quarter, (0.125, 0.375), True), (quarter[::-1], (), True), ([[-4, 2], [-3, 0], [-4, -2]], (), True),
            ([[4, -2], [5, 0], [4, 2]], (), False), ([[4, -2], [5, 0], [4, 2]], (-0.5, 0.0), True),
            ([[4.0, -2.0], [4.0, -1.0], [3.0, 1.0], [4.0, 2.0]], (), True),  # the middle point is row 2 of 4
            ([[4.0, -2.0], [3.0, -1.0], [4.0, 1.0], [4.0, 2.0]], (), False),  # row 1 bulges, row 2 is on the chord
            (((0.5, 0.5), (0.25, 0.75), (0.5, 1.0)), (), True)]):  # tuples
        _check_band(in_band, points, args, want, f"band edge case {case} ({points})")
    for case, (points, args) in enumerate([([], ()), ([[4.0, -2.0], [4.0, 2.0]], ()), ([[4, 2], [3, 0], [4, 2]], ()),
                                           (quarter, (0.3, 0.3)), (quarter, (0.7, 0.1))]):
        try:
            in_band(points, *args)
        except ValueError:
            continue
        raise AssertionError(f"band edge case {case} (points {points}, (low, high) = {args}): fewer than 3 points, "
                             "no chord or an empty band: raise ValueError")
    # the legs: the chord range is inclusive, the band strict, the padding one beam at the middle point's range
    increment = float(np.radians(0.5))
    exact = [[2.0, -0.125], [1.9375, 0.0], [2.0, 0.125]]  # chord 0.25, middle point 1/4 of it towards the sensor
    for case, (points, args, kwargs, want) in enumerate([
            (exact, (increment,), {"padding_beams": 0.0}, True),
            (exact, (increment,), {"padding_beams": 0.0, "chord_range": (0.25, 0.5)}, True),
            (exact, (increment,), {}, False),  # padded: 0.25 + 1.94 * 0.0087 m is too wide
            (exact, (increment,), {"padding_beams": 0.0, "middle_range": (0.25, 0.7)}, False),
            (exact, (-increment,), {"padding_beams": 0.0}, True),
            ([[2.0, -0.045], [1.96, 0.0], [2.0, 0.045]], (-increment,), {}, True),  # a clockwise scan: |increment|
            ([[2.0, -0.045], [1.96, 0.0], [2.0, 0.045]], (increment,), {"padding_beams": 0.0}, False),
            ([[2.0, 0.0], [1.95, 0.05], [2.0, 0.0]], (0.06,), {}, False),  # no chord, yet a padded width in range
            ([[2.0, -0.07], [2.0, 0.07]], (increment,), {}, False), ([], (increment,), {}, False),
            ([[40, -1], [39, 0], [40, 1]], (0,), {"chord_range": (1, 3)}, True),  # integers
            ([[2.0, -0.07], [2.05, 0.0], [2.0, 0.07]], (increment,), {}, False)]):  # hollow
        _check_leg(is_leg, points, args, kwargs, want, f"leg edge case {case} ({points})")


def test_own_work(inscribed_angles, is_circle, circle_from_angle, in_band, is_leg, rng):
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
    for trial in range(6):
        points, ratio = _band_shape(rng, float(rng.choice([-0.2, 0.05, 0.3, 0.5, 0.85])))
        _check_band(in_band, points, (), bool(0.1 < ratio < 0.7), f"own-work band {trial}")
    _check_built_legs(is_leg, rng, 6, "own-work leg")


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
''', "band_leg": '''
import labkit


def in_band(points, low=0.1, high=0.7):
    if not low < high:
        raise ValueError("low must be below high")
    return bool(low < labkit.middle_point_offset(points) < high)


def is_leg(points, angle_increment, chord_range=(0.1, 0.25), middle_range=(0.1, 0.7), padding_beams=1.0):
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return False
    width = np.hypot(*(p[-1] - p[0])) + padding_beams * abs(angle_increment) * np.hypot(*p[len(p) // 2])
    try:
        return bool(chord_range[0] <= width <= chord_range[1] and in_band(p, *middle_range))
    except ValueError:
        return False
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
    "band: the offset in metres, not divided by the chord": ("ratio = offset / chord", "ratio = offset"),
    "band: the edges swapped": ("in_band(p, *middle_range)", "in_band(p, *middle_range[::-1])"),
    "band: the edges inclusive (the paper's 0.1 d < x < 0.7 d is strict)": (
        "return bool(low < ratio < high)", "return bool(low <= ratio <= high)"),
    "band: either side of the chord (the sensor's side ignored)": (
        "offset = -offset if towards_sensor < 0 else offset", "offset = abs(offset)"),
    "band: the side away from the sensor": ("if towards_sensor < 0 else", "if towards_sensor > 0 else"),
    "band: the middle point as the mean of the points, not row M // 2": (
        "middle = p[len(p) // 2]", "middle = p.mean(axis=0)"),
    "band: no ValueError for an empty band (low == high)": ("if not low < high:", "if low > high:"),
    "leg: the width as the bare chord, not the padded diameter": (
        "width = chord + padding_beams * abs(angle_increment) * rho", "width = chord"),
    "leg: the padding without the middle point's range": (
        "padding_beams * abs(angle_increment) * rho", "padding_beams * abs(angle_increment)"),
    "leg: a negative angle increment narrows the leg": ("abs(angle_increment)", "angle_increment"),
    "leg: the chord range exclusive": (
        "chord_range[0] <= width <= chord_range[1]", "chord_range[0] < width < chord_range[1]"),
    "leg: in_band's ValueError for a zero chord escapes": ("if chord == 0.0:\n        return False", "pass"),
}
