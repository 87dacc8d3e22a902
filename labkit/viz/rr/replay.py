"""An algorithm's steps on one scan (:class:`labkit.Step`) replayed on rerun's ``step`` timeline."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import rerun as rr

from ..._safe import safe_output
from ...geometry import project_onto_line
from ...scan import Scan
from ...steps import Step
from ..style import COLORS
from .blueprint import _Y_UP, STEP, steps_blueprint
from .entities import POINT_RADIUS_UI, new_recording
from .recording import RRD_FILE, _close

__all__ = ["log_steps", "record_steps"]

def _step_geometry(scan: Scan, step: Step) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(beams' points, line strips (K, 2, 2), circle centres (C, 2), circle radii (C,)) of a step."""
    from ..step_plots import step_beams

    run = scan.points[step_beams(scan, step)]
    strips = np.zeros((0, 2, 2))
    if step.has_line and len(run):
        strips = project_onto_line(run[[0, -1]], step.r, step.alpha)[None]
    centers, radii = np.zeros((0, 2)), np.zeros(0)
    if step.has_circle:
        centers, radii = np.array([step.center], dtype=np.float64), np.array([step.radius])
    return run, strips, centers, radii


def log_steps(rec: rr.RecordingStream, scan: Scan, steps: list[Step], *, world: str = "world") -> int:
    """Log the steps of an algorithm on one scan, so that scrubbing the ``step`` timeline replays it.

    Step ``k`` is logged at ``step = k``. Entities: ``{world}/scan/points`` the scan (static),
    ``{world}/steps/beams`` the step's beams (orange), ``{world}/steps/line`` and
    ``{world}/steps/circle`` its line and circle (empty when it has none), ``{world}/steps/at``
    its beam of interest (red, labelled with ``value``), ``{world}/steps/accepted`` and
    ``{world}/steps/accepted_circles`` what the earlier ``"accept"`` steps kept,
    ``steps/compared/{value,threshold}`` the numbers the step compared (scalars), and
    ``steps/log`` one text line per step (kind, beams, reason). Use :func:`steps_blueprint` for
    the layout (or :func:`record_steps` for an ``.rrd``).

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    scan : Scan
        The scan the algorithm ran on.
    steps : list of Step
        Its trace (``trace=True`` of the algorithm).
    world : str
        The root entity of the spatial layers.

    Returns
    -------
    int
        How many steps were logged.
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    steps = list(steps)
    if not all(isinstance(s, Step) for s in steps):
        raise ValueError("steps must be a list of labkit.Step records")
    rec.log(world, rr.Transform3D(mat3x3=_Y_UP), static=True)
    rec.log(f"{world}/sensor", rr.Points2D([[0.0, 0.0]], radii=[-5.0], colors=[COLORS["sensor"]],
                                           labels=["sensor"]), static=True)
    rec.log(f"{world}/scan/points", rr.Points2D(scan.xy, radii=POINT_RADIUS_UI, colors=COLORS["invalid"]),
            static=True)
    kept_strips: list[np.ndarray] = []
    kept_centers: list[np.ndarray] = []
    kept_radii: list[float] = []
    none2 = np.zeros((0, 2))
    for k, step in enumerate(steps):
        rec.set_time(STEP, sequence=k)
        run, strips, centers, radii = _step_geometry(scan, step)
        rec.log(f"{world}/steps/beams", rr.Points2D(run, radii=-2.5, colors=COLORS["corners"]))
        rec.log(f"{world}/steps/line", rr.LineStrips2D(strips, radii=-2.0, colors=(0, 0, 0),
                                                       labels=[step.kind] * len(strips)))
        rec.log(f"{world}/steps/circle", rr.Ellipses2D(centers=centers, half_sizes=np.c_[radii, radii],
                                                       line_radii=-2.0, colors=(0, 0, 0)))
        at = none2
        if 0 <= step.at < scan.n_beams and scan.valid[step.at]:
            at = scan.points[step.at][None]
        value = "" if math.isnan(step.value) else f"{step.value:.3f}"
        rec.log(f"{world}/steps/at", rr.Points2D(at, radii=-5.0, colors=COLORS["sensor"],
                                                 labels=[f"beam {step.at} {value}"] * len(at)))
        rec.log(f"{world}/steps/accepted", rr.LineStrips2D(
            np.array(kept_strips).reshape(-1, 2, 2), radii=-2.5, colors=COLORS["lines"]))
        kc = np.array(kept_centers).reshape(-1, 2)
        kr = np.repeat(np.array(kept_radii).reshape(-1, 1), 2, axis=1)
        rec.log(f"{world}/steps/accepted_circles", rr.Ellipses2D(centers=kc, half_sizes=kr, line_radii=-2.0,
                                                                 colors=COLORS["circles"]))
        rec.log("steps/compared/value", rr.Scalars(step.value))
        rec.log("steps/compared/threshold", rr.Scalars(step.threshold))
        where = f" beams {step.first}..{step.last}" if step.first >= 0 else ""
        level = "WARN" if step.kind == "reject" else "INFO"
        rec.log("steps/log", rr.TextLog(f"{k}: {step.algorithm} {step.kind}{where}: {step.reason}", level=level))
        if step.kind == "accept":  # shown from the next step on, as in the widget
            kept_strips.extend(strips)
            kept_centers.extend(centers)
            kept_radii.extend(radii.tolist())
    return len(steps)


def record_steps(scan: Scan, steps: list[Step], out: str | Path, *, name: str = "steps",
                 overwrite: bool = False) -> int:
    """Write :func:`log_steps` to an ``.rrd`` with :func:`steps_blueprint`.

    Open it with ``rerun out.rrd`` and scrub the ``step`` timeline. Written under a temporary
    name and renamed when complete.

    Parameters
    ----------
    scan : Scan
        The scan the algorithm ran on.
    steps : list of Step
        Its trace.
    out : str or Path
        The ``.rrd`` file.
    name : str
        The recording's name.
    overwrite : bool
        Replace an existing ``.rrd``.

    Returns
    -------
    int
        How many steps were written.
    """
    with safe_output(out, RRD_FILE, overwrite=overwrite) as tmp:
        rec = new_recording(name)
        rec.save(tmp, default_blueprint=steps_blueprint())
        n = log_steps(rec, scan, steps)
        _close(rec, tmp)
    return n
