"""Figures of notebook 06 (DBSCAN in one dimension), kept here so that a notebook's code cell stays short.

The notebook computes every role, label and time; these functions only draw what they are given.
Every function draws into an ``Axes`` (made for you when ``ax`` is None) and returns it, as in
:mod:`labkit.viz.plot`.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from labkit.viz.plot import axes_or_new

__all__ = ["ROLE_STYLE", "plot_roles", "plot_policy", "plot_reference_clusters", "plot_timings"]

#: The colour and the marker of each DBSCAN role.
ROLE_STYLE = {"core": ("tab:blue", "o"), "border": ("tab:orange", "s"), "noise": ("tab:gray", "x")}

_MARKERS = ("o-", "^-", "s-", "d-", "v-")


def _cluster_colours(labels) -> list[str]:
    return [f"C{k}" if k >= 0 else "gray" for k in labels]


def plot_roles(x, role, eps: float, *, title: str | None = None, ax=None):
    """Points on a line coloured by their role, each with its eps-interval stacked below it.

    Parameters
    ----------
    x : array_like of shape (N,)
        The points, sorted.
    role : array_like of str, shape (N,)
        ``"core"``, ``"border"`` or ``"noise"`` for each point (see :data:`ROLE_STYLE`).
    eps : float
        The radius: point ``i``'s bar spans ``x[i] - eps`` to ``x[i] + eps``.
    title : str, optional
        The axes' title.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (11, 3.6))
    x, role = np.asarray(x, dtype=float), np.asarray(role)
    for name, (colour, marker) in ROLE_STYLE.items():
        sel = role == name
        ax.scatter(x[sel], np.zeros(sel.sum()), c=colour, marker=marker, s=60, zorder=3, label=name)
    for i, xi in enumerate(x):  # one eps-interval per point, stacked below the line
        colour = ROLE_STYLE[str(role[i])][0]
        ax.plot([xi - eps, xi + eps], [-0.15 - 0.07 * i] * 2, color=colour, lw=2, alpha=0.7)
        ax.plot([xi, xi], [-0.15 - 0.07 * i, 0], color=colour, lw=0.5, alpha=0.4)
    ax.axhline(0, color="k", lw=0.5, zorder=1)
    ax.set_yticks([])
    ax.set_xlabel("x")
    ax.legend(loc="upper right", ncol=3)
    ax.set_ylim(-0.3 - 0.07 * len(x), 0.35)
    if title:
        ax.set_title(title)
    return ax


