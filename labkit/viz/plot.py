"""matplotlib figures of scans, segments and ground truth.

Every function draws into an ``Axes`` (made for you when ``ax`` is None) and returns it,
so figures compose. Coordinates are the sensor frame: x to the right, y up, metres.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle as CirclePatch

from ..geometry import arc_points
from ..scan import Scan
from .style import label_colors, mpl

__all__ = ["plot_scan", "plot_ranges", "plot_truth", "plot_lines", "plot_corners", "plot_circles", "plot_legs",
           "plot_features", "scan_figure"]


def axes_or_new(ax, figsize=(7, 6)):
    """The axes to draw into: ``ax``, or new ones of ``figsize`` (inches) when ``ax`` is None."""
    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_scan(
    scan: Scan,
    ax=None,
    *,
    labels=None,
    show_invalid: bool = True,
    point_size: float = 9.0,
    title: str | None = None,
    adjustable: str = "datalim",
):
    """Draw a scan's valid points, the sensor, and faint rays for beams without a valid return.

    The axes keep equal scales; pass ``adjustable="box"`` when you set the limits yourself
    (the default, ``"datalim"``, widens them to fit the axes' shape).

    Parameters
    ----------
    scan : Scan
        The scan.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    labels : ndarray of shape (N,) or None
        Per-beam labels to colour the points by, as :func:`labkit.segmentation.segment_labels`
        returns them.
    show_invalid : bool
        Draw the rays of the beams without a valid return.
    point_size : float
        The points' marker size.
    title : str or None
        The axes' title.
    adjustable : str
        ``"datalim"`` or ``"box"``.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    if show_invalid and (~scan.valid).any():
        a = scan.angles[~scan.valid]
        reach = 0.5 * float(np.nanmax(np.abs(scan.xy))) if len(scan.xy) else 1.0
        segs = [[(0, 0), (reach * np.cos(t), reach * np.sin(t))] for t in a]
        ax.add_collection(LineCollection(segs, colors=[mpl("invalid")], linewidths=0.4, alpha=0.5,
                                         label=f"invalid beams ({len(a)})", zorder=1))
    colors: np.ndarray | list[tuple[float, float, float]]
    if labels is not None:
        labels = np.asarray(labels)
        if labels.shape != (scan.n_beams,):
            raise ValueError(f"labels must have shape ({scan.n_beams},), got {labels.shape}")
        colors = label_colors(labels[scan.valid_indices]) / 255
    else:
        colors = [mpl("points")]
    ax.scatter(scan.xy[:, 0], scan.xy[:, 1], s=point_size, c=colors, label=f"valid beams ({len(scan.xy)})",
               zorder=3, linewidths=0)
    ax.plot([0], [0], marker=(3, 0, -90), color=mpl("sensor"), markersize=12, linestyle="none", zorder=4,
            label="sensor")
    ax.set_aspect("equal", adjustable=adjustable)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title:
        ax.set_title(title)
    return ax


def plot_ranges(scan: Scan, ax=None, *, title: str | None = None):
    """Range against beam angle: the scan as the sensor reports it, invalid beams marked.

    Parameters
    ----------
    scan : Scan
        The scan.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    title : str or None
        The axes' title.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    deg = np.degrees(scan.angles)
    ok = scan.valid
    ax.plot(deg[ok], scan.ranges[ok], ".", ms=3, color=mpl("points"), label="valid")
    bad = ~ok
    if bad.any():
        shown = np.where(np.isfinite(scan.ranges[bad]), scan.ranges[bad], 0.0)
        ax.plot(deg[bad], shown, "x", ms=4, color=mpl("sensor"), label="invalid (NaN drawn at 0)")
    top = float(np.max(scan.ranges[ok])) if ok.any() else 0.0
    if np.isfinite(scan.range_max) and scan.range_max < 1.5 * top:
        ax.axhline(scan.range_max, color=mpl("invalid"), lw=0.8, ls="--", label="range_max")
    ax.set_xlabel("beam angle (deg)")
    ax.set_ylabel("range (m)")
    if title:
        ax.set_title(title)
    return ax


def plot_truth(truth, ax=None):
    """Overlay simulator ground truth: walls as lines, circles and arcs in green, legs in purple.

    Parameters
    ----------
    truth : labkit.sim.ScanTruth
        The scan's ground truth.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    for k, w in enumerate(truth.walls):
        ax.plot(*np.array([w.start, w.end]).T, "-", color=mpl("truth"), lw=1.2, alpha=0.7,
                label="true walls" if k == 0 else None, zorder=2)
    for k, c in enumerate(truth.circles):
        ax.add_patch(CirclePatch(c.center, c.radius, fill=False, color=mpl("circles"), lw=1.2,
                                 label="true circles" if k == 0 else None))
    for k, a in enumerate(truth.arcs):
        ax.plot(*arc_points(a.center, a.radius, a.start, a.end).T, "-", color=mpl("circles"), lw=1.5,
                label="true arcs" if k == 0 else None, zorder=2)
    for k, g in enumerate(truth.legs):
        ax.add_patch(CirclePatch(g.center, g.diameter / 2, fill=False, color=mpl("legs"), lw=1.2,
                                 label="true legs" if k == 0 else None))
    return ax


def plot_lines(lines, ax=None, *, label: str | None = None, color=None, lw: float = 2.2, annotate: bool = False):
    """Draw :class:`labkit.LineSegment` records from ``start`` to ``end``.

    Parameters
    ----------
    lines : sequence of LineSegment
        The lines.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    label : str or None
        The legend's label; None: "lines (count)".
    color : color or None
        A matplotlib colour; None: the lines' colour of the house palette.
    lw : float
        The line width, points.
    annotate : bool
        Number each line by its place in the list.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    segs = [[tuple(ln.start), tuple(ln.end)] for ln in lines]
    if segs:
        ax.add_collection(LineCollection(segs, colors=[color or mpl("lines")], linewidths=lw, zorder=5,
                                         label=f"lines ({len(segs)})" if label is None else label))
        ax.autoscale_view()
    if annotate:
        for k, ln in enumerate(lines):
            mid = (np.asarray(ln.start) + np.asarray(ln.end)) / 2
            ax.annotate(str(k), mid, fontsize=7, color=color or mpl("lines"), zorder=6)
    return ax


def plot_corners(corners, ax=None):
    """Draw :class:`labkit.Corner` records: filled diamonds concave, open convex, a cross across a gap.

    A corner extrapolated across a gap gets the cross.

    Parameters
    ----------
    corners : sequence of Corner
        The corners.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    for kind, marker_face in (("concave", mpl("corners")), ("convex", "none")):
        pts = [c.point for c in corners if c.kind == kind and not c.extrapolated]
        if pts:
            ax.scatter(*np.array(pts).T, s=70, marker="D", facecolors=marker_face, edgecolors=[mpl("corners")],
                       linewidths=1.5, zorder=7, label=f"{kind} corners ({len(pts)})")
    pts = [c.point for c in corners if c.extrapolated]
    if pts:
        ax.scatter(*np.array(pts).T, s=70, marker="X", color=mpl("corners"), zorder=7,
                   label=f"extrapolated corners ({len(pts)})")
    return ax


def plot_circles(circles, ax=None, *, label: str = "circles"):
    """Draw :class:`labkit.Circle` records (circles and arcs) with their centres.

    Parameters
    ----------
    circles : sequence of Circle
        The circles and arcs.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    label : str
        The legend's label.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    for k, c in enumerate(circles):
        ax.add_patch(CirclePatch(tuple(c.center), c.radius, fill=False, color=mpl("circles"), lw=2.0,
                                 zorder=6, label=f"{label} ({len(circles)})" if k == 0 else None))
        ax.plot(*c.center, "+", color=mpl("circles"), zorder=6)
    return ax


def plot_legs(legs, ax=None, *, people=()):
    """Draw :class:`labkit.Leg` records as circles of their diameter, and people as a star between their legs.

    Parameters
    ----------
    legs : sequence of Leg
        The legs.
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    people : sequence of Person
        Pairs of legs.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    ax = axes_or_new(ax)
    for k, g in enumerate(legs):
        ax.add_patch(CirclePatch(tuple(g.center), g.diameter / 2, fill=False, color=mpl("legs"), lw=2.0,
                                 zorder=6, label=f"legs ({len(legs)})" if k == 0 else None))
    if len(people):
        ax.scatter(*np.array([p.center for p in people]).T, marker="*", s=120, color=mpl("legs"), zorder=7,
                   label=f"people ({len(people)})")
    return ax


def plot_features(scan: Scan, features=None, *, lines=(), corners=(), circles=(), arcs=(), legs=(), people=(),
                  truth=None, labels=None, ax=None, title: str | None = None, adjustable: str = "datalim"):
    """One scan with every feature drawn over it (and the ground truth when given).

    Pass a :class:`labkit.Features` (from :func:`labkit.extract_features`) as ``features``
    to draw all of it, points coloured by its range segments, or the layers one by one.

    Parameters
    ----------
    scan : Scan
        The scan.
    features : Features or None
        Every layer at once (and the segments' colours).
    lines : sequence of LineSegment
        Lines, when ``features`` is not given.
    corners : sequence of Corner
        Corners, when ``features`` is not given.
    circles : sequence of Circle
        Circles, when ``features`` is not given.
    arcs : sequence of Circle
        Arcs, when ``features`` is not given.
    legs : sequence of Leg
        Legs, when ``features`` is not given.
    people : sequence of Person
        People, when ``features`` is not given.
    truth : labkit.sim.ScanTruth or None
        The scan's ground truth, drawn beneath.
    labels : ndarray or None
        Per-beam segment labels to colour the points by (``features``' own otherwise).
    ax : matplotlib.axes.Axes or None
        Where to draw; None: a new figure.
    title : str or None
        The axes' title.
    adjustable : str
        ``"datalim"`` or ``"box"`` (for axes shared with others; see :func:`plot_scan`).

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    if features is not None:
        lines, corners, circles, arcs = features.lines, features.corners, features.circles, features.arcs
        legs, people = features.legs, features.people
        labels = features.labels if labels is None else labels
    ax = plot_scan(scan, ax, labels=labels, title=title, adjustable=adjustable)
    if truth is not None:
        plot_truth(truth, ax)
    plot_lines(lines, ax)
    plot_corners(corners, ax)
    plot_circles(circles, ax)
    if len(arcs):
        plot_circles(arcs, ax, label="arcs")
    plot_legs(legs, ax, people=people)
    ax.legend(loc="upper right", fontsize=8)
    return ax


def scan_figure(scan: Scan, *, labels=None, truth=None, title: str | None = None):
    """A two-panel figure: ranges against angle, and the points in the plane.

    Parameters
    ----------
    scan : Scan
        The scan.
    labels : ndarray or None
        Per-beam labels to colour the points by.
    truth : labkit.sim.ScanTruth or None
        Ground truth drawn over the points.
    title : str or None
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [1, 1.3]})
    plot_ranges(scan, a0, title="what the sensor reports")
    plot_scan(scan, a1, labels=labels, title="the same beams as points")
    if truth is not None:
        plot_truth(truth, a1)
    a1.legend(loc="upper right", fontsize=8)
    a0.legend(loc="upper right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
