"""rerun recordings of scans and features: the only labkit module that knows rerun.

Layout of a labkit recording
----------------------------
Timelines
    ``ros_time`` (the scan's time stamp) and ``scan`` (its sequence number).
Entities
    ``world/scan/points`` valid beams, ``world/scan/invalid`` short grey rays where a beam
    returned nothing usable, ``world/sensor`` the sensor, ``world/segments`` the points
    coloured by range segment, ``world/{lines,corners,circles,arcs,legs,people}`` the
    features :func:`labkit.extract_features` found (hover one for its parameters),
    ``world/truth/{walls,circles,arcs,legs}`` simulator ground truth,
    ``metrics/count/*`` per-scan counts and ``metrics/time_ms/*`` per-stage times as time
    series, ``log`` a text log, and ``description`` a Markdown note. Features of a second
    configuration logged with ``name="B"`` go to ``world/B/...`` and ``metrics/B/...``.
    ``world`` is the sensor frame, drawn with x to the right and y up, as in labkit's
    matplotlib figures (rerun's 2D views point y down, so ``world`` carries a static
    mirror transform).
Map (when the scans carry poses: :attr:`labkit.Scan.pose`)
    ``map`` is the world frame (y up too): ``map/path`` the sensor's path, ``map/sensor`` the
    sensor's pose at each scan as a rerun transform, under it ``map/sensor/points`` and the
    current scan's features (``map/sensor/lines`` ...) -- the scan placed in the world --, and
    ``map/accumulated/{points,lines,corners,circles,legs}`` what the scans saw so far, in world
    coordinates: every ``map_every``-th scan with a pose (a keyframe; default 10) adds its points
    that fall in grid cells of ``map_cell_m`` (default 5 cm) no earlier keyframe filled, and its
    features. The map view shows the accumulated entities from the start of the recording up to
    the time cursor, so the map grows as you scrub; thinning keeps it to one point per cell, so
    even a 5000-scan log draws smoothly (a few tens of thousands of points for a building).
    ``map/truth/walls``: the simulator's walls, when its ground truth lies beside the recording.
    The map view sits beside the sensor view, on the same timelines; without poses there is
    no ``map`` and the layout is as before.

Importing this module sets ``RERUN_NOTEBOOK_ASSET=serve-local`` (unless already set) before
it imports rerun, so the viewer embedded in a notebook loads its assets from the installed
``rerun-notebook`` package instead of the internet.
"""

from __future__ import annotations

import os
import sys

# rerun-notebook reads the variable when it is first imported (by rerun.notebook)
if "rerun_notebook" in sys.modules and "RERUN_NOTEBOOK_ASSET" not in os.environ:  # pragma: no cover
    import warnings

    warnings.warn(
        "rerun's notebook support was loaded before labkit.viz.rr: set RERUN_NOTEBOOK_ASSET=serve-local "
        "before importing rerun.notebook, or the inline viewer will load its assets from the internet",
        stacklevel=2,
    )
os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")

import contextlib  # noqa: E402
import errno  # noqa: E402
import itertools  # noqa: E402
import math  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Iterable  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import rerun as rr  # noqa: E402
import rerun.blueprint as rrb  # noqa: E402

from .._safe import OutputKind, check_output, safe_output, starts_with  # noqa: E402
from ..errors import CorruptFileError  # noqa: E402
from ..features import Features  # noqa: E402
from ..geometry import arc_points, project_onto_line, transform_points  # noqa: E402
from ..pipeline import Config, extract_features  # noqa: E402
from ..poses import GridThinning  # noqa: E402
from ..scan import Scan  # noqa: E402
from ..segmentation import segment_labels  # noqa: E402
from ..steps import Step  # noqa: E402
from .style import COLORS, label_colors  # noqa: E402

__all__ = [
    "APP_ID",
    "TIME",
    "SEQUENCE",
    "blueprint",
    "new_recording",
    "log_static",
    "log_scans",
    "log_features",
    "log_truth",
    "log_map",
    "log_text",
    "record",
    "record_scans",
    "RecordSummary",
    "StampsCollapsedWarning",
    "describe",
    "show_inline",
    "STEP",
    "steps_blueprint",
    "log_steps",
    "record_steps",
]

APP_ID = "labkit"
TIME = "ros_time"
SEQUENCE = "scan"
#: The timeline of an algorithm's steps on one scan (:func:`log_steps`).
STEP = "step"
INVALID_RAY_M = 0.4  # length of the grey ray drawn for an invalid beam
# radii in UI points (negative in rerun): dots keep their size on screen at any zoom
POINT_RADIUS_UI = -1.5
SEGMENT_RADIUS_UI = -2.5
_BATCH = 128  # scans per send_columns call: memory in flight grows with it, the file's footer with 1 / _BATCH
_PEEK = 256  # scans looked at before writing: do they carry poses, do their stamps advance?
#: Map decimation: every MAP_EVERY-th scan with a pose adds to the accumulated map, one point per
#: MAP_CELL_M grid cell; the path keeps a point every PATH_STEP_M.
MAP_EVERY = 10
MAP_CELL_M = 0.05
PATH_STEP_M = 0.02
_MAP_COLORS = {"path": (40, 100, 210), "accumulated": (120, 120, 120), "lines": (235, 150, 140),
               "pose": (220, 40, 40)}
_ACCUMULATED = ("points", "lines", "corners", "circles", "legs")

# rerun's 2D views have y pointing down; mirror so that y points up as in matplotlib.
_Y_UP = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]

# The time-series panels are small beside the scan view, and a legend of five to seven series
# covers most of one: no legend (hovering a curve names it, the entity tree lists them all).
_NO_LEGEND = rrb.PlotLegend(visible=False)


def map_view() -> rrb.Spatial2DView:
    """The world-frame view: ``map/**``, the accumulated map shown from the start up to the cursor."""
    grow = rrb.VisibleTimeRanges([
        rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                             end=rrb.TimeRangeBoundary.cursor_relative())
        for timeline in (SEQUENCE, TIME)])
    return rrb.Spatial2DView(origin="/", contents="map/**", name="Map (world frame)",
                             overrides={f"/map/accumulated/{layer}": grow for layer in _ACCUMULATED})


