"""Figures of notebook 02 (weighted line fitting), kept here so that a notebook's code cell stays short.

The notebook computes every fit, objective and time; these functions only draw what they are given. Each
returns the ``Axes`` it drew into (made for you when ``ax`` is None), as in :mod:`labkit.viz.plot`.
"""

from __future__ import annotations

import numpy as np

from labkit.geometry import angle_difference
from labkit.viz.plot import axes_or_new
from labkit.viz.style import mpl

__all__ = ["FIT_STYLE", "draw_line", "plot_normal_form", "plot_objective", "plot_sum_timings", "plot_fits",
           "error_ellipse", "plot_error_ellipse", "plot_uncertainty_band"]

#: The 95% quantile of the chi-square distribution with 2 degrees of freedom.
CHI2_95_2D = 5.99

#: The line style and colour of each of the three fits.
FIT_STYLE = {"OLS": ("-", mpl("corners")), "TLS": ("--", mpl("circles")), "weighted polar": (":", mpl("lines"))}


def _sensor(ax) -> None:
    ax.plot(0, 0, marker=(3, 0, -90), color=mpl("sensor"), markersize=12, linestyle="none", label="sensor")


def draw_line(ax, line_r: float, line_alpha: float, half_length: float = 20.0, **style):
    """The line ``x cos(line_alpha) + y sin(line_alpha) = line_r``, ``half_length`` either side of its foot point.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    line_r, line_alpha : float
        The line in normal form: distance from the origin (m) and the normal's direction (rad).
    half_length : float, default 20.0
        Half the drawn length, in metres.
    **style
        Passed to ``ax.plot`` (``alpha`` there is the opacity).

    Returns
    -------
    list of matplotlib.lines.Line2D
        What ``ax.plot`` returned.
    """
    n = np.array([np.cos(line_alpha), np.sin(line_alpha)])
    ends = line_r * n + np.outer([-half_length, half_length], [-n[1], n[0]])
    return ax.plot(*ends.T, **style)


def plot_normal_form(x, y, r: float, alpha: float, *, along: float = 1.2, beyond: float = 0.3, ax=None):
    """A wall in normal form: the normal of length r at angle alpha, and one point's distance to the wall.

    Parameters
    ----------
    x, y : array_like
        The scan points, in metres.
    r, alpha : float
        The wall in normal form (m, rad).
    along : float, default 1.2
        Where the example point lies along the wall from the normal's foot, in metres.
    beyond : float, default 0.3
        How far the example point lies beyond the wall, in metres (made up, so that its distance shows).
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (7, 6))
    normal = np.array([np.cos(alpha), np.sin(alpha)])
    tangent = np.array([-normal[1], normal[0]])
    foot = r * normal + along * tangent
    point = foot + beyond * normal
    ax.plot(*(r * normal + np.outer([-0.3, 3.0], tangent)).T, color=mpl("truth"), lw=2, label="true wall")
    ax.scatter(x, y, s=6, color=mpl("points"), alpha=0.5, label="scan points")
    ax.annotate("", r * normal, (0, 0), arrowprops={"arrowstyle": "->", "color": mpl("lines"), "lw": 1.5})
    ax.text(*(0.5 * r * normal + [-0.2, 0.0]), "r", color=mpl("lines"), fontsize=13)
    ax.plot([0, 0.8], [0, 0], color="0.5", lw=0.8)
    arc = np.linspace(0, alpha, 30)
    ax.plot(0.45 * np.cos(arc), 0.45 * np.sin(arc), color=mpl("lines"), lw=1)
    ax.text(0.5, -0.3, "alpha", color=mpl("lines"), fontsize=11)
    ax.plot(*np.c_[[0, 0], point], ":", color="0.3", lw=1)
    ax.text(*(0.55 * point + [0.0, 0.08]), "rho_i", color="0.3", fontsize=11)
    ax.plot(*np.c_[point, foot], color=mpl("corners"), lw=2.5, label="distance d_i")
    ax.plot(*point, "o", color=mpl("corners"), label="point (rho_i, theta_i)")
    _sensor(ax)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("a wall in normal form (r, alpha)")
    ax.legend(loc="upper right", fontsize=8)
    return ax


def plot_objective(alpha_grid, objective, alpha_fit: float, *, ax=None):
    """The objective S against alpha, with the closed-form alpha marked.

    Parameters
    ----------
    alpha_grid : array_like
        Angles, in radians.
    objective : array_like
        S at each angle.
    alpha_fit : float
        The closed-form alpha, in radians.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (8, 3.5))
    ax.plot(np.degrees(alpha_grid), objective, color=mpl("points"))
    ax.axvline(np.degrees(alpha_fit), color=mpl("lines"), ls="--", label="closed-form alpha")
    ax.set_xlabel("alpha (deg)")
    ax.set_ylabel("S(alpha)  (m)")
    ax.set_title("the objective with the best r for each alpha")
    ax.legend()
    return ax


