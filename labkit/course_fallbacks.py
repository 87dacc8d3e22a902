"""What a course notebook goes on with while a "your turn" function is still a stub.

:func:`labkit.course.check` returns the fallback when the student's function still raises
``NotImplementedError``, so the rest of the notebook runs. The fallbacks live here, not in the
notebook's cells, so that no answer is written below its task: each is labkit's own function (or the
closed form it computes), under the name the notebook asks the student for.

A few course helpers live here for the same reason: a notebook that wrote them out would show code
an exercise grades (the brute-force neighbourhood bounds, the walk of a cluster's expansion).
"""

from __future__ import annotations

import numpy as np

from . import geometry
from .circles.legs import pair_legs
from .features import Leg
from .fitting import fit_line_polar
from .geometry import signed_distance_to_line
from .lines.angular import local_directions
from .lines.split_merge import lines_similar
from .pipeline import Config
from .poses import compose, interpolate_poses
from .scan import Scan
from .segmentation import segment_labels
from .tracking import assign, cv_model

__all__ = ["closed_form_alpha", "ideal_weights", "is_core", "wall_offsets", "config_for", "mean_per_scan",
           "fewer_lines_share", "rates", "pose_at", "cut_points", "jacobian", "chord_distances", "similar_lines",
           "is_border", "triplet_direction", "normal_form_match", "three_beam_residual", "ray_axis_error",
           "compose_poses", "bounds_from_table", "expand_upwards", "radius_and_height", "pair_two_legs",
           "process_noise", "best_assignment"]


def closed_form_alpha(rho, theta, w):
    """Notebook 02: the weighted polar line fit's angle.

    Parameters
    ----------
    rho : array_like of shape (N,)
        The ranges, metres.
    theta : array_like of shape (N,)
        The beam angles, radians.
    w : array_like of shape (N,)
        The weights.

    Returns
    -------
    float
        The normal angle ``alpha`` of :func:`labkit.fitting.fit_line_polar`, radians.
    """
    return fit_line_polar(rho, theta, w).alpha


def ideal_weights(sigma, theta, alpha):
    """Notebook 03: ``1 / Var(d_i)`` of each point's distance across the line.

    Parameters
    ----------
    sigma : float or array_like of shape (N,)
        The range noise, metres.
    theta : array_like of shape (N,)
        The beam angles, radians.
    alpha : float
        The line's normal angle, radians.

    Returns
    -------
    ndarray of shape (N,)
        ``1 / (sigma cos(theta - alpha))^2``.
    """
    return 1 / (np.asarray(sigma) * np.cos(np.asarray(theta) - alpha)) ** 2


def is_core(L, U, min_pts):
    """Notebook 06: a point is a core point when its neighbourhood ``L..U`` holds ``min_pts`` points.

    Parameters
    ----------
    L : array_like of int
        The first sorted position of each point's neighbourhood.
    U : array_like of int
        The last one (inclusive).
    min_pts : int
        The fewest points of a core point's neighbourhood.

    Returns
    -------
    ndarray of bool
        Whether each point is a core point.
    """
    return (np.asarray(U) - np.asarray(L) + 1) >= min_pts


def wall_offsets(points, direction):
    """Notebook 07: the signed distances of the points across lines of ``direction`` through the origin.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points, metres.
    direction : float
        The lines' direction, radians.

    Returns
    -------
    ndarray of shape (N,)
        Each point's signed distance, metres.
    """
    return signed_distance_to_line(points, 0.0, direction + np.pi / 2)


def config_for(method, split_threshold_cm):
    """Notebook 09: the default :class:`labkit.Config` with a line method and a split threshold in cm.

    Parameters
    ----------
    method : str
        A line extractor's name.
    split_threshold_cm : float
        The split threshold, centimetres.

    Returns
    -------
    Config
        The configuration.
    """
    return Config().updated({"lines.method": method, "lines.split_threshold_m": split_threshold_cm / 100})


def mean_per_scan(feats, kind):
    """Notebook 09: the mean count of one kind of feature per scan.

    Parameters
    ----------
    feats : sequence of Features
        The features of each scan.
    kind : str
        The layer: ``"lines"``, ``"circles"``, ``"legs"``, ...

    Returns
    -------
    float
        The mean number per scan.
    """
    return float(np.mean([len(getattr(f, kind)) for f in feats]))


