"""The cases of the course notebooks' "your turn" checks, kept here so that a check cell stays short.

A check cell reads ``f = check(f, cases.NAME(), fallback=fallbacks.NAME)``: the cases below give inputs
whose answers follow from geometry worked out by hand (written beside each case), and a hint for each;
:func:`labkit.course.check` runs them. No answer is written here, only the values it must give.
"""

from __future__ import annotations

import math

import numpy as np

from .course import Case

__all__ = ["intersection", "is_v_shaped", "middle_ratio", "radius_and_height", "ray_axis_error", "similar_lines",
           "three_beam_residual", "triplet_direction", "wall_offsets", "pair_two_legs",
           "normal_form_match", "jacobian", "ideal_weights", "simulated_weights",
           "fewer_lines_share", "compose_poses", "pose_at", "config_for", "closed_form_alpha",
           "chord_distances", "iepf", "is_core", "is_border", "cut_points", "adaptive_threshold"]


def _line(r: float, degrees: float):
    """A line (r, alpha) to test with: labkit's LineSegment record, its other fields unused."""
    from .features import LineSegment

    return LineSegment(r=r, alpha=math.radians(degrees), covariance=np.full((2, 2), np.nan), start=np.zeros(2),
                       end=np.zeros(2), first=0, last=1, n_points=2, error=0.0, indices=np.arange(2))


def similar_lines(piece_a, piece_b) -> list[Case]:
    """Notebook 05: cases of ``similar_lines(a, b, dr_max_m, dalpha_max)``, with 5 cm and 5 degrees.

    Parameters
    ----------
    piece_a, piece_b : labkit.LineSegment
        Two pieces of one wall whose normals lie near +180 and -180 degrees; labkit's own test
        (:func:`labkit.course_fallbacks.similar_lines`) gives their expected answer.

    Returns
    -------
    list of Case
        Lines 3 cm and 2 degrees apart (similar), 10 cm apart (not), 178 and -179 degrees (similar:
        3 degrees apart), one line through near the sensor with opposite normals (similar), walls 2 m
        ahead and behind (not), and the two pieces.
    """
    from .course_fallbacks import similar_lines as labkits

    strict = {"dr_max_m": 0.05, "dalpha_max": math.radians(5.0)}
    return [
        Case((_line(2.0, 10.0), _line(2.03, 12.0)), True, kwargs=strict, hint="3 cm and 2 degrees apart: similar"),
        Case((_line(2.0, 10.0), _line(2.1, 10.0)), False, kwargs=strict, hint="|r2 - r1| = 0.1 m is not < dr_max_m"),
        Case((_line(3.0, 178.0), _line(3.01, -179.0)), True, kwargs=strict,
             hint="angles wrap: 178 and -179 degrees are 3 degrees apart, not 357"),
        Case((_line(0.02, 10.0), _line(0.01, -170.0)), True, kwargs=strict,
             hint="one line with opposite normals: compare with (-r2, alpha2 + pi)"),
        Case((_line(2.0, 0.0), _line(2.0, 180.0)), False, kwargs=strict, hint="walls 2 m ahead and 2 m behind"),
        Case((piece_a, piece_b), labkits(piece_a, piece_b), label="the office's two pieces behind the robot",
             hint="angles wrap: the two pieces' normals are close to +180 and -180 degrees"),
    ]


def _is_none(got, expected) -> bool:
    return got is None


def intersection(first, second, corner_point) -> list[Case]:
    """Notebook 05: cases of ``intersection(r1, alpha1, r2, alpha2)``.

    Parameters
    ----------
    first, second : labkit.LineSegment
        The two lines of a corner labkit found.
    corner_point : array_like
        That corner's point, which the intersection of ``first`` and ``second`` must give.

    Returns
    -------
    list of Case
        ``x = 2`` and ``y = 1`` meet at (2, 1); ``x + y = 2`` and ``x = 0.5`` at (0.5, 1.5); ``x = 1`` and
        ``x = 2`` never (None), nor ``x = 1`` and ``x = -1`` (opposite normals); and the corner.
    """
    return [
        Case((2.0, 0.0, 1.0, math.pi / 2), [2.0, 1.0], hint="x = 2 and y = 1 meet at (2, 1): check y"),
        Case((math.sqrt(2.0), math.pi / 4, 0.5, 0.0), [0.5, 1.5], hint="x + y = 2 and x = 0.5 meet at (0.5, 1.5)"),
        Case((1.0, 0.0, 2.0, 0.0), None, compare=_is_none,
             hint="parallel lines (x = 1, x = 2) never meet: return None"),
        Case((1.0, 0.0, 1.0, math.pi), None, compare=_is_none,
             hint="x = 1 and x = -1 (normals opposite) are parallel too: return None"),
        Case((first.r, first.alpha, second.r, second.alpha), np.asarray(corner_point), atol=1e-9,
             label="the room's first corner", hint="the corner labkit found between these two lines"),
    ]


def _same_verdict(got, want) -> bool:
    return isinstance(got, (bool, np.bool_)) and bool(got) == want


