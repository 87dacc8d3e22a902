"""Plane geometry shared by every extractor: angles, normal-form lines, points.

Lines are kept in normal (Hesse) form ``x cos(alpha) + y sin(alpha) = r`` with
``r >= 0`` and ``alpha`` wrapped to (-pi, pi]. For a line through the origin
(``r == 0``) the normal has two equally valid directions; labkit keeps the one with
``alpha`` in (-pi/2, pi/2].
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "wrap_angle",
    "angle_difference",
    "circular_mean",
    "normalize_line",
    "line_through_points",
    "signed_distance_to_line",
    "project_onto_line",
    "intersect_lines",
    "rotation_matrix",
    "transform_points",
    "inverse_transform_points",
    "arc_points",
]


def wrap_angle(angle):
    """Wrap angles (radians) to the interval (-pi, pi].

    Parameters
    ----------
    angle : float or array_like
        Angles in radians, any value.

    Returns
    -------
    float or ndarray
        The same angles in (-pi, pi], a float for a scalar input, an array of the input's shape otherwise.

    Examples
    --------
    >>> float(wrap_angle(3 * np.pi / 2))
    -1.5707963267948966
    >>> float(wrap_angle(-np.pi))
    3.141592653589793
    """
    a = np.asarray(angle, dtype=np.float64)
    out = np.pi - np.mod(np.pi - a, 2 * np.pi)
    return out if out.ndim else out[()]


def angle_difference(a, b):
    """Smallest signed difference ``a - b`` across the wrap, in (-pi, pi].

    Parameters
    ----------
    a, b : float or array_like
        Angles in radians (broadcast against each other).

    Returns
    -------
    float or ndarray
        ``a - b`` wrapped to (-pi, pi]: how far to turn from ``b`` to reach ``a`` the short way round.

    Examples
    --------
    >>> round(float(np.degrees(angle_difference(np.radians(170), np.radians(-170)))), 9)
    -20.0
    """
    return wrap_angle(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))


def circular_mean(angles, period: float = 2 * np.pi, weights=None) -> float:
    """Mean of angles on a circle of the given period.

    The angles are mapped to the unit circle (``2 pi x / period``), averaged as vectors
    and mapped back to ``[0, period)``. Use ``period=np.pi`` for line directions, which
    are defined modulo pi. Raises ``ValueError`` for an empty input or when the mean
    direction is undefined (the vectors cancel).

    Parameters
    ----------
    angles : array_like
        The angles, in the unit of ``period`` (radians by default).
    period : float, default 2 pi
        The period of the circle: ``np.pi`` for line directions.
    weights : array_like, optional
        One weight per angle (the vectors' lengths); equal weights by default.

    Returns
    -------
    float
        The mean in ``[0, period)``.

    Raises
    ------
    ValueError
        For no angles, a period that is not positive, weights of another shape, or vectors that cancel.

    Examples
    --------
    >>> round(float(np.degrees(circular_mean(np.radians([350.0, 20.0])))), 9)
    5.0
    >>> round(float(np.degrees(circular_mean(np.radians([178.0, 4.0]), period=np.pi))), 9)
    1.0
    """
    x = np.asarray(angles, dtype=np.float64).ravel()
    if x.size == 0:
        raise ValueError("angles must not be empty")
    if not period > 0:
        raise ValueError(f"period must be > 0, got {period!r}")
    w = np.ones_like(x) if weights is None else np.asarray(weights, dtype=np.float64).ravel()
    if w.shape != x.shape:
        raise ValueError(f"weights must have the shape of angles {x.shape}, got {w.shape}")
    phase = x * (2 * np.pi / period)
    c, s = np.sum(w * np.cos(phase)), np.sum(w * np.sin(phase))
    if np.hypot(c, s) <= 1e-12 * max(np.sum(np.abs(w)), 1e-300):
        raise ValueError("the circular mean is undefined: the angles cancel out")
    mean = float(np.mod(np.arctan2(s, c) * period / (2 * np.pi), period))
    return mean - period if mean >= period else mean  # np.mod(-tiny, p) rounds to p


def normalize_line(r, alpha):
    """Bring ``(r, alpha)`` to labkit's convention: ``r >= 0``, alpha in (-pi, pi].

    A negative ``r`` is made positive by turning the normal around (alpha + pi).

    Parameters
    ----------
    r : float
        Distance of the line from the origin, metres.
    alpha : float
        Angle of its normal, radians.

    Returns
    -------
    r : float
        The same line's ``r >= 0``.
    alpha : float
        Its normal's angle in (-pi, pi].
    """
    r = np.asarray(r, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    flip = r < 0
    r = np.where(flip, -r, r)
    alpha = wrap_angle(np.where(flip, alpha + np.pi, alpha))
    # r == 0: both normals describe the line; keep alpha in (-pi/2, pi/2]
    zero = r == 0
    alpha = np.where(zero & (np.abs(alpha) > np.pi / 2), wrap_angle(alpha + np.pi), alpha)
    alpha = np.where(zero & np.isclose(alpha, -np.pi / 2), np.pi / 2, alpha)
    if r.ndim == 0:
        return float(r), float(alpha)
    return r, alpha


def line_through_points(p, q) -> tuple[float, float]:
    """Normal-form ``(r, alpha)`` of the line through two distinct points.

    Parameters
    ----------
    p, q : array_like of shape (2,)
        Two distinct points ``(x, y)``, metres.

    Returns
    -------
    r : float
        Distance of the line from the origin, ``r >= 0``, metres.
    alpha : float
        Angle of the line's normal, radians in (-pi, pi].

    Raises
    ------
    ValueError
        When ``p`` and ``q`` are the same point.

    Examples
    --------
    >>> r, a = line_through_points((1.0, -1.0), (1.0, 1.0))
    >>> round(r, 12), round(a, 12)
    (1.0, 0.0)
    """
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    d = q - p
    length = np.hypot(d[0], d[1])
    if not length > 0:
        raise ValueError("p and q must be distinct points")
    alpha = np.arctan2(d[0], -d[1])  # the normal: the direction turned by +90 deg
    r = p[0] * np.cos(alpha) + p[1] * np.sin(alpha)
    return normalize_line(r, alpha)


def signed_distance_to_line(points, r: float, alpha: float) -> np.ndarray:
    """Signed orthogonal distance of points to the line ``(r, alpha)``.

    Positive on the far side of the line from the origin. Shape (N,) for points (N, 2).

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points, metres.
    r : float
        Distance of the line from the origin, metres.
    alpha : float
        Angle of its normal, radians.

    Returns
    -------
    ndarray of shape (N,)
        The signed distances, metres.
    """
    pts = np.asarray(points, dtype=np.float64)
    return pts[..., 0] * np.cos(alpha) + pts[..., 1] * np.sin(alpha) - r


def project_onto_line(points, r: float, alpha: float) -> np.ndarray:
    """Orthogonal projection of points onto the line ``(r, alpha)``; same shape as points.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points, metres.
    r : float
        Distance of the line from the origin, metres.
    alpha : float
        Angle of its normal, radians.

    Returns
    -------
    ndarray of shape (N, 2)
        The projections, metres.
    """
    pts = np.asarray(points, dtype=np.float64)
    d = signed_distance_to_line(pts, r, alpha)
    n = np.array([np.cos(alpha), np.sin(alpha)])
    return pts - d[..., None] * n


def intersect_lines(r1: float, alpha1: float, r2: float, alpha2: float) -> np.ndarray | None:
    """Intersection point (2,) of two normal-form lines, or ``None`` if they are parallel.

    Parameters
    ----------
    r1, alpha1 : float
        The first line in normal form, metres and radians.
    r2, alpha2 : float
        The second line.

    Returns
    -------
    ndarray of shape (2,) or None
        The intersection point, metres; None for parallel lines.
    """
    a = np.array([[np.cos(alpha1), np.sin(alpha1)], [np.cos(alpha2), np.sin(alpha2)]])
    det = np.linalg.det(a)
    if abs(det) < 1e-12:
        return None
    return np.linalg.solve(a, np.array([r1, r2], dtype=np.float64))


def rotation_matrix(theta: float) -> np.ndarray:
    """2x2 counter-clockwise rotation by ``theta`` radians.

    Parameters
    ----------
    theta : float
        The angle, radians.

    Returns
    -------
    ndarray of shape (2, 2)
        ``[[cos, -sin], [sin, cos]]``.
    """
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def transform_points(points, pose) -> np.ndarray:
    """Map points from a frame at ``pose = (x, y, theta)`` into the parent frame.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        Points in the child frame, metres.
    pose : array_like of shape (3,)
        ``(x, y, theta)`` of the child frame in the parent frame, metres and radians.

    Returns
    -------
    ndarray of shape (N, 2)
        ``R(theta) p + (x, y)`` for every point ``p``.
    """
    x, y, theta = pose
    pts = np.asarray(points, dtype=np.float64)
    return pts @ rotation_matrix(theta).T + np.array([x, y])


def inverse_transform_points(points, pose) -> np.ndarray:
    """Map points from the parent frame into the frame at ``pose = (x, y, theta)``.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        Points in the parent frame, metres.
    pose : array_like of shape (3,)
        ``(x, y, theta)`` of the child frame in the parent frame, metres and radians.

    Returns
    -------
    ndarray of shape (N, 2)
        ``R(theta)^T (p - (x, y))`` for every point ``p``.
    """
    x, y, theta = pose
    pts = np.asarray(points, dtype=np.float64)
    return (pts - np.array([x, y])) @ rotation_matrix(theta)


def arc_points(center, radius: float, start, end, n: int = 32) -> np.ndarray:
    """Points (n, 2) along the shorter circular arc from ``start`` to ``end`` about ``center``.

    Parameters
    ----------
    center : array_like of shape (2,)
        Centre of the circle, metres.
    radius : float
        Its radius, metres.
    start, end : array_like of shape (2,)
        Points whose directions from the centre bound the arc.
    n : int, default 32
        The number of points.

    Returns
    -------
    ndarray of shape (n, 2)
        The points, from ``start``'s direction to ``end``'s.
    """
    c = np.asarray(center, dtype=np.float64)
    a0 = np.arctan2(start[1] - c[1], start[0] - c[0])
    a1 = np.arctan2(end[1] - c[1], end[0] - c[0])
    sweep = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
    t = a0 + np.linspace(0.0, sweep, n)
    return c + radius * np.stack([np.cos(t), np.sin(t)], axis=1)