def blueprint(compare: tuple[str, ...] | list[str] = (), *, with_map: bool = False,
              with_times: bool = True, timeline: str | None = None) -> rrb.Blueprint:
    """The default layout: the scan view on the left; counts, stage times, log and notes on
    the right. ``with_map``: the map view (world frame) beside the scan view; ``with_times=False``
    leaves out the stage-time panel (a recording without features has no stage times);
    ``timeline``: the timeline the viewer opens on (:data:`SEQUENCE` for a recording whose
    stamps do not advance). With
    ``compare=("A", "B")`` there is one scan view per named configuration
    (features logged with ``log_features(..., name="A")``), side by side, each showing the
    scan, the ground truth and that configuration's features."""
    if compare:
        others = {n: [f"- /world/{m}/**" for m in compare if m != n] for n in compare}
        views = [rrb.Spatial2DView(origin="/", contents=["+ /world/**", *others[n]], name=f"{n}")
                 for n in compare]
        plots = [rrb.Tabs(rrb.TimeSeriesView(origin=f"metrics/{n}/count", name=f"{n}: counts", plot_legend=_NO_LEGEND),
                          rrb.TimeSeriesView(origin=f"metrics/{n}/time_ms", name=f"{n}: ms per stage",
                                            plot_legend=_NO_LEGEND))
                 for n in compare]
        below = rrb.Horizontal(*plots, rrb.TextDocumentView(origin="description", name="About"))
        return rrb.Blueprint(rrb.Vertical(rrb.Horizontal(*views), below, row_shares=[3, 2]), collapse_panels=False)
    views = [rrb.Spatial2DView(origin="/", contents="world/**", name="Scan (sensor frame)")]
    if with_map:
        views.append(map_view())
    panels = [(rrb.TimeSeriesView(origin="metrics/count", name="Per-scan counts", plot_legend=_NO_LEGEND), 2),
              (rrb.TimeSeriesView(origin="metrics/time_ms", name="Milliseconds per stage", plot_legend=_NO_LEGEND), 2),
              (rrb.TextLogView(origin="log", name="Log"), 1),
              (rrb.TextDocumentView(origin="description", name="About"), 2)]
    if not with_times:
        del panels[1]
    return rrb.Blueprint(
        rrb.Horizontal(
            *views,
            rrb.Vertical(*[view for view, _ in panels], row_shares=[share for _, share in panels]),
            column_shares=[3, 3, 2] if with_map else [3, 2],
        ),
        *([rrb.TimePanel(timeline=timeline)] if timeline else []),
        collapse_panels=False,
    )


def new_recording(name: str | None = None, *, recording_id: str | None = None) -> rr.RecordingStream:
    """A recording stream with no sink yet (data is buffered until one is set).

    Only the ``ros_time`` and ``scan`` timelines are kept (rerun's own ``log_time`` is
    switched off so that recordings of the same data are the same).
    """
    rec = rr.RecordingStream(APP_ID, recording_id=recording_id)
    rec.set_log_time_enabled(False)
    if name:
        rec.send_recording_name(name)
    return rec


def log_static(rec: rr.RecordingStream, description: str | None = None) -> None:
    """Log what does not change: the y-up view transform, the sensor, the notes."""
    rec.log("world", rr.Transform3D(mat3x3=_Y_UP), static=True)
    rec.log("world/sensor", rr.Points2D([[0.0, 0.0]], radii=[-5.0], colors=[COLORS["sensor"]],
                                        labels=["sensor"]), static=True)
    if description:
        rec.log("description", rr.TextDocument(description, media_type=rr.MediaType.MARKDOWN), static=True)


def _hide_labels(rec: rr.RecordingStream, world: str) -> None:
    """Features are drawn over the scan's points (rerun draws points over lines by default),
    and their labels show when hovered, not all at once (dozens would hide the scan)."""
    for layer, archetype, order in (("lines", rr.LineStrips2D, 40.0), ("corners", rr.Points2D, 45.0),
                                    ("circles", rr.Ellipses2D, 42.0), ("arcs", rr.Ellipses2D, 42.0),
                                    ("legs", rr.Ellipses2D, 42.0), ("people", rr.Points2D, 44.0)):
        rec.log(f"{world}/{layer}", archetype.from_fields(show_labels=layer == "people", draw_order=order),
                static=True)


def log_text(rec: rr.RecordingStream, text: str, level: str = "INFO") -> None:
    """Append a line to the ``log`` entity at the current time."""
    rec.log("log", rr.TextLog(text, level=level))


def _time_columns(indices: np.ndarray, stamps: np.ndarray) -> list:
    return [
        rr.TimeColumn(SEQUENCE, sequence=indices),
        rr.TimeColumn(TIME, timestamp=stamps.astype("datetime64[ns]")),
    ]


def _segments(starts, ends) -> np.ndarray:
    """Two-point line strips as one (N, 2, 2) array (rerun converts that in one go; a list of
    small arrays costs it about 20 us per strip)."""
    out = np.zeros((len(starts), 2, 2))
    if len(starts):
        out[:, 0], out[:, 1] = starts, ends
    return out


def _invalid_rays(scan: Scan) -> np.ndarray:
    a = scan.angles[~scan.valid]
    return _segments(np.zeros((a.size, 2)), INVALID_RAY_M * np.stack([np.cos(a), np.sin(a)], axis=1))


def log_scans(
    rec: rr.RecordingStream,
    scans: Iterable[Scan],
    *,
    start_index: int = 0,
    segment_threshold_m: float | None = 0.08,
    labels: Iterable[np.ndarray] | None = None,
    features: Iterable[Features] | None = None,
    show_invalid: bool = True,
) -> int:
    """Log scans in bulk (``send_columns``) on both timelines; return how many.

    Each scan is logged at ``scan = start_index + k`` and ``ros_time = scan.stamp_ns``.
    With ``features`` (one :class:`labkit.Features` per scan, e.g. from
    :func:`labkit.extract_all`) every feature layer, the per-scan counts and stage times are
    logged too (see :func:`log_features`), and the segments are the features' own. The
    points are also logged coloured by range segment (``world/segments``, with the segment
    count in ``metrics/count/segments``): from ``features``, from ``labels`` (one per-beam
    label array per scan) or else segmented here as the pipeline does (adaptive breakpoints
    with ``segment_threshold_m`` as the floor; ``None``: no segment layer). If iterating
    ``scans`` (or ``features``) raises (a damaged file), every scan before the fault is sent,
    then the error propagates.
    """

    def frames():
        if features is not None:
            for scan, f in zip(scans, features, strict=False):
                yield scan, f.labels, f
        elif labels is not None:
            for scan, lab in zip(scans, labels, strict=False):
                yield scan, lab, None
        else:
            for scan in scans:
                yield scan, _segment(scan, segment_threshold_m), None

    return _log_frames(rec, frames(), start_index, show_invalid)