def is_v_shaped(clean_corner, stride: int) -> list[Case]:
    """Notebook 08: cases of ``is_v_shaped(angles, n_neighbours=4, stride=1)``.

    Parameters
    ----------
    clean_corner : ndarray
        The inscribed angles of a noise-free V-shaped corner (radians): a V at ``stride``.
    stride : int
        The stride to try ``clean_corner`` with.

    Returns
    -------
    list of Case
        A clean V, an arc's wobbling angles, a flat apex (two equal smallest angles), a minimum too near
        an end for two neighbours (and with one), a dense V whose neighbours swap next to the apex (at
        stride 1 and 2), and the clean corner. The answer must be a bool.
    """
    v_dense = np.radians([150, 140, 130, 121, 112, 112, 100, 103, 111, 120, 131, 140, 150])  # noise beside the apex
    return [
        Case((np.radians([170, 150, 120, 90, 120, 150, 170]),), True, "the smallest angle's neighbours grow on both "
             "sides: a V", compare=_same_verdict),
        Case((np.radians([120, 118, 121, 117, 122, 119, 120]),), False, "an arc's angles wobble around one value: "
             "the neighbours must grow strictly away from the minimum on both sides", compare=_same_verdict),
        Case((np.radians([150, 120, 90, 90, 120, 150]),), False, "strictly: two equal angles at the apex are no V",
             compare=_same_verdict),
        Case((np.radians([130, 100, 120, 150, 170]),), False, "the minimum has only one angle on its left: "
             "n_neighbours // 2 = 2 are needed on each side, else False", compare=_same_verdict),
        Case((np.radians([130, 100, 120, 150, 170]),), True, "n_neighbours=2: one neighbour on each side",
             kwargs={"n_neighbours": 2}, compare=_same_verdict),
        Case((v_dense,), False, "stride 1: the neighbours next to the apex (112, 112) do not grow",
             compare=_same_verdict),
        Case((v_dense,), True, "take the neighbours stride angles apart, not next to each other",
             kwargs={"stride": 2}, compare=_same_verdict),
        Case((np.asarray(clean_corner),), True, "the corner above: its angles grow away from the apex",
             kwargs={"stride": stride}, compare=_same_verdict),
    ]


def middle_ratio() -> list[Case]:
    """Notebook 08: cases of ``middle_ratio(points, viewpoint)``.

    Returns
    -------
    list of Case
        A half circle of the unit circle bulging towards +y (0.5, or -0.5 seen from below), 120 degrees of
        it (``tan(30 deg) / 2``, 0.2887), the half circle moved and scaled, and a straight segment (0).
    """
    t = np.radians([0.0, 45.0, 90.0, 135.0, 180.0])
    half_circle = np.c_[np.cos(t), np.sin(t)]                     # bulges towards +y: offset 0.5 d
    t120 = np.radians(np.linspace(30.0, 150.0, 7))
    column_120 = np.c_[np.cos(t120), np.sin(t120)]                # 120 deg: (1/2) tan(30 deg) = 0.2887
    return [
        Case((half_circle, (0.0, 10.0)), 0.5, "offset over the chord length d: a half circle gives 0.5"),
        Case((column_120, (0.0, 10.0)), 0.5 * np.tan(np.radians(30.0)), "divide the offset by the chord length d"),
        Case((half_circle, (0.0, -10.0)), -0.5, "the sign: negative when the middle point is on the far side "
             "of the chord from the viewpoint"),
        Case((2.0 * half_circle + 5.0, (5.0, 20.0)), 0.5,
             "moved and scaled: measure from P_1, divide by |P_n - P_1|"),
        Case(([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0]], (0.0, 0.0)), 0.0, "a straight segment gives 0"),
    ]


def _same_pair(got, want) -> bool:
    return len(got) == 2 and bool(np.allclose(np.asarray(got, dtype=float), want, atol=1e-9))


def radius_and_height() -> list[Case]:
    """Notebook 08: cases of ``radius_and_height(chord, mean_angle)``.

    Each case is an arc of ``span`` degrees of a circle of radius ``R``: its chord is ``2 R sin(span / 2)``,
    its points see the chord under ``180 deg - span / 2``, and the centre lies ``R cos(span / 2)`` from the
    chord's midpoint, away from the points.

    Returns
    -------
    list of Case
        Arcs of 120, 90, 180 and 240 degrees; the answer is a pair ``(R, height)``.
    """
    cases = []
    for radius, span, hint_text in [
            (0.25, 120.0, "the centre's height above the chord is (d/2) tan(theta): half the chord"),
            (1.0, 90.0, "theta = mean_angle - 90 deg; radius (d/2) / cos(theta)"),
            (0.5, 180.0, "a half circle: the centre is the chord's midpoint, height 0"),
            (2.0, 240.0, "more than half a circle: tan(theta) < 0 puts the centre on the points' side"),
    ]:
        half = np.radians(span) / 2
        cases.append(Case((2 * radius * np.sin(half), np.pi - half), (radius, radius * np.cos(half)), hint_text,
                          compare=_same_pair, label=f"arc of {span:.0f} deg of R = {radius} m"))
    return cases


