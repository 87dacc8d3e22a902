"""Figures of the course notebooks, kept here so that a notebook's code cell stays a few lines long.

Every function draws into an ``Axes`` (made for you when ``ax`` is None) and returns it, as in
:mod:`labkit.viz.plot`.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection

from labkit.viz import plot as lkplot
from labkit.viz.plot import axes_or_new
from labkit.viz.style import mpl

__all__ = ["chord_frame", "plot_middle_band", "plot_circle_fits", "plot_angular_clusters", "plot_lines_and_corners",
           "plot_lines_and_corners_grid", "extraction_controls", "plot_counts_and_timings",
           "plot_map", "plot_seam_merges"]


def chord_frame(points) -> np.ndarray:
    """Points moved into their chord's own frame: the first at (0, 0), the last at (1, 0).

    Parameters
    ----------
    points : array_like of shape (N, 2)
        Points ``(x, y)``; the first and the last must differ.

    Returns
    -------
    ndarray of shape (N, 2)
        The points along the chord and across it (to its left, seen from the first point towards the
        last), in chord lengths.

    Raises
    ------
    ValueError
        When the first and the last point coincide.
    """
    p = np.asarray(points, dtype=float)
    d = p[-1] - p[0]
    chord = float(np.hypot(d[0], d[1]))
    if chord == 0.0:
        raise ValueError("the first and the last point coincide: there is no chord")
    along = d / chord
    across = np.array([-along[1], along[0]])
    q = p - p[0]
    return np.column_stack([q @ along, q @ across]) / chord


def plot_middle_band(examples: dict, ratios: dict, low: float = 0.1, high: float = 0.7, ax=None):
    """Notebook 08, Fig. 5 of Xavier et al.: the middle point of each example against the band.

    Each example is drawn in its chord's frame (every bulge on the sensor's side), its middle point
    circled, with the band ``low`` to ``high`` chord lengths away from the chord.

    Parameters
    ----------
    examples : dict
        ``{name: points}``, the points of each example an array_like of shape (N, 2).
    ratios : dict
        ``{name: ratio}``, the middle point's distance from the chord in chord lengths, for each example;
        the legend says whether it lies in the band.
    low, high : float, default 0.1, 0.7
        The band's limits, in chord lengths.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (8, 4.5))
    ax.axhspan(low, high, color="tab:green", alpha=0.12, label=f"band: {low} d to {high} d")
    ax.plot([0, 1], [0, 0], "k", lw=2, label="chord (length d)")
    for k, (name, points) in enumerate(examples.items()):
        q = chord_frame(points)
        q[:, 1] = np.abs(q[:, 1])
        inside = low < ratios[name] < high
        ax.plot(*q.T, ".-", color=f"C{k}", label=f"{name}: {ratios[name]:.2f} d ({'in' if inside else 'out'})")
        ax.plot(*q[len(q) // 2], "o", ms=11, mfc="none", mec=f"C{k}", mew=2)
    ax.annotate("sensor side", (0.5, 0.8), ha="center", color="0.4")
    ax.set_aspect("equal")
    ax.set_xlim(-0.1, 1.1)
    ax.set_ylim(-0.1, 0.95)
    ax.set_xlabel("along the chord / d")
    ax.set_ylabel("towards the sensor / d")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    ax.set_title("Fig. 5: the middle point (circled) must lie in the band")
    return ax


def plot_circle_fits(points, circles: dict, ax=None):
    """Notebook 08: points and the circles fitted to them, with the chord between the extreme points.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        The points ``(x, y)``, metres.
    circles : dict
        ``{name: (centre, radius, colour)}``: a centre ``(x, y)`` and a radius in metres and a matplotlib
        colour; the first is drawn wide (the truth).
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (6, 5))
    full = np.linspace(0, 2 * np.pi, 200)
    for k, (name, (c, r, colour)) in enumerate(circles.items()):
        ax.plot(c[0] + r * np.cos(full), c[1] + r * np.sin(full), color=colour, lw=5 if k == 0 else 2, alpha=0.8,
                label=f"{name}: R = {r:.3f} m")
        ax.plot(*c, "+", color=colour, ms=12, mew=2)
    points = np.asarray(points, dtype=float)
    ax.plot(*points.T, "o", color="tab:blue", label="points")
    ax.plot(*points[[0, -1]].T, "k--", lw=1, label="chord")
    ax.set_aspect("equal")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.set_title("centre and radius from the mean inscribed angle")
    return ax


def plot_angular_clusters(scan, phi, labels, n_clusters: int, xlim=(-1.5, 19), ylim=(-2, 2.5)):
    """Notebook 07: a histogram of the local directions per angular cluster, beside the scan's points.

    Parameters
    ----------
    scan : Scan
        The laser scan (N beams).
    phi : ndarray of shape (N,)
        The local direction at each beam, radians (NaN where there is none).
    labels : ndarray of shape (N,), int
        The angular cluster of each beam, 0 to ``n_clusters - 1``; -1 for noise (drawn grey).
    n_clusters : int
        The number of clusters.
    xlim, ylim : tuple of (float, float), default (-1.5, 19), (-2, 2.5)
        The limits of the scan's plot, metres.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure: the histogram (degrees) on the left, the points coloured by cluster on the right.
    """
    from .plot import plot_scan

    fig, (ax_h, ax_s) = plt.subplots(1, 2, figsize=(14, 4.5), gridspec_kw={"width_ratios": [1, 1.6]})
    bins = np.arange(0, 181, 2)
    for k in range(n_clusters):
        ax_h.hist(np.degrees(phi[labels == k]), bins=bins, color=f"C{k}", label=f"cluster {k}")
    ax_h.hist(np.degrees(phi[np.isfinite(phi) & (labels == -1)]), bins=bins, color="lightgray", label="noise")
    ax_h.set_xlabel("local direction (deg)")
    ax_h.set_ylabel("points")
    ax_h.legend(fontsize=8)
    ax_h.set_title("angular clusters (same colour at 0 and 180: one cluster)")
    plot_scan(scan, ax_s, labels=labels, show_invalid=False, title="points coloured by angular cluster",
              point_size=6, adjustable="box")
    ax_s.set_xlim(*xlim)
    ax_s.set_ylim(*ylim)
    fig.tight_layout()
    return fig


def plot_lines_and_corners(scan, lines, corners, *, truth=None, title: str | None = None, point_size: float = 5,
                           show_invalid: bool = True, legend_fontsize: float | None = 7, figsize=(9, 6.5), ax=None):
    """Notebook 05: a scan with its line segments and corners (and its ground truth when given).

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    lines : list of labkit.LineSegment
        Its line segments.
    corners : list of labkit.Corner
        Its corners.
    truth : labkit.sim.ScanTruth, optional
        The ground truth, drawn under the lines.
    title : str, optional
        The axes' title.
    point_size : float, default 5
        Size of the scan's points.
    show_invalid : bool, default True
        Draw faint rays for beams without a valid return.
    legend_fontsize : float or None, default 7
        The legend's font size, in the upper right corner; None for no legend.
    figsize : tuple of float, default (9, 6.5)
        The figure's size when ``ax`` is None.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, figsize)
    lkplot.plot_scan(scan, ax, point_size=point_size, show_invalid=show_invalid, title=title)
    if truth is not None:
        lkplot.plot_truth(truth, ax)
    lkplot.plot_lines(lines, ax)
    lkplot.plot_corners(corners, ax)
    if legend_fontsize is not None:
        ax.legend(loc="upper right", fontsize=legend_fontsize)
    return ax


def plot_lines_and_corners_grid(panels, ncols: int = 3, *, point_size: float = 5, legend: bool = True,
                                figsize=(15, 9.5)):
    """Notebook 05: several scans side by side, each with its line segments and corners.

    Parameters
    ----------
    panels : sequence of tuple
        ``(scan, lines, corners, title)`` per panel, drawn as :func:`plot_lines_and_corners` draws one
        (without faint rays for invalid beams), row by row.
    ncols : int, default 3
        Panels per row.
    point_size : float, default 5
        Size of the scans' points.
    legend : bool, default True
        One legend, in the first panel's lower left corner.
    figsize : tuple of float, default (15, 9.5)
        The figure's size, inches.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure; axes left over in the last row are hidden.
    """
    panels = list(panels)
    nrows = max(1, -(-len(panels) // ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=figsize, squeeze=False)
    for ax, (scan, lines, corners, title) in zip(axes.flat, panels, strict=False):
        plot_lines_and_corners(scan, lines, corners, title=title, point_size=point_size, show_invalid=False,
                               legend_fontsize=None, ax=ax)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    if legend and panels:
        axes.flat[0].legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    return fig


def extraction_controls(show, scenes, n_scans: int = 20, scene: str | None = None):
    """Notebook 05: controls for split-and-merge on a simulated scan, calling ``show`` when one changes.

    Parameters
    ----------
    show : callable
        ``show(scene, k, method, split_threshold_m, min_points, merge)``: extracts and draws scan ``k`` of
        ``scene``; ``method`` is ``"endpoints"`` or ``"fit"``, ``merge`` ``"thresholds"``, ``"chi2"`` or
        ``"none"``.
    scenes : sequence of str
        The scenes to choose from.
    n_scans : int, default 20
        The scans of each scene, numbered 0 to ``n_scans - 1``.
    scene : str, optional
        The scene shown first; None: ``"corridor"`` when offered, else the first.

    Returns
    -------
    ipywidgets.VBox
        The controls (scene and scan, method, split threshold, min points and merge) above ``show``'s output.
    """
    import ipywidgets as widgets

    scenes = list(scenes)
    first = scene if scene is not None else ("corridor" if "corridor" in scenes else scenes[0])
    controls = {
        "scene": widgets.Dropdown(options=scenes, value=first, description="scene"),
        "k": widgets.IntSlider(value=0, min=0, max=n_scans - 1, description="scan", continuous_update=False),
        "method": widgets.ToggleButtons(options=["endpoints", "fit"], description="method"),
        "split_threshold_m": widgets.FloatSlider(value=0.05, min=0.005, max=0.5, step=0.005, readout_format=".3f",
                                                 description="split (m)", continuous_update=False),
        "min_points": widgets.IntSlider(value=5, min=2, max=30, description="min points", continuous_update=False),
        "merge": widgets.Dropdown(options=["thresholds", "chi2", "none"], value="thresholds", description="merge"),
    }
    plot_area = widgets.interactive_output(show, controls)
    return widgets.VBox([widgets.HBox([controls["scene"], controls["k"]]), controls["method"],
                         widgets.HBox([controls["split_threshold_m"], controls["min_points"], controls["merge"]]),
                         plot_area])


def plot_counts_and_timings(counts: dict, times_ms: dict, kinds, *, skip=(), title: str = ""):
    """Features per scan, one small panel per kind, over the milliseconds of each stage per scan.

    Parameters
    ----------
    counts : dict
        ``{kind: array of shape (N,)}``: how many features of each kind every scan produced.
    times_ms : dict
        ``{stage: array of shape (N,)}``: the milliseconds each stage took on every scan; must hold
        ``"total"``, whose 99.5th percentile (times 1.2) tops the time axis.
    kinds : sequence of str
        The kinds to draw, one panel each, from the top; each panel's title gives its mean per scan.
    skip : sequence of str, optional
        Stages of ``times_ms`` not to draw.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: ``len(kinds)`` count panels, then the time panel, against the scan index.
    """
    kinds = list(kinds)
    fig, axes = plt.subplots(len(kinds) + 1, 1, figsize=(12, 10), sharex=True,
                             gridspec_kw={"height_ratios": [1] * len(kinds) + [3]})
    for n, (ax, k) in enumerate(zip(axes, kinds, strict=False)):
        c = np.asarray(counts[k])
        ax.plot(np.arange(len(c)), c, drawstyle="steps-mid", lw=0.8, color=f"C{n}")
        ax.set_ylabel(k, rotation=0, ha="right", va="center")
        ax.set_ylim(-0.5, c.max() + 0.5)
        ax.set_title(f"mean {c.mean():.2f} per scan", fontsize=8, loc="right", pad=2)
    ax_t = axes[-1]
    for k, v in times_ms.items():
        if k not in skip:
            ax_t.plot(np.arange(len(v)), v, lw=0.8, label=f"{k} (median {np.median(v):.2f} ms)")
    ax_t.set_ylabel("ms per scan")
    ax_t.set_xlabel("scan index (10 per second)")
    ax_t.set_ylim(0, np.percentile(times_ms["total"], 99.5) * 1.2)
    ax_t.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_map(points, segments, path, *, points_label: str = "points", lines_label: str = "lines", title: str = "",
             ax=None):
    """A map in the world frame: points in grey, line segments in faint red, the sensor's path in blue.

    The segments are drawn faint, so that they darken where many scans saw the same wall.

    Parameters
    ----------
    points : array_like of shape (N, 2)
        Map points, in metres.
    segments : array_like of shape (M, 2, 2)
        Line segments, each its two end points, in metres.
    path : array_like of shape (K, 2)
        The sensor's positions in order, in metres.
    points_label : str, default "points"
        The points' legend entry.
    lines_label : str, default "lines"
        The segments' legend entry, after their number.
    title : str, optional
        The axes' title.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones (9 x 9 inches) when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into, at equal scales.
    """
    ax = axes_or_new(ax, (9, 9))
    points, path = np.asarray(points, dtype=float), np.asarray(path, dtype=float)
    segments = np.asarray(segments, dtype=float).reshape(-1, 2, 2)
    ax.scatter(points[:, 0], points[:, 1], s=1, color="0.55", label=points_label)
    ax.add_collection(LineCollection(segments, colors="tab:red", linewidths=0.4, alpha=0.25,
                                     label=f"{len(segments):,} {lines_label}"))
    ax.plot(path[:, 0], path[:, 1], color="tab:blue", lw=1, label="sensor path")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, world)")
    ax.set_ylabel("y (m, world)")
    ax.legend(loc="upper right")
    if title:
        ax.set_title(title)
    return ax


def plot_seam_merges(scan, merges: dict, *, title: str = "office, scan 0"):
    """One panel per merge of a full-circle scan's lines, the lines at the seam drawn wide.

    In each panel the first line (in the colour of circles) and the last one (in the colour of legs)
    are drawn wide when they cross the seam (first beam after the last) or face backwards (their normal
    within 10 degrees of +-180), each labelled with its beams and alpha.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    merges : dict
        ``{name: lines}``, e.g. ``{"naive": ..., "wrapped": ...}``: the merged lines, in scan order.
    title : str, default "office, scan 0"
        The start of each panel's title; ", merged with the NAME angle difference" follows.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, one panel per merge side by side.
    """
    fig, axes = plt.subplots(1, len(merges), figsize=(6.5 * len(merges), 7), squeeze=False)
    for ax, (name, lines) in zip(axes[0], merges.items(), strict=True):
        lkplot.plot_scan(scan, ax, point_size=5, title=f"{title}, merged with the {name} angle difference")
        lkplot.plot_lines(lines, ax, label=f"{len(lines)} line segments")
        for line, color in [(lines[0], mpl("circles")), (lines[-1], mpl("legs"))]:
            if line.first > line.last or np.degrees(abs(line.alpha)) > 170:
                lkplot.plot_lines([line], ax, color=color, lw=4, label=f"beams {line.first}..{line.last}, "
                                                               f"alpha {np.degrees(line.alpha):.1f} deg")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize=8)
    fig.tight_layout()
    return fig