def _log_frames(rec, frames: Iterable[tuple[Scan, np.ndarray | None, Features | None]], start_index: int,
                show_invalid: bool, world_map: _Map | None = None) -> int:
    """Send ``(scan, labels, features)`` frames in batches (see :func:`_batched`), and to the
    map (``world_map``) those that have a pose."""

    def send(batch, k: int) -> None:
        _send_batch(rec, batch, start_index + k, show_invalid, k == 0)
        if world_map is not None:
            world_map.send(batch, start_index + k)

    return _batched(frames, send)


class _Map:
    """Logs the world frame (module docstring, "Map"): the sensor's transform per scan, the
    scan and its features under it, and the decimated accumulated map; the path at the end."""

    def __init__(self, rec: rr.RecordingStream, every: int = MAP_EVERY, cell_m: float = MAP_CELL_M,
                 features: bool = True) -> None:
        if every < 1:
            raise ValueError(f"map_every must be >= 1, got {every}")
        self.rec, self.every, self.thin = rec, int(every), GridThinning(cell_m)
        self.n_posed = 0
        self.labels_hidden = False
        self.path: list[tuple[float, float]] = []
        rec.log("map", rr.Transform3D(mat3x3=_Y_UP), static=True)
        rec.log("map/sensor/marker", rr.Points2D([[0.0, 0.0]], radii=[-5.0], colors=[_MAP_COLORS["pose"]],
                                                 labels=["sensor"], show_labels=False), static=True)
        rec.log("map/sensor/heading", rr.Arrows2D(vectors=[[0.6, 0.0]], colors=[_MAP_COLORS["pose"]],
                                                  radii=[-1.5]), static=True)
        layers = (("points", rr.Points2D), ("lines", rr.LineStrips2D), ("corners", rr.Points2D),
                  ("circles", rr.Points2D), ("legs", rr.Points2D))
        for layer, archetype in layers if features else layers[:1]:  # (a layer declared without data: a badge)
            rec.log(f"map/accumulated/{layer}", archetype.from_fields(show_labels=False, draw_order=10.0 + len(layer)),
                    static=True)

    def send(self, items: list, first_index: int) -> None:
        scans = [scan for scan, _, _ in items]
        posed = [k for k, scan in enumerate(scans) if scan.pose is not None]
        idx = np.arange(first_index, first_index + len(items))
        stamps = np.array([s.stamp_ns for s in scans], dtype=np.int64)
        if posed:
            poses = np.array([scans[k].pose for k in posed])
            half = poses[:, 2] / 2
            quaternions = np.column_stack([np.zeros((len(posed), 2)), np.sin(half), np.cos(half)])
            self.rec.send_columns("map/sensor", indexes=_time_columns(idx[posed], stamps[posed]),
                                  columns=rr.Transform3D.columns(
                                      translation=np.column_stack([poses[:, :2], np.zeros(len(posed))]),
                                      quaternion=quaternions))
        # the scan under the transform; a scan without a pose shows nothing (not the last one's place)
        times = _time_columns(idx, stamps)
        pts = [s.xy if s.pose is not None else np.zeros((0, 2)) for s in scans]
        self.rec.send_columns("map/sensor/points", indexes=times, columns=rr.Points2D.columns(
            positions=np.concatenate(pts), colors=_colors("points", sum(map(len, pts))),
            radii=np.full(sum(map(len, pts)), POINT_RADIUS_UI, dtype=np.float32)).partition([len(p) for p in pts]))
        if items[0][2] is not None:
            feats = [f if s.pose is not None else Features(f.stamp_ns, f.n_beams, f.labels)
                     for s, (_, _, f) in zip(scans, items, strict=True)]
            _send_features(self.rec, times, feats, "map/sensor", None, segment_count=False,
                           hide_labels=not self.labels_hidden)
            self.labels_hidden = True
        keys = []
        for k in posed:
            if self.n_posed % self.every == 0:
                keys.append(k)
            self.n_posed += 1
            x, y = scans[k].pose[:2]
            if not self.path or np.hypot(x - self.path[-1][0], y - self.path[-1][1]) >= PATH_STEP_M:
                self.path.append((x, y))
        if keys:
            self._accumulate([items[k] for k in keys], _time_columns(idx[keys], stamps[keys]), idx[keys])

    def _accumulate(self, items: list, times, indices) -> None:
        """The keyframes' new points and their features, in world coordinates."""
        rec = self.rec
        pts = []
        for scan, _, _ in items:
            world = transform_points(scan.xy, scan.pose)
            pts.append(world[self.thin.new(world)])
        rec.send_columns("map/accumulated/points", indexes=times, columns=rr.Points2D.columns(
            positions=np.concatenate(pts), colors=_colors_rgb(_MAP_COLORS["accumulated"], sum(map(len, pts))),
            radii=np.full(sum(map(len, pts)), -1.0, dtype=np.float32)).partition([len(p) for p in pts]))
        if items[0][2] is None:
            return
        where = [f"scan {k}" for k in indices]

        def world(scan, points):
            return transform_points(np.asarray(points, dtype=float).reshape(-1, 2), scan.pose)

        strips = [world(s, [p for ln in f.lines for p in (ln.start, ln.end)]).reshape(-1, 2, 2) for s, _, f in items]
        rec.send_columns("map/accumulated/lines", indexes=times, columns=rr.LineStrips2D.columns(
            strips=np.concatenate(strips), colors=_colors_rgb(_MAP_COLORS["lines"], sum(map(len, strips))),
            radii=np.full(sum(map(len, strips)), -1.5, dtype=np.float32),
            labels=[w for w, st in zip(where, strips, strict=True) for _ in st]).partition([len(x) for x in strips]))
        for layer, attr in (("corners", "point"), ("circles", "center"), ("legs", "center")):
            centres = [world(s, [getattr(x, attr) for x in getattr(f, layer)]) for s, _, f in items]
            n = sum(map(len, centres))
            labels = [w for w, c in zip(where, centres, strict=True) for _ in c]
            rec.send_columns(f"map/accumulated/{layer}", indexes=times, columns=rr.Points2D.columns(
                positions=np.concatenate(centres), colors=_colors(layer, n), radii=np.full(n, -2.5, dtype=np.float32),
                labels=labels).partition([len(c) for c in centres]))

    def finish(self, truth=None) -> None:
        """The path (and the simulator's walls, from ``truth``), static: they hold for the whole recording."""
        if self.path:
            self.rec.log("map/path", rr.LineStrips2D([np.array(self.path)], colors=[_MAP_COLORS["path"]],
                                                     radii=[-0.75], labels=["path"], show_labels=False,
                                                     draw_order=15.0), static=True)
        walls = (truth.header.get("world", {}) if truth is not None else {}).get("walls", [])
        if walls:
            self.rec.log("map/truth/walls", rr.LineStrips2D(
                np.array([[w["start"], w["end"]] for w in walls], dtype=float), colors=_colors("truth", len(walls)),
                radii=np.full(len(walls), -1.0, dtype=np.float32), labels=[w.get("name", "") for w in walls],
                show_labels=False, draw_order=1.0), static=True)


