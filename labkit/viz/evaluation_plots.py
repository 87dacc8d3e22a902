"""Figures of the evaluation notebooks (10 and 10b), kept here so that a notebook's code cell stays short.

The notebooks compute every number (matches, rates, sweeps, residuals); these functions only draw them.
Rows are the dicts of :mod:`labkit.app.experiments` (``noise_std_m``, ``method``, ``tp_rate``,
``fp_rate``, ...), passed in, never computed here.
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.ticker import LogLocator, NullFormatter, StrMethodFormatter

from labkit.viz import plot as lkplot
from labkit.viz.style import mpl

__all__ = [
    "STATUS_COLORS",
    "line_status",
    "draw_match",
    "plot_match",
    "plot_split_match",
    "threshold_controls",
    "plot_every_extractor",
    "plot_rate_bars",
    "plot_threshold_sweep",
    "plot_auto_against_fixed",
    "plot_round_objects",
    "plot_ray_errors",
    "plot_rmse_coverage",
    "plot_error_shares",
    "plot_noise_residuals",
    "plot_placement_frontier",
]

#: The colour of a line by its fate under the matching rule.
STATUS_COLORS = {"matched": "tab:green", "false positive": "tab:red", "not scored": "tab:orange"}

_WALL_STYLES = {"found wall": dict(ls="-", lw=5, alpha=0.35), "missed wall": dict(ls="--", lw=2.5, alpha=0.9),
                "wall not in the truth": dict(ls=":", lw=1.5, alpha=0.9)}


def line_status(n_lines: int, match) -> list[str]:
    """The fate of every line under the matching rule.

    Parameters
    ----------
    n_lines : int
        How many lines were matched (the length of the list given to :func:`labkit.match_lines`).
    match : labkit.LineMatch
        The result of :func:`labkit.match_lines` on those lines.

    Returns
    -------
    list of str
        ``"matched"``, ``"false positive"`` or ``"not scored"``, one per line.
    """
    matched = {i for i, _ in match.pairs}
    return ["matched" if i in matched else "false positive" if i in match.scored else "not scored"
            for i in range(n_lines)]


def _truth_walls(ax, truth, match) -> None:
    missed, in_truth = set(match.missed), set(match.truth)
    labelled = set()
    for j, wall in enumerate(truth.walls):
        kind = "missed wall" if j in missed else "found wall" if j in in_truth else "wall not in the truth"
        ax.plot(*np.array([wall.start, wall.end]).T, color=mpl("truth"), zorder=2, solid_capstyle="butt",
                label=None if kind in labelled else kind, **_WALL_STYLES[kind])
        labelled.add(kind)


def draw_match(ax, scan, truth, lines, match, *, annotate: bool = True, point_size: float = 4):
    """One scan, its true walls and the extracted lines coloured by the matching rule.

    True wall pieces are solid and wide where a line found them, dashed where none did, dotted where
    the piece is not in the truth; lines are green (matched), red (false positive) or orange (not
    scored), and each match can carry its ``|dr|`` and ``|dalpha|``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    scan : labkit.Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth.
    lines : list of labkit.LineSegment
        The extracted lines.
    match : labkit.LineMatch
        ``labkit.match_lines(lines, truth)``.
    annotate : bool, optional
        Write each match's errors beside its line.
    point_size : float, optional
        Size of the scan's points.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    lkplot.plot_scan(scan, ax, point_size=point_size, show_invalid=False, adjustable="datalim")
    _truth_walls(ax, truth, match)
    status = line_status(len(lines), match)
    for kind, color in STATUS_COLORS.items():
        segs = [[tuple(ln.start), tuple(ln.end)] for ln, s in zip(lines, status, strict=True) if s == kind]
        if segs:
            ax.add_collection(LineCollection(segs, colors=color, linewidths=2.5, zorder=5,
                                             label=f"{kind} ({len(segs)})"))
    if annotate:
        for (i, _), dr, da in zip(match.pairs, match.dr, match.dalpha, strict=True):
            mid = (np.asarray(lines[i].start) + np.asarray(lines[i].end)) / 2
            ax.annotate(f"|dr| {1000 * abs(dr):.0f} mm\n|dα| {np.degrees(abs(da)):.2f}°", mid,
                        xytext=(4, 4), textcoords="offset points", fontsize=7, color="tab:green", zorder=6,
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.7))
    ax.autoscale_view()
    return ax


