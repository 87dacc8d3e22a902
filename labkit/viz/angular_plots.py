"""Figures of notebook 07 (angular segmentation), kept here so that a notebook's code cell stays short.

The notebook computes every direction, offset, label and line; these functions only draw what they are given.
"""

from __future__ import annotations

import numpy as np

from labkit.viz import plot as lkplot
from labkit.viz.plot import axes_or_new

__all__ = ["plot_local_directions", "plot_segments", "plot_offsets_and_segments", "plot_side_by_side", "eps_sliders",
           "plot_column_up_close"]

_CORRIDOR_XLIM, _CORRIDOR_YLIM = (-1.5, 19.0), (-2.0, 2.5)


def plot_local_directions(scan, phi, *, length: float = 0.2, truth=None, xlim=None, ylim=None,
                          title: str | None = None, ax=None):
    """A short tick through every point along its local direction, coloured by that direction.

    The colour map is cyclic (``twilight``) over 0 to 180 degrees, so that 0 and 180 degrees, the same
    direction modulo pi, share a colour; a colour bar says which.

    Parameters
    ----------
    scan : labkit.Scan
        The scan (N beams); its valid points are drawn black.
    phi : array_like of shape (N,)
        The local direction at each beam, radians in [0, pi); NaN where there is none (no tick).
    length : float, default 0.2
        The ticks' length, metres.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn under the ticks.
    xlim, ylim : tuple of (float, float), optional
        The axes' limits, metres.
    title : str, optional
        The axes' title.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    from matplotlib.collections import LineCollection

    ax = axes_or_new(ax, (13, 5.5))
    phi = np.asarray(phi, dtype=float)
    ok = np.isfinite(phi)
    p = np.asarray(scan.points, dtype=float)[ok]
    u = 0.5 * length * np.column_stack([np.cos(phi[ok]), np.sin(phi[ok])])
    ticks = LineCollection(list(np.stack([p - u, p + u], axis=1)), array=np.degrees(phi[ok]), cmap="twilight", lw=2)
    ticks.set_clim(0, 180)
    ax.add_collection(ticks)
    ax.scatter(*scan.xy.T, s=1, c="k", zorder=3)
    ax.plot([0], [0], marker=(3, 0, -90), color="tab:red", markersize=12)
    if truth is not None:
        lkplot.plot_truth(truth, ax)
    ax.set_aspect("equal")
    if xlim is not None:
        ax.set_xlim(*xlim)
    if ylim is not None:
        ax.set_ylim(*ylim)
    if title is not None:
        ax.set_title(title)
    ax.figure.colorbar(ticks, ax=ax, label="local direction (deg)", shrink=0.8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return ax


def plot_segments(scan, labels, *, truth=None, title: str | None = None, xlim=_CORRIDOR_XLIM, ylim=_CORRIDOR_YLIM,
                  point_size: float = 5, ax=None):
    """A scan's points coloured by segment (grey: in no segment), with the true walls when given.

    Parameters
    ----------
    scan : labkit.Scan
        The scan (N beams).
    labels : array_like of shape (N,), int
        The segment of each beam; -1 for none.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn as thin grey lines.
    title : str, optional
        The axes' title.
    xlim, ylim : tuple of (float, float), default (-1.5, 19), (-2, 2.5)
        The axes' limits, metres (the corridor's first scan).
    point_size : float, default 5
        The points' marker size.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (13, 3.8))
    lkplot.plot_scan(scan, ax, labels=np.asarray(labels), show_invalid=False, point_size=point_size, title=title,
                     adjustable="box")
    if truth is not None:
        lkplot.plot_truth(truth, ax)
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    return ax