def ray_axis_error() -> list[Case]:
    """Notebook 10b: cases of ``ray_axis_error(range_m, angle, line_r, line_alpha)``.

    Returns
    -------
    list of Case
        A beam along the line's normal, two slanted beams (walls ``x = 2`` and ``x + y = 2 sqrt(2)``)
        and a beam pointing away from the line (NaN).
    """
    return [
        Case((2.5, 0.0, 2.0, 0.0), 0.5, "a beam along the line's normal: its error is the range minus r"),
        Case((4.1, math.radians(60), 2.0, 0.0), 0.1,
             "60 deg off the normal the ray reaches the wall x = 2 at (2, 2 tan 60 deg), 4 m away: "
             "measure along the ray"),
        Case((1.9, math.radians(90), 2.0, math.radians(45)), 1.9 - 2.0 * math.sqrt(2),
             "the wall x + y = 2 sqrt(2) meets the y axis at y = 2 sqrt(2): measure along the ray"),
        Case((3.0, math.radians(100), 2.0, 0.0), math.nan,
             "a ray 100 deg from the normal points away from the line: it never meets it ahead of the sensor (NaN)"),
    ]


def _wall_ranges(d: float, alpha: float, thetas) -> tuple[float, ...]:
    """The ranges of beams at the angles ``thetas`` on the wall ``x cos(alpha) + y sin(alpha) = d``."""
    return tuple(float(d / math.cos(t - alpha)) for t in thetas)


def three_beam_residual() -> list[Case]:
    """Notebook 10b: cases of ``three_beam_residual(r_prev, r_mid, r_next, dtheta)``.

    Returns
    -------
    list of Case
        Three beams on a wall (0), three on a wall 70 degrees off its normal (0), a 1 cm error on the
        middle range of the first (about -1 cm, exactly ``-0.01 r_mid' / r_mid``), and three equal ranges,
        on a circle about the sensor (``r (1 - 1 / cos(dtheta))``).
    """
    step = math.radians(0.5)
    near = _wall_ranges(2.0, 0.0, [math.radians(10) - step, math.radians(10), math.radians(10) + step])
    steep = _wall_ranges(3.0, math.radians(-60), [math.radians(9), math.radians(10), math.radians(11)])
    bumped = (near[0], near[1] + 0.01, near[2])
    return [
        Case((*near, step), 0.0, "three points on one wall give 0: the neighbours' inverse ranges add up to "
             "2 cos(dtheta) times the middle one's, so divide their sum by 2 cos(dtheta)", atol=1e-12),
        Case((*steep, math.radians(1)), 0.0, "0 on a wall at any incidence: divide by 2 cos(dtheta)", atol=1e-12),
        Case((*bumped, step), -0.01 * bumped[1] / near[1],
             "a 1 cm error on the middle range gives about -1 cm: multiply the inverse-range residual by r_mid**2"),
        Case((3.0, 3.0, 3.0, math.radians(1)), 3.0 * (1 - 1 / math.cos(math.radians(1))),
             "equal ranges lie on a circle, which bends away from the chord: s = r (1 - 1 / cos(dtheta))"),
    ]


def _on_line(direction_deg: float, offset=(1.0, 2.0)) -> tuple:
    """Three points on the line through ``offset`` with the given direction (closed form)."""
    u = np.array([np.cos(np.radians(direction_deg)), np.sin(np.radians(direction_deg))])
    return tuple(np.asarray(offset) + t * u for t in (-0.3, 0.1, 0.5))


def _same_direction(got, want) -> bool:
    """Equal modulo pi, and ``got`` in [0, pi)."""
    return bool(abs(np.cos(2 * got) - np.cos(2 * want)) < 1e-9 and abs(np.sin(2 * got) - np.sin(2 * want)) < 1e-9
                and 0 <= got < np.pi)


def triplet_direction(scan, phi, i: int) -> list[Case]:
    """Notebook 07: cases of ``triplet_direction(p0, p1, p2)``, compared modulo pi, the answer in [0, pi).

    Parameters
    ----------
    scan : labkit.Scan
        A scan.
    phi : ndarray
        The local direction of every beam of ``scan``, from :func:`labkit.local_directions`.
    i : int
        A beam with a local direction: the triplet of beams ``i - 1 .. i + 1`` must give ``phi[i]``.

    Returns
    -------
    list of Case
        Three points on lines at 30, 135 and 90 degrees, and the scan's triplet.
    """
    return [
        Case(_on_line(30.0), np.radians(30.0), label="3 points on a line at 30 deg",
             hint="the direction of largest spread: half the angle atan2 gives", compare=_same_direction),
        Case(_on_line(135.0), np.radians(135.0), label="3 points on the line y = -x (135 deg)",
             hint="directions are taken modulo pi, in [0, pi): 135 deg, not -45 deg", compare=_same_direction),
        Case(_on_line(90.0), np.radians(90.0), label="3 points on a vertical line", hint="atan2, not arctan of a ratio",
             compare=_same_direction),
        Case(tuple(scan.points[i - 1:i + 2]), phi[i], label=f"beams {i - 1}..{i + 1} of the corridor scan",
             hint="centre the points on their mean before you sum the squares", compare=_same_direction),
    ]


