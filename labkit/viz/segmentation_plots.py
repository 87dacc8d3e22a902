"""Figures of notebooks 01 (scans and range segmentation) and 04 (split and merge), kept here so that a notebook's
code cell stays short.

The notebook computes every gap, range, incidence and threshold; these functions only draw what they are
given. Each returns the ``Axes`` it drew into (made for you when ``ax`` is None), as in
:mod:`labkit.viz.plot`.
"""

from __future__ import annotations

import numpy as np

from labkit.geometry import project_onto_line
from labkit.viz.plot import axes_or_new, plot_lines, plot_scan, plot_truth
from labkit.viz.style import mpl

__all__ = ["wall_spacing", "plot_neighbour_gaps", "plot_threshold_curves", "plot_first_split"]


def wall_spacing(rho, dphi: float, incidence_deg: float) -> np.ndarray:
    """The distance between neighbouring points on a wall: ``rho * dphi / cos(incidence)``.

    Parameters
    ----------
    rho : array_like
        Ranges, in metres.
    dphi : float
        The angle between neighbouring beams, in radians.
    incidence_deg : float
        The angle between the beam and the wall's normal, in degrees (0: head-on).

    Returns
    -------
    ndarray
        The spacing, in metres, one per range.
    """
    return np.asarray(rho, dtype=float) * dphi / np.cos(np.radians(incidence_deg))


def plot_neighbour_gaps(rho, gap, incidence, dphi: float, *, incidences=(0, 60, 75, 85),
                        threshold_m: float = 0.08, rho_max: float = 12.0, gap_max_mm: float = 400.0, ax=None):
    """Gaps between neighbouring points on walls against range, coloured by incidence, over the spacing curves.

    Parameters
    ----------
    rho, gap, incidence : array_like of shape (M,)
        One entry per pair of neighbouring beams: the range (m), the distance between the two points (m)
        and the incidence angle (degrees).
    dphi : float
        The angle between neighbouring beams, in radians, for the curves :func:`wall_spacing`.
    incidences : sequence of float, optional
        The incidences (degrees) of the curves; the first is drawn solid, the others dotted.
    threshold_m : float, default 0.08
        The fixed threshold, drawn as a dashed line.
    rho_max : float, default 12.0
        The right end of the range axis, in metres.
    gap_max_mm : float, default 400.0
        The top of the gap axis, in millimetres.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (9, 5))
    points = ax.scatter(rho, 1000 * np.asarray(gap, dtype=float), c=incidence, s=10, cmap="viridis", vmin=0, vmax=90,
                        zorder=3)
    rho_axis = np.linspace(0.1, rho_max, 200)
    for k, beta in enumerate(incidences):
        ax.plot(rho_axis, 1000 * wall_spacing(rho_axis, dphi, beta), lw=1, color="0.3", ls=(0, (1, 1)) if k else "-")
        # the label where the curve leaves the axes (at 0.9 of their height), or at their right end
        label_at = min(rho_axis[-1], 0.9 * gap_max_mm / 1000 / float(wall_spacing(1.0, dphi, beta)))
        ax.annotate(f"beta = {beta:g} deg", (label_at, 1000 * float(wall_spacing(label_at, dphi, beta))),
                    fontsize=8, ha="right", va="bottom")
    ax.axhline(1000 * threshold_m, color=mpl("sensor"), ls="--", label=f"fixed threshold, {1000 * threshold_m:g} mm")
    ax.set_xlim(0, rho_max)
    ax.set_ylim(0, gap_max_mm)
    ax.set_xlabel("range (m)")
    ax.set_ylabel("distance between neighbouring points (mm)")
    ax.set_title(f"neighbouring points on the same wall, {np.degrees(dphi):g} degree step")
    ax.figure.colorbar(points, ax=ax, label="incidence angle (deg)")
    ax.legend(loc="lower right")
    return ax


def plot_threshold_curves(rho, thresholds: dict, dphi: float, *, incidences=(0, 60, 80), threshold_m: float = 0.08,
                          title: str = "", ax=None):
    """Breakpoint thresholds against range, beside the spacing of points on a wall at a few incidences.

    Parameters
    ----------
    rho : array_like of shape (K,)
        Ranges, in metres.
    thresholds : dict
        ``{step_deg: thresholds}``: for each angular step (degrees) the threshold (m) at every range;
        the first is drawn solid, the others dashed.
    dphi : float
        The angular step of the spacing curves, in radians.
    incidences : sequence of float, optional
        The incidences (degrees) of the spacing curves.
    threshold_m : float, default 0.08
        The fixed threshold, drawn as a dashed line.
    title : str, optional
        The axes' title.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (9, 5))
    for k, (step_deg, d) in enumerate(thresholds.items()):
        ax.plot(rho, 1000 * np.asarray(d, dtype=float), "--" if k else "-", color=mpl("lines"), lw=2,
                label=f"adaptive, step {step_deg} deg")
    for beta in incidences:
        ax.plot(rho, 1000 * wall_spacing(rho, dphi, beta), color="0.5", lw=1, ls=":",
                label=f"wall spacing, step {np.degrees(dphi):g} deg, incidence {beta:g} deg")
    ax.axhline(1000 * threshold_m, color=mpl("sensor"), ls="--", lw=1, label=f"fixed, {1000 * threshold_m:g} mm")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("largest gap inside a segment (mm)")
    ax.set_title(title)
    ax.set_ylim(0, 1300)
    ax.legend(fontsize=8)
    return ax


def plot_first_split(scan, truth, first_fit, lines, *, title: str = "", xlim=(-1.6, 0.9), ylim=(0.95, 1.85),
                     ax=None):
    """A split-and-merge run's first line and its worst point over the scan, with the lines it ended with.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth, drawn under the lines.
    first_fit : labkit.Step
        The first ``"fit"`` step of the segment: the line ``r``, ``alpha`` measured against, drawn dashed
        between the projections of the first and last finite point of beams ``first..last``, and its worst
        point, beam ``at``, ``value`` metres from the line, drawn as a cross.
    lines : sequence of labkit.LineSegment
        The lines the run ended with.
    title : str, optional
        The axes' title.
    xlim, ylim : (float, float)
        The window, in metres (default: notebook 04's corridor corner).
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into; the legend leaves out the scan's and the sensor's entries.
    """
    ax = axes_or_new(ax, (6.5, 5.5))
    run = scan.points[first_fit.first:first_fit.last + 1]           # beams in order: no seam inside a segment
    run = run[np.isfinite(run).all(axis=1)]
    plot_scan(scan, ax, point_size=6, adjustable="box")
    plot_truth(truth, ax)
    ends = project_onto_line(run[[0, -1]], first_fit.r, first_fit.alpha)
    ax.plot(*ends.T, "k--", lw=1.2, label="first line measured against")
    ax.plot(*scan.points[first_fit.at], "x", color=mpl("sensor"), ms=12, mew=2.5,
            label=f"its worst point ({first_fit.value:.2f} m)")
    plot_lines(lines, ax, label="final line segments")
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    if title:
        ax.set_title(title)
    handles, labels = ax.get_legend_handles_labels()
    chosen = [k for k, text in enumerate(labels) if not text.startswith(("invalid", "valid", "sensor"))]
    ax.legend([handles[k] for k in chosen], [labels[k] for k in chosen], loc="lower right", fontsize=8)
    return ax
