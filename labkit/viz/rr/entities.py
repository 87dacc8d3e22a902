"""Scans, features and ground truth logged as rerun entities, in bulk (``send_columns``, a batch of scans
per call) on the ``ros_time`` and ``scan`` timelines (the layout is in :mod:`labkit.viz.rr`'s docstring)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa  # type: ignore[import-untyped]  # (comes with rerun)
import rerun as rr

from ...features import Features
from ...geometry import arc_points
from ...scan import Scan
from ...segmentation import segment_labels
from ..style import COLORS, label_colors
from .blueprint import _Y_UP, APP_ID, SEQUENCE, TIME

if TYPE_CHECKING:
    from ...sim import ScanTruth

__all__ = ["new_recording", "log_static", "log_text", "log_scans", "log_features", "log_truth"]

INVALID_RAY_M = 0.4  # length of the grey ray drawn for an invalid beam
# radii in UI points (negative in rerun): dots keep their size on screen at any zoom
POINT_RADIUS_UI = -1.5
SEGMENT_RADIUS_UI = -2.5
_BATCH = 128  # scans per send_columns call: memory in flight grows with it, the file's footer with 1 / _BATCH


def new_recording(name: str | None = None, *, recording_id: str | None = None) -> rr.RecordingStream:
    """A recording stream with no sink yet (data is buffered until one is set).

    Only the ``ros_time`` and ``scan`` timelines are kept (rerun's own ``log_time`` is
    switched off so that recordings of the same data are the same).

    Parameters
    ----------
    name : str or None
        The recording's name shown by the viewer; None: none (the application id is always
        ``"labkit"``).
    recording_id : str or None
        The rerun recording id; None: a new one.

    Returns
    -------
    rerun.RecordingStream
        The stream.
    """
    rec = rr.RecordingStream(APP_ID, recording_id=recording_id)
    rec.set_log_time_enabled(False)
    if name:
        rec.send_recording_name(name)
    return rec


class _Column:
    """A time or component column as ``send_columns`` reads it (``build_column_args`` asks each for its
    name and its arrow array, nothing else)."""

    def __init__(self, name, array: pa.Array) -> None:
        self.name, self.array = name, array

    def timeline_name(self) -> str:
        return self.name

    def component_descriptor(self):
        return self.name

    def as_arrow_array(self) -> pa.Array:
        return self.array


class _Pending:
    """The columns of one entity sent but not yet written, in order."""

    def __init__(self, signature: tuple) -> None:
        self.signature = signature
        self.times: dict[str, list[pa.Array]] = {}
        self.components: dict = {}
        self.rows = self.nbytes = 0


class _Chunked:
    """A recording stream whose ``send_columns`` gathers each entity's columns until they make a chunk
    worth writing (``CHUNK_BYTES`` or ``CHUNK_ROWS``), then sends them as one chunk.

    Why: an ``.rrd`` file's footer lists every chunk, and rerun (0.41) keeps that list in memory until
    the file is closed, some kilobytes per chunk. Sent a batch of scans at a time, a labkit recording
    makes a chunk per entity (some forty with the map) per batch: 20,000 simulated corridor scans with
    poses grew by 1.4 KiB per scan and peaked at 474 MiB. Gathered, the small
    entities (counts, stage times, features, the sensor's pose, truth) make a chunk per few thousand
    scans; the heavy ones (the scan's points, about
    1.5 MB a batch) still go out a batch at a time, so what waits stays small.

    Everything else is the stream's own (``log``, ``set_time``, ...); :meth:`flush` sends what waits
    first. Call it (or :meth:`send_pending`) before the file is closed.
    """

    CHUNK_BYTES = 1 << 18  # what waits: at most some forty entities of 256 KiB
    CHUNK_ROWS = 4096

    def __init__(self, rec: rr.RecordingStream) -> None:
        self._rec = rec
        self._pending: dict[str, _Pending] = {}

    def __getattr__(self, name: str):
        return getattr(self._rec, name)

    def send_columns(self, entity_path: str, indexes, columns) -> None:
        times = {t.timeline_name(): t.as_arrow_array() for t in indexes}
        components = {c.component_descriptor(): c.as_arrow_array() for c in columns}
        if not times:  # static: as it comes
            self._rec.send_columns(entity_path, indexes=indexes, columns=columns)
            return
        signature = (tuple((k, v.type) for k, v in times.items()), tuple((k, v.type) for k, v in components.items()))
        pending = self._pending.get(entity_path)
        if pending is not None and pending.signature != signature:  # other columns: what waits goes first
            self._send(entity_path)
            pending = None
        if pending is None:
            pending = self._pending[entity_path] = _Pending(signature)
        for key, array in times.items():
            pending.times.setdefault(key, []).append(array)
        for key, array in components.items():
            pending.components.setdefault(key, []).append(array)
        pending.rows += len(next(iter(times.values())))
        pending.nbytes += sum(a.nbytes for a in components.values())
        if pending.rows >= self.CHUNK_ROWS or pending.nbytes >= self.CHUNK_BYTES:
            self._send(entity_path)

    def _send(self, entity_path: str) -> None:
        pending = self._pending.pop(entity_path)
        self._rec.send_columns(
            entity_path,
            indexes=[_Column(k, pa.concat_arrays(v)) for k, v in pending.times.items()],
            columns=[_Column(k, pa.concat_arrays(v)) for k, v in pending.components.items()],  # type: ignore[misc]
        )

    def send_pending(self) -> None:
        """Send every entity's waiting columns."""
        for entity_path in list(self._pending):
            self._send(entity_path)

    def flush(self, *args, **kwargs):
        self.send_pending()
        return self._rec.flush(*args, **kwargs)


def log_static(rec: rr.RecordingStream, description: str | None = None) -> None:
    """Log what does not change: the y-up view transform, the sensor, the notes.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    description : str or None
        The Markdown notes (e.g. from :func:`describe`); None: none.
    """
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
    """Append a line to the ``log`` entity at the current time.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    text : str
        The line.
    level : str
        Its level: ``"INFO"``, ``"WARN"``, ``"ERROR"``, ...
    """
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
    """Log scans in bulk (``send_columns``) on both timelines.

    Each scan is logged at ``scan = start_index + k`` and ``ros_time = scan.stamp_ns``. The
    points are also logged coloured by range segment (``world/segments``, with the segment count
    in ``metrics/count/segments``): from ``features``, from ``labels`` or else segmented here as
    the pipeline does. If iterating ``scans`` (or ``features``) raises (a damaged file), every
    scan before the fault is sent, then the error propagates.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    scans : iterable of Scan
        The scans, in order.
    start_index : int
        The ``scan`` timeline's number of the first.
    segment_threshold_m : float or None
        The floor of the adaptive breakpoints of the segments computed here, metres; None: no
        segment layer.
    labels : iterable of ndarray or None
        One per-beam label array per scan, the segments to show.
    features : iterable of Features or None
        One per scan (e.g. from :func:`labkit.extract_all`): every feature layer, the per-scan
        counts and stage times are logged too (see :func:`log_features`), and the segments are
        the features' own.
    show_invalid : bool
        Also log the invalid beams, as rays (``world/scan/invalid``).

    Returns
    -------
    int
        How many scans were logged.
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
                show_invalid: bool) -> int:
    """Send ``(scan, labels, features)`` frames in batches (see :func:`_batched`)."""
    return _batched(frames, lambda batch, k: _send_batch(rec, batch, start_index + k, show_invalid, k == 0))


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
        _send_features(rec, times, [f for _, _, f in items if f is not None], "world", "metrics", segment_count=False,
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
    """Log features alone (the scans logged already, e.g. by :func:`log_scans`).

    Each is logged at ``scan = start_index + k`` and ``ros_time = features.stamp_ns``.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    features : iterable of Features
        One per scan, in order.
    start_index : int
        The ``scan`` timeline's number of the first.
    name : str or None
        Puts them under ``world/<name>/...`` and ``metrics/<name>/...``, so that two
        configurations can be compared side by side (``blueprint(compare=[...])``).

    Returns
    -------
    int
        How many were logged.
    """
    world, metrics = ("world", "metrics") if not name else (f"world/{name}", f"metrics/{name}")

    def send(batch: list[Features], k: int) -> None:
        k0 = start_index + k
        times = _time_columns(np.arange(k0, k0 + len(batch)), np.array([f.stamp_ns for f in batch], np.int64))
        _send_features(rec, times, batch, world, metrics, segment_count=True, hide_labels=k == 0)

    return _batched(features, send)


def log_truth(rec: rr.RecordingStream, truths: Iterable, index_of: dict[int, int]) -> int:
    """Log simulator ground truth under ``world/truth``, in grey, so that the features in colour stand out.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    truths : iterable of labkit.sim.ScanTruth
        The truth of each scan.
    index_of : dict of int to int
        ``stamp_ns`` -> the scan's sequence number; truths of stamps not in it are skipped.

    Returns
    -------
    int
        How many were logged.
    """
    known = ((index_of[tr.stamp_ns], tr) for tr in truths if tr.stamp_ns in index_of)
    n = _batched(known, lambda batch, _first: _send_truth(rec, batch))
    _hide_truth_labels(rec)
    return n


def _hide_truth_labels(rec: rr.RecordingStream) -> None:
    for layer in ("walls", "arcs"):
        rec.log(f"world/truth/{layer}", rr.LineStrips2D.from_fields(show_labels=False), static=True)


def _send_truth(rec: rr.RecordingStream, batch: list[tuple[int, ScanTruth]]) -> None:
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