def plot_policy(x, eps: float, core, border, labels, *, title: str = "", ax=None):
    """Roles as markers, clusters as colours, and a red ring on every point two clusters share.

    Parameters
    ----------
    x : array_like of shape (N,)
        The points, sorted.
    eps : float
        The radius, for the eps-interval drawn below each point (coloured by its first cluster).
    core, border : array_like of bool, shape (N,)
        Where the points are core points and border points; the others are drawn as noise.
    labels : array_like of int, shape (N,) or (N, 2)
        Cluster labels as :func:`labkit.dbscan1d` returns them (-1: none); with two columns (border
        policy ``"all"``) the second is a second cluster, and those points get the ring.
    title : str, optional
        The start of the title; the counts of clusters, core, border and unclustered points follow it.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (11, 2.6))
    x, c, b, labels = np.asarray(x, dtype=float), np.asarray(core), np.asarray(border), np.asarray(labels)
    first, second = (labels[:, 0], labels[:, 1]) if labels.ndim == 2 else (labels, np.full(len(x), -1))
    for name, sel, marker in [("core", c, "o"), ("border", b, "s"), ("noise", ~c & ~b, "x")]:
        ax.scatter(x[sel], np.zeros(sel.sum()), c=_cluster_colours(first[sel]), marker=marker, s=70, zorder=3,
                   label=name)
    two = second >= 0
    shared = ", ".join(f"{x[i]:g} (clusters {first[i]} and {second[i]})" for i in np.flatnonzero(two))
    ax.scatter(x[two], np.zeros(two.sum()), s=260, facecolors="none", edgecolors="tab:red", lw=2, zorder=4,
               label=f"in two clusters: {shared or 'none'}")
    for i, xi in enumerate(x):
        ax.plot([xi - eps, xi + eps], [-0.12 - 0.05 * i] * 2, color=_cluster_colours([first[i]])[0], lw=1.5,
                alpha=0.6)
    ax.set_yticks([])
    ax.set_ylim(-0.9, 0.4)
    ax.set_xlabel("x (marker: role from your functions; colour: cluster from labkit.dbscan1d)")
    ax.legend(loc="upper right", ncol=4, fontsize=8)
    counts = (f"{int(first.max()) + 1} cluster(s), {int(c.sum())} core, {int(b.sum())} border, "
              f"{int(np.sum(first < 0))} unclustered")
    ax.set_title(f"{title}: {counts}" if title else counts)
    return ax


def plot_reference_clusters(x, labels, clusters, *, ax=None):
    """The points coloured by cluster (grey: noise), each cluster's index range shaded behind them.

    Parameters
    ----------
    x : array_like of shape (N,)
        The points, sorted.
    labels : array_like of int, shape (N,)
        Each point's cluster, -1 for noise.
    clusters : sequence
        The clusters as :func:`labkit.dbscan1d_reference` returns them: each with ``id``, ``lower`` and
        ``upper`` (the first and the last sorted index it covers).
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (11, 2.2))
    x = np.asarray(x, dtype=float)
    for c in clusters:
        ax.axvspan(x[c.lower] - 0.1, x[c.upper] + 0.1, color=f"C{c.id}", alpha=0.2,
                   label=f"cluster {c.id}: indices {c.lower}..{c.upper}")
    ax.scatter(x, np.zeros_like(x), c=_cluster_colours(labels), s=50, zorder=3)
    ax.set_yticks([])
    ax.set_xlabel("x")
    ax.legend(loc="upper right")
    ax.set_title("clusters found by dbscan1d_reference (grey: noise)")
    return ax


def plot_timings(sizes, times_n: dict, eps_values, times_eps: dict, n_eps: int):
    """Two log-log panels: time against N (with a line proportional to N) and time against eps.

    Parameters
    ----------
    sizes : array_like of shape (K,)
        The numbers of points of the first panel.
    times_n : dict
        ``{label: times}``, seconds per entry of ``sizes`` (NaN where a method was not run); the dashed
        line proportional to N goes through the first method's last time.
    eps_values : array_like of shape (M,)
        The radii of the second panel.
    times_eps : dict
        ``{label: times}``, seconds per entry of ``eps_values``.
    n_eps : int
        The number of points of the second panel, for its title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, (ax_n, ax_e) = plt.subplots(1, 2, figsize=(13, 4.5))
    sizes = np.asarray(sizes, dtype=float)
    for k, (label, t) in enumerate(times_n.items()):
        ax_n.loglog(sizes, np.asarray(t, dtype=float), _MARKERS[k % len(_MARKERS)], label=label)
    first = np.asarray(next(iter(times_n.values())), dtype=float)
    ax_n.loglog(sizes, sizes * first[-1] / sizes[-1], "k--", lw=0.8, label=r"$\propto N$")
    ax_n.set_xlabel("N (points)")
    ax_n.set_title("time against N, small neighbourhoods (cf. paper Fig. 7)")
    for k, (label, t) in enumerate(times_eps.items()):
        ax_e.loglog(eps_values, t, _MARKERS[k % len(_MARKERS)], label=label)
    ax_e.set_xlabel(r"$\varepsilon$ (one point per unit length)")
    ax_e.set_title(f"time against eps, N = {n_eps:,} (cf. paper Fig. 8)")
    for ax in (ax_n, ax_e):
        ax.set_ylabel("time (s)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
