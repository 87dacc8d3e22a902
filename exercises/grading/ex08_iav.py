"""Hidden tests of exercise 8, ``inscribed_angles(points)``, ``is_circle(points, std_max, mean_range)``,
``circle_from_angle(p_first, p_last, mean_angle, side)`` (the centre and radius, with the paper's erratum),
``in_band(points, low, high)`` (the circle prerequisite of Fig. 5) and ``is_leg(points, angle_increment,
chord_range, middle_range, padding_beams)`` (the leg criteria of Sec. II-E as ``labkit.detect_legs``
applies them with ``range_sigma_m=0``, the paper's test).

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit import sim
from labkit.grading import random_arc, random_band_segment, random_shape


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


def _exact(rng, points, integer=False):
    """``points`` turned about the sensor by a multiple of 90 degrees and scaled by a power of two (integer points:
    by 1, 2 or 4): every distance ratio and the sensor's side stay exactly as they were. Returns (points, scale)."""
    scale = float(2 ** rng.integers(0, 3)) if integer else float(2.0 ** rng.integers(-2, 3))
    quarter = int(rng.integers(0, 4))
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2) * scale
    for _ in range(quarter):
        p = np.column_stack([-p[:, 1], p[:, 0]])
    if integer:
        return p.astype(np.int64).tolist(), scale
    return p, scale


def _bool(got, what, where):
    assert isinstance(got, (bool, np.bool_)), f"{where}: {what} must return a bool, got {type(got).__name__}"
    return bool(got)


def _check_band(in_band, points, args, want, where):
    got = _bool(in_band(points, *args), "in_band", where)
    assert got == want, f"{where}: in_band{' with other edges' if args else ''} should be {want}, got {got}"


def _check_leg(is_leg, points, args, kwargs, want, where):
    got = _bool(is_leg(points, *args, **kwargs), "is_leg", where)
    assert got == want, f"{where}: is_leg should be {want}, got {got}"


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
                       f"{setting} scan {s} ({lidar.name}), a segment of {len(points)} points that labkit.detect_legs "
                       f"{'accepts' if want else 'rejects'}")
            checked += 1
    return checked


