"""Figures of notebooks 08 (inscribed angles, circles) and 08b (legs), kept here so that a code cell stays short.

The notebooks compute every angle, error, detection and rate; these functions only draw what they are given.
"""

from __future__ import annotations

import numpy as np

from labkit.viz.plot import axes_or_new

__all__ = ["plot_inscribed_angles", "arc_sliders", "plot_iav_shapes", "plot_fit_errors", "plot_leg_tracks"]


def plot_inscribed_angles(points, angles_deg, span_deg: float, ax=None):
    """Notebook 08: an arc of the unit circle, its chord, and the angle each interior point sees the chord under.

    Parameters
    ----------
    points : array_like of shape (M, 2)
        Points on the unit circle centred at the origin: ``P_1``, the interior points, ``P_n``, in the
        order of the arc (counter-clockwise), M >= 3.
    angles_deg : array_like of shape (M - 2,)
        The inscribed angle at each interior point, degrees; written beside the point.
    span_deg : float
        The arc's span at the centre, degrees (drawn from ``P_1`` counter-clockwise); the title gives the
        theorem's value ``180 - span_deg / 2``.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (5.5, 5.5))
    pts = np.asarray(points, dtype=float)
    full = np.linspace(0, 2 * np.pi, 361)
    ax.plot(np.cos(full), np.sin(full), color="0.85", lw=1)
    start = np.arctan2(pts[0, 1], pts[0, 0])
    t = start + np.radians(np.linspace(0, span_deg, 200))
    ax.plot(np.cos(t), np.sin(t), color="tab:green", lw=3, label=f"arc, {span_deg:.0f} deg at the centre")
    p1, pn = pts[0], pts[-1]
    ax.plot(*np.c_[p1, pn], color="k", lw=1.5, label="chord $P_1 P_n$")
    for k, (p, a) in enumerate(zip(pts[1:-1], np.asarray(angles_deg, dtype=float), strict=True)):
        ax.plot(*np.c_[p1, p, pn], color=f"C{k}", lw=1)
        ax.annotate(f"{a:.1f}°", p, xytext=(8, 4), textcoords="offset points", color=f"C{k}", fontsize=11)
    ax.plot(*pts.T, "o", color="k", ms=5)
    ax.plot(0, 0, "+", color="0.4")
    ax.set_aspect("equal")
    ax.set_xlim(-1.45, 1.45)
    ax.set_ylim(-1.45, 1.45)
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(f"inscribed angles: theory {180 - span_deg / 2:.1f}°")
    return ax


def arc_sliders(redraw, span_deg: float = 200.0, fractions=(0.2, 0.5, 0.8)):
    """Notebook 08: sliders for an arc's span and three interior points, calling ``redraw`` on release.

    Parameters
    ----------
    redraw : callable
        ``redraw(span_deg, s1, s2, s3)``: draws the arc of ``span_deg`` degrees with interior points at
        the fractions ``s1``, ``s2``, ``s3`` (0 to 1) of it.
    span_deg : float, default 200
        The span the first slider starts at, degrees (20 to 340).
    fractions : tuple of float, default (0.2, 0.5, 0.8)
        Where the three point sliders start (0.02 to 0.98).

    Returns
    -------
    ipywidgets.interactive
        The four sliders and ``redraw``'s output; the figure is redrawn when a slider is released.
    """
    import ipywidgets as widgets

    slider = dict(min=0.02, max=0.98, step=0.01, continuous_update=False)
    return widgets.interactive(
        redraw,
        span_deg=widgets.FloatSlider(value=span_deg, min=20.0, max=340.0, step=5.0, continuous_update=False,
                                     description="arc (deg)"),
        **{f"s{k}": widgets.FloatSlider(value=s, description=f"point {k}", **slider)
           for k, s in enumerate(fractions, start=1)},
    )


def plot_iav_shapes(shapes: dict, angles: dict, stats: dict, *, xlim=(2.4, 3.4), ylim=(-0.5, 0.5),
                    circle_mean_deg=(90.0, 135.0)):
    """Notebook 08: each shape's points with its chord, and the inscribed angles of all of them in one panel.

    Parameters
    ----------
    shapes : dict
        ``{name: points}``, each an array_like of shape (N, 2), metres; one panel per shape.
    angles : dict
        ``{name: angles}``: the inscribed angles of each shape's interior points, radians.
    stats : dict
        ``{name: (mean, std)}``: the mean and the standard deviation of each shape's inscribed angles,
        radians, for the panel's title.
    xlim, ylim : tuple of (float, float), default (2.4, 3.4), (-0.5, 0.5)
        The limits of the shapes' panels, metres.
    circle_mean_deg : tuple of (float, float), default (90, 135)
        The circle test's range of the mean, degrees, shaded in the angles' panel.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure: one panel per shape, then the angles (degrees) against the interior point's index.
    """
    import matplotlib.pyplot as plt

    n = len(shapes)
    fig, axes = plt.subplots(1, n + 1, figsize=(15, 3.8), gridspec_kw={"width_ratios": [1] * n + [1.6]})
    for ax, (name, p) in zip(axes, shapes.items(), strict=False):
        p = np.asarray(p, dtype=float)
        ax.plot(*p.T, ".", color="tab:blue")
        ax.plot(*p[[0, -1]].T, "k--", lw=1)
        ax.set_aspect("equal")
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        mean, std = stats[name][:2]
        ax.set_title(f"{name}: mean {np.degrees(mean):.0f}°, std {np.degrees(std):.1f}°", fontsize=10)
        axes[-1].plot(np.degrees(np.asarray(angles[name], dtype=float)), ".-", label=name)
    axes[0].set_ylabel("y (m); sensor at x = 0, to the left")
    axes[-1].axhspan(*circle_mean_deg, color="tab:green", alpha=0.1, label="circle mean range")
    axes[-1].set_xlabel("interior point")
    axes[-1].set_ylabel("inscribed angle (deg)")
    axes[-1].legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_fit_errors(spans, center_err: dict, radius_err: dict, title: str = ""):
    """Notebook 08: the median centre and radius errors of each circle method against the visible arc.

    Parameters
    ----------
    spans : array_like of shape (K,)
        The visible arcs, degrees at the centre.
    center_err, radius_err : dict
        ``{method: errors}``: each an array_like of shape (K,), metres, one per span; drawn in centimetres
        on a log scale, one marker per method.
    title : str, default ""
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure: the centre errors on the left, the radius errors on the right.
    """
    import matplotlib.pyplot as plt

    fig, (ax_c, ax_r) = plt.subplots(1, 2, figsize=(12, 4.2), sharex=True)
    for k, m in enumerate(center_err):
        marker = "os^dv"[k % 5]
        ax_c.semilogy(spans, 100 * np.asarray(center_err[m], dtype=float), marker + "-", label=m)
        ax_r.semilogy(spans, 100 * np.asarray(radius_err[m], dtype=float), marker + "-", label=m)
    ax_c.set_ylabel("median centre error (cm)")
    ax_r.set_ylabel("median |radius error| (cm)")
    for ax in (ax_c, ax_r):
        ax.set_xlabel("visible arc (deg at the centre)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(title)
    return fig


def plot_leg_tracks(true_t, true_xy, det_t, det_xy, *, first_walk_s: float = 6.0, near_m: float = 4.0,
                    title: str = ""):
    """Notebook 08b: a walker's true and detected legs, seen from above and as distance against time.

    Parameters
    ----------
    true_t : array_like of shape (T,)
        The time of each true leg, seconds from the recording's start.
    true_xy : array_like of shape (T, 2)
        The true leg centres, metres, sensor frame.
    det_t : array_like of shape (D,)
        The time of each detection, seconds from the recording's start.
    det_xy : array_like of shape (D, 2)
        The detected leg centres, metres, sensor frame.
    first_walk_s : float, default 6.0
        The left panel shows the legs before this time (seconds), coloured by time.
    near_m : float, default 4.0
        The right panel shows the detections within this distance of the true legs' mean position,
        metres (leaving out legs detected elsewhere in the room).
    title : str, default ""
        The right panel's title.

    Returns
    -------
    matplotlib.figure.Figure
        A new figure: the first walk from above on the left, the distance from the sensor against time
        on the right.
    """
    import matplotlib.pyplot as plt

    true_t, det_t = np.asarray(true_t, dtype=float), np.asarray(det_t, dtype=float)
    true_xy = np.asarray(true_xy, dtype=float).reshape(-1, 2)
    det_xy = np.asarray(det_xy, dtype=float).reshape(-1, 2)
    fig, (ax_xy, ax_t) = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1, 1.3]})
    first_true, first_det = true_t < first_walk_s, det_t < first_walk_s
    ax_xy.plot(*true_xy[first_true].T, "o", mfc="none", mec="0.5", ms=9, label="true legs")
    sc = ax_xy.scatter(*det_xy[first_det].T, c=det_t[first_det], s=12, cmap="viridis", zorder=3,
                       label="detected legs")
    ax_xy.plot(0, 0, ">", color="tab:red", ms=10, label="sensor")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel("x (m)")
    ax_xy.set_ylabel("y (m)")
    ax_xy.set_title(f"first walk, 0 to {first_walk_s:g} s (sensor frame)")
    fig.colorbar(sc, ax=ax_xy, label="time (s)")
    ax_xy.legend(loc="upper right", fontsize=8)

    ax_t.plot(true_t, np.hypot(*true_xy.T), "o", mfc="none", mec="0.5", ms=6, label="true legs")
    near = np.hypot(*(det_xy - true_xy.mean(axis=0)).T) < near_m
    ax_t.plot(det_t[near], np.hypot(*det_xy[near].T), ".", color="tab:purple", ms=4, label="detected legs")
    ax_t.set_xlabel("time (s)")
    ax_t.set_ylabel("distance from the sensor (m)")
    ax_t.legend(fontsize=8)
    ax_t.set_title(title)
    return fig