def plot_offsets_and_segments(offsets, marks, scan, labels, *, truth=None, offsets_title: str = "",
                              segments_title: str = "", bins=None):
    """The histogram of the points' offsets across a direction, beside the scan coloured by segment.

    Parameters
    ----------
    offsets : array_like of shape (M,)
        The signed offsets of one angular cluster's points from the line through the origin, metres.
    marks : sequence of float
        Offsets to mark with a dashed red line (e.g. each wall's median), metres.
    scan : labkit.Scan
        The scan (N beams).
    labels : array_like of shape (N,), int
        The final segment of each beam; -1 for none.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn in the scan's panel.
    offsets_title, segments_title : str, default ""
        The two panels' titles.
    bins : array_like, optional
        The histogram's bin edges, metres; by default 2 cm bins from -2 m to 2 m.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure: the histogram on the left, the segments on the right.
    """
    import matplotlib.pyplot as plt

    fig, (ax_h, ax_s) = plt.subplots(1, 2, figsize=(14, 4.5), gridspec_kw={"width_ratios": [1, 1.6]})
    ax_h.hist(np.asarray(offsets, dtype=float), bins=np.arange(-2.0, 2.0, 0.02) if bins is None else bins,
              color="tab:gray")
    for mark in marks:
        ax_h.axvline(mark, color="tab:red", ls="--", lw=0.8)
    ax_h.set_xlabel("signed offset from the line through the origin (m)")
    ax_h.set_ylabel("points")
    ax_h.set_title(offsets_title)
    plot_segments(scan, labels, truth=truth, title=segments_title, point_size=6, ax=ax_s)
    fig.tight_layout()
    return fig


def plot_side_by_side(scan, results: dict, *, truth=None, xlim=None, ylim=None, point_size: float = 4,
                      legend_loc: str = "upper right", figsize=(13, 4.5)):
    """One scan in several panels, each with the lines one extractor found.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    results : dict
        ``{title: (lines, colour)}``: each panel's title, its :class:`labkit.LineSegment` list and the
        colour to draw them in.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn in every panel.
    xlim, ylim : tuple of (float, float), optional
        The panels' limits, metres; None: the scan's extent.
    point_size : float, default 4
        The points' marker size.
    legend_loc : str, default "upper right"
        Where each panel's legend goes.
    figsize : tuple of float, default (13, 4.5)
        The figure's size, inches.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure, one panel per entry of ``results``, in order.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=figsize, squeeze=False)
    box = xlim is not None or ylim is not None
    for ax, (title, (lines, colour)) in zip(axes[0], results.items(), strict=True):
        lkplot.plot_scan(scan, ax, show_invalid=False, point_size=point_size, title=title,
                         adjustable="box" if box else "datalim")
        if truth is not None:
            lkplot.plot_truth(truth, ax)
        lkplot.plot_lines(lines, ax, color=colour)
        if xlim is not None:
            ax.set_xlim(*xlim)
        if ylim is not None:
            ax.set_ylim(*ylim)
        ax.legend(loc=legend_loc, fontsize=8)
    fig.tight_layout()
    return fig


def eps_sliders(redraw, eps_theta_deg: float = 3.0, eps_dist_m: float = 0.03):
    """Sliders for angular segmentation's two radii, calling ``redraw`` when one is released.

    Parameters
    ----------
    redraw : callable
        ``redraw(eps_theta_deg, eps_dist_m)``: prints and draws the segmentation with these radii.
    eps_theta_deg : float, default 3.0
        Where the direction radius starts, degrees (0.5 to 20).
    eps_dist_m : float, default 0.03
        Where the offset radius starts, metres (0.005 to 0.5).

    Returns
    -------
    ipywidgets.interactive
        The two sliders and ``redraw``'s output.
    """
    import ipywidgets as widgets

    style = {"description_width": "initial"}
    return widgets.interactive(
        redraw,
        eps_theta_deg=widgets.FloatSlider(value=eps_theta_deg, min=0.5, max=20.0, step=0.5,
                                          description="eps_theta (deg)", continuous_update=False, style=style),
        eps_dist_m=widgets.FloatSlider(value=eps_dist_m, min=0.005, max=0.5, step=0.005, readout_format=".3f",
                                       description="eps_dist (m)", continuous_update=False, style=style),
    )


def plot_column_up_close(scan, angular_lines, split_merge_lines, truth=None):
    """A column seen from under a metre: angular segmentation's lines beside split-and-merge's.

    Parameters
    ----------
    scan : labkit.Scan
        The scan, the column about 1 m ahead (x from 0 to 1.4 m, y within 0.45 m are shown).
    angular_lines, split_merge_lines : list of labkit.LineSegment
        The two extractors' lines.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn in both panels.

    Returns
    -------
    matplotlib.figure.Figure
        :func:`plot_side_by_side` of the two, in blue and orange.
    """
    return plot_side_by_side(scan, {"a column seen up close: angular segmentation": (angular_lines, "tab:blue"),
                                    "a column seen up close: split-and-merge": (split_merge_lines, "tab:orange")},
                             truth=truth, xlim=(0.0, 1.4), ylim=(-0.45, 0.45), point_size=6, legend_loc="upper left",
                             figsize=(13, 5))