def wall_offsets(points, direction: float, offsets) -> list[Case]:
    """Notebook 07: cases of ``wall_offsets(points, direction)``.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        The points of an angular cluster.
    direction : float
        The cluster's mean direction, radians.
    offsets : ndarray, shape (N,)
        The offsets labkit gives those points (``angular_arrays(scan).distances``).

    Returns
    -------
    list of Case
        Points on ``y = -0.8`` at direction 0 (offsets -0.8), on ``x = 2`` at 90 degrees (-2), and the
        cluster.
    """
    xs = np.linspace(-1.0, 5.0, 7)
    return [
        Case((np.column_stack([xs, np.full(7, -0.8)]), 0.0), np.full(7, -0.8), label="points on y = -0.8, direction 0",
             hint="the offset is measured across the line, along its normal (-sin, cos), not along it"),
        Case((np.column_stack([np.full(7, 2.0), xs]), np.pi / 2), np.full(7, -2.0),
             label="points on x = 2, direction 90 deg", hint="normal of direction phi: (-sin phi, cos phi)"),
        Case((np.asarray(points), direction), np.asarray(offsets), atol=1e-9,
             label="the corridor walls' points, their cluster's mean direction",
             hint="d = -x sin(direction) + y cos(direction)"),
    ]


def _same_person(got, want) -> bool:
    return (got is None) == (want is None) and (want is None or bool(np.allclose(got, want, atol=1e-9)))


def pair_two_legs(two_legs) -> list[Case]:
    """Notebook 08b: cases of ``pair_two_legs(centre_a, centre_b, max_distance_m=0.6)``.

    Parameters
    ----------
    two_legs : list of list of labkit.Leg
        Scans' detections of exactly two legs each: :func:`labkit.circles.legs.pair_legs` on each gives
        the expected person (or None).

    Returns
    -------
    list of Case
        Legs 0.3 m apart (the midpoint), 0.9 m (None), exactly 0.6 m (pairs: the limit is included),
        0.71 m though 0.5 m apart in x and in y (None), 0.3 m with a 0.2 m limit (None), then the scans.
    """
    from .circles.legs import pair_legs

    def case(*args, **kwargs):
        return Case(*args, compare=_same_person, **kwargs)

    cases = [case(((0.0, 0.0), (0.3, 0.0)), (0.15, 0.0), "the person stands half-way between the legs"),
             case(((1.0, 2.0), (1.0, 2.9)), None, "legs 0.9 m apart are not one person's: return None"),
             case(((0.0, 0.0), (0.6, 0.0)), (0.3, 0.0),
                  "exactly max_distance_m apart still pairs: the limit is included"),
             case(((0.0, 0.0), (0.5, 0.5)), None, "0.71 m apart: compare the distance between the centres, not x "
                  "and y separately"),
             case(((2.0, 1.0), (2.3, 1.0)), None, "use max_distance_m", kwargs={"max_distance_m": 0.2})]
    for f in two_legs:
        paired = pair_legs(f)
        cases.append(case((f[0].center, f[1].center), paired[0].center if paired else None,
                          "as labkit's pair_legs on this scan",
                          label=f"the legs of a hall scan, {np.hypot(*(f[0].center - f[1].center)):.2f} m apart"))
    return cases


def normal_form_match() -> list[Case]:
    """Notebook 10: cases of ``normal_form_match(line_r, line_alpha, wall_r, wall_alpha, max_dr_m, max_dalpha)``.

    Returns
    -------
    list of Case
        3 cm and 1 degree apart (True), 7 cm (False), 4 degrees (False), 179.5 and -179.5 degrees (True:
        1 degree apart), -2 and 358 degrees (True: the same angle), and 1 cm with a 5 mm limit (False).
    """
    deg = math.radians
    return [
        Case((2.0, deg(30), 2.03, deg(31)), True, "3 cm and 1 deg are inside both limits"),
        Case((2.0, deg(30), 2.07, deg(30)), False, "|dr| = 7 cm is more than 5 cm"),
        Case((2.0, deg(30), 2.0, deg(34)), False, "|dalpha| = 4 deg is more than 3 deg"),
        Case((2.0, deg(179.5), 2.0, deg(-179.5)), True,
             "179.5 deg and -179.5 deg are 1 deg apart: wrap the angle difference"),
        Case((1.0, deg(-2), 1.0, deg(358)), True, "-2 deg and 358 deg are the same angle: wrap the angle difference"),
        Case((2.0, 0.0, 2.01, 0.0), False, "a stricter limit applies when it is given", kwargs={"max_dr_m": 0.005}),
    ]


