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

__all__ = ["random_beams", "random_wall_beams", "random_iepf_trace"]

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
    Returns ``(scan, threshold_m, min_points, steps)``; ``threshold_m`` (0.02 to 0.5 m) and
    ``min_points`` (2 to 10) are drawn where not given. The hidden tests of the
    split-and-merge exercises (ex04's split index, ex05's runs) read their answers from it.

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