def plot_sum_timings(sizes, t_double, t_product, *, ax=None):
    """Times of the double sums and of the products of single sums against n, log-log, with a slope-2 line.

    Parameters
    ----------
    sizes : array_like of int
        The numbers of points.
    t_double, t_product : array_like
        Seconds per evaluation at each size: the double sums over all pairs, and the products of sums.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into. The slope-2 line runs from the third size to the last, through the last
        double-sum time.
    """
    ax = axes_or_new(ax, (7, 4.5))
    sizes, t_double = np.asarray(sizes), np.asarray(t_double, dtype=float)
    ax.loglog(sizes, 1e3 * t_double, "o-", color=mpl("lines"), label="double sums, all pairs: O(n^2)")
    ax.loglog(sizes, 1e3 * np.asarray(t_product, dtype=float), "s-", color=mpl("points"),
              label="products of single sums: O(n)")
    n_ref = np.array([sizes[2], sizes[-1]], dtype=float)
    ax.loglog(n_ref, 1e3 * t_double[-1] * (n_ref / n_ref[-1]) ** 2, ":", color="0.4", label="slope 2")
    ax.set_xlabel("number of points n")
    ax.set_ylabel("time per evaluation (ms)")
    ax.set_title("the same two numbers, two ways")
    ax.legend()
    return ax


def plot_fits(r: float, alpha: float, points, fits: dict, *, title: str = "", ax=None):
    """Points, the true wall and each fit's line, labelled with how far its alpha is off.

    Parameters
    ----------
    r, alpha : float
        The true wall in normal form (m, rad).
    points : array_like of shape (N, 2)
        The points fitted.
    fits : dict
        ``{name: fit}``, names among :data:`FIT_STYLE`; a fit has ``r`` and ``alpha``, or is the exception
        its fitting raised (shown in the legend instead of a line).
    title : str, optional
        The axes' title.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into: a square window around the points and the sensor.
    """
    ax = axes_or_new(ax, (7, 6))
    pts = np.asarray(points, dtype=float)
    ax.scatter(*pts.T, s=8, color=mpl("points"), label="points", zorder=3)
    draw_line(ax, r, alpha, color=mpl("truth"), lw=4, alpha=0.5, label="true wall")
    for name, f in fits.items():
        ls, color = FIT_STYLE[name]
        if isinstance(f, Exception):
            ax.plot([], [], ls=ls, color=color, label=f"{name}: {f}"[:60] + "...")
            continue
        err = np.degrees(angle_difference(f.alpha, alpha))
        draw_line(ax, f.r, f.alpha, ls=ls, color=color, lw=2, label=f"{name}: alpha off by {err:+.2f} deg")
    box = np.vstack([pts, [0.0, 0.0]])
    center = (box.min(axis=0) + box.max(axis=0)) / 2
    half = (box.max(axis=0) - box.min(axis=0)).max() / 2 + 0.4
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.plot(0, 0, marker=(3, 0, -90), color=mpl("sensor"), markersize=12, linestyle="none")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="lower left", fontsize=8)
    if title:
        ax.set_title(title)
    return ax