def jacobian(rho, theta, sigma: float) -> list[Case]:
    """Notebook 03: cases of ``jacobian(rho, theta, w, h=1e-6)``, checked through the covariance it gives.

    A Jacobian ``J`` passes when ``sigma**2 J J^T`` equals labkit's covariance of the same fit
    (:func:`labkit.fit_line_polar` with ``range_sigma=sigma``) to 1e-4.

    Parameters
    ----------
    rho, theta : ndarray
        A wall's ranges (m) and bearings (rad).
    sigma : float
        The constant range noise, metres.

    Returns
    -------
    list of Case
        The wall with ``w = 1 / rho``, with uniform weights, and a noise-free wall behind the sensor
        (alpha = pi, where alpha jumps between pi and -pi).
    """
    from .fitting import fit_line_polar

    def propagates_to(J, C):
        J = np.asarray(J, dtype=float)
        return J.ndim == 2 and J.shape[0] == 2 and bool(np.allclose(sigma**2 * J @ J.T, C, rtol=1e-4, atol=1e-12))

    behind = np.radians(np.arange(150, 210.1, 2.0))        # a noise-free wall behind the sensor: alpha = pi
    rho_behind = 3.0 / np.cos(behind - np.pi)
    return [
        Case((rho, theta, 1 / rho), fit_line_polar(rho, theta, 1 / rho, range_sigma=sigma).covariance,
             compare=propagates_to, label="the wall, w = 1/rho",
             hint="hold the weights fixed: pass the same w to every refit (the default 1/rho would change with "
                  "the nudged range)"),
        Case((rho, theta, np.ones_like(rho)), fit_line_polar(rho, theta, "uniform", range_sigma=sigma).covariance,
             compare=propagates_to, label="the wall, uniform weights", hint="use the weights w you are given"),
        Case((rho_behind, behind, 1 / rho_behind),
             fit_line_polar(rho_behind, behind, 1 / rho_behind, range_sigma=sigma).covariance,
             compare=propagates_to, label="a wall behind the sensor, alpha = pi",
             hint="alpha jumps between pi and -pi: take its difference with labkit.angle_difference"),
    ]


def simulated_weights(sigma, theta, alpha: float, r: float = 1.0, n: int = 200_000, seed: int = 7) -> np.ndarray:
    """``1 / Var(d_i)`` measured: noisy ranges to the line (r, alpha), their orthogonal distances, the variance.

    Parameters
    ----------
    sigma : float or ndarray
        The range noise, one or one per beam, metres.
    theta : ndarray
        The beams, radians.
    alpha : float
        The line's normal angle, radians.
    r : float, default 1.0
        The line's distance, metres.
    n : int, default 200000
        Noisy copies.
    seed : int, default 7
        The generator's seed.

    Returns
    -------
    ndarray
        One weight per beam.
    """
    sigma = np.broadcast_to(sigma, np.shape(theta))
    noisy = r / np.cos(theta - alpha) + sigma * np.random.default_rng(seed).standard_normal((n, len(theta)))
    return 1 / np.var(noisy * np.cos(theta - alpha) - r, axis=0)


def ideal_weights() -> list[Case]:
    """Notebook 03: cases of ``ideal_weights(sigma, theta, alpha)``, against :func:`simulated_weights` (2 %).

    Returns
    -------
    list of Case
        Beams at 0, 40 and 60 degrees with 2 cm of noise and alpha = 0, and with 1, 2 and 4 cm and alpha = 20 deg.
    """
    three = np.radians([0.0, 40.0, 60.0])
    sigmas = np.array([0.01, 0.02, 0.04])
    return [
        Case((0.02, three, 0.0), simulated_weights(0.02, three, 0.0), rtol=0.02, label="sigma 2 cm, beams 0/40/60 deg",
             hint="a range error e moves the point across the line by e cos(theta - alpha): Var(d) = "
                  "sigma^2 cos^2(theta - alpha), and the weight is its inverse"),
        Case((sigmas, three, np.radians(20.0)), simulated_weights(sigmas, three, np.radians(20.0)), rtol=0.02,
             label="one sigma per beam, alpha = 20 deg", hint="use each point's own sigma_i"),
    ]


def fewer_lines_share(iepf, angular) -> list[Case]:
    """Notebook 09b: cases of ``fewer_lines_share(a, b)``, the share of scans where run ``b`` found fewer lines.

    Parameters
    ----------
    iepf, angular : list of labkit.Features
        Two runs over the same scans; some scans must have as many lines in both (else the strictness
        of "fewer" goes untested).

    Returns
    -------
    list of Case
        Both orders of the two runs (counted here from ``counts()["lines"]``), and the first 50 scans of
        ``iepf`` against themselves (0).

    Raises
    ------
    ValueError
        When no scan has as many lines in both runs.
    """
    lines_iepf = np.array([f.counts()["lines"] for f in iepf])
    lines_angular = np.array([f.counts()["lines"] for f in angular])
    if not (lines_iepf == lines_angular).any():
        raise ValueError("the check needs scans where both find as many lines")
    return [
        Case((iepf, angular), float(np.mean(lines_angular < lines_iepf)),
             "strictly fewer: a scan where both find as many lines does not count", label="iepf, angular"),
        Case((angular, iepf), float(np.mean(lines_iepf < lines_angular)), "b is the run that finds fewer",
             label="angular, iepf"),
        Case((iepf[:50], iepf[:50]), 0.0, "strictly fewer: a run never finds fewer lines than itself",
             label="feats[:50], feats[:50]"),
    ]


