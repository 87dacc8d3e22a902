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
from .fitting import fit_line_polar
from .geometry import signed_distance_to_line
from .lines.angular import local_directions
from .lines.split_merge import lines_similar
from .pipeline import Config
from .poses import compose, interpolate_poses
from .scan import Scan
from .segmentation import segment_labels
from .tracking import assign, cv_model

__all__ = ["closed_form_alpha", "ideal_weights", "is_core", "wall_offsets", "config_for", "mean_per_scan", "rates",
           "pose_at", "cut_points", "jacobian", "chord_distances", "similar_lines", "is_border", "triplet_direction",
           "normal_form_match", "three_beam_residual", "compose_poses", "bounds_from_table", "expand_upwards",
           "radius_and_height", "process_noise", "best_assignment"]


def closed_form_alpha(rho, theta, w):
    """Notebook 02: the weighted polar line fit's angle."""
    return fit_line_polar(rho, theta, w).alpha


def ideal_weights(sigma, theta, alpha):
    """Notebook 03: ``1 / Var(d_i)`` of each point's distance across the line."""
    return 1 / (np.asarray(sigma) * np.cos(np.asarray(theta) - alpha)) ** 2


def is_core(L, U, min_pts):
    """Notebook 06: a point is a core point when its neighbourhood ``L..U`` holds ``min_pts`` points."""
    return (np.asarray(U) - np.asarray(L) + 1) >= min_pts


def wall_offsets(points, direction):
    """Notebook 07: the signed distances of the points across lines of ``direction`` through the origin."""
    return signed_distance_to_line(points, 0.0, direction + np.pi / 2)


def config_for(method, split_threshold_cm):
    """Notebook 09: the default :class:`labkit.Config` with a line method and a split threshold in cm."""
    return Config().updated({"lines.method": method, "lines.split_threshold_m": split_threshold_cm / 100})


def mean_per_scan(feats, kind):
    """Notebook 09: the mean count of one kind of feature per scan."""
    return float(np.mean([len(getattr(f, kind)) for f in feats]))


def rates(n_truth, n_matched, n_scored):
    """Notebook 10: Nguyen's TruePos and FalsePos rates."""
    return n_matched / n_truth, (n_scored - n_matched) / n_scored


def pose_at(t0, p0, t1, p1, t):
    """Notebook 11: the pose at ``t`` between two stamped poses."""
    return interpolate_poses([t0, t1], [p0, p1], [t])[0]


def process_noise(dt, q):
    """Notebook 12: the constant-velocity model's process noise ``Q`` (4 x 4) over ``dt`` seconds."""
    return cv_model(dt, q)[1]


def best_assignment(cost):
    """Notebook 12: the (row, column) pairs of least total cost of a square cost matrix, sorted by row."""
    rows, cols = assign(np.asarray(cost, dtype=float))
    return sorted(zip(rows.tolist(), cols.tolist(), strict=True))


def cut_points(scan, threshold_m=0.08):
    """Notebook 01: where the segments of :func:`labkit.segment_labels` (every run kept, a fixed gap) change."""
    labels = segment_labels(scan, threshold_m=threshold_m, min_points=1, adaptive=False)
    return (labels[:-1] != labels[1:]) | (labels[:-1] < 0) | (labels[1:] < 0)


def jacobian(rho, theta, w, h=1e-6):
    """Notebook 03: labkit's polar fit refitted with one range nudged at a time, the weights held fixed."""
    rho = np.asarray(rho, dtype=float)
    columns = []
    for step in h * np.eye(len(rho)):
        up, down = fit_line_polar(rho + step, theta, w), fit_line_polar(rho - step, theta, w)
        columns.append([(up.r - down.r) / (2 * h), geometry.angle_difference(up.alpha, down.alpha) / (2 * h)])
    return np.array(columns).T


def chord_distances(points):
    """Notebook 04: the distance of every point from the line through the first and the last point."""
    points = np.asarray(points, dtype=float)
    r, alpha = geometry.line_through_points(points[0], points[-1])
    return np.abs(signed_distance_to_line(points, r, alpha))


def similar_lines(a, b, dr_max_m=0.2, dalpha_max=0.17453292519943295):
    """Notebook 05: :func:`labkit.lines_similar` with fixed thresholds (by default 0.2 m and 10 degrees)."""
    return lines_similar(a, b, merge="thresholds", merge_dr_m=dr_max_m, merge_dalpha_deg=np.degrees(dalpha_max))[0]


def is_border(L, U, core):
    """Notebook 06: not a core point, with a core point among its neighbours (counted by a cumulative sum)."""
    core = np.asarray(core, dtype=bool)
    counts = np.concatenate([[0], np.cumsum(core)])
    return ~core & (counts[np.asarray(U) + 1] - counts[np.asarray(L)] > 0)


def triplet_direction(p0, p1, p2):
    """Notebook 07: :func:`labkit.local_directions` at the middle beam of three points."""
    tri = np.array([p0, p1, p2], dtype=float)
    scan = Scan(ranges=np.hypot(tri[:, 0], tri[:, 1]), angles=np.arctan2(tri[:, 1], tri[:, 0]))
    return float(local_directions(scan)[1])


def normal_form_match(line_r, line_alpha, wall_r, wall_alpha, max_dr_m=0.05, max_dalpha=0.05235987755982989):
    """Notebook 10: one pair under :func:`labkit.match_lines`' limits (by default 5 cm and 3 degrees)."""
    dalpha = geometry.angle_difference(line_alpha, wall_alpha)
    return bool(abs(line_r - wall_r) <= max_dr_m and abs(dalpha) <= max_dalpha)


def three_beam_residual(r_prev, r_mid, r_next, dtheta):
    """Notebook 10: the three-beam residual of :func:`labkit.range_noise_residuals`, before its scale factor."""
    return r_mid * (1.0 - (r_mid / r_prev + r_mid / r_next) / (2.0 * np.cos(dtheta)))


def compose_poses(a, b):
    """Notebook 11: :func:`labkit.poses.compose`."""
    return compose(a, b)


def bounds_from_table(near):
    """Notebook 06: the bounds ``L``, ``U`` read off a brute-force neighbour table (row i: the points within
    eps of point i): the first and the last True of every row."""
    near = np.asarray(near, dtype=bool)
    return near.argmax(axis=1), len(near) - 1 - near[:, ::-1].argmax(axis=1)


def expand_upwards(p, L, U, min_pts):
    """Notebook 06: print the upward walk of DBSCAN's cluster expansion from core point ``p`` (Algorithm 4)."""
    u, i = int(U[p]), p + 1
    print(f"start at core point p = {p}, bound u = U[{p}] = {u}")
    while i < len(U) and i <= u:
        core = U[i] - L[i] + 1 >= min_pts
        u = max(u, int(U[i])) if core else u
        print(f"  i = {i:2}: label it; {'core, bound u -> ' + str(u) if core else 'not core, u stays ' + str(u)}")
        i += 1
    print(f"stop at i = {i}: the cluster ends at index {i - 1}")


def radius_and_height(chord, mean_angle):
    """Notebook 08: the radius of the circle whose arc sees a chord of length ``chord`` under ``mean_angle``,
    and the centre's height above the chord's midpoint, away from the arc (the corrected construction)."""
    theta = mean_angle - np.pi / 2
    return chord / 2 / np.cos(theta), chord / 2 * np.tan(theta)
