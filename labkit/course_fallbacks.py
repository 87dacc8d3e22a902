"""What a course notebook goes on with while a "your turn" function is still a stub.

:func:`labkit.course.check` returns the fallback when the student's function still raises
``NotImplementedError``, so the rest of the notebook runs. The fallbacks live here, not in the
notebook's cells, so that no answer is written below its task: each is labkit's own function (or the
closed form it computes), under the name the notebook asks the student for.
"""

from __future__ import annotations

import numpy as np

from .fitting import fit_line_polar
from .geometry import signed_distance_to_line
from .pipeline import Config
from .poses import interpolate_poses
from .tracking import assign, cv_model

__all__ = ["closed_form_alpha", "ideal_weights", "is_core", "wall_offsets", "config_for", "mean_per_scan", "rates",
           "pose_at", "process_noise", "best_assignment"]


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