def plot_match(scan, truth, lines, match, *, title: str = "", figsize=(10, 7), ax=None):
    """:func:`draw_match` in a figure of its own, titled, with the legend outside on the right.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth.
    lines : list of labkit.LineSegment
        The extracted lines.
    match : labkit.LineMatch
        ``labkit.match_lines(lines, truth)``.
    title : str, optional
        The axes' title.
    figsize : (float, float), default (10, 7)
        The new figure's size in inches, when ``ax`` is None.
    ax : matplotlib.axes.Axes, optional
        The axes to draw into; new ones when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn into.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    draw_match(ax, scan, truth, lines, match)
    if title:
        ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.figure.tight_layout()
    return ax


def plot_split_match(scan, truth, lines, match, score, split_threshold_m: float, noise_std_m: float):
    """:func:`plot_match` of one split threshold, its rates in the title and its counts printed below.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth.
    lines : list of labkit.LineSegment
        The lines split-and-merge found with ``split_threshold_m``.
    match : labkit.LineMatch
        ``labkit.match_lines(lines, truth)``.
    score : labkit.LineScore
        ``labkit.score_lines([(lines, truth)])``; its ``tp_rate`` and ``fp_rate`` go in the title.
    split_threshold_m : float
        The split threshold the lines were found with, metres.
    noise_std_m : float
        The scan's range noise, metres.

    Returns
    -------
    str
        The line printed: how many lines, matched, false positives, not scored, and the missed walls.
    """
    plot_match(scan, truth, lines, match, title=f"noise {1000 * noise_std_m:.0f} mm, split threshold "
               f"{100 * split_threshold_m:.1f} cm: TruePos {score.tp_rate:.2f}, FalsePos {score.fp_rate:.2f}")
    plt.show()
    counts = (f"{len(lines)} lines: {match.n_matched} matched, {len(match.false_positives)} false positives, "
              f"{len(lines) - len(match.scored)} not scored; missed walls {list(match.missed)}")
    print(counts)
    return counts


def threshold_controls(show, noise_levels, *, noise: float, value: float = 0.05):
    """A split-threshold slider and a noise drop-down that redraw ``show(split_threshold_m, noise)``.

    The slider runs from 0.5 cm to 30 cm in steps of 0.5 cm and updates on release
    (``continuous_update=False``); the drop-down lists the noise levels in millimetres.

    Parameters
    ----------
    show : callable
        ``show(split_threshold_m, noise)`` draws one setting; called once at once, then on every change.
    noise_levels : sequence of float
        The noise levels to choose from, metres.
    noise : float
        The noise level chosen first, one of ``noise_levels``.
    value : float, default 0.05
        The split threshold chosen first, metres.

    Returns
    -------
    ipywidgets.VBox
        The two controls in a row above the figure's output.
    """
    import ipywidgets as widgets  # only the notebooks need ipywidgets

    if noise not in noise_levels:
        raise ValueError(f"noise {noise!r} is not one of noise_levels {list(noise_levels)}")
    slider = widgets.FloatSlider(value=value, min=0.005, max=0.3, step=0.005, readout_format=".3f",
                                 description="split (m)", continuous_update=False)
    picker = widgets.Dropdown(options=[(f"{1000 * n:.0f} mm", n) for n in noise_levels], value=noise,
                              description="noise")
    out = widgets.interactive_output(show, {"split_threshold_m": slider, "noise": picker})
    return widgets.VBox([widgets.HBox([slider, picker]), out])


def _legend_handles() -> list:
    return [Line2D([], [], color=c, lw=2.5, label=k) for k, c in STATUS_COLORS.items()] + [
        Line2D([], [], color=mpl("truth"), lw=5, alpha=0.35, label="found wall"),
        Line2D([], [], color=mpl("truth"), lw=2.5, ls="--", label="missed wall"),
        Line2D([], [], color=mpl("truth"), lw=1.5, ls=":", label="wall not in the truth"),
        Line2D([], [], color=mpl("points"), marker="o", ls="none", ms=3, label="scan points")]


def plot_every_extractor(scan, truth, results: dict, title: str = ""):
    """One panel per extractor: :func:`draw_match` of its lines on the same scan, with its counts.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    truth : labkit.sim.ScanTruth
        Its ground truth.
    results : dict
        ``{name: (lines, match)}`` per extractor, at most eight.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, two rows of four panels sharing the scan's limits.
    """
    pts = np.vstack([scan.xy, [[0.0, 0.0]]] + [np.array([w.start, w.end]) for w in truth.walls])
    lo, hi = pts.min(axis=0) - 0.5, pts.max(axis=0) + 0.5
    fig, axes = plt.subplots(2, 4, figsize=(18, 9.5))
    for ax in axes.flat[len(results):]:
        ax.set_visible(False)
    for ax, (name, (lines, m)) in zip(axes.flat[:len(results)], results.items(), strict=True):
        draw_match(ax, scan, truth, lines, m, annotate=False, point_size=2)
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]))
        ax.set_aspect("equal", adjustable="box")
        ax.set_title(f"{name}\nfound {m.n_matched}/{len(m.truth)} walls, "
                     f"{len(m.false_positives)}/{len(m.scored)} lines wrong", fontsize=10)
    handles = _legend_handles()
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    return fig


def _noise_colors(levels) -> dict:
    palette = ["tab:blue", "tab:orange"] if len(levels) == 2 else ["tab:blue", "tab:green", "tab:orange", "tab:red"]
    return {noise: palette[k % len(palette)] for k, noise in enumerate(levels)}


def plot_rate_bars(rows, published: dict | None = None, title: str = ""):
    """TruePos, FalsePos and speed of every method at every noise level, as horizontal bars.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`labkit.app.experiments.compare_lines`: ``noise_std_m``, ``method``, ``tp_rate``,
        ``fp_rate``, ``scans_per_s``.
    published : dict, optional
        ``{method: FalsePos}`` published for some methods, drawn as black diamonds.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels sharing the methods' axis; the speed on a log scale.
    """
    methods = list(dict.fromkeys(row["method"] for row in rows))
    levels = sorted({row["noise_std_m"] for row in rows})
    by_key = {(row["noise_std_m"], row["method"]): row for row in rows}
    colors = _noise_colors(levels)
    fig, axes = plt.subplots(1, 3, figsize=(16, 6), sharey=True)
    y = np.arange(len(methods))
    height = 0.8 / len(levels)
    panels = [("tp_rate", "TruePos: share of true walls found"),
              ("fp_rate", "FalsePos: share of scored lines that are wrong"),
              ("scans_per_s", "scans per second (log scale)")]
    for k, noise in enumerate(levels):
        offset = (k - (len(levels) - 1) / 2) * height
        for ax, (key, _) in zip(axes, panels, strict=True):
            ax.barh(y + offset, [by_key[noise, m][key] for m in methods], height=height, color=colors[noise],
                    label=f"range noise {1000 * noise:.0f} mm")
    shown = [(published[m], y[i]) for i, m in enumerate(methods) if published and m in published]
    if shown:
        axes[1].scatter(*np.array(shown).T, marker="D", color="black", zorder=5, label="published")
    for ax, (key, label) in zip(axes, panels, strict=True):
        ax.set_xlabel(label)
        ax.grid(axis="x", alpha=0.3)
        if key != "scans_per_s":
            ax.set_xlim(0, 1)
    axes[2].set_xscale("log")
    axes[2].xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axes[2].xaxis.set_major_formatter(StrMethodFormatter("{x:,.0f}"))
    axes[2].xaxis.set_minor_formatter(NullFormatter())
    axes[0].set_yticks(y, methods)
    axes[0].invert_yaxis()
    axes[0].set_ylabel("method")
    axes[1].legend(loc="lower right", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_threshold_sweep(sweep, fixed_m: float, marks=(), title: str = ""):
    """TruePos against FalsePos of split-and-merge over its split threshold, one panel per noise level.

    Parameters
    ----------
    sweep : list of dict
        Rows of :func:`labkit.app.experiments.sweep_split_and_merge`: ``noise_std_m``,
        ``split_threshold_m``, ``tp_rate``, ``fp_rate``.
    fixed_m : float
        A threshold to ring on every curve (the papers' fixed one), metres.
    marks : sequence of (dict, str, dict), optional
        Points to mark on each panel: ``({noise: row}, label, marker keywords)``; a row needs
        ``tp_rate`` and ``fp_rate``.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per noise level (two side by side, or a grid), each with its own scale.
    """
    levels = sorted({r["noise_std_m"] for r in sweep})
    colors = _noise_colors(levels)
    ncols = len(levels) if len(levels) <= 2 else 2
    nrows = math.ceil(len(levels) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(7.5 * ncols, 5.5 * nrows + 0.5), squeeze=False)
    for ax in axes.flat[len(levels):]:
        ax.set_visible(False)
    for ax, noise in zip(axes.flat[:len(levels)], levels, strict=True):
        curve = sorted((r for r in sweep if r["noise_std_m"] == noise), key=lambda r: r["split_threshold_m"])
        color = colors[noise]
        ax.plot([r["fp_rate"] for r in curve], [r["tp_rate"] for r in curve], "o-", color=color,
                label="split thresholds (labels in cm)")
        for k, r in enumerate(curve):  # labels above and below in turn: neighbours crowd
            ax.annotate(f"{100 * r['split_threshold_m']:g}", (r["fp_rate"], r["tp_rate"]),
                        xytext=(6, 5 if k % 2 else -13), textcoords="offset points", fontsize=9, color=color)
            if math.isclose(r["split_threshold_m"], fixed_m):
                ax.plot(r["fp_rate"], r["tp_rate"], "o", ms=16, mfc="none", mec="black", zorder=4,
                        label=f"the papers' fixed {100 * fixed_m:g} cm")
        for k, (rows_by_noise, label, style) in enumerate(marks):
            row = rows_by_noise[noise]
            ax.plot(row["fp_rate"], row["tp_rate"], ls="none", zorder=5 + k,
                    label=label.format(row=row, cm=100 * row.get("split_threshold_m", math.nan)),
                    **{"color": color, "mec": "black", **style})
        ax.set(xlabel="FalsePos (share of scored lines that are wrong)",
               ylabel="TruePos (share of true walls found)", title=f"range noise {1000 * noise:.0f} mm")
        ax.margins(0.12)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower left", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_auto_against_fixed(sweep, auto_rows, fixed_m: float, n_per_level: int,
                            every_line: str = "auto threshold, every line", default: str = "AUTO_LINES"):
    """:func:`plot_threshold_sweep` of the fixed thresholds with two auto methods marked on every panel.

    The auto threshold with every line reported is a white diamond, the default (which also drops the
    lines it cannot place) a star in the level's colour.

    Parameters
    ----------
    sweep : list of dict
        Rows of the fixed thresholds, as :func:`plot_threshold_sweep` takes them.
    auto_rows : list of dict
        Rows of :func:`labkit.app.experiments.compare_lines`, one per method and noise level of ``sweep``:
        ``method``, ``noise_std_m``, ``tp_rate``, ``fp_rate``.
    fixed_m : float
        The papers' fixed threshold, ringed, metres.
    n_per_level : int
        How many scans each level has, for the title.
    every_line, default : str
        The two methods' names in ``auto``.

    Returns
    -------
    matplotlib.figure.Figure
        The figure of :func:`plot_threshold_sweep`.
    """
    levels = sorted({r["noise_std_m"] for r in sweep})
    auto = {(row["method"], row["noise_std_m"]): row for row in auto_rows}
    marks = [({n: auto[every_line, n] for n in levels}, "auto threshold, every line reported",
              dict(marker="D", ms=11, color="white", mew=1.5)),
             ({n: auto[default, n] for n in levels}, f"{default}, the default (also drops lines it cannot place)",
              dict(marker="*", ms=22))]
    return plot_threshold_sweep(sweep, fixed_m, marks, f"split-and-merge (IEPF) on {n_per_level} scans per level: "
                                "fixed thresholds against \"auto\" (top left is better)")


def plot_round_objects(scan, features, truth, notes, zoom_m: float = 0.6, title: str = ""):
    """A scan with its circles and legs, and a zoom on the true legs with a note per true object.

    Parameters
    ----------
    scan : labkit.Scan
        The scan.
    features : labkit.Features
        What the pipeline found in it.
    truth : labkit.sim.ScanTruth
        Its ground truth (with at least one leg).
    notes : list of (array_like, str)
        ``(centre, text)`` of each true object; those inside the zoom are written beside it.
    zoom_m : float, optional
        Half the width of the zoom around the legs' mean centre, metres.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The whole scan on the left, the zoom on the right.
    """
    fig, axes = plt.subplots(1, 2, figsize=(12, 6.5))
    for ax in axes:
        lkplot.plot_features(scan, features, truth=truth, ax=ax, adjustable="box")
    centre = np.array([g.center for g in truth.legs]).mean(axis=0)
    axes[1].set(xlim=(centre[0] - zoom_m, centre[0] + zoom_m), ylim=(centre[1] - zoom_m, centre[1] + zoom_m))
    for xy, text in notes:
        if np.all(np.abs(np.asarray(xy) - centre) < zoom_m):
            axes[1].annotate(text, xy, xytext=(0, 40), textcoords="offset points", ha="center", fontsize=9,
                             arrowprops=dict(arrowstyle="->", color="0.3"))
    axes[1].legend().remove()
    axes[0].set_title("the scan, truth (thin) and detections (thick)")
    axes[1].set_title("the legs, zoomed")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_ray_errors(scan, segment, along_ray, meets, ax=None):
    """Each beam's ray, where it meets a segment, and its ray-axis error as a thick bar.

    Parameters
    ----------
    scan : labkit.Scan
        A small scan.
    segment : labkit.LineSegment
        The segment the beams are measured against.
    along_ray : ndarray of shape (N,)
        Distance from the sensor along each beam's ray to the segment's line, metres.
    meets : ndarray of shape (N,), bool
        Whether that crossing lies on the segment.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(9, 8))
    for k, theta in enumerate(scan.angles):
        far = 1.15 * max(scan.ranges[k], along_ray[k] if meets[k] else 0.0)
        ax.plot([0, far * np.cos(theta)], [0, far * np.sin(theta)], color="0.7", lw=0.8, ls="--", zorder=1,
                label="beam rays" if k == 0 else None)
    ax.plot(*np.array([segment.start, segment.end]).T, color=mpl("lines"), lw=3, zorder=3, label="extracted segment")
    u = np.c_[np.cos(scan.angles), np.sin(scan.angles)]
    hit = (along_ray[:, None] * u)[meets]
    errors = scan.ranges[meets] - along_ray[meets]
    for k, (p, q) in enumerate(zip(scan.points[meets], hit, strict=True)):
        ax.plot(*np.c_[p, q], color="tab:purple", lw=5, alpha=0.7, solid_capstyle="butt", zorder=4,
                label="ray-axis error $e_i$" if k == 0 else None)
        ax.annotate(f"{100 * errors[k]:+.1f} cm", p, xytext=(8, -4), textcoords="offset points", fontsize=8,
                    color="tab:purple")
    ax.scatter(*hit.T, marker="x", s=50, color="black", zorder=5, label="ray meets the segment")
    ax.scatter(*scan.points.T, s=30, color=mpl("points"), zorder=6, label="measured endpoints")
    ax.scatter(*scan.points[~meets].T, s=90, facecolors="none", edgecolors="tab:orange", lw=2, zorder=6,
               label="rays that meet no segment (not covered)")
    ax.plot(0, 0, marker=(3, 0, -90), color=mpl("sensor"), ms=12, ls="none", label="sensor")
    if len(hit) > 2:
        q = scan.points[meets][2]
        n = np.array([np.cos(segment.alpha), np.sin(segment.alpha)])
        foot = q - (q @ n - segment.r) * n
        ax.plot(*np.c_[q, foot], color="black", lw=1, ls=":", zorder=5, label="perpendicular distance (one beam)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x (m)", ylabel="y (m)")
    ax.legend(loc="upper left", fontsize=8)
    return ax