def fewer_lines_share(a, b):
    """Notebook 09b: the share of the scans in which run ``b`` found strictly fewer lines than run ``a``.

    Parameters
    ----------
    a, b : sequence of Features
        Two runs' features of the same scans, in the same order.

    Returns
    -------
    float
        The share, from 0 to 1.

    Raises
    ------
    ValueError
        If the two runs do not have as many scans.
    """
    fewer = [len(y.lines) < len(x.lines) for x, y in zip(a, b, strict=True)]
    return float(np.mean(fewer))


def rates(n_truth, n_matched, n_scored):
    """Notebook 10: Nguyen's TruePos and FalsePos rates.

    Parameters
    ----------
    n_truth : int
        The walls in the truth.
    n_matched : int
        The lines matched to a wall.
    n_scored : int
        The lines scored.

    Returns
    -------
    tp_rate : float
        ``n_matched / n_truth``.
    fp_rate : float
        ``(n_scored - n_matched) / n_scored``.
    """
    return n_matched / n_truth, (n_scored - n_matched) / n_scored


def pose_at(t0, p0, t1, p1, t):
    """Notebook 11: the pose at ``t`` between two stamped poses.

    Parameters
    ----------
    t0 : float
        The first pose's time.
    p0 : array_like of shape (3,)
        The first pose ``(x, y, theta)``.
    t1 : float
        The second pose's time.
    p1 : array_like of shape (3,)
        The second pose.
    t : float
        The time asked for.

    Returns
    -------
    ndarray of shape (3,)
        The pose, interpolated as :func:`labkit.poses.interpolate_poses` does.
    """
    return interpolate_poses([t0, t1], [p0, p1], [t])[0]


def process_noise(dt, q):
    """Notebook 12: the constant-velocity model's process noise ``Q`` (4 x 4) over ``dt`` seconds.

    Parameters
    ----------
    dt : float
        The time step, seconds.
    q : float
        The spectral density of the acceleration white noise in each axis, m^2/s^3.

    Returns
    -------
    ndarray of shape (4, 4)
        ``Q`` for the state ``(x, y, vx, vy)``, the second matrix of :func:`labkit.tracking.cv_model`.
    """
    return cv_model(dt, q)[1]


def best_assignment(cost):
    """Notebook 12: the (row, column) pairs of least total cost of a square cost matrix, sorted by row.

    Parameters
    ----------
    cost : array_like of shape (T, D)
        The cost of each pair of a track (row) and a detection (column); ``inf`` marks a pair outside its
        gate, which is never chosen. The notebook's matrices are square; :func:`labkit.tracking.assign`
        takes any shape.

    Returns
    -------
    list of tuple of (int, int)
        The chosen ``(row, column)`` pairs, by :func:`labkit.tracking.assign`, sorted by row.
    """
    rows, cols = assign(np.asarray(cost, dtype=float))
    return sorted(zip(rows.tolist(), cols.tolist(), strict=True))


def cut_points(scan, threshold_m=0.08):
    """Notebook 01: where the segments of :func:`labkit.segment_labels` (every run kept, a fixed gap) change.

    Parameters
    ----------
    scan : Scan
        The laser scan (N beams).
    threshold_m : float, default 0.08
        The fixed gap, metres: the largest distance between neighbouring points of one segment.

    Returns
    -------
    ndarray of shape (N - 1,), bool
        Entry ``i`` is True when beams ``i`` and ``i + 1`` lie in different segments, or when either of
        them is invalid.
    """
    labels = segment_labels(scan, threshold_m=threshold_m, min_points=1, adaptive=False)
    return (labels[:-1] != labels[1:]) | (labels[:-1] < 0) | (labels[1:] < 0)


def jacobian(rho, theta, w, h=1e-6):
    """Notebook 03: labkit's polar fit refitted with one range nudged at a time, the weights held fixed.

    Parameters
    ----------
    rho, theta, w : array_like of shape (N,)
        The ranges (metres), bearings (radians) and weights of the points, as for
        :func:`labkit.fitting.fit_line_polar`.
    h : float, default 1e-6
        The nudge of a range, metres.

    Returns
    -------
    ndarray of shape (2, N)
        The Jacobian by central differences: row 0 is ``dr / drho_i``, row 1 is ``dalpha / drho_i``
        (the angle's difference taken across the wrap).
    """
    rho = np.asarray(rho, dtype=float)
    columns = []
    for step in h * np.eye(len(rho)):
        up, down = fit_line_polar(rho + step, theta, w), fit_line_polar(rho - step, theta, w)
        columns.append([(up.r - down.r) / (2 * h), geometry.angle_difference(up.alpha, down.alpha) / (2 * h)])
    return np.array(columns).T