def _batched(items: Iterable, send) -> int:
    """Call ``send(batch, index of its first item)`` for every ``_BATCH`` items and for the
    rest; if iterating ``items`` raises, what came before is sent, then the error propagates.
    Returns how many items there were."""
    count = 0
    batch: list = []
    try:
        for item in items:
            batch.append(item)
            count += 1
            if len(batch) >= _BATCH:
                send(batch, count - len(batch))
                batch = []
    finally:
        if batch:
            send(batch, count - len(batch))
    return count


def _segment(scan: Scan, threshold_m: float | None) -> np.ndarray | None:
    """Range segments as the pipeline's default makes them (adaptive, ``threshold_m`` floor)."""
    return None if threshold_m is None else segment_labels(scan, threshold_m=threshold_m, adaptive=True)


def _scalars(rec, path: str, times, values) -> None:
    rec.send_columns(path, indexes=times, columns=rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)))


def _send_batch(rec, items: list[tuple[Scan, np.ndarray | None, Features | None]], first_index: int,
                show_invalid, first_batch: bool = True) -> None:
    batch = [scan for scan, _, _ in items]
    idx = np.arange(first_index, first_index + len(batch))
    stamps = np.array([s.stamp_ns for s in batch], dtype=np.int64)
    times = _time_columns(idx, stamps)
    lengths = [len(s.xy) for s in batch]
    pts = np.concatenate([s.xy for s in batch]) if sum(lengths) else np.zeros((0, 2))
    rec.send_columns(
        "world/scan/points",
        indexes=times,
        columns=rr.Points2D.columns(positions=pts, colors=_colors("points", len(pts)),
                                    radii=np.full(len(pts), POINT_RADIUS_UI, dtype=np.float32)).partition(lengths),
    )
    _scalars(rec, "metrics/valid_beams", times, lengths)
    if show_invalid:
        rays = [_invalid_rays(s) for s in batch]
        rec.send_columns(
            "world/scan/invalid",
            indexes=times,
            columns=rr.LineStrips2D.columns(
                strips=np.concatenate(rays),
                colors=_colors("invalid", sum(map(len, rays))),
            ).partition([len(r) for r in rays]),
        )
    if items[0][1] is not None:
        colors, n_segments = [], []
        for s, beam_labels, _ in items:
            labels = np.asarray(beam_labels)[s.valid_indices]
            colors.append(label_colors(labels))
            n_segments.append(float(labels.max() + 1) if labels.size else 0.0)
        rec.send_columns(
            "world/segments",
            indexes=times,
            columns=rr.Points2D.columns(positions=pts,
                                        colors=np.concatenate(colors) if colors else np.zeros((0, 3)),
                                        radii=np.full(len(pts), SEGMENT_RADIUS_UI, dtype=np.float32)
                                        ).partition(lengths),
        )
        _scalars(rec, "metrics/count/segments", times, n_segments)
    if items[0][2] is not None:
        _send_features(rec, times, [f for _, _, f in items], "world", "metrics", segment_count=False,
                       hide_labels=first_batch)


def _forever(value):
    while True:
        yield value


def _colors(name: str, n: int) -> np.ndarray:
    return _colors_rgb(COLORS[name], n)


def _colors_rgb(rgb, n: int) -> np.ndarray:
    return np.tile(np.array(rgb, dtype=np.uint8), (n, 1))


