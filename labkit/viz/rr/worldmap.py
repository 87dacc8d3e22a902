"""The world frame of a recording whose scans carry poses: the sensor's path and pose, the scan placed in
the world, and the accumulated map (see :mod:`labkit.viz.rr`, "Map")."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import rerun as rr

from ...features import Features
from ...geometry import transform_points
from ...poses import GridThinning
from ...scan import Scan
from .blueprint import _Y_UP
from .entities import POINT_RADIUS_UI, _batched, _colors, _colors_rgb, _forever, _send_features, _time_columns

__all__ = ["MAP_EVERY", "MAP_CELL_M", "log_map"]

#: Map decimation: every MAP_EVERY-th scan with a pose adds to the accumulated map, one point per
#: MAP_CELL_M grid cell; the path keeps a point every PATH_STEP_M.
MAP_EVERY = 10
MAP_CELL_M = 0.05
PATH_STEP_M = 0.02
_MAP_COLORS = {"path": (40, 100, 210), "accumulated": (120, 120, 120), "lines": (235, 150, 140),
               "pose": (220, 40, 40)}


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
            placed = transform_points(scan.xy, scan.pose)
            pts.append(placed[self.thin.new(placed)])
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


def log_map(rec: rr.RecordingStream, scans: Iterable[Scan], features: Iterable[Features] | None = None, *,
            start_index: int = 0, truth=None, map_every: int = MAP_EVERY, map_cell_m: float = MAP_CELL_M) -> int:
    """Log the world frame of scans with poses (module docstring, "Map").

    The sensor's transform per scan, the scan and its features under it, the accumulated map, the
    path, and the world's walls from ``truth``. Use it beside :func:`log_scans` and show it with
    ``show_inline(rec, with_map=True)``.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    scans : iterable of Scan
        The scans, with poses.
    features : iterable of Features or None
        One per scan, optional.
    start_index : int
        The ``scan`` timeline's number of the first.
    truth : labkit.sim.GroundTruth or None
        The world's walls to draw.
    map_every : int
        Every so many scans with a pose add to the accumulated map.
    map_cell_m : float
        The accumulated map keeps one point per grid cell of this size, metres.

    Returns
    -------
    int
        How many scans were logged.
    """
    the_map = _Map(rec, map_every, map_cell_m)
    side = features if features is not None else _forever(None)
    n = _batched(((scan, None, f) for scan, f in zip(scans, side, strict=False)),
                 lambda batch, k: the_map.send(batch, start_index + k))
    the_map.finish(truth)
    return n