def compose_poses() -> list[Case]:
    """Notebook 11: cases of ``compose_poses(a, b)``, poses ``(x, y, theta)``.

    Returns
    -------
    list of Case
        Facing +y, 1 m ahead is +y: (1, 1, pi/2); facing -x, b = (0.5, -0.3, 0.4) lands at (1.5, 1.3) with
        heading pi + 0.4 wrapped to 0.4 - pi; headings 3 + 1 rad wrap to 4 - 2 pi.
    """
    return [
        Case(((1.0, 0.0, np.pi / 2), (1.0, 0.0, 0.0)), (1.0, 1.0, np.pi / 2),
             "facing +y, 1 m ahead is +y: rotate b's translation by a's heading"),
        Case(((2.0, 1.0, np.pi), (0.5, -0.3, 0.4)), (1.5, 1.3, 0.4 - np.pi),
             "facing -x, b's +x is -x and b's -y is +y; pi + 0.4 wraps to 0.4 - pi"),
        Case(((0.0, 0.0, 3.0), (0.0, 0.0, 1.0)), (0.0, 0.0, 4.0 - 2 * np.pi),
             "3 + 1 rad is past pi: wrap the angle to (-pi, pi]"),
    ]


def pose_at() -> list[Case]:
    """Notebook 11: cases of ``pose_at(t0, p0, t1, p1, t)``, linear between two stamped poses.

    Returns
    -------
    list of Case
        Halfway between (0, 0, 0) and (1, 2, 0.5): (0.5, 1, 0.25); from 170 to -170 degrees (+20 the short
        way round), a quarter: 175 degrees, three quarters: -175; at ``t0``: ``p0``.
    """
    a, b = (0.0, 0.0, np.radians(170)), (1.0, 2.0, np.radians(-170))
    return [
        Case((0, (0.0, 0.0, 0.0), 10, (1.0, 2.0, 0.5), 5), (0.5, 1.0, 0.25), "halfway: half of each change"),
        Case((0, a, 100, b, 25), (0.25, 0.5, np.radians(175)),
             "170 deg to -170 deg is +20 deg the short way round: a quarter of it is 175 deg"),
        Case((0, a, 100, b, 75), (0.75, 1.5, np.radians(-175)),
             "three quarters of +20 deg from 170 deg is 185 deg, wrapped: -175 deg"),
        Case((100, b, 300, a, 100), b, "at t0 the pose is p0"),
    ]


def config_for(config) -> list[Case]:
    """Notebook 09: cases of ``config_for(method, split_threshold_cm)``.

    The first expected config is written without ``Config.updated``: ``config``'s own TOML with the
    method and the threshold replaced, read back.

    Parameters
    ----------
    config : labkit.Config
        The default config (its TOML is edited for the first case).

    Returns
    -------
    list of Case
        ``("split_and_merge", 3)``: 0.03 m; ``("angular", 8)``: 0.08 m; ``("iepf", 5)``: every other key at
        its default.
    """
    from .pipeline import Config

    expected_sm = Config.from_toml(config.to_toml().replace(
        f'method = "{config.lines.method}"', 'method = "split_and_merge"').replace(
        f"split_threshold_m = {config.lines.split_threshold_m!r}".replace("'", '"'), "split_threshold_m = 0.03"))
    if not (expected_sm.lines.split_threshold_m == 0.03 and expected_sm.lines.method == "split_and_merge"):
        raise ValueError("the config's TOML did not take the edit")
    return [
        Case(("split_and_merge", 3), expected_sm,
             "the Config wants metres: 3 cm is lines.split_threshold_m = 0.03", label="'split_and_merge', 3"),
        Case(("angular", 8), Config().updated({"lines.method": "angular", "lines.split_threshold_m": 0.08}),
             "lines.method is the method's name, the threshold 8 cm = 0.08 m", label="'angular', 8"),
        Case(("iepf", 5), Config().updated({"lines.split_threshold_m": 0.05}),
             "every other key keeps its default", label="'iepf', 5"),
    ]


def _same_normal(got, expected) -> bool:
    """The same line: alpha equal up to a multiple of pi (the normal may point either way)."""
    return bool(np.ndim(got) == 0 and abs(np.sin(got - expected)) < 1e-9)