def _send_features(rec, times, feats: list[Features], world: str, metrics: str | None, segment_count: bool,
                   hide_labels: bool = True) -> None:
    """Every feature layer of a batch of scans, as one ``send_columns`` call per layer (and,
    under ``metrics``, their counts and stage times). ``hide_labels``: also log the layers' static
    draw order and label visibility (once per recording: every static log is a chunk of its own,
    and every chunk costs the file's footer memory until the file is closed)."""

    # the layers' draw order and labels, only where features are logged: an entity that names an archetype
    # without its required component (Ellipses2D without half_sizes) shows an error badge in the viewer
    if hide_labels:
        _hide_labels(rec, world)

    def send(layer: str, archetype, colour: str, size_ui: float, **columns) -> None:
        per_scan = [getattr(f, layer) for f in feats]
        counts = [len(xs) for xs in per_scan]
        items = [x for xs in per_scan for x in xs]
        size = "line_radii" if archetype is rr.Ellipses2D else "radii"  # outline width or dot/line size
        columns = {name: make(items) for name, make in columns.items()}
        columns.update({"colors": _colors(colour, len(items)), size: np.full(len(items), size_ui, dtype=np.float32)})
        rec.send_columns(f"{world}/{layer}", indexes=times, columns=archetype.columns(**columns).partition(counts))

    def xy(attr: str):
        return lambda items: np.array([getattr(x, attr) for x in items]).reshape(-1, 2)

    def half_sizes(radius):
        return lambda items: np.repeat(np.array([radius(x) for x in items]).reshape(-1, 1), 2, axis=1)

    send("lines", rr.LineStrips2D, "lines", -2.5,
         strips=lambda lines: _segments([ln.start for ln in lines], [ln.end for ln in lines]),
         labels=lambda lines: [f"line r={ln.r:.3f} m alpha={np.degrees(ln.alpha):.1f} deg, beams {ln.first}-"
                               f"{ln.last}, {ln.n_points} pts, rms {ln.error * 1e3:.1f} mm" for ln in lines])
    send("corners", rr.Points2D, "corners", -5.0, positions=xy("point"),
         labels=lambda corners: [f"{c.kind} corner {np.degrees(c.angle):.0f} deg"
                                 + (" (extrapolated)" if c.extrapolated else "") for c in corners])
    for layer in ("circles", "arcs"):
        send(layer, rr.Ellipses2D, layer, -2.0, centers=xy("center"), half_sizes=half_sizes(lambda c: c.radius),
             labels=lambda items: [f"{c.kind} r={c.radius:.3f} m, IAV {np.degrees(c.iav_mean):.0f}+-"
                                   f"{np.degrees(c.iav_std):.1f} deg, confidence {c.confidence:.2f}" for c in items])
    send("legs", rr.Ellipses2D, "legs", -2.0, centers=xy("center"), half_sizes=half_sizes(lambda g: g.diameter / 2),
         labels=lambda legs: [f"leg d={g.diameter * 100:.0f} cm" for g in legs])
    send("people", rr.Points2D, "people", -3.5, positions=xy("center"), labels=lambda people: ["person"] * len(people))
    if metrics is None:
        return
    for layer in ("segments",) * segment_count + Features.LAYERS:
        _scalars(rec, f"{metrics}/count/{layer}", times,
                 [f.n_segments if layer == "segments" else len(getattr(f, layer)) for f in feats])
    for stage in feats[0].timings:
        _scalars(rec, f"{metrics}/time_ms/{stage}", times, [1e3 * f.timings.get(stage, np.nan) for f in feats])


def log_features(
    rec: rr.RecordingStream,
    features: Iterable[Features],
    *,
    start_index: int = 0,
    name: str | None = None,
) -> int:
    """Log features alone (the scans logged already, e.g. by :func:`log_scans`), at
    ``scan = start_index + k`` and ``ros_time = features.stamp_ns``; return how many.

    ``name`` puts them under ``world/<name>/...`` and ``metrics/<name>/...``, so that two
    configurations can be compared side by side (``blueprint(compare=[...])``).
    """
    world, metrics = ("world", "metrics") if not name else (f"world/{name}", f"metrics/{name}")

    def send(batch: list[Features], k: int) -> None:
        k0 = start_index + k
        times = _time_columns(np.arange(k0, k0 + len(batch)), np.array([f.stamp_ns for f in batch], np.int64))
        _send_features(rec, times, batch, world, metrics, segment_count=True, hide_labels=k == 0)

    return _batched(features, send)


def log_map(rec: rr.RecordingStream, scans: Iterable[Scan], features: Iterable[Features] | None = None, *,
            start_index: int = 0, truth=None, map_every: int = MAP_EVERY, map_cell_m: float = MAP_CELL_M) -> int:
    """Log the world frame of scans with poses (module docstring, "Map"): the sensor's transform
    per scan, the scan and its ``features`` (one per scan, optional) under it, the accumulated
    map, the path, and the world's walls from ``truth`` (a :class:`labkit.sim.GroundTruth`).
    Use it beside :func:`log_scans` and show it with ``show_inline(rec, with_map=True)``;
    returns how many scans were logged."""
    the_map = _Map(rec, map_every, map_cell_m)
    side = features if features is not None else _forever(None)
    n = _batched(((scan, None, f) for scan, f in zip(scans, side, strict=False)),
                 lambda batch, k: the_map.send(batch, start_index + k))
    the_map.finish(truth)
    return n


def log_truth(rec: rr.RecordingStream, truths: Iterable, index_of: dict[int, int]) -> int:
    """Log simulator ground truth (:class:`labkit.sim.ScanTruth`) under ``world/truth``, in
    grey so that the detected features (in colour) stand out against it.

    ``index_of`` maps ``stamp_ns`` to the scan's sequence number; truths of stamps not in
    it are skipped. Returns how many were logged.
    """
    known = ((index_of[tr.stamp_ns], tr) for tr in truths if tr.stamp_ns in index_of)
    n = _batched(known, lambda batch, _first: _send_truth(rec, batch))
    _hide_truth_labels(rec)
    return n


def _hide_truth_labels(rec: rr.RecordingStream) -> None:
    for layer in ("walls", "arcs"):
        rec.log(f"world/truth/{layer}", rr.LineStrips2D.from_fields(show_labels=False), static=True)


def _send_truth(rec: rr.RecordingStream, batch: list[tuple[int, object]]) -> None:
    """One ``send_columns`` call per truth layer for ``(scan index, ScanTruth)`` pairs."""
    times = _time_columns(np.array([k for k, _ in batch]), np.array([tr.stamp_ns for _, tr in batch], np.int64))
    truths = [tr for _, tr in batch]
    walls = [w for tr in truths for w in tr.walls]
    rec.send_columns("world/truth/walls", indexes=times, columns=rr.LineStrips2D.columns(
        strips=_segments([w.start for w in walls], [w.end for w in walls]), colors=_colors("truth", len(walls)),
        labels=[w.name for w in walls], radii=np.full(len(walls), -1.0, dtype=np.float32),
    ).partition([len(tr.walls) for tr in truths]))
    arcs = [a for tr in truths for a in tr.arcs]
    rec.send_columns("world/truth/arcs", indexes=times, columns=rr.LineStrips2D.columns(
        strips=[arc_points(a.center, a.radius, a.start, a.end) for a in arcs], colors=_colors("truth", len(arcs)),
        labels=[a.name for a in arcs], radii=np.full(len(arcs), -1.0, dtype=np.float32),
    ).partition([len(tr.arcs) for tr in truths]))
    for key in ("circles", "legs"):
        items = [c for tr in truths for c in getattr(tr, key)]
        half = np.array([getattr(c, "radius", None) or c.diameter / 2 for c in items]).reshape(-1, 1)
        rec.send_columns(f"world/truth/{key}", indexes=times, columns=rr.Ellipses2D.columns(
            centers=np.array([c.center for c in items]).reshape(-1, 2), half_sizes=np.repeat(half, 2, axis=1),
            colors=_colors("truth", len(items)), line_radii=np.full(len(items), -1.0, dtype=np.float32),
        ).partition([len(getattr(tr, key)) for tr in truths]))


