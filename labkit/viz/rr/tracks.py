"""Tracks (:mod:`labkit.tracking`) logged as rerun entities beside the scans, in bulk (``send_columns``,
a batch of scans per call) on the ``ros_time`` and ``scan`` timelines.

Entities (``<view>`` is ``world``, the sensor frame, and, when the scans carry poses, ``map``)
    ``<view>/tracks/points`` each confirmed track's position, in a colour of its own that stays the
    same for its whole life (:func:`labkit.viz.style.track_color`), labelled with its id (``id 3``); tracks
    confirmed *static* (a column, a bin) are grey and labelled ``id 4 static``; tentative tracks
    are not drawn. ``<view>/tracks/trails`` each moving track's path over the last
    ``trail_s`` seconds (default :data:`TRAIL_S`), ``<view>/tracks/velocity`` its velocity as an
    arrow (the distance covered in :data:`ARROW_S` seconds).
Timeline
    ``tracks/events`` a text log of the life cycle: ``birth`` (DEBUG: a tentative track),
    ``confirm`` and ``static`` (INFO), ``delete`` (INFO); ``metrics/count/tracks`` the number of
    moving tracks per scan and ``metrics/time_ms/tracking`` the tracker's milliseconds per scan.

Frames. The tracker works in the map frame when the scans carry poses (``[tracking] frame``):
its states are then moved into the sensor frame of each scan for the scan view (a scan without
a pose shows no tracks there); tracking in the sensor frame, the map view places the tracks by
the scan's pose. A trail is drawn in the current scan's frame, so in the scan view it shows the
path relative to where the sensor is now.

Memory. Only the trails of live tracks are kept, and only their last ``trail_s`` seconds: a
deleted track's trail is dropped at its deletion, so what is held does not grow with the length
of the recording.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

import numpy as np
import rerun as rr

from ...geometry import inverse_transform_points, rotation_matrix, transform_points
from ...tracking import TrackTable
from ..style import track_color
from .entities import _batched, _scalars, _time_columns

__all__ = ["TRAIL_S", "ARROW_S", "track_color", "TrackLogger", "log_tracks"]

#: Seconds of path drawn behind each moving track.
TRAIL_S = 3.0
#: A velocity arrow is the distance the track covers in this many seconds.
ARROW_S = 0.5
_STATIC_RGB = (150, 150, 150)
_LEVEL = {"birth": "DEBUG", "confirm": "INFO", "static": "INFO", "delete": "INFO"}
_SAY = {"birth": "born (tentative)", "confirm": "confirmed, moving", "static": "confirmed static",
        "delete": "deleted"}


class TrackLogger:
    """Logs one :class:`labkit.tracking.TrackTable` per scan (see the module docstring).

    Call :meth:`send` with a batch of ``(scan index, table)`` pairs (scans in time order).

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log into.
    views : tuple of str, default ("world",)
        The entity roots to draw in, ``"world"`` (the sensor frame) and/or ``"map"``.
    trail_s : float, default TRAIL_S
        Seconds of path drawn behind each moving track, >= 0.

    Raises
    ------
    ValueError
        When ``trail_s`` is negative.
    """

    def __init__(self, rec: rr.RecordingStream, views: tuple[str, ...] = ("world",), trail_s: float = TRAIL_S) -> None:
        if trail_s < 0:
            raise ValueError(f"trail_s must be >= 0, got {trail_s}")
        self.rec, self.views, self.trail_ns = rec, tuple(views), int(trail_s * 1e9)
        self.trails: dict[int, deque] = {}  # id -> (stamp_ns, x, y) in the tracking frame, the last trail_s
        self.confirmed: set[int] = set()  # every id ever confirmed as moving
        for view in self.views:
            rec.log(f"{view}/tracks/points", rr.Points2D.from_fields(show_labels=True, draw_order=60.0), static=True)
            rec.log(f"{view}/tracks/trails", rr.LineStrips2D.from_fields(show_labels=False, draw_order=55.0),
                    static=True)
            rec.log(f"{view}/tracks/velocity", rr.Arrows2D.from_fields(show_labels=False, draw_order=58.0),
                    static=True)

    def send(self, batch: list[tuple[int, TrackTable]]) -> None:
        """Log a batch of scans' tables: one ``send_columns`` call per entity."""
        if not batch:
            return
        times = _time_columns(np.array([k for k, _ in batch]), np.array([t.stamp_ns for _, t in batch], np.int64))
        keys = ("pts", "col", "lab", "n", "strips", "scol", "ns", "org", "vec", "vcol", "nv")
        drawn: dict[str, dict[str, list]] = {view: {key: [] for key in keys} for view in self.views}
        events_text, events_level, n_events = [], [], []
        for _, table in batch:
            self._remember(table)
            n_events.append(len(table.events))
            for what, tid in table.events:
                kind = table.kinds[table.ids == tid]
                events_text.append(f"track {tid}" + (f" ({kind[0]})" if kind.size else "") + f": {_SAY[what]}")
                events_level.append(_LEVEL[what])
            for view in self.views:
                self._draw(drawn[view], table, view)
        for view, d in drawn.items():
            self._send_view(view, times, d)
        rec = self.rec
        rec.send_columns("tracks/events", indexes=times, columns=rr.TextLog.columns(
            text=events_text, level=events_level).partition(n_events))
        _scalars(rec, "metrics/count/tracks", times, [int(np.count_nonzero(t.status == "confirmed")) for _, t in batch])
        _scalars(rec, "metrics/time_ms/tracking", times, [1e3 * t.seconds for _, t in batch])

    def _remember(self, table: TrackTable) -> None:
        """Add this scan's positions to the trails, forget the deleted tracks and what is too old."""
        for tid, status, state in zip(table.ids.tolist(), table.status, table.states, strict=True):
            if status == "deleted":
                self.trails.pop(tid, None)
                continue
            if status == "confirmed":
                self.confirmed.add(tid)
            trail = self.trails.setdefault(tid, deque())
            if not table.late:
                trail.append((table.stamp_ns, float(state[0]), float(state[1])))
            while trail and trail[0][0] < table.stamp_ns - self.trail_ns:
                trail.popleft()

    def _placement(self, table: TrackTable, view: str):
        """How to move the tracking frame's points into ``view``'s: a function of (N, 2) points and a
        rotation of vectors, or None when this scan cannot be placed there."""
        if (view == "world") == (table.frame == "sensor"):
            return (lambda p: p), np.eye(2)
        if table.pose is None:
            return None
        if view == "world":  # map -> sensor
            return (lambda p: inverse_transform_points(p, table.pose).reshape(-1, 2)), rotation_matrix(-table.pose[2])
        return (lambda p: transform_points(p, table.pose).reshape(-1, 2)), rotation_matrix(table.pose[2])

    def _draw(self, d: dict, table: TrackTable, view: str) -> None:
        shown = np.isin(table.status, ("confirmed", "static"))
        placement = self._placement(table, view) if shown.any() else None
        if placement is None:
            for key in ("n", "ns", "nv"):
                d[key].append(0)
            return
        move, rot = placement
        ids = table.ids[shown].tolist()
        moving = (table.status[shown] == "confirmed")
        pts = move(table.states[shown, :2])
        d["pts"].append(pts)
        d["col"] += [track_color(i) if m else _STATIC_RGB for i, m in zip(ids, moving, strict=True)]
        d["lab"] += [f"id {i}" if m else f"id {i} static" for i, m in zip(ids, moving, strict=True)]
        d["n"].append(len(ids))
        n_strips = 0
        for i, m in zip(ids, moving, strict=True):
            trail = self.trails.get(i)
            if m and trail and len(trail) >= 2:
                d["strips"].append(move(np.array([(x, y) for _, x, y in trail])))
                d["scol"].append(track_color(i))
                n_strips += 1
        d["ns"].append(n_strips)
        d["org"].append(pts[moving])
        d["vec"].append(ARROW_S * table.states[shown][moving, 2:] @ rot.T)
        d["vcol"] += [track_color(i) for i, m in zip(ids, moving, strict=True) if m]
        d["nv"].append(int(moving.sum()))

    def _send_view(self, view: str, times, d: dict) -> None:
        rec = self.rec
        pts = np.concatenate(d["pts"]) if d["pts"] else np.zeros((0, 2))
        rec.send_columns(f"{view}/tracks/points", indexes=times, columns=rr.Points2D.columns(
            positions=pts, colors=np.array(d["col"], dtype=np.uint8).reshape(-1, 3), labels=d["lab"],
            radii=np.full(len(pts), -5.0, dtype=np.float32)).partition(d["n"]))
        rec.send_columns(f"{view}/tracks/trails", indexes=times, columns=rr.LineStrips2D.columns(
            strips=d["strips"], colors=np.array(d["scol"], dtype=np.uint8).reshape(-1, 3),
            radii=np.full(len(d["strips"]), -2.0, dtype=np.float32)).partition(d["ns"]))
        org = np.concatenate(d["org"]) if d["org"] else np.zeros((0, 2))
        vec = np.concatenate(d["vec"]) if d["vec"] else np.zeros((0, 2))
        rec.send_columns(f"{view}/tracks/velocity", indexes=times, columns=rr.Arrows2D.columns(
            origins=org, vectors=vec, colors=np.array(d["vcol"], dtype=np.uint8).reshape(-1, 3),
            radii=np.full(len(org), -1.5, dtype=np.float32)).partition(d["nv"]))


def log_tracks(rec: rr.RecordingStream, tables: Iterable[TrackTable], *, start_index: int = 0,
               views: tuple[str, ...] = ("world",), trail_s: float = TRAIL_S) -> int:
    """Log the tracker's tables, one per scan, as rerun entities (see the module docstring).

    Show them with ``show_inline(rec, with_tracks=True)``.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording to log into.
    tables : iterable of TrackTable
        One :class:`labkit.tracking.TrackTable` per scan in time order, e.g. from
        :func:`labkit.track_scans`; the ``k``-th is logged at ``scan = start_index + k``.
    start_index : int, default 0
        The ``scan`` index of the first table.
    views : tuple of str, default ("world",)
        The entity roots to draw in: ``"world"`` (the sensor frame) and/or ``"map"`` (beside
        :func:`labkit.viz.rr.log_map`).
    trail_s : float, default TRAIL_S
        Seconds of path drawn behind each moving track, >= 0.

    Returns
    -------
    int
        How many tables were logged.
    """
    logger = TrackLogger(rec, views, trail_s)
    return _batched(tables, lambda batch, k: logger.send(list(enumerate(batch, start=start_index + k))))
