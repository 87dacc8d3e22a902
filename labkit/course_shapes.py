"""Synthetic shapes of the course notebooks (08): arcs, walls and V-shaped corners seen by a sensor at the origin.

Noise-free points come out of the generators; :func:`add_range_noise` moves each point along its beam, as
a scanner's range noise would.
"""

from __future__ import annotations

import numpy as np

__all__ = ["add_range_noise", "iav_test_shapes", "v_corner_points", "noisy_arc"]


def add_range_noise(points, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Move each point along its beam (from the sensor at the origin) by Gaussian noise.

    Parameters
    ----------
    points : array_like, shape (M, 2)
        The points, metres; none at the origin.
    sigma : float
        The noise's standard deviation, metres.
    rng : numpy.random.Generator
        Draws the M offsets, in the points' order.

    Returns
    -------
    ndarray, shape (M, 2)
        Each point ``p`` moved to ``p * (|p| + e) / |p|``.
    """
    points = np.asarray(points, dtype=float)
    r = np.hypot(*points.T)
    return points * ((r + rng.normal(0, sigma, len(r))) / r)[:, None]


def iav_test_shapes(n: int = 25) -> dict[str, np.ndarray]:
    """Three noise-free segments 3 m in front of the sensor, ``n`` points each.

    Parameters
    ----------
    n : int, default 25
        Points per segment.

    Returns
    -------
    dict
        ``"arc"``: the 120 degrees of a column of radius 0.25 m centred at (3, 0) that face the sensor;
        ``"line"``: 0.8 m of the wall x = 3; ``"V-corner"``: a 90-degree corner with two 0.4 m arms, its
        apex towards the sensor.
    """
    t = np.radians(np.linspace(120, 240, n))
    u = np.linspace(-1, 1, n)
    arm = 0.4 / np.sqrt(2)
    return {"arc": np.c_[3.0 + 0.25 * np.cos(t), 0.25 * np.sin(t)],
            "line": np.c_[np.full(n, 3.0), np.linspace(-0.4, 0.4, n)],
            "V-corner": np.c_[3.0 - arm + arm * np.abs(u), arm * u]}


def v_corner_points(opening_deg: float, arm_m: float = 0.4, n: int = 25, apex=(2.6, 0.0)) -> np.ndarray:
    """A V with its apex towards the sensor at the origin, symmetric about the x axis.

    Parameters
    ----------
    opening_deg : float
        The angle between the two arms, degrees.
    arm_m : float, default 0.4
        Each arm's length, metres.
    n : int, default 25
        Points, the apex among them when ``n`` is odd.
    apex : (float, float), default (2.6, 0.0)
        The apex, metres.

    Returns
    -------
    ndarray, shape (n, 2)
        The points from one arm's end through the apex to the other's.
    """
    half = np.radians(opening_deg) / 2
    s = arm_m * np.abs(np.linspace(-1.0, 1.0, n))
    sign = np.sign(np.linspace(-1.0, 1.0, n))
    return np.c_[apex[0] + s * np.cos(half), apex[1] + sign * s * np.sin(half)]


def noisy_arc(center, radius: float, span_deg: float, rng: np.random.Generator, *, beam_step_m: float,
              sigma_m: float, turn_deg: float = 15.0) -> np.ndarray:
    """An arc of a circle facing the sensor at the origin, with as many points as beams fall on it, and range noise.

    Parameters
    ----------
    center : (float, float)
        The circle's centre, metres, on the positive x axis side.
    radius : float
        The circle's radius, metres.
    span_deg : float
        The arc's span at the centre, degrees.
    rng : numpy.random.Generator
        Draws the turn (first) and the noise.
    beam_step_m : float
        The arc length between neighbouring beams, metres: the arc gets ``max(4, span / step + 1)`` points.
    sigma_m : float
        The range noise, metres (:func:`add_range_noise`).
    turn_deg : float, default 15.0
        The arc is turned away from facing the sensor by a uniform draw in ``[-turn_deg, turn_deg]``.

    Returns
    -------
    ndarray, shape (M, 2)
        The points, in order along the arc.
    """
    n_pts = max(4, int(np.radians(span_deg) * radius / beam_step_m) + 1)
    start = 180 - span_deg / 2 + rng.uniform(-turn_deg, turn_deg)
    t = np.radians(np.linspace(start, start + span_deg, n_pts))
    return add_range_noise(np.asarray(center, dtype=float) + radius * np.c_[np.cos(t), np.sin(t)], sigma_m, rng)