@dataclass(frozen=True)
class RecordSummary:
    """What :func:`record` wrote: the file, how many scans and truths, the error that
    stopped reading (or ``None``), and over all scans the feature counts and the seconds
    spent per pipeline stage (empty without features)."""

    path: Path
    n_scans: int
    n_truth: int
    error: Exception | None
    counts: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)


_LAYER_NOTES = {
    "world/scan/points": "valid beams",
    "world/scan/invalid": "grey rays: beams without a valid return",
    "world/segments": "points coloured by range segment",
    "world/lines": "line segments (hover for r, alpha, beams, points, RMS error)",
    "world/corners": "corners where two lines meet",
    "world/circles": "IAV circles",
    "world/arcs": "arcs embedded in walls",
    "world/legs": "legs",
    "world/people": "pairs of legs",
    "world/truth/*": "simulator ground truth, grey",
    "metrics/count/*": "per-scan counts",
    "metrics/valid_beams": "valid beams per scan",
    "metrics/time_ms/*": "milliseconds per pipeline stage",
}


_MAP_NOTES = {
    "map/path": "the sensor's path (world frame)",
    "map/sensor": "the sensor's pose at the current scan (a transform); the scan and its features under it",
    "map/accumulated/*": f"what the scans saw so far, in the world frame: every {MAP_EVERY}th scan's points, one "
                         f"per {MAP_CELL_M * 100:g} cm cell, and its features (hover: which scan)",
}


def describe(title: str, *, source: str = "", config: Config | None = None, truth: bool = False,
             compare: dict[str, Config] | None = None, world_map: bool = False) -> str:
    """The Markdown note logged with a recording: what each entity shows, and the config;
    with ``compare`` (``{name: config}`` of features logged with ``log_features(...,
    name=name)``) the named layers and every config."""
    lines = [f"# {title}", ""]
    if source:
        lines += [source, ""]
    lines += ["| entity | shows |", "|---|---|"]
    for entity, note in _LAYER_NOTES.items():
        if (entity.startswith("world/truth") and not truth) or (config is None and entity not in (
                "world/scan/points", "world/scan/invalid", "world/segments", "world/truth/*", "metrics/count/*",
                "metrics/valid_beams")):
            continue
        lines.append(f"| `{entity}` | {note} |")
    if world_map:
        lines += [f"| `{entity}` | {note} |" for entity, note in _MAP_NOTES.items()]
        if truth:
            lines.append("| `map/truth/walls` | the simulator's walls, grey |")
    for name in compare or {}:
        lines.append(f"| `world/{name}/*`, `metrics/{name}/*` | the features, counts and stage times of config "
                     f"`{name}` |")
    if config is not None:
        lines += ["", "## Config", "", "```toml", config.to_toml(), "```"]
    for name, cfg in (compare or {}).items():
        lines += ["", f"## Config `{name}`", "", "```toml", cfg.to_toml(), "```"]
    return "\n".join(lines)


def record_scans(
    scans: Iterable[Scan],
    out: str | Path,
    *,
    name: str,
    truth=None,
    labels: Iterable[np.ndarray] | None = None,
    features: Iterable[Features] | None = None,
    config: Config | None = None,
    segment_threshold_m: float | None = 0.08,
    description: str | None = None,
    overwrite: bool = False,
    inputs: Iterable[str | Path] = (),
    with_map: bool | None = None,
    map_every: int = MAP_EVERY,
    map_cell_m: float = MAP_CELL_M,
    start_index: int = 0,
) -> RecordSummary:
    """Write scans to an ``.rrd`` file with the default blueprint, as they come: the file is
    written while the scans are read (``RecordingStream.save`` before anything is logged, then
    ``send_columns`` every :data:`_BATCH` scans), so memory stays flat however long the recording.

    When the scans carry poses (``with_map=None``: when one of the first 256 does), the map view
    is logged beside the scan view: the path, the sensor's pose per scan, the scan and its
    features in the world frame, and the accumulated map (``map_every``, ``map_cell_m``: see the
    module docstring). ``with_map=False`` leaves it out.

    Features are logged when given (``features``, one per scan) or computed here with
    ``config`` (a :class:`labkit.Config`); otherwise only the scans and their range
    segments (``labels`` per scan, or adaptive with ``segment_threshold_m`` as floor). ``truth`` is
    a :class:`labkit.sim.GroundTruth`, or a :class:`labkit.sim.TruthStream` read along with the
    scans (both in time order), to log beside them. If iterating ``scans`` raises
    :class:`labkit.CorruptFileError` (a damaged file), the ``.rrd`` holds every scan that
    could be read, the error is logged to ``log`` and returned in the summary (not raised).
    ``start_index``: the ``scan`` timeline's number of the first scan (a range of a recording).

    When the scans' time stamps do not advance (at least 1 % of them no later than the scan
    before, as in the Radish ``infinite-corridor`` log), a :class:`StampsCollapsedWarning` says so:
    scrub the ``scan`` timeline, which the viewer then opens on.

    The file is written under a temporary name and renamed when complete; ``overwrite``
    replaces only an existing ``.rrd``, and the output may not be one of ``inputs`` (see
    :mod:`labkit._safe`). Interrupted (Ctrl-C), the recording so far is closed and kept as
    ``<name>.partial.rrd``. A write that fails (a full disk) raises ``OSError`` naming ``out``,
    and no file is left.
    """
    scans = iter(scans)
    first: list[Scan] = []  # a look at the first batch: poses? stamps?
    damage = None
    try:
        first.extend(itertools.islice(scans, _PEEK))
    except CorruptFileError as exc:  # logged, as any damage, after the scans before it
        damage = exc
    if with_map is None:
        with_map = any(s.pose is not None for s in first)
    timeline = SEQUENCE if _Stamps.collapsed(first) else None
    scans = itertools.chain(first, scans if damage is None else _raise(damage))
    with safe_output(out, RRD_FILE, overwrite=overwrite, inputs=inputs) as tmp:
        return _record_scans(scans, tmp, Path(out), name=name, truth=truth, labels=labels, features=features,
                             config=config, segment_threshold_m=segment_threshold_m, description=description,
                             world_map=(map_every, map_cell_m) if with_map else None, start_index=start_index,
                             timeline=timeline)


