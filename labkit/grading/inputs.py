"""Random inputs for the hidden tests of the exercises: beams of one scan with every kind of invalid reading.

:func:`random_beams` draws a scan's worth of beams with every kind of invalid reading (NaN, +/-inf,
zero, negative, below ``range_min``, at or beyond ``range_max``), as keyword arguments that both
the student's function and :class:`labkit.Scan` accept. :func:`random_wall_beams` draws a partial
sweep across a random scene of walls (runs of neighbouring points, jumps between walls, clutter and
invalid readings), the input of segmentation and line-fitting exercises.

The grader's trusted side calls them with a generator seeded per submission (see
:mod:`labkit.grading`), so every student is graded on inputs of their own.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["random_beams", "random_wall_beams", "random_iepf_trace", "random_threshold_case", "random_shape",
           "random_arc", "random_band_segment"]

_INVALID_KINDS = ("nan", "inf", "-inf", "zero", "negative", "at_max", "beyond_max", "below_min")


def _draw_sizes(rng, n_beams, max_beams: int, invalid_fraction, most_invalid: float) -> tuple[int, float]:
    """Check the random-scan arguments; draw the beam count and the invalid fraction (up to
    ``most_invalid``) where they are not given."""
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if n_beams is None:
        if max_beams < 2:
            raise ValueError(f"max_beams must be >= 2, got {max_beams!r}")
        n_beams = int(rng.integers(2, max_beams + 1))
    elif int(n_beams) != n_beams or n_beams < 0:
        raise ValueError(f"n_beams must be a non-negative integer, got {n_beams!r}")
    if invalid_fraction is None:
        invalid_fraction = float(rng.uniform(0.0, most_invalid))
    elif not 0.0 <= invalid_fraction <= 1.0:
        raise ValueError(f"invalid_fraction must be in [0, 1], got {invalid_fraction!r}")
    return int(n_beams), invalid_fraction


def random_beams(
    rng: np.random.Generator,
    n_beams: int | None = None,
    *,
    invalid_fraction: float | None = None,
    max_beams: int = 720,
) -> dict[str, Any]:
    """Random beams of one scan, with invalid readings mixed in.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness: the same generator state gives the same bytes.
    n_beams : int or None
        Number of beams N (0 and 1 allowed). None draws it from ``[2, max_beams]``.
    invalid_fraction : float in [0, 1] or None
        Probability that a beam's reading is replaced by an invalid one. None draws it
        from ``[0, 0.5]``; 1 gives a scan without a single valid beam.
    max_beams : int
        Upper bound for a drawn ``n_beams``.

    Returns
    -------
    dict
        ``ranges`` (ndarray (N,), metres), ``angles`` (ndarray (N,), radians, strictly
        increasing, spanning at most 2 pi, unevenly spaced), ``range_min`` and ``range_max``
        (float, metres; ``range_min`` is 0 in about a third of the draws). Pass it as
        ``**kwargs`` to :class:`labkit.Scan` and to the student's function. An invalid
        reading is one of NaN, +inf, -inf, 0, negative, exactly ``range_max``, beyond
        ``range_max`` or (when ``range_min > 0``) below ``range_min``. Valid readings
        include some exactly at ``range_min``, which is valid.

    Examples
    --------
    >>> beams = random_beams(np.random.default_rng(0), 5)
    >>> beams["ranges"].shape, beams["angles"].shape
    ((5,), (5,))
    >>> bool(np.all(np.diff(beams["angles"]) > 0))
    True
    """
    n, invalid_fraction = _draw_sizes(rng, n_beams, max_beams, invalid_fraction, 0.5)

    range_min = 0.0 if rng.random() < 1 / 3 else float(rng.uniform(0.02, 0.5))
    range_max = float(rng.uniform(4.0, 60.0))

    span = float(rng.uniform(0.1, 2 * np.pi))
    angle_min = float(rng.uniform(-np.pi, np.pi - span))
    steps = rng.uniform(0.5, 1.5, size=max(n - 1, 0))
    offsets = np.concatenate([[0.0], np.cumsum(steps)])[:n]
    if n > 1:
        offsets *= span / offsets[-1]
    angles = angle_min + offsets

    ranges = rng.uniform(range_min, range_max, size=n)
    ranges[rng.random(n) < 0.05] = range_min  # the boundary: valid
    if range_min == 0.0:
        ranges[ranges == 0.0] = range_max / 2  # ... except that 0 is never a return
    invalid = np.flatnonzero(rng.random(n) < invalid_fraction)
    kinds = rng.integers(0, len(_INVALID_KINDS), size=invalid.size)
    for i, kind in zip(invalid, kinds, strict=True):
        name = _INVALID_KINDS[kind]
        if name == "below_min" and range_min == 0.0:
            name = "negative"
        ranges[i] = {
            "nan": np.nan,
            "inf": np.inf,
            "-inf": -np.inf,
            "zero": 0.0,
            "negative": -float(rng.uniform(1e-3, 5.0)),
            "at_max": range_max,
            "beyond_max": float(rng.uniform(range_max, 2 * range_max)) + 1e-9,
            "below_min": float(rng.uniform(0.0, range_min)) if range_min > 0 else 0.0,
        }[name]
    return {"ranges": ranges, "angles": angles, "range_min": range_min, "range_max": range_max}


_WALL_INVALID_KINDS = ("nan", "inf", "-inf", "zero", "negative")


def random_wall_beams(
    rng: np.random.Generator,
    n_beams: int | None = None,
    *,
    invalid_fraction: float | None = None,
    max_beams: int = 720,
) -> dict[str, np.ndarray]:
    """Random beams of a partial sweep across a scene of walls, with clutter and invalid readings.

    The sweep is cut into a few angular sectors; each sector sees one straight wall at a
    random distance (0.3 to 8 m) and orientation, so neighbouring beams form runs of
    points a few centimetres apart and the range jumps between walls. Beams that would
    meet their wall at more than 80 degrees from its normal see nothing (``+inf``). Range
    noise (standard deviation up to 2 cm, the same for the whole scan), isolated clutter
    returns (up to 10 % of the beams) and invalid readings are added on top.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness: the same generator state gives the same bytes.
    n_beams : int or None
        Number of beams N (0 and 1 allowed). None draws it from ``[2, max_beams]``.
    invalid_fraction : float in [0, 1] or None
        Probability that a beam's reading is replaced by NaN, +inf, -inf, 0 or a negative
        number. None draws it from ``[0, 0.2]``.
    max_beams : int
        Upper bound for a drawn ``n_beams``.

    Returns
    -------
    dict
        ``ranges`` (ndarray (N,), metres) and ``angles`` (ndarray (N,), radians, strictly
        increasing, unevenly spaced). The sweep never covers the full circle
        (:attr:`labkit.Scan.is_full_circle` is False), so its first and last beams are not
        neighbours. Pass it as ``**kwargs`` to :class:`labkit.Scan` (default range limits:
        a reading is valid when it is finite and > 0) and to the student's function.

    Examples
    --------
    >>> beams = random_wall_beams(np.random.default_rng(0), 50)
    >>> sorted(beams), beams["ranges"].shape
    (['angles', 'ranges'], (50,))
    >>> bool(np.all(np.diff(beams["angles"]) > 0))
    True
    """
    n, invalid_fraction = _draw_sizes(rng, n_beams, max_beams, invalid_fraction, 0.2)

    # Scan.is_full_circle: span + 1.5 * step >= 2 pi, with step = span / (n - 1)
    widest = 1.5 * np.pi if n < 3 else min(1.5 * np.pi, 0.9 * 2 * np.pi * (n - 1) / (n + 0.5))
    span = float(rng.uniform(min(0.05, widest), widest))
    angle_min = float(rng.uniform(-np.pi, np.pi - span))
    steps = rng.uniform(0.5, 1.5, size=max(n - 1, 0))
    offsets = np.concatenate([[0.0], np.cumsum(steps)])[:n]
    if n > 1:
        offsets *= span / offsets[-1]
    angles = angle_min + offsets

    n_walls = int(rng.integers(1, 9)) + int(np.ceil(span / (np.pi / 2)))
    cuts = np.sort(rng.uniform(angle_min, angle_min + span, size=n_walls - 1))
    bounds = np.concatenate([[angle_min], cuts, [angle_min + span]])
    wall = np.searchsorted(cuts, angles, side="right")
    middle = (bounds[:-1] + bounds[1:]) / 2
    normal = middle + rng.uniform(-0.6, 0.6, size=n_walls)
    distance = rng.uniform(0.3, 8.0, size=n_walls)
    cosine = np.cos(angles - normal[wall])
    ranges = np.full(n, np.inf)
    seen = cosine > np.cos(np.radians(80.0))
    ranges[seen] = distance[wall[seen]] / cosine[seen]
    ranges[seen] += rng.normal(0.0, float(rng.uniform(0.0, 0.02)), size=int(seen.sum()))
    clutter = np.flatnonzero(rng.random(n) < float(rng.uniform(0.0, 0.1)))
    ranges[clutter] = rng.uniform(0.2, 10.0, size=clutter.size)

    invalid = np.flatnonzero(rng.random(n) < invalid_fraction)
    kinds = rng.integers(0, len(_WALL_INVALID_KINDS), size=invalid.size)
    for i, kind in zip(invalid, kinds, strict=True):
        name = _WALL_INVALID_KINDS[kind]
        if name == "negative":
            ranges[i] = -float(rng.uniform(1e-3, 5.0))
        else:
            ranges[i] = {"nan": np.nan, "inf": np.inf, "-inf": -np.inf, "zero": 0.0}[name]
    return {"ranges": ranges, "angles": angles}


def random_iepf_trace(rng: np.random.Generator, n_beams: int | None = None, *, threshold_m: float | None = None,
                      min_points: int | None = None):
    """A random scan of walls (valid beams only, at least two) and labkit's IEPF split step on it.

    One range segment of all the valid beams, no gap splits, no merging, no length limit: the
    trace holds only the split decisions (``fit``/``split``), runs too short to keep and their
    points joined to a neighbour (``reject``/``absorb``), and the accepted runs (``accept``).
    The hidden tests of the split-and-merge exercises (ex04's split index, ex05's runs) read
    their answers from it.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness.
    n_beams : int or None
        Beams of the scan before invalid ones are dropped; None: drawn as :func:`random_wall_beams` does.
    threshold_m : float or None
        The split threshold, metres; None: drawn from 0.02 to 0.5 m.
    min_points : int or None
        The fewest points of a line; None: drawn from 2 to 10.

    Returns
    -------
    scan : Scan
        The scan.
    threshold_m : float
        The split threshold used.
    min_points : int
        The fewest points used.
    steps : list of Step
        The trace of the split step.

    Examples
    --------
    >>> scan, threshold_m, min_points, steps = random_iepf_trace(np.random.default_rng(1))
    >>> {s.kind for s in steps} <= {"segment", "fit", "split", "accept", "reject", "absorb"}
    True
    """
    import labkit  # the grader's trusted side only; inputs need no labkit otherwise

    while True:
        beams = random_wall_beams(rng, n_beams, invalid_fraction=0.0)
        valid = np.isfinite(beams["ranges"]) & (beams["ranges"] > 0)
        if valid.sum() >= 2:
            break
    scan = labkit.Scan(ranges=beams["ranges"][valid], angles=beams["angles"][valid])
    threshold_m = float(rng.uniform(0.02, 0.5)) if threshold_m is None else threshold_m
    min_points = int(rng.integers(2, 11)) if min_points is None else min_points
    _, steps = labkit.split_and_merge(
        scan, method="endpoints", split_threshold_m=threshold_m, min_points=min_points, min_length_m=0.0,
        max_gap_m=1e9, merge=None, segment_threshold_m=1e9, adaptive_segmentation=False, trace=True,
    )
    return scan, threshold_m, min_points, steps


def random_threshold_case(rng: np.random.Generator, n_beams: int | None = None, *,
                          invalid_fraction: float | None = None, max_beams: int = 720):
    """Random wall beams and the adaptive breakpoint threshold's parameters, every angle step below the incidence.

    Returns ``(beams, threshold_m, incidence_deg, range_sigma_m)``: beams as :func:`random_wall_beams` draws
    them (the sweep narrowed where a step would reach 0.8 of the incidence angle), ``threshold_m`` 3 to
    30 cm, ``incidence_deg`` 5 to 30 degrees and ``range_sigma_m`` up to 3 cm. The cases of exercise 1's
    ``adaptive_threshold``: labkit's answer is ``labkit.breakpoint_thresholds`` for every pair of
    neighbours, NaN where either beam is invalid.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness.
    n_beams : int or None
        Number of beams, as for :func:`random_wall_beams`.
    invalid_fraction : float or None
        Probability of an invalid reading, as for :func:`random_wall_beams`.
    max_beams : int
        Upper bound for a drawn ``n_beams``.

    Returns
    -------
    beams : dict
        The beams, as :func:`random_wall_beams` returns them.
    threshold_m : float
        The threshold floor, metres.
    incidence_deg : float
        The incidence angle, degrees.
    range_sigma_m : float
        The range noise, metres.

    Examples
    --------
    >>> beams, threshold_m, incidence_deg, sigma = random_threshold_case(np.random.default_rng(0), 50)
    >>> bool(np.diff(beams["angles"]).max() < np.radians(incidence_deg))
    True
    """
    incidence_deg = float(rng.uniform(5.0, 30.0))
    beams = random_wall_beams(rng, n_beams, invalid_fraction=invalid_fraction, max_beams=max_beams)
    angles = beams["angles"]
    widest = np.diff(angles).max() if angles.size > 1 else 0.0
    if widest >= 0.8 * np.radians(incidence_deg):
        beams["angles"] = angles[0] + (angles - angles[0]) * (rng.uniform(0.1, 0.8) * np.radians(incidence_deg)
                                                              / widest)
    return beams, float(rng.uniform(0.03, 0.3)), incidence_deg, float(rng.uniform(0.0, 0.03))


def random_shape(rng: np.random.Generator, kind: str, n: int) -> np.ndarray:
    """``n`` points of a random noisy shape: an arc, a line or a corner, shifted by up to 5 m.

    The shapes of exercise 8's inscribed angles, whose answer is ``labkit.inscribed_angles``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness.
    kind : str
        ``"arc"`` (radius 5 cm to 2 m, 20 to 340 degrees), ``"line"`` or ``"corner"`` (a V of two
        legs, 30 to 170 degrees); anything else raises ``ValueError``.
    n : int
        The number of points.

    Returns
    -------
    ndarray of shape (n, 2)
        The points, metres.

    Examples
    --------
    >>> random_shape(np.random.default_rng(0), "arc", 7).shape
    (7, 2)
    """
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
    elif kind == "corner":  # two legs of random lengths at a random angle
        opening = np.radians(float(rng.uniform(30.0, 170.0)))
        k = int(rng.integers(1, n - 1))
        left = np.linspace(1.0, 0.0, k + 1)[:-1] * float(rng.uniform(0.2, 2.0))
        right = np.linspace(0.0, 1.0, n - k) * float(rng.uniform(0.2, 2.0))
        p = np.concatenate([left[:, None] * [[1.0, 0.0]], right[:, None] * [[np.cos(opening), np.sin(opening)]]])
        noise = float(rng.choice([0.0, 0.005]))
    else:
        raise ValueError(f"kind must be 'arc', 'line' or 'corner', got {kind!r}")
    return p + noise * rng.standard_normal(p.shape) + rng.uniform(-5.0, 5.0, 2)


def random_arc(rng: np.random.Generator):
    """A random arc of a known circle: its chord, mean inscribed angle and side, and that circle.

    Closed-form truth for exercise 8's ``circle_from_angle`` (the points of an arc walked
    counter-clockwise lie right of its chord, ``side < 0``).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the circle and the arc.

    Returns
    -------
    arc : tuple
        ``(p_first, p_last, mean_angle, side)``: the chord's ends (ndarray of shape (2,), metres),
        the mean inscribed angle (radians) and the side of the chord the arc lies on.
    center : ndarray of shape (2,)
        The circle's centre, metres.
    radius : float
        Its radius, metres.

    Examples
    --------
    >>> (p_first, p_last, mean_angle, side), center, radius = random_arc(np.random.default_rng(0))
    >>> bool(np.isclose(np.hypot(*(p_first - center)), radius))
    True
    """
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


def random_band_segment(rng: np.random.Generator, ratio: float | None = None, chord: float | None = None):
    """Points of a random segment whose middle point lies ``ratio`` chord lengths from the chord, and that ratio.

    The middle point (row ``N // 2``) lies towards the sensor at the origin (a negative ratio:
    away from it). Closed-form truth for exercise 8's band (``in_band``) and legs.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws what is not given, and the segment's place.
    ratio : float or None
        The middle point's distance from the chord, in chord lengths; None: drawn from [-0.5, 1).
    chord : float or None
        The chord's length, metres; None: around 5 cm, 20 cm or 1 m.

    Returns
    -------
    points : ndarray of shape (N, 2)
        The segment's points, metres.
    ratio : float
        The ratio.

    Examples
    --------
    >>> points, ratio = random_band_segment(np.random.default_rng(0), 0.3, 0.2)
    >>> bool(np.isclose(np.hypot(*(points[-1] - points[0])), 0.2)), ratio
    (True, 0.3)
    """
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