def closed_form_alpha(rho, theta, r_true: float, alpha_true: float) -> list[Case]:
    """Notebook 02: cases of ``closed_form_alpha(rho, theta, w)``, alpha compared modulo pi.

    Parameters
    ----------
    rho, theta : ndarray
        A noisy wall's ranges (m) and bearings (rad); labkit's weighted fit with ``w = 1/rho`` gives the
        expected alpha.
    r_true, alpha_true : float
        The true wall (m, rad): its noise-free ranges on ``theta`` must give ``alpha_true``.

    Returns
    -------
    list of Case
        The noise-free wall, a noise-free wall straight ahead (x = 2, alpha 0: atan loses the quadrant
        there), and the noisy wall with ``w = 1/rho``.
    """
    from .fitting import fit_line_polar

    ahead = np.radians(np.arange(-40, 40.1, 5.0))       # a wall straight ahead, x = 2
    w_noisy = 1 / np.asarray(rho)
    return [
        Case((r_true / np.cos(theta - alpha_true), theta, np.ones_like(theta)), alpha_true, compare=_same_normal,
             label="noise-free wall at alpha = -60 deg", hint="alpha = atan2(2 S_uv, S_uu - S_vv) / 2 + pi / 2"),
        Case((2.0 / np.cos(ahead), ahead, np.ones_like(ahead)), 0.0, compare=_same_normal,
             label="noise-free wall straight ahead",
             hint="atan2(2 S_uv, S_uu - S_vv), not atan(2 S_uv / (S_uu - S_vv)): atan loses the quadrant"),
        Case((rho, theta, w_noisy), fit_line_polar(rho, theta, w_noisy).alpha, compare=_same_normal,
             label="the noisy wall, w = 1/rho",
             hint="weights w_i in every sum, and W = sum of w in the products of sums"),
    ]


def chord_distances() -> list[Case]:
    """Notebook 04: cases of ``chord_distances(points)``.

    Returns
    -------
    list of Case
        A roof on the chord y = 0 (the distances are the y values); an upright run on the 4 m chord x = 1
        (0, 0.0625, 0.25, 0, 0); and 8 random points against labkit's distances.
    """
    from .course_fallbacks import chord_distances as labkits

    roof = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, 0.0]])          # chord y = 0: the distances are the y values
    upright = np.array([[1.0, -1.0], [0.9375, -0.5], [1.25, 0.0], [1.0, 1.0], [1.0, 3.0]])   # chord x = 1, 4 m long
    wiggly = np.random.default_rng(4).normal(size=(8, 2))
    return [
        Case((roof,), [0.0, 0.5, 0.0], hint="the roof's chord is y = 0: each distance is the point's y value"),
        Case((upright,), [0.0, 0.0625, 0.25, 0.0, 0.0], hint="divide the cross product by the chord's length |b - a|?"),
        Case((wiggly,), labkits(wiggly), label="8 random points",
             hint="the chord goes through the FIRST and the LAST point; distances are >= 0 (abs)"),
    ]


def iepf(room_segment) -> list[Case]:
    """Notebook 04: cases of ``iepf(points, threshold_m=0.05, min_points=5)``, lines as index ranges [a, b).

    Parameters
    ----------
    room_segment : ndarray, shape (N, 2)
        A real range segment: :func:`labkit.lines.iepf` on it gives the expected lines.

    Returns
    -------
    list of Case
        A straight run of 6 points (one line), of 4 (none: fewer than ``min_points``), an L of 12 with its
        corner at index 5 (two lines, in scan order), a run whose worst point sits where no split is
        allowed (one line), and the segment.
    """
    from .lines import iepf as labkits

    corner_run = np.array([[x, 0.0] for x in range(6)] + [[5.0, y] for y in range(1, 7)])   # an L: corner at index 5
    protected = np.array([[0.0, 0.0], [1.0, 0.9], [2.0, 0.05], [3.0, 0.0], [4.0, 0.0]])    # worst point at index 1
    return [
        Case((corner_run[:6], 0.05, 5), [(0, 6)], hint="a straight run is accepted whole"),
        Case((corner_run[:4], 0.05, 5), [], hint="a run of fewer than min_points points makes no line"),
        Case((corner_run, 0.05, 5), [(0, 6), (6, 12)],
             hint="runs in scan order: push the right half first, so that the left half is popped first?"),
        Case((protected, 0.1, 4), [(0, 5)],
             hint="with min_points = 4 the first and last 2 points may not be the worst point; "
                  "the one allowed is 0.05 m off"),
        Case((room_segment, 0.05, 5), labkits(room_segment, 0.05, 5), label="the room's first range segment",
             hint="labkit's runs on a real segment: compare the split rule step by step"),
    ]


def _second_data_set():
    """Notebook 06's second data set: three close points, a gap, two points; eps = 1, brute-force table."""
    from .course_fallbacks import bounds_from_table

    x2 = np.array([0.0, 0.5, 1.0, 5.0, 5.5])
    near2 = np.abs(x2[:, None] - x2[None, :]) <= 1.0
    lower, upper = bounds_from_table(near2)
    return near2, lower, upper


def is_core(L, U, min_pts: int, core) -> list[Case]:
    """Notebook 06: cases of ``is_core(L, U, min_pts)``.

    Parameters
    ----------
    L, U : ndarray of int
        The neighbourhood bounds of section 1's data.
    min_pts : int
        Section 1's ``min_pts``.
    core : ndarray of bool
        Section 1's core points, counted by brute force.

    Returns
    -------
    list of Case
        Section 1's data; a second data set (three close points, a gap, two points, eps = 1) with
        min_pts 3 (core points from its brute-force table) and 1 (every point).
    """
    near2, lower, upper = _second_data_set()
    hint = "a neighbourhood L[i]..U[i] holds U - L + 1 points, the point itself included"
    return [
        Case((L, U, min_pts), core, label="L, U of section 1, min_pts=4", hint=hint),
        Case((lower, upper, 3), near2.sum(axis=1) >= 3, label="L2, U2, min_pts=3", hint=hint),
        Case((lower, upper, 1), np.ones(5, bool), label="L2, U2, min_pts=1",
             hint="with min_pts = 1 every point is a core point: its neighbourhood holds at least itself"),
    ]