class StampsCollapsedWarning(UserWarning):
    """The scans of a recording written by :func:`record_scans` do not advance in time."""


class _Stamps:
    """Counts the scans whose stamp is no later than the one before (stamps that do not advance)."""

    SHARE = 0.01  # warn from this share of such scans on

    def __init__(self) -> None:
        self.n = self.stuck = 0
        self.last: int | None = None

    def add(self, stamp_ns: int) -> None:
        if self.last is not None and stamp_ns <= self.last:
            self.stuck += 1
        self.last = stamp_ns
        self.n += 1

    @property
    def bad(self) -> bool:
        return self.stuck >= 2 and self.stuck >= self.SHARE * self.n

    @classmethod
    def collapsed(cls, scans: Iterable[Scan]) -> bool:
        stamps = cls()
        for scan in scans:
            stamps.add(scan.stamp_ns)
        return stamps.bad


class _TruthFeed:
    """The ground truth of each batch of scans, by stamp: from a :class:`~labkit.sim.GroundTruth`
    by lookup, or read along from a stream of truths in time order (memory stays flat)."""

    def __init__(self, truth) -> None:
        from ..sim import GroundTruth

        self.lookup = truth if isinstance(truth, GroundTruth) else None
        self.items = None if self.lookup is not None else iter(truth)
        self.ahead: dict[int, object] = {}  # read, not yet matched
        self.last: int | None = None  # stamp of the last truth read

    def take(self, stamps: list[int]) -> list:
        """The truths of ``stamps`` (each once), in the order of ``stamps``."""
        if self.lookup is not None:
            return [self.lookup[s] for s in dict.fromkeys(stamps) if s in self.lookup]
        top = max(stamps)
        while self.items is not None and (self.last is None or self.last <= top):
            truth = next(self.items, None)
            if truth is None:
                self.items = None
                break
            self.ahead[truth.stamp_ns] = truth
            self.last = truth.stamp_ns
        matched = [self.ahead.pop(s) for s in dict.fromkeys(stamps) if s in self.ahead]
        for s in [s for s in self.ahead if s <= top]:  # no later scan has them (scans in time order)
            del self.ahead[s]
        return matched


def _raise(exc: Exception):
    raise exc
    yield  # a generator that raises when first iterated


def _writer_failed(tmp: Path, exc: RuntimeError) -> OSError:
    """rerun's file writer stopped ("File-writer thread shut down prematurely": it does not say
    why). Find out by writing beside the output: a full disk, a quota, an I/O error."""
    probe = tmp.with_name(f".{tmp.name}.probe")
    try:
        with open(probe, "wb") as fh:
            fh.write(b"\0" * (1 << 20))
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as err:
        return OSError(err.errno, err.strerror, str(tmp))
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()
    return OSError(errno.EIO, f"rerun could not write the recording ({exc})", str(tmp))


def _close(rec: rr.RecordingStream, tmp: Path) -> None:
    """Flush and close ``rec``'s file; a write that failed is an ``OSError`` (see :func:`_writer_failed`)."""
    try:
        rec.flush()
    except RuntimeError as exc:
        with contextlib.suppress(RuntimeError):
            rec.disconnect()
        raise _writer_failed(tmp, exc) from None
    rec.disconnect()


def _record_scans(scans, tmp: Path, out: Path, *, name, truth, labels, features, config, segment_threshold_m,
                  description, world_map=None, start_index: int = 0, timeline: str | None = None) -> RecordSummary:
    rec = new_recording(name)
    with_features = features is not None or config is not None
    rec.save(tmp, default_blueprint=blueprint(with_map=world_map is not None, with_times=with_features,
                                              timeline=timeline))
    log_static(rec, description)
    the_map = _Map(rec, *world_map, features=with_features) if world_map is not None else None
    feed = _TruthFeed(truth) if truth is not None else None
    stamps = _Stamps()
    counts: dict[str, int] = {}
    seconds: dict[str, float] = {}
    n_truth = 0

    def stamped():
        for s in scans:
            stamps.add(s.stamp_ns)
            yield s

    side = features if features is not None else labels if labels is not None else _forever(None)

    def frames():
        for scan, x in zip(stamped(), side, strict=False):
            f = x if features is not None else extract_features(scan, config) if config is not None else None
            if f is not None:
                for k, v in f.counts().items():
                    counts[k] = counts.get(k, 0) + v
                for k, v in f.timings.items():
                    seconds[k] = seconds.get(k, 0.0) + v
                yield scan, f.labels, f
            elif labels is not None:
                yield scan, x, None
            else:
                yield scan, _segment(scan, segment_threshold_m), None

    def send(batch, k: int) -> None:
        nonlocal n_truth
        first = start_index + k
        _send_batch(rec, batch, first, True, k == 0)
        if the_map is not None:
            the_map.send(batch, first)
        if feed is not None:
            index_of = {scan.stamp_ns: first + i for i, (scan, _, _) in enumerate(batch)}
            matched = feed.take([scan.stamp_ns for scan, _, _ in batch])
            if matched:
                _send_truth(rec, [(index_of[tr.stamp_ns], tr) for tr in matched])
                n_truth += len(matched)

    error: Exception | None = None
    try:
        n = _batched(frames(), send)
    except CorruptFileError as exc:
        error, n = exc, stamps.n
        rec.set_time(SEQUENCE, sequence=start_index + max(n - 1, 0))
        log_text(rec, f"damaged input: {exc}", level="ERROR")
    except BaseException:  # interrupted or failed: close the file properly (labkit._safe decides its fate)
        with contextlib.suppress(RuntimeError):
            rec.flush()
        with contextlib.suppress(RuntimeError):
            rec.disconnect()
        raise
    if n_truth:
        _hide_truth_labels(rec)
    if the_map is not None:
        the_map.finish(truth)
    rec.set_time(SEQUENCE, sequence=start_index)
    log_text(rec, f"{n} scans from {name}" + (f", ground truth for {n_truth}" if n_truth else ""))
    if stamps.bad:
        note = (f"{name}: {stamps.stuck} of {stamps.n} scans have a time stamp no later than the scan before: the "
                f"'{TIME}' timeline cannot order them; scrub the '{SEQUENCE}' timeline (the scan's number) instead")
        log_text(rec, note, level="WARN")
        warnings.warn(note, StampsCollapsedWarning, stacklevel=3)
    _close(rec, tmp)
    return RecordSummary(out, n, n_truth, error, counts, seconds)