def chord_distances(points):
    """Notebook 04: the distance of every point from the line through the first and the last point.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        Points ``(x, y)``, metres; the first and the last must differ.

    Returns
    -------
    ndarray of shape (N,)
        The unsigned distances, metres (zero at the first and the last point).
    """
    points = np.asarray(points, dtype=float)
    r, alpha = geometry.line_through_points(points[0], points[-1])
    return np.abs(signed_distance_to_line(points, r, alpha))


def similar_lines(a, b, dr_max_m=0.2, dalpha_max=0.17453292519943295):
    """Notebook 05: :func:`labkit.lines_similar` with fixed thresholds (by default 0.2 m and 10 degrees).

    Parameters
    ----------
    a, b : LineSegment
        The two lines.
    dr_max_m : float, default 0.2
        The largest difference of the lines' distances from the origin, metres.
    dalpha_max : float, default 0.17453292519943295
        The largest difference of their normals' angles, radians (10 degrees).

    Returns
    -------
    bool
        Whether both differences are under their thresholds (strictly), as
        ``lines_similar(a, b, merge="thresholds", ...)`` decides.
    """
    return lines_similar(a, b, merge="thresholds", merge_dr_m=dr_max_m, merge_dalpha_deg=np.degrees(dalpha_max))[0]


def is_border(L, U, core):
    """Notebook 06: not a core point, with a core point among its neighbours (counted by a cumulative sum).

    Parameters
    ----------
    L, U : array_like of shape (N,), int
        The first and the last index of each point's neighbourhood (both included).
    core : array_like of shape (N,), bool
        Which points are core points.

    Returns
    -------
    ndarray of shape (N,), bool
        True for the border points.
    """
    core = np.asarray(core, dtype=bool)
    counts = np.concatenate([[0], np.cumsum(core)])
    return ~core & (counts[np.asarray(U) + 1] - counts[np.asarray(L)] > 0)


def triplet_direction(p0, p1, p2):
    """Notebook 07: :func:`labkit.local_directions` at the middle beam of three points.

    Parameters
    ----------
    p0, p1, p2 : array_like of shape (2,)
        Three neighbouring points ``(x, y)`` of a scan in beam order, metres, in the sensor's frame.

    Returns
    -------
    float
        The direction of the line through them (not its normal), radians in [0, pi); NaN when the points
        coincide.
    """
    tri = np.array([p0, p1, p2], dtype=float)
    scan = Scan(ranges=np.hypot(tri[:, 0], tri[:, 1]), angles=np.arctan2(tri[:, 1], tri[:, 0]))
    return float(local_directions(scan)[1])


def normal_form_match(line_r, line_alpha, wall_r, wall_alpha, max_dr_m=0.05, max_dalpha=0.05235987755982989):
    """Notebook 10: one pair under :func:`labkit.match_lines`' limits (by default 5 cm and 3 degrees).

    Parameters
    ----------
    line_r, line_alpha : float
        The extracted line in normal form: distance from the origin (metres) and normal angle (radians).
    wall_r, wall_alpha : float
        The ground-truth wall in the same form.
    max_dr_m : float, default 0.05
        The largest difference of the distances, metres.
    max_dalpha : float, default 0.05235987755982989
        The largest difference of the angles (taken across the wrap), radians (3 degrees).

    Returns
    -------
    bool
        Whether both differences are within their limits (limits included).
    """
    dalpha = geometry.angle_difference(line_alpha, wall_alpha)
    return bool(abs(line_r - wall_r) <= max_dr_m and abs(dalpha) <= max_dalpha)


def three_beam_residual(r_prev, r_mid, r_next, dtheta):
    """Notebook 10b: the three-beam residual of :func:`labkit.range_noise_residuals`, before its scale factor.

    Parameters
    ----------
    r_prev, r_mid, r_next : float or ndarray
        The ranges of three neighbouring beams, metres.
    dtheta : float
        The angular step between beams, radians.

    Returns
    -------
    float or ndarray
        ``r_mid (1 - (r_mid / r_prev + r_mid / r_next) / (2 cos dtheta))``, metres: zero on a straight
        wall without noise.
    """
    return r_mid * (1.0 - (r_mid / r_prev + r_mid / r_next) / (2.0 * np.cos(dtheta)))