def error_ellipse(covariance, chi2: float = CHI2_95_2D, n: int = 200):
    """Points on the ellipse ``d^T C^-1 d = chi2`` of a 2x2 covariance ``C``, centred on zero.

    Parameters
    ----------
    covariance : array_like of shape (2, 2)
        The covariance C (symmetric, positive definite).
    chi2 : float, default 5.99
        The level: 5.99 holds 95% of a 2-D Gaussian.
    n : int, default 200
        How many points (the first and the last coincide).

    Returns
    -------
    numpy.ndarray of shape (2, n)
        The ellipse's points, one column each.
    """
    angle = np.linspace(0, 2 * np.pi, n)
    return np.linalg.cholesky(np.asarray(covariance, dtype=float)) @ np.vstack([np.cos(angle), np.sin(angle)]) \
        * np.sqrt(chi2)


def plot_error_ellipse(errors, covariance, *, title: str = "", label: str = "Monte Carlo fits", size: float = 2,
                       ax=None):
    """Errors (r, alpha) of many fits as points, with the 95% ellipse of their covariance; in mm and degrees.

    Parameters
    ----------
    errors : array_like of shape (K, 2)
        Each fit's error in r (m) and in alpha (rad).
    covariance : array_like of shape (2, 2)
        The propagated covariance of (r, alpha), in m and rad.
    title : str, optional
        The axes' title; one longer than 60 characters is drawn at 9 points so that it fits.
    label : str, default "Monte Carlo fits"
        The points' legend entry.
    size : float, default 2
        The points' marker size.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    ax = axes_or_new(ax, (7, 5))
    d = np.asarray(errors, dtype=float)
    ellipse = error_ellipse(covariance)
    ax.scatter(1000 * d[:, 0], np.degrees(d[:, 1]), s=size, color="0.6", label=label)
    ax.plot(1000 * ellipse[0], np.degrees(ellipse[1]), color=mpl("lines"), lw=2, label="95% ellipse of C")
    ax.set_xlabel("r error (mm)")
    ax.set_ylabel("alpha error (deg)")
    if title:
        ax.set_title(title, **({"fontsize": 9} if len(title) > 60 else {}))
    ax.legend(fontsize=8)
    return ax


def plot_uncertainty_band(s, band, offsets, s_points, s_star: float, *, n_lines: int = 100, ax=None):
    """A line fit's uncertainty band in the wall's frame: Monte Carlo fits as grey lines, +-band in red.

    Parameters
    ----------
    s : array_like of shape (M,)
        Positions along the true wall, in metres.
    band : array_like of shape (M,)
        The band's half-width at each position (e.g. 2 sigma(s)), in metres.
    offsets : array_like of shape (K, M)
        Each Monte Carlo fit's offset from the true wall at each position, in metres.
    s_points : array_like
        Where the points lie along the wall, in metres; their span is shaded.
    s_star : float
        The band's narrowest position, in metres.
    n_lines : int, default 100
        How many of the fits to draw (the first ones).
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into, offsets in millimetres.
    """
    ax = axes_or_new(ax, (8, 4.8))
    band = np.asarray(band, dtype=float)
    ax.plot(s, 1000 * np.asarray(offsets, dtype=float)[:n_lines].T, color="0.6", lw=0.5)
    ax.plot(s, 1000 * band, color=mpl("lines"), lw=2, label="+-2 sigma(s) from the covariance")
    ax.plot(s, -1000 * band, color=mpl("lines"), lw=2)
    ax.axvspan(np.min(s_points), np.max(s_points), color=mpl("points"), alpha=0.1, label="where the points are")
    ax.axvline(s_star, color="0.3", ls=":", label="narrowest point s*")
    ax.set_xlabel("position along the wall, s (m)")
    ax.set_ylabel("offset from the true wall (mm)")
    ax.set_title("Monte Carlo fits (grey) and the propagated band")
    ax.legend(loc="upper center", fontsize=8)
    return ax