def _check_built_legs(is_leg, rng, count, setting):
    """Segments built with a known chord and middle point: the leg verdict in closed form."""
    for trial in range(count):
        chord = float(rng.uniform(0.03, 0.45))
        points, ratio = random_band_segment(rng, float(rng.uniform(-0.3, 0.9)), chord)
        increment = float(rng.choice([-1.0, 1.0]) * np.radians(rng.choice([0.25, 0.5, 1.0])))
        kwargs, (chord_range, middle_range, padding) = _leg_kwargs(rng)
        width = chord + padding * abs(increment) * float(np.hypot(*points[len(points) // 2]))
        if _near(width, chord_range, 1e-7) or _near(ratio, middle_range, 1e-7):
            continue
        want = bool(chord_range[0] <= width <= chord_range[1] and middle_range[0] < ratio < middle_range[1])
        _check_leg(is_leg, points, (increment,), kwargs, want, f"{setting} {trial} ({len(points)} points)")


def _check_circle(circle_from_angle, args, center, radius, where, atol=1e-6):
    got = circle_from_angle(*args)
    assert isinstance(got, tuple) and len(got) == 2, f"{where}: return (center, radius), got a {type(got).__name__}"
    c, r = got
    assert isinstance(c, np.ndarray) and c.shape == (2,), f"{where}: center must be an array of shape (2,)"
    scale = max(1.0, radius)
    if not np.allclose(c, center, rtol=0.0, atol=atol * scale):
        raise AssertionError(f"{where}: the centre is off (the height (d/2) tan(theta), theta = mean - 90 deg, away "
                             "from the points' side?)")
    if not abs(float(r) - radius) <= atol * scale:
        raise AssertionError(f"{where}: the radius is off ((d/2) / cos(theta)?)")


def _check_angles(inscribed_angles, points, where):
    reference = labkit.inscribed_angles(points)
    angles = inscribed_angles(points)
    assert isinstance(angles, np.ndarray), f"{where}: angles must be a numpy array, got {type(angles).__name__}"
    assert angles.shape == reference.shape, f"{where}: one angle per interior point, got shape {angles.shape}"
    assert np.issubdtype(angles.dtype, np.floating), f"{where}: angles must be floats, got {angles.dtype}"
    wrong = np.flatnonzero(~np.isclose(angles, reference, rtol=0.0, atol=1e-6))
    if wrong.size:
        raise AssertionError(f"{where}: {wrong.size} of {angles.size} angles differ from the reference (the first at "
                             f"interior point {wrong[0]}): radians, in [0, pi], the angle at P_i between P_1 and P_n")


def _check_verdict(is_circle, points, kwargs, where, exact=False):
    """is_circle against the test on labkit.iav_stats; False (no check) when too close to a threshold, unless the
    points are ``exact`` (integers whose angles and their mean are exact, e.g. exactly pi/2 on the edge)."""
    std_max = kwargs.get("std_max", 0.15)
    low, high = kwargs.get("mean_range", (np.pi / 2, 3 * np.pi / 4))
    mean, std, _ = labkit.iav_stats(points)
    if not exact and min(abs(std - std_max), abs(mean - low), abs(mean - high)) < 1e-6:
        return False  # too close to a threshold to grade fairly
    want = bool(std < std_max and low <= mean <= high)
    got = _bool(is_circle(points, **kwargs), "is_circle", where)
    assert got == want, f"{where}{' with other thresholds' if kwargs else ''}: is_circle should be {want}, got {got}"
    return True


def _decimal_line(rng):
    """A noise-free line of points with one-decimal coordinates: the cosine of its angles rounds past -1 more often
    than not (an unclipped arccos gives NaN)."""
    n = int(rng.integers(5, 12))
    dx, dy = 0, 0
    while dx == 0 and dy == 0:
        dx, dy = rng.integers(-9, 10, 2)
    x0, y0 = rng.integers(-50, 50, 2)
    return [[round((x0 + k * dx) / 10, 1), round((y0 + k * dy) / 10, 1)] for k in range(n)]


def _between_deviations(rng):
    """A random shape and thresholds that tell the population standard deviation from the sample one (ddof=1):
    std_max halfway between them, every mean allowed. The answer is True."""
    while True:
        points = random_shape(rng, str(rng.choice(["arc", "corner"])), int(rng.integers(4, 30)))
        _, std, _ = labkit.iav_stats(points)
        m = len(points) - 2
        if std > 0.01:
            return points, {"std_max": std * (1 + np.sqrt(m / (m - 1))) / 2, "mean_range": (0.0, np.pi)}


def _decisive_leg(rng):
    """A leg whose verdict needs every part of the width: seen by a clockwise scan (a negative increment) a few
    metres away, its bare chord too short, its padding too short without the middle point's range, but its padded
    width in range; the middle point in the default band. The answer is True."""
    while True:
        points, _ = random_band_segment(rng, float(rng.uniform(0.2, 0.6)), float(rng.uniform(0.04, 0.2)))
        rho = float(np.hypot(*points[len(points) // 2]))
        if rho > 2.0:
            break
    chord = float(np.hypot(*(points[-1] - points[0])))
    increment = -float(np.radians(rng.choice([0.5, 1.0])))
    width, without_range = chord + abs(increment) * rho, chord + abs(increment)
    return points, increment, {"chord_range": ((without_range + width) / 2, 1.5 * width)}


def _random_thresholds(rng):
    std_max = float(rng.uniform(0.02, 0.4))
    low = float(rng.uniform(0.0, 2.5))
    return {"std_max": std_max, "mean_range": (low, float(rng.uniform(low + 0.1, np.pi)))}


def _degenerate(rng):
    """Point sets whose inscribed angles are undefined: none, one, two points, identical ends, an interior point on
    an end point (as lists)."""
    a, b, c = (rng.integers(-5, 6, 2).tolist() for _ in range(3))
    while a == b:
        b = rng.integers(-5, 6, 2).tolist()
    return [("no points", []), ("one point", [a]), ("two points", [a, b]), ("identical ends", [a, c, a]),
            ("an interior point on an end point", [a, c, b, b])]


# ---------------------------------------------------------------------------- inscribed_angles
def test_hidden_random__inscribed_angles(inscribed_angles, rng):
    """200 random noisy arcs, lines and V-corners against labkit.inscribed_angles, to 1e-6."""
    for trial in range(200):
        kind = ("arc", "arc", "line", "corner")[trial % 4]
        n = int(rng.integers(3, 61)) if trial % 3 else int(rng.integers(3, 8))
        _check_angles(inscribed_angles, random_shape(rng, kind, n), f"random {kind} {trial} ({n} points)")


#: Exact shapes, as integer lists (turned by quarter turns and scaled when graded), and their known angles.
EXACT_SHAPES = [([[0, 0], [1, 1], [2, 0]], "a right angle"), ([[0, 0], [1, 0], [2, 1], [0, 0]], "identical ends"),
                ([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [5, 0]], "a line of integers"),
                ([[0, 1], [0, 0], [1, 0]], "a corner of three points")]


def test_hidden_edges__inscribed_angles(inscribed_angles, rng):
    """0 to 2 points, identical ends and an interior point on an end (ValueError); integer lists, identical end
    points, exact lines and corners, turned and scaled."""
    for what, points in _degenerate(rng):
        if what == "identical ends":
            continue  # defined: every angle is 0 (graded below)
        try:
            inscribed_angles(points)
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError(f"{what}: the angles are undefined, raise ValueError")
    for points, what in EXACT_SHAPES:
        moved, _ = _exact(rng, points, integer=True)
        _check_angles(inscribed_angles, moved, f"edge case: {what} (integers in a list)")
    t = np.radians(np.sort(rng.uniform(-60.0, 60.0, int(rng.integers(3, 12)))))
    _check_angles(inscribed_angles, (np.column_stack([-np.cos(t), np.sin(t)]) * rng.uniform(0.1, 3.0)).tolist(),
                  "edge case: an arc as a list of floats")
    for trial in range(12):
        _check_angles(inscribed_angles, _decimal_line(rng), f"a straight line of decimals {trial} (clip the cosine)")


def test_own_work__inscribed_angles(inscribed_angles, rng):
    """Six more random arcs: right answers where labkit cannot be imported."""
    for trial in range(6):
        _check_angles(inscribed_angles, random_shape(rng, "arc", int(rng.integers(4, 40))), f"own-work arc {trial}")
    for trial in range(12):
        _check_angles(inscribed_angles, _decimal_line(rng), f"own-work straight line {trial}")


# ---------------------------------------------------------------------------- is_circle
def test_hidden_random__is_circle(is_circle, rng):
    """200 random noisy arcs, lines and V-corners: the verdict against a test on labkit.iav_stats with the same
    thresholds (the defaults, or random ones)."""
    checked = 0
    for trial in range(200):
        kind = ("arc", "arc", "line", "corner")[trial % 4]
        n = int(rng.integers(3, 61)) if trial % 3 else int(rng.integers(3, 8))
        kwargs = {} if trial % 2 else _random_thresholds(rng)
        checked += _check_verdict(is_circle, random_shape(rng, kind, n), kwargs, f"random {kind} {trial} ({n} points)")
    assert checked > 150, "the hidden test skipped too many cases"
    for trial in range(3):
        _check_verdict(is_circle, *_between_deviations(rng), f"random shape {trial} with std_max between the "
                       "population and the sample deviation", exact=True)


def test_hidden_edges__is_circle(is_circle, rng):
    """Undefined angles (False, never an exception); integers, identical ends, exact lines and arcs, other
    thresholds, a bent arc."""
    for what, points in _degenerate(rng):
        if what == "identical ends":
            continue
        for form in (points, np.array(points, dtype=float).reshape(-1, 2)):
            assert not _bool(is_circle(form), "is_circle", what), f"{what}: is_circle must return False"
    t = np.linspace(-60.0, 60.0, int(rng.integers(5, 12)))
    arc_120 = np.column_stack([-np.cos(np.radians(t)), np.sin(np.radians(t))]) * rng.uniform(0.2, 3.0)  # mean 120 deg
    bent = arc_120.copy()
    bent[len(t) // 2:, 1] += 0.05 * np.abs(arc_120).max()
    cases = [(EXACT_SHAPES[0][0], {}), (EXACT_SHAPES[0][0], {"mean_range": (0.5, 1.5)}),
             (EXACT_SHAPES[1][0], {}), (EXACT_SHAPES[1][0], {"mean_range": (0.0, 0.5), "std_max": 0.01}),
             (EXACT_SHAPES[2][0], {}), (EXACT_SHAPES[2][0], {"std_max": 0.05, "mean_range": (3.0, np.pi)}),
             (arc_120.tolist(), {}), (arc_120.tolist(), {"mean_range": (np.pi / 2, 2.0)}),  # 2.094 rad: too large
             (bent, {"std_max": 0.01}), (EXACT_SHAPES[3][0], {"mean_range": (1.5, 1.6), "std_max": 1e-3})]
    for case, (points, kwargs) in enumerate(cases):
        exact = isinstance(points[0][0], int)
        if exact:
            points, _ = _exact(rng, points, integer=True)
        assert _check_verdict(is_circle, points, kwargs, f"edge case {case}", exact), "an edge case on a threshold"
    for trial in range(3):
        _check_verdict(is_circle, *_between_deviations(rng), f"std_max between the population and the sample "
                       f"deviation {trial}", exact=True)


def test_own_work__is_circle(is_circle, rng):
    """Six more random arcs with the default thresholds: right answers where labkit cannot be imported."""
    for trial in range(6):
        t = float(rng.uniform(-np.pi, np.pi)) + np.sort(rng.uniform(0.0, np.radians(200.0), int(rng.integers(4, 40))))
        points = float(rng.uniform(0.1, 1.0)) * np.column_stack([np.cos(t), np.sin(t)])
        _check_verdict(is_circle, points + 0.01 * rng.standard_normal(points.shape), {}, f"own-work arc {trial}")
    for trial in range(3):
        _check_verdict(is_circle, *_between_deviations(rng), f"own-work thresholds {trial}", exact=True)


# ---------------------------------------------------------------------------- circle_from_angle
def test_hidden_random__circle_from_angle(circle_from_angle, rng):
    """100 random arcs: the circle from their ends and mean inscribed angle against the circle they come from."""
    for trial in range(100):
        args, center, radius = random_arc(rng)
        _check_circle(circle_from_angle, args, center, radius, f"random circle {trial}")


def test_hidden_edges__circle_from_angle(circle_from_angle, rng):
    """A half circle and a quarter given as integer lists and tuples; the undefined ones (no chord, an angle of 0,
    pi or outside, side 0 or NaN): ValueError."""
    k, shift = int(rng.integers(1, 5)), rng.integers(-5, 6, 2)
    start = rng.integers(0, 4)
    ends = [np.array(v) for v in ([k, 0], [0, k], [-k, 0], [0, -k])]
    p1, p2, p3 = ends[start] + shift, ends[(start + 1) % 4] + shift, ends[(start + 2) % 4] + shift
    _check_circle(circle_from_angle, (p1.tolist(), p3.tolist(), np.pi / 2, -int(rng.integers(1, 4))),
                  shift.astype(float), float(k), "a half circle, integers in lists")
    _check_circle(circle_from_angle, (tuple(p2.tolist()), tuple(p1.tolist()), 3 * np.pi / 4, int(rng.integers(1, 4))),
                  shift.astype(float), float(k), "a quarter circle, integers in tuples")
    a, b = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
    for what, args in [("no chord", (a.tolist(), a.tolist(), float(rng.uniform(0.5, 2.5)), 1)),
                       ("a mean angle of 0", (a, b, 0.0, 1)), ("a mean angle of pi", (a, b, np.pi, 1)),
                       ("a negative mean angle", (a, b, -float(rng.uniform(0.1, 2.0)), 1)),
                       ("side 0", (a, b, float(rng.uniform(0.5, 2.5)), 0)),
                       ("side NaN", (a, b, float(rng.uniform(0.5, 2.5)), np.nan))]:
        try:
            circle_from_angle(*args)
        except ValueError:
            continue
        raise AssertionError(f"an undefined circle ({what}): raise ValueError")


def test_own_work__circle_from_angle(circle_from_angle, rng):
    """Six more random arcs: right answers where labkit cannot be imported."""
    for trial in range(6):
        args, center, radius = random_arc(rng)
        _check_circle(circle_from_angle, args, center, radius, f"own-work circle {trial}")


# ---------------------------------------------------------------------------- in_band
def test_hidden_random__in_band(in_band, rng):
    """150 random segments built with a known middle point: the band, the default edges or random ones."""
    for trial in range(150):
        points, ratio = random_band_segment(rng)
        low, high, args = 0.1, 0.7, ()
        if trial % 2:
            low = float(rng.uniform(-0.3, 0.5))
            high = low + float(rng.uniform(0.1, 0.6))
            args = (low, high)
        if _near(ratio, (low, high), 1e-7):
            continue
        _check_band(in_band, points, args, bool(low < ratio < high), f"random segment {trial} ({len(points)} points)")


QUARTER = [[4, -2], [3, 0], [4, 2]]  # the middle point 1/4 of the chord towards the sensor, exactly
#: Exact band cases (integer points turned by quarter turns and scaled when graded): (points, (low, high), answer).
BAND_CASES = [(QUARTER, (), True), (QUARTER, (0.25, 0.5), False), (QUARTER, (0.125, 0.25), False),
              (QUARTER, (0.125, 0.375), True), (QUARTER[::-1], (), True), ([[-4, 2], [-3, 0], [-4, -2]], (), True),
              ([[4, -2], [5, 0], [4, 2]], (), False), ([[4, -2], [5, 0], [4, 2]], (-0.5, 0.0), True),
              ([[4, -2], [4, -1], [3, 1], [4, 2]], (), True),  # the middle point is row 2 of 4
              ([[4, -2], [3, -1], [4, 1], [4, 2]], (), False)]  # row 1 bulges, row 2 is on the chord


def test_hidden_edges__in_band(in_band, rng):
    """The band's exact edges (strict), the sensor's side, the middle row of an even number of points, turned and
    scaled; fewer than 3 points, no chord, an empty band (ValueError)."""
    for case, (points, args, want) in enumerate(BAND_CASES):
        moved, _ = _exact(rng, points, integer=True)
        _check_band(in_band, moved if case % 2 else tuple(map(tuple, moved)), args, want, f"band edge case {case}")
    moved, _ = _exact(rng, QUARTER, integer=True)
    for what, points, args in [("no points", [], ()), ("two points", moved[::2], ()),
                               ("no chord", [moved[0], moved[1], moved[0]], ()), ("an empty band", moved, (0.3, 0.3)),
                               ("low above high", moved, (0.7, 0.1))]:
        try:
            in_band(points, *args)
        except ValueError:
            continue
        raise AssertionError(f"in_band with {what}: raise ValueError")


def test_own_work__in_band(in_band, rng):
    """Six more segments: right answers where labkit cannot be imported."""
    for trial, ratio in enumerate(rng.permutation([-0.2, 0.05, 0.3, 0.5, 0.85, 0.15])):
        points, ratio = random_band_segment(rng, float(ratio), float(rng.uniform(0.05, 0.3)))  # a leg's size
        _check_band(in_band, points, (), bool(0.1 < ratio < 0.7), f"own-work segment {trial}")


# ---------------------------------------------------------------------------- is_leg
def test_hidden_random__is_leg(is_leg, rng):
    """Every segment of 8 simulated scans against labkit.detect_legs; 80 segments of known chord in closed form."""
    assert _check_sim_legs(is_leg, rng, 8, "random") > 40, "the hidden test skipped too many segments"
    _check_built_legs(is_leg, rng, 80, "random leg")
    for trial in range(3):
        points, increment, kwargs = _decisive_leg(rng)
        _check_leg(is_leg, points, (increment,), kwargs, True, f"a leg seen by a clockwise scan {trial}")


#: Exact leg cases (chord 0.25, the middle point 1/4 of it towards the sensor), turned and scaled when graded:
#: (points, angle increment in half degrees, kwargs, answer).
EXACT_LEG = [[2.0, -0.125], [1.9375, 0.0], [2.0, 0.125]]
LEG_CASES = [(EXACT_LEG, 1, {"padding_beams": 0.0}, True),
             (EXACT_LEG, 1, {"padding_beams": 0.0, "chord_range": (0.25, 0.5)}, True),
             (EXACT_LEG, 1, {}, False),  # padded: 0.25 + 1.94 * 0.0087 m is too wide
             (EXACT_LEG, 1, {"padding_beams": 0.0, "middle_range": (0.25, 0.7)}, False),
             (EXACT_LEG, -1, {"padding_beams": 0.0}, True),
             ([[2.0, -0.045], [1.96, 0.0], [2.0, 0.045]], -1, {}, True),  # a clockwise scan: |increment|
             ([[2.0, -0.045], [1.96, 0.0], [2.0, 0.045]], 1, {"padding_beams": 0.0}, False),
             ([[2.0, 0.0], [1.95, 0.05], [2.0, 0.0]], 12, {}, False),  # no chord, yet a padded width in range
             ([[2.0, -0.07], [2.0, 0.07]], 1, {}, False), ([], 1, {}, False),
             ([[2.0, -0.07], [2.05, 0.0], [2.0, 0.07]], 1, {}, False)]  # hollow


def test_hidden_edges__is_leg(is_leg, rng):
    """The chord range inclusive, the band strict, the padding one beam at the middle point's range, a clockwise
    scan, no chord, fewer than 3 points, a hollow: turned and scaled about the sensor (the chord range with it)."""
    half_degree = float(np.radians(0.5))
    for case, (points, steps, kwargs, want) in enumerate(LEG_CASES):
        moved, scale = _exact(rng, points) if points else (np.zeros((0, 2)), 1.0)
        kwargs = dict(kwargs, chord_range=tuple(scale * np.asarray(kwargs.get("chord_range", (0.1, 0.25)))))
        _check_leg(is_leg, moved, (steps * half_degree,), kwargs, want, f"leg edge case {case}")
    points, _ = _exact(rng, [[40, -1], [39, 0], [40, 1]], integer=True)
    _check_leg(is_leg, points, (0,), {"chord_range": (1, 8)}, True, "a leg of integers")
    for trial in range(2):
        points, increment, kwargs = _decisive_leg(rng)
        _check_leg(is_leg, points, (increment,), kwargs, True, f"a leg seen by a clockwise scan {trial}")


def test_own_work__is_leg(is_leg, rng):
    """Six more segments of known chord, and legs seen by a clockwise scan: right answers where labkit cannot be
    imported."""
    _check_built_legs(is_leg, rng, 6, "own-work leg")
    for trial in range(3):
        points, increment, kwargs = _decisive_leg(rng)
        _check_leg(is_leg, points, (increment,), kwargs, True, f"own-work leg, a clockwise scan {trial}")


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