def plot_rmse_coverage(recordings, n_scans: int):
    """Ray-axis RMSE against coverage, one point per extractor, one panel per recording.

    Parameters
    ----------
    recordings : list of (str, list of dict)
        ``(title, rows)`` per recording, the rows of :func:`labkit.app.experiments.compare_on_logs`
        (``method``, ``rmse_m``, ``coverage``).
    n_scans : int
        How many scans of each recording the rows cover (for the titles).

    Returns
    -------
    matplotlib.figure.Figure
        The RMSE on a log scale; the good corner is bottom right.
    """
    fig, axes = plt.subplots(1, len(recordings), figsize=(8 * len(recordings), 6), squeeze=False)
    markers = "oosDv^<>ph"
    for ax, (title, rows) in zip(axes[0], recordings, strict=True):
        for k, row in enumerate(rows):
            ax.scatter(row["coverage"], row["rmse_m"], s=80, marker=markers[k % len(markers)], color=f"C{k}",
                       edgecolors="black", zorder=3, label=row["method"])
        ax.set_yscale("log")
        ax.set(xlim=(0, 1), xlabel="coverage (share of valid beams whose ray meets a segment)",
               ylabel="ray-axis RMSE (m, log scale)", title=f"{title}, first {n_scans} scans")
        ax.grid(alpha=0.3, which="both")
    axes[0][-1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def plot_error_shares(per_beam: dict, mark_m: float = 0.1, ax=None):
    """Per extractor, the share of covered beams whose ray-axis error exceeds each size.

    Parameters
    ----------
    per_beam : dict
        ``{method: ndarray of |error| per covered beam}``, metres.
    mark_m : float, optional
        An error size to mark with a vertical line, metres.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib.axes.Axes
        Both axes on log scales.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(10, 5.5))
    sizes = np.logspace(-4, 1, 200)
    for k, (name, e) in enumerate(per_beam.items()):
        ax.plot(sizes, [np.mean(e > x) for x in sizes], color=f"C{k}", lw=2, ls="-" if k < 5 else "--", label=name)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set(xlabel="error size x (m, log scale)", ylabel="share of covered beams with |e| > x (log scale)",
           ylim=(1e-4, 1.1))
    ax.axvline(mark_m, color="0.5", lw=0.8, ls=":")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower left", fontsize=8)
    return ax


def plot_noise_residuals(beams, z, one_wall, sigma_m: float, estimate_m: float, title: str = ""):
    """Each beam's normalised three-beam residual, and their histogram against the true Gaussian.

    Parameters
    ----------
    beams : ndarray of shape (M,), int
        The beams that have a residual.
    z : ndarray of shape (M,)
        Their residuals (:func:`labkit.range_noise_residuals`), metres.
    one_wall : ndarray of shape (M,), bool
        Whether the truth puts each beam and its two neighbours on one wall.
    sigma_m : float
        The true range noise, metres; the plot spans eight times it.
    estimate_m : float
        The estimated range noise, metres (drawn as +-3.5 times it).
    title : str, optional
        The left panel's title.

    Returns
    -------
    matplotlib.figure.Figure
        The residual of every beam (beyond the range: arrows) and their distribution.
    """
    beams, z, one_wall = np.asarray(beams), np.asarray(z), np.asarray(one_wall, dtype=bool)
    limit = 8 * sigma_m
    fig, (ax, ax_h) = plt.subplots(1, 2, figsize=(15, 5.5), gridspec_kw={"width_ratios": [2.2, 1]})
    out = np.abs(z) > limit
    for sel, color, size, label in [(one_wall, "0.45", 8, f"three beams on one wall ({one_wall.sum()})"),
                                    (~one_wall, "tab:red", 22,
                                     f"corner, jump edge or round object ({(~one_wall).sum()})")]:
        ax.scatter(beams[sel & ~out], 1000 * z[sel & ~out], s=size, color=color, label=label, zorder=2 + (size > 8))
        beyond: str | None = f"beyond ±{1000 * limit:.0f} mm ({(sel & out).sum()})"
        for sign, marker in [(1, "^"), (-1, "v")]:
            far = sel & out & (np.sign(z) == sign)
            if far.any():
                ax.scatter(beams[far], np.full(far.sum(), sign * 1000 * limit), marker=marker, s=60, color=color,
                           zorder=4, label=beyond)
                beyond = None  # one legend entry for both arrows
    for sign in (-1, 1):
        ax.axhline(sign * 3.5 * 1000 * estimate_m, color="black", lw=0.8, ls="--",
                   label="±3.5 × the estimate" if sign > 0 else None)
    ax.set(xlabel="beam index", ylabel="$z_i$ (mm)", ylim=(-1050 * limit, 1050 * limit), title=title)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8, ncol=3)
    ax.grid(alpha=0.3)
    bins = np.linspace(-1000 * limit, 1000 * limit, 49)
    ax_h.hist(1000 * np.clip(z, -limit, limit), bins=bins, color="0.6", label="every residual (clipped)")
    ax_h.hist(1000 * np.clip(z[~one_wall], -limit, limit), bins=bins, color="tab:red", label="not on one wall")
    x = np.linspace(-1000 * limit, 1000 * limit, 300)
    scale = 1000 * sigma_m
    ax_h.plot(x, len(z) * (bins[1] - bins[0]) * np.exp(-0.5 * (x / scale) ** 2) / (math.sqrt(2 * math.pi) * scale),
              color="black", lw=1.5, label="Gaussian of the true sigma")
    ax_h.set(xlabel="$z_i$ (mm)", ylabel="beams", title="their distribution")
    ax_h.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_placement_frontier(frontier, goal=(0.9, 0.05), ax=None):
    """TruePos against FalsePos as the placing confidence varies, for the extractor and the walls' own beams.

    Parameters
    ----------
    frontier : list of dict
        Rows of :func:`labkit.app.experiments.placement_frontier`: ``noise_std_m``, ``method``,
        ``tp_rate``, ``fp_rate``.
    goal : tuple of float, optional
        ``(TruePos at least, FalsePos at most)``, drawn as a grey box.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    matplotlib.axes.Axes
        One curve per noise level and kind of lines.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(9, 6))
    tp_goal, fp_goal = goal
    ax.add_patch(plt.Rectangle((0, tp_goal), fp_goal, 1 - tp_goal, color="0.85", zorder=0,
                               label=f"the goal: TruePos >= {tp_goal:g}, FalsePos <= {fp_goal:g}"))
    levels = sorted({r["noise_std_m"] for r in frontier})
    colors = _noise_colors(levels)
    for noise in levels:
        for method in dict.fromkeys(r["method"] for r in frontier):
            rows = [r for r in frontier if r["noise_std_m"] == noise and r["method"] == method]
            ax.plot([r["fp_rate"] for r in rows], [r["tp_rate"] for r in rows], "-" if method == "extractor" else "--",
                    marker="o", ms=4, color=colors[noise], label=f"{1000 * noise:.0f} mm, {method}")
    ax.set(xlabel="FalsePos", ylabel="TruePos", xlim=(0, None),
           title="placing confidence from 0 (right) to 0.9 (left): the default against the walls' own beams")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return ax
