"""Replay an algorithm's steps (:class:`labkit.Step`) in matplotlib and in a notebook widget.

:func:`draw_step` draws one step of any algorithm onto two axes, the whole scan and a zoom on
the step's beams; :func:`step_viewer` puts a slider over the steps (and, given several traces,
buttons to switch between them) and redraws the figure for the chosen step.

Example (in a notebook)::

    lines, steps = labkit.split_and_merge(scan, trace=True)
    step_viewer(scan, steps)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

from ..geometry import project_onto_line
from ..scan import Scan
from ..steps import Step
from .style import mpl

__all__ = ["step_beams", "draw_step", "step_viewer"]

_LINE_LABELS = {"merge": "merged line", "keep": "first line of the pair", "accept": "accepted line"}


def step_beams(scan: Scan, step: Step) -> np.ndarray:
    """The valid beams a step concerns.

    Parameters
    ----------
    scan : Scan
        The scan the step is on.
    step : Step
        The step.

    Returns
    -------
    ndarray of int
        ``step.beams`` when given, else ``first..last`` (wrapping past the end of a full-circle
        scan), valid beams only; empty when the step names no beams.
    """
    if step.beams:
        beams = np.asarray(step.beams, dtype=np.int64)
    elif step.first < 0 or step.last < 0:
        return np.zeros(0, dtype=np.int64)
    elif step.first <= step.last:
        beams = np.arange(step.first, step.last + 1)
    else:
        beams = np.r_[step.first:scan.n_beams, 0:step.last + 1]
    beams = beams[(beams >= 0) & (beams < scan.n_beams)]
    return beams[scan.valid[beams]]


def _line_between(points: np.ndarray, r: float, alpha: float) -> np.ndarray:
    """The line (r, alpha) between the projections of the first and the last point."""
    return project_onto_line(points[[0, -1]], r, alpha)


def _draw_feature(ax, scan: Scan, step: Step, **style) -> None:
    beams = step_beams(scan, step)
    if step.has_line and beams.size:
        ax.plot(*_line_between(scan.points[beams], step.r, step.alpha).T, **style)
    if step.center is not None and step.has_circle:
        t = np.linspace(0.0, 2 * np.pi, 73)
        cx, cy = step.center
        ax.plot(cx + step.radius * np.cos(t), cy + step.radius * np.sin(t), **style)


def draw_step(scan: Scan, steps: Sequence[Step], k: int, axes) -> None:
    """Draw step ``k`` of ``steps`` onto ``axes = (whole, zoom)``.

    Both panels show the scan (grey), the sensor and the features accepted by the earlier
    steps (red); the step's beams are orange (for ``"merge"``/``"keep"``, the two lines'
    points in orange and green), its line dashed black, its circle dashed black, and its
    beam of interest ``at`` a red cross (with its distance to the line when the step has
    one). The left title names the step, the right one gives its reason.

    Parameters
    ----------
    scan : Scan
        The scan the algorithm ran on.
    steps : sequence of Step
        Its trace.
    k : int
        The step to draw.
    axes : tuple of matplotlib.axes.Axes
        The whole scan's panel and the zoomed one.
    """
    if not 0 <= k < len(steps):
        raise ValueError(f"k must be in 0..{len(steps) - 1}, got {k}")
    step = steps[k]
    pts = scan.points
    whole, zoom = axes
    for ax in axes:
        ax.scatter(*scan.xy.T, s=5, color="0.75", zorder=1)
        ax.plot(0, 0, marker=(3, 0, -90), color=mpl("sensor"), markersize=10, linestyle="none")
        for done in steps[:k]:
            if done.kind == "accept":
                _draw_feature(ax, scan, done, color=mpl("lines"), lw=2, alpha=0.6)
    beams = step_beams(scan, step)
    run = pts[beams]
    pair = step.kind in ("merge", "keep") and step.at in beams
    for ax in axes:
        if pair:
            cut = int(np.flatnonzero(beams == step.at)[0]) + 1
            ax.scatter(*pts[beams[:cut]].T, s=12, color=mpl("corners"), zorder=3, label="first line's points")
            ax.scatter(*pts[beams[cut:]].T, s=12, color=mpl("circles"), zorder=3, label="second line's points")
        elif beams.size:
            ax.scatter(*run.T, s=12, color=mpl("corners"), zorder=3, label="beams of this step")
        if step.has_line and beams.size:
            ends = _line_between(run, step.r, step.alpha)
            ax.plot(*ends.T, "k--", lw=1.2, zorder=4, label=_LINE_LABELS.get(step.kind, "line measured against"))
        if step.center is not None and step.has_circle:
            t = np.linspace(0.0, 2 * np.pi, 73)
            cx, cy = step.center
            ax.plot(cx + step.radius * np.cos(t), cy + step.radius * np.sin(t), "k--", lw=1.2, zorder=4,
                    label=f"circle, radius {step.radius:.3f} m")
        if 0 <= step.at < scan.n_beams and scan.valid[step.at] and step.kind not in ("merge", "keep"):
            p = pts[step.at]
            if step.kind == "gap" and step.at in beams and np.flatnonzero(beams == step.at)[0] + 1 < beams.size:
                after = beams[np.flatnonzero(beams == step.at)[0] + 1]  # the next point of the run
                ax.plot(*np.c_[p, pts[after]], color=mpl("sensor"), lw=3, zorder=5, label=f"gap {step.value:.2f} m")
            else:
                if step.has_line:
                    foot = project_onto_line(p, step.r, step.alpha)
                    ax.plot(*np.c_[p, foot], color=mpl("sensor"), lw=1.5, zorder=5)
                label = f"beam {step.at}" + ("" if math.isnan(step.value) else f", {step.value:.3f}")
                ax.plot(*p, "x", color=mpl("sensor"), ms=10, mew=2, zorder=5, label=label)
    where = f", beams {step.first}..{step.last}" if step.first >= 0 else ""
    whole.set_aspect("equal", adjustable="datalim")
    whole.set_title(f"step {k + 1} of {len(steps)}: {step.algorithm} {step.kind.upper()}{where}")
    focus = run if run.size else (np.array([step.center]) if step.has_circle else scan.xy)
    if focus.size:
        center = (focus.min(axis=0) + focus.max(axis=0)) / 2
        half = max(np.ptp(focus, axis=0).max() / 2 + 0.3, 0.5)
        if step.has_circle:
            half = max(half, step.radius + 0.3)
        zoom.set_xlim(center[0] - half, center[0] + half)
        zoom.set_ylim(center[1] - half, center[1] + half)
    zoom.set_aspect("equal", adjustable="box")
    zoom.set_title(step.reason, fontsize=10)
    if zoom.get_legend_handles_labels()[0]:
        zoom.legend(loc="upper right", fontsize=8)
    for ax in axes:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")


def step_viewer(scan: Scan, steps: Sequence[Step] | Mapping[str, Sequence[Step]], *,
                figsize: tuple[float, float] = (13, 5.5), description: str = "trace"):
    """A notebook widget that replays ``steps`` on ``scan``: a slider over the steps and the chosen one's figure.

    The figure is :func:`draw_step`'s. With several traces by name, toggle buttons switch between
    them (the slider goes back to the first step). The slider updates on release.

    Parameters
    ----------
    scan : Scan
        The scan.
    steps : sequence of Step, or mapping of str to sequence of Step
        One trace (a list of :class:`labkit.Step`) or several by name, e.g.
        ``{"endpoints": steps_a, "fit": steps_b}``.
    figsize : tuple of float
        The figure's size, inches.
    description : str
        The label of the buttons.

    Returns
    -------
    ipywidgets.VBox
        The widget, with the attributes ``slider``, ``choice`` (the buttons, or None), ``output``
        and ``figure`` (the figure last drawn).
    """
    import ipywidgets as widgets  # here, so that draw_step works without ipywidgets

    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    traces = dict(steps) if isinstance(steps, Mapping) else {description: steps}
    if not traces:
        raise ValueError("steps must hold at least one trace")
    for name, trace in traces.items():
        if len(trace) == 0:
            raise ValueError(f"trace {name!r} has no steps")
        if not all(isinstance(s, Step) for s in trace):
            raise ValueError(f"trace {name!r} must be a list of labkit.Step records")
    names = list(traces)
    choice = widgets.ToggleButtons(options=names, description=description) if len(names) > 1 else None
    slider = widgets.IntSlider(value=0, min=0, max=len(traces[names[0]]) - 1, description="step",
                               continuous_update=False, layout=widgets.Layout(width="90%"))
    out = widgets.Output()
    box = widgets.VBox(([choice] if choice else []) + [slider, out])

    def current() -> Sequence[Step]:
        return traces[choice.value if choice else names[0]]

    def render(*_) -> None:
        with out:
            out.clear_output(wait=True)
            if box.figure is not None:
                plt.close(box.figure)
            fig, axes = plt.subplots(1, 2, figsize=figsize)
            draw_step(scan, current(), slider.value, axes)
            fig.tight_layout()
            box.figure = fig
            plt.show()

    def switch(*_) -> None:
        with slider.hold_trait_notifications():
            slider.value = 0
            slider.max = len(current()) - 1
        render()

    box.figure = None
    box.slider, box.choice, box.output = slider, choice, out
    slider.observe(render, names="value")
    if choice is not None:
        choice.observe(switch, names="value")
    render()
    return box