def is_border(L, U, core, border) -> list[Case]:
    """Notebook 06: cases of ``is_border(L, U, core)``.

    Parameters
    ----------
    L, U : ndarray of int
        The neighbourhood bounds of section 1's data.
    core, border : ndarray of bool
        Section 1's core and border points, by brute force.

    Returns
    -------
    list of Case
        Section 1's data, and the second data set of :func:`is_core` with min_pts 3 (border points by
        brute force: not core, and a core point within eps).
    """
    near2, lower, upper = _second_data_set()
    core2 = near2.sum(axis=1) >= 3
    border2 = ~core2 & (near2 & core2[None, :]).any(axis=1)
    return [
        Case((L, U, core), border, label="L, U, core of section 1",
             hint="a core point is never a border point, even with core points around it"),
        Case((lower, upper, core2), border2, label="L2, U2, core2",
             hint="look for a core point anywhere in L[i]..U[i], both ends included"),
    ]


def cut_points(scan) -> list[Case]:
    """Notebook 01: cases of ``cut_points(scan, threshold_m)``.

    Parameters
    ----------
    scan : labkit.Scan
        A whole scan: labkit's cuts (:func:`labkit.course_fallbacks.cut_points`) at 8 cm are expected.

    Returns
    -------
    list of Case
        Seven beams one degree apart at 1, 1, 1, 3, 3 m, NaN, 2 m (gaps 1.7 cm, 1.7 cm, 2 m, 5.2 cm, then
        NaN on both sides of the invalid beam) at 8 and 4 cm, and the scan at 8 cm.
    """
    from .course_fallbacks import cut_points as labkits
    from .scan import Scan

    tiny = Scan(ranges=np.array([1.0, 1.0, 1.0, 3.0, 3.0, np.nan, 2.0]), angles=np.radians(np.arange(7.0)))
    return [
        Case((tiny, 0.08), np.array([False, False, True, False, True, True]),
             hint="cut where the gap is at least threshold_m, and next to every invalid beam (its point is NaN, "
                  "and NaN >= threshold_m is False)"),
        Case((tiny, 0.04), np.array([False, False, True, True, True, True]),
             hint="the 5.2 cm gap at 3 m is not below a 4 cm threshold: cut"),
        Case((scan, 0.08), labkits(scan, 0.08), label="corridor scan, 0.08",
             hint="the whole corridor scan: compare with labkit.segment_labels(scan, threshold_m=0.08, "
                  "min_points=1, adaptive=False)"),
    ]


def _triangle_gap(r: float, dphi: float, incidence_deg: float) -> float:
    """|P_{n-1} P_n| from geometry, a surface leaving P_{n-1} = (r, 0) at ``incidence_deg`` to the beam.

    It meets the next beam, direction (cos dphi, sin dphi), at P_n.
    """
    lam = np.radians(incidence_deg)
    # P + t (cos lam, sin lam) = s (cos dphi, sin dphi): solve for (t, s)
    t, _ = np.linalg.solve([[np.cos(lam), -np.cos(dphi)], [np.sin(lam), -np.sin(dphi)]], [-r, 0.0])
    return float(t)


def adaptive_threshold() -> list[Case]:
    """Notebook 01: cases of ``adaptive_threshold(r_a, r_b, dphi, threshold_m, incidence_deg, range_sigma_m)``.

    Returns
    -------
    list of Case
        At 1, 5 and 10 m with 0.5 degree beams: the gap a surface at 10 degrees leaves between two beams,
        solved as a triangle, plus 3 sigma, at least 8 cm; then two pairs of ranges against
        :func:`labkit.breakpoint_thresholds` (the smaller range counts; the arguments are used).
    """
    from .segmentation import breakpoint_thresholds

    step = np.radians(0.5)
    by_geometry = np.array([max(_triangle_gap(r, step, 10.0) + 0.03, 0.08) for r in [1.0, 5.0, 10.0]])
    near, far = np.array([2.0, 6.0, 9.5]), np.array([2.4, 6.1, 12.0])
    return [
        Case((np.array([1.0, 5.0, 10.0]), np.array([1.0, 5.0, 10.0]), step), by_geometry,
             hint="D_max = r sin(dphi) / sin(lambda - dphi) + 3 sigma_r with lambda in radians, then the 80 mm floor"),
        Case((near, far, step), breakpoint_thresholds(near, far, step),
             hint="use the smaller of the two ranges, r = min(r_a, r_b)"),
        Case((near, far, np.radians(1.0)), breakpoint_thresholds(near, far, np.radians(1.0), 0.05,
                                                                 incidence_deg=15.0, range_sigma_m=0.02),
             kwargs={"threshold_m": 0.05, "incidence_deg": 15.0, "range_sigma_m": 0.02},
             hint="use the arguments threshold_m, incidence_deg and range_sigma_m, not the defaults"),
    ]