#: What :func:`record_scans` writes (see labkit._safe): how an existing recording is recognised.
RRD_FILE = OutputKind("a rerun recording (.rrd)", (".rrd",), starts_with(b"RRF"))


def record(
    source,
    out: str | Path,
    *,
    topic: str | None = None,
    config: Config | None = None,
    features: bool = True,
    progress: bool = False,
    segment_threshold_m: float | None = 0.08,
    description: str | None = None,
    overwrite: bool = False,
    strict: bool = False,
    poses: str | bool | None = None,
    scans: slice | None = None,
) -> RecordSummary:
    """Write every scan of a recording (any format :func:`labkit.read_scans` reads) to an
    ``.rrd`` file with the default blueprint, with the features the pipeline finds in each
    (``config``, default :class:`labkit.Config` (); ``features=False``: scans and range
    segments only), plus the ground truth when a ``<name>.truth.jsonl`` lies beside it (read
    along with the scans). ``scans``: only this range of scans (a slice, as
    :func:`labkit.read_scans` takes it), numbered on the ``scan`` timeline as in the whole
    recording. See :func:`record_scans` for damaged inputs, for ``overwrite`` and for memory;
    ``strict`` stops reading at the first bad record. When the recording has poses (``poses``
    as in :func:`labkit.read_scans`), the map view is logged too (module docstring).
    """
    from ..io import read_scans
    from ..sim import TruthStream, truth_path_for

    check_output(out, RRD_FILE, overwrite=overwrite, inputs=[source])  # before any reading
    stream = read_scans(source, topic=topic, strict=strict, poses=poses, scans=scans)
    name = Path(source).name
    if features and config is None:
        config = Config()
    truth_file = truth_path_for(source)
    truth = TruthStream(truth_file) if truth_file.exists() else None
    if description is None:
        origin = f"Format: `{stream.format}`, topic: `{stream.topic}`, poses: {stream.poses or 'none'}."
        if scans is not None:
            origin += f" Scans {stream.first} to {'the end' if stream.stop is None else stream.stop - 1}."
        if not features:
            origin += f" Range segments: adaptive breakpoints, {segment_threshold_m} m floor."
        description = describe(name, source=origin, config=config if features else None, truth=truth is not None,
                               world_map=stream.poses is not None)
    items = iter(stream)
    if progress:
        from tqdm.auto import tqdm

        items = tqdm(items, total=stream.count, unit="scan", desc=f"view {name}")
    inputs = [source, truth_file] if truth is not None else [source]
    return record_scans(items, out, name=name, truth=truth, config=config if features else None,
                        segment_threshold_m=segment_threshold_m, description=description, overwrite=overwrite,
                        inputs=inputs, with_map=None if stream.poses is not None else False,
                        start_index=stream.first)


def show_inline(rec: rr.RecordingStream, *, width: int = 950, height: int = 600, compare=(),
                with_map: bool = False) -> None:
    """Show a recording in the notebook with the default blueprint (``with_map``: and the map
    view), or the side-by-side one for ``compare``; works offline."""
    rec.notebook_show(width=width, height=height, blueprint=blueprint(compare, with_map=with_map))


# ============================================================================ steps of one scan
def steps_blueprint() -> rrb.Blueprint:
    """The layout of :func:`log_steps`: the scan and the current step on the left; the step's
    value against its threshold over the steps, and the steps' log, on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="/", contents="world/**", name="Steps (sensor frame)"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="steps/compared", name="Value and threshold per step"),
                rrb.TextLogView(origin="steps/log", name="Steps"),
                row_shares=[1, 2],
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=False,
    )


def _step_geometry(scan: Scan, step: Step) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(beams' points, line strips (K, 2, 2), circle centres (C, 2), circle radii (C,)) of a step."""
    from .step_plots import step_beams

    run = scan.points[step_beams(scan, step)]
    strips = np.zeros((0, 2, 2))
    if step.has_line and len(run):
        strips = project_onto_line(run[[0, -1]], step.r, step.alpha)[None]
    centers, radii = np.zeros((0, 2)), np.zeros(0)
    if step.has_circle:
        centers, radii = np.array([step.center], dtype=np.float64), np.array([step.radius])
    return run, strips, centers, radii


def log_steps(rec: rr.RecordingStream, scan: Scan, steps: list[Step], *, world: str = "world") -> int:
    """Log the steps of an algorithm on one scan, step ``k`` at ``step = k`` on the ``step``
    timeline, so that scrubbing that timeline replays the algorithm; return how many.

    Entities: ``{world}/scan/points`` the scan (static), ``{world}/steps/beams`` the step's
    beams (orange), ``{world}/steps/line`` and ``{world}/steps/circle`` its line and circle
    (empty when it has none), ``{world}/steps/at`` its beam of interest (red, labelled with
    ``value``), ``{world}/steps/accepted`` and ``{world}/steps/accepted_circles`` what the
    earlier ``"accept"`` steps kept, ``steps/compared/{value,threshold}`` the numbers the
    step compared (scalars), and ``steps/log`` one text line per step (kind, beams, reason).
    Use :func:`steps_blueprint` for the layout (or :func:`record_steps` for an ``.rrd``).
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
    """Write :func:`log_steps` to an ``.rrd`` with :func:`steps_blueprint`; return how many steps.
    Open it with ``rerun out.rrd`` and scrub the ``step`` timeline. Written under a temporary
    name and renamed when complete (see :mod:`labkit._safe`)."""
    with safe_output(out, RRD_FILE, overwrite=overwrite) as tmp:
        rec = new_recording(name)
        rec.save(tmp, default_blueprint=steps_blueprint())
        n = log_steps(rec, scan, steps)
        _close(rec, tmp)
    return n