def ray_axis_error(range_m, angle, line_r, line_alpha):
    """Notebook 10b: a beam's error along its own ray against a line, as :func:`labkit.ray_errors` measures it.

    Parameters
    ----------
    range_m : float or ndarray
        The measured range of the beam, metres.
    angle : float or ndarray
        The beam's angle, radians.
    line_r, line_alpha : float
        The line in normal form ``x cos(alpha) + y sin(alpha) = r``: metres and radians.

    Returns
    -------
    float or ndarray
        The measured range minus the distance along the ray to the line, metres (positive: the beam
        measured beyond the line); NaN where the ray never meets the line ahead of the sensor.
    """
    c = np.cos(np.asarray(angle, dtype=float) - line_alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        along = np.where(c > 0, line_r / np.where(c > 0, c, 1.0), np.nan)
    error = np.asarray(range_m, dtype=float) - along
    return float(error) if error.ndim == 0 else error


def compose_poses(a, b):
    """Notebook 11: :func:`labkit.poses.compose`.

    Parameters
    ----------
    a, b : array_like of shape (3,) or (N, 3)
        Poses ``(x, y, theta)``, metres and radians: frame ``b`` given in frame ``a``.

    Returns
    -------
    ndarray of shape (3,) or (N, 3)
        The pose ``a ∘ b`` (frame ``b`` in ``a``'s parent), theta wrapped to (-pi, pi].
    """
    return compose(a, b)


def bounds_from_table(near):
    """Notebook 06: the bounds ``L``, ``U`` read off a brute-force neighbour table.

    Parameters
    ----------
    near : array_like of shape (N, N), bool
        Row ``i`` marks the points within ``eps`` of point ``i`` (point ``i`` among them).

    Returns
    -------
    L, U : ndarray of shape (N,), int
        The first and the last True of every row.
    """
    near = np.asarray(near, dtype=bool)
    return near.argmax(axis=1), len(near) - 1 - near[:, ::-1].argmax(axis=1)


def expand_upwards(p, L, U, min_pts):
    """Notebook 06: print the upward walk of DBSCAN's cluster expansion from core point ``p`` (Algorithm 4).

    Parameters
    ----------
    p : int
        The index of the core point the walk starts at.
    L, U : array_like of shape (N,), int
        The first and the last index of each point's neighbourhood (both included).
    min_pts : int
        The number of points a neighbourhood needs for its point to be a core point.
    """
    u, i = int(U[p]), p + 1
    print(f"start at core point p = {p}, bound u = U[{p}] = {u}")
    while i < len(U) and i <= u:
        core = U[i] - L[i] + 1 >= min_pts
        u = max(u, int(U[i])) if core else u
        print(f"  i = {i:2}: label it; {'core, bound u -> ' + str(u) if core else 'not core, u stays ' + str(u)}")
        i += 1
    print(f"stop at i = {i}: the cluster ends at index {i - 1}")


def radius_and_height(chord, mean_angle):
    """Notebook 08: the radius of a circle from a chord and the angle its arc sees it under.

    The corrected construction: the circle whose arc sees a chord of length ``chord`` under ``mean_angle``.

    Parameters
    ----------
    chord : float
        The chord's length, metres.
    mean_angle : float
        The (mean) inscribed angle under which the arc's points see the chord, radians.

    Returns
    -------
    radius : float
        The circle's radius, metres.
    height : float
        The centre's height above the chord's midpoint, counted away from the arc, metres (negative when
        the centre lies on the arc's side, for ``mean_angle`` under pi / 2).
    """
    theta = mean_angle - np.pi / 2
    return chord / 2 / np.cos(theta), chord / 2 * np.tan(theta)


def pair_two_legs(centre_a, centre_b, max_distance_m=0.6):
    """Notebook 08b: the person :func:`labkit.circles.legs.pair_legs` makes of two legs, if any.

    Parameters
    ----------
    centre_a, centre_b : array_like of shape (2,)
        The two legs' centres ``(x, y)``, metres.
    max_distance_m : float, default 0.6
        The farthest two leg centres of one person can be, metres (the limit included).

    Returns
    -------
    ndarray of shape (2,) or None
        The person's centre, the midpoint of the two leg centres, metres; None when the centres are
        farther apart than ``max_distance_m``.
    """
    legs = [Leg(np.asarray(c, dtype=float), 0.0, np.asarray(c, dtype=float), k, k, 3, np.nan, np.nan)
            for k, c in enumerate((centre_a, centre_b))]
    people = pair_legs(legs, max_distance_m)
    return people[0].center if people else None
