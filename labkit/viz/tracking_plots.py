"""Figures of tracking (:mod:`labkit.tracking`) for the course notebook and for reports: a Kalman
filter's estimates and covariance ellipses against the truth, gating ellipses, an assignment's cost
matrix, and the tracks of a whole recording.

Example (in a notebook)::

    fig, ax = plt.subplots()
    draw_filter_run(ax, truth_xy, detections_xy, states, covariances)
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse

from ..tracking import TrackTable, gate_threshold
from .style import mpl, track_color

__all__ = ["covariance_ellipse", "draw_filter_run", "draw_gates", "draw_cost_matrix", "draw_tracks", "track_rgb"]


def track_rgb(track_id: int) -> tuple[float, float, float]:
    """The colour of a track in matplotlib (0-1), the same as in rerun (:func:`labkit.viz.style.track_color`).

    Parameters
    ----------
    track_id : int
        The track's id.

    Returns
    -------
    tuple of (float, float, float)
        Red, green and blue, 0 to 1.
    """
    r, g, b = track_color(track_id)
    return r / 255, g / 255, b / 255


def covariance_ellipse(ax, center, covariance, d2: float = 1.0, **style) -> Ellipse:
    """Draw the ellipse ``(p - center)' C^-1 (p - center) = d2`` of a 2 x 2 covariance ``C``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    center : array_like of shape (2,) or longer
        The ellipse's centre: its first two entries ``(x, y)`` (a state ``(x, y, vx, vy)`` will do).
    covariance : array_like of shape (2, 2) or larger
        The covariance ``C``: its upper-left 2 x 2 block.
    d2 : float, default 1.0
        The squared Mahalanobis distance of the ellipse: 1 for one standard deviation,
        ``gate_threshold(p)`` for the gate at probability ``p``.
    **style
        Keywords of :class:`matplotlib.patches.Ellipse` (colour, line width, ...); not filled unless
        ``fill=True``.

    Returns
    -------
    matplotlib.patches.Ellipse
        The patch, added to ``ax``.
    """
    values, vectors = np.linalg.eigh(np.asarray(covariance, dtype=float)[:2, :2])
    width, height = 2 * np.sqrt(d2 * np.clip(values, 0.0, None))
    angle = np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1]))
    patch = Ellipse(tuple(np.asarray(center, dtype=float)[:2]), height, width, angle=angle,
                    **{"fill": False, **style})
    ax.add_patch(patch)
    return patch


def draw_filter_run(ax, truth_xy, detections_xy, states, covariances, *, every: int = 5, d2: float = 4.0) -> None:
    """One target: its true path, the detections, the filter's estimates and covariance ellipses.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    truth_xy : array_like of shape (K, 2)
        The target's true positions, metres.
    detections_xy : array_like of shape (M, 2)
        The detections, metres.
    states : array_like of shape (K, 4)
        The filter's estimates ``(x, y, vx, vy)``, one per step.
    covariances : sequence of array_like of shape (4, 4)
        The estimates' covariances; the ellipse of the position block is drawn.
    every : int, default 5
        Draw an ellipse every ``every`` steps.
    d2 : float, default 4.0
        The squared Mahalanobis distance of the ellipses (4: two standard deviations).
    """
    truth_xy, detections_xy, states = (np.asarray(a, dtype=float) for a in (truth_xy, detections_xy, states))
    ax.plot(truth_xy[:, 0], truth_xy[:, 1], color="0.4", lw=1.5, label="truth")
    ax.scatter(detections_xy[:, 0], detections_xy[:, 1], s=12, color=mpl("people"), label="detections", zorder=3)
    ax.plot(states[:, 0], states[:, 1], "-", color="tab:blue", lw=1.2, label="estimate")
    for k in range(0, len(states), max(int(every), 1)):
        covariance_ellipse(ax, states[k], covariances[k], d2, color="tab:blue", lw=0.8, alpha=0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=8)


def draw_gates(ax, predicted: Sequence, innovation_covariances: Sequence, detections_xy, *,
               probability: float = 0.99, labels: Sequence[str] | None = None) -> np.ndarray:
    """Gating ellipses of predicted positions, and the detections, filled when inside at least one gate.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    predicted : sequence of array_like of shape (2,) or longer
        The predicted position ``(x, y)`` of each track (the first two entries of a state will do).
    innovation_covariances : sequence of array_like of shape (2, 2)
        The innovation covariance ``S`` of each track.
    detections_xy : array_like of shape (D, 2)
        The detections, metres.
    probability : float, default 0.99
        The gates' probability: each ellipse is ``d2 = gate_threshold(probability)``.
    labels : sequence of str, optional
        The legend's label of each track; by default ``track i: prediction and gate``.

    Returns
    -------
    ndarray of shape (T, D)
        The squared Mahalanobis distance ``d2`` of every detection from every track's prediction.
    """
    threshold = gate_threshold(probability)
    detections_xy = np.asarray(detections_xy, dtype=float).reshape(-1, 2)
    d2 = np.zeros((len(predicted), len(detections_xy)))
    for i, (p, S) in enumerate(zip(predicted, innovation_covariances, strict=True)):
        colour = plt.cm.tab10(i % 10)
        covariance_ellipse(ax, p, S, threshold, color=colour, lw=1.2)
        ax.plot(*np.asarray(p, dtype=float)[:2], "+", color=colour, ms=10,
                label=labels[i] if labels else f"track {i}: prediction and gate")
        nu = detections_xy - np.asarray(p, dtype=float)[:2]
        d2[i] = np.einsum("ni,ij,nj->n", nu, np.linalg.inv(np.asarray(S, dtype=float)), nu)
    inside = (d2 <= threshold).any(axis=0)
    ax.scatter(*detections_xy[inside].T, s=30, color="k", label="detection inside a gate", zorder=3)
    ax.scatter(*detections_xy[~inside].T, s=30, facecolors="none", edgecolors="k", label="outside every gate",
               zorder=3)
    for j, (x, y) in enumerate(detections_xy):
        ax.annotate(f"d{j}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize=8)
    return d2


def draw_cost_matrix(ax, cost, rows=None, cols=None) -> None:
    """A cost matrix as a table of numbers (``inf``: outside the gate), the chosen pairs framed.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    cost : array_like of shape (T, D)
        The cost of each pair of a track (row) and a detection (column).
    rows, cols : sequence of int, optional
        The chosen pairs ``rows[k], cols[k]``, framed in red; none when None.
    """
    cost = np.asarray(cost, dtype=float)
    shown = np.where(np.isfinite(cost), cost, np.nan)
    ax.imshow(shown, cmap="Blues_r")
    for (i, j), value in np.ndenumerate(cost):
        ax.text(j, i, "inf" if not np.isfinite(value) else f"{value:.1f}", ha="center", va="center", fontsize=10)
    for i, j in zip(rows if rows is not None else [], cols if cols is not None else [], strict=True):
        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, color="tab:red", lw=2.5))
    ax.set_xticks(range(cost.shape[1]), [f"d{j}" for j in range(cost.shape[1])])
    ax.set_yticks(range(cost.shape[0]), [f"track {i}" for i in range(cost.shape[0])])


def draw_tracks(ax, tables: Iterable[TrackTable], *, min_scans: int = 1, background=None) -> dict[int, int]:
    """The paths of every moving track of a recording, each in its colour and labelled with its id where it ends.

    Only the confirmed rows of the tables are drawn.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw into.
    tables : iterable of TrackTable
        One :class:`labkit.tracking.TrackTable` per scan, in time order.
    min_scans : int, default 1
        Tracks confirmed in fewer scans are left out.
    background : array_like of shape (N, 2), optional
        Points drawn grey beneath the paths (e.g. a map).

    Returns
    -------
    dict of {int: int}
        ``{id: scans confirmed}`` of the tracks drawn.
    """
    paths: dict[int, list] = {}
    for table in tables:
        for i in np.flatnonzero(table.status == "confirmed"):
            paths.setdefault(int(table.ids[i]), []).append(table.states[i, :2])
    if background is not None and len(background):
        bg = np.asarray(background, dtype=float)
        ax.scatter(bg[:, 0], bg[:, 1], s=0.5, color="0.7", zorder=1)
    drawn = {}
    for tid, points in paths.items():
        if len(points) < min_scans:
            continue
        p = np.array(points)
        ax.plot(p[:, 0], p[:, 1], "-", color=track_rgb(tid), lw=1.2, zorder=2)
        ax.annotate(str(tid), p[-1], fontsize=7, color=track_rgb(tid))
        drawn[tid] = len(points)
    ax.set_aspect("equal")
    return drawn
