"""A whole recording to an ``.rrd`` file as the scans come: the default blueprint, the scans, their
features, the map and the ground truth, written under a temporary name; damage, Ctrl-C and a full disk
handled as ``labkit._safe`` says."""

from __future__ import annotations

import contextlib
import errno
import itertools
import os
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np
import rerun as rr

from ..._safe import OutputKind, safe_output, starts_with
from ...errors import CorruptFileError
from ...features import Features
from ...pipeline import Config, extract_features
from ...scan import Scan
from .blueprint import SEQUENCE, TIME, blueprint
from .entities import (
    _batched,
    _Chunked,
    _forever,
    _hide_truth_labels,
    _segment,
    _send_batch,
    _send_truth,
    log_static,
    log_text,
    new_recording,
)
from .tracks import TrackLogger
from .worldmap import MAP_CELL_M, MAP_EVERY, _Map

__all__ = ["RRD_FILE", "RecordSummary", "StampsCollapsedWarning", "describe", "record_scans"]

_PEEK = 256  # scans looked at before writing: do they carry poses, do their stamps advance?


@dataclass(frozen=True)
class RecordSummary:
    """What :func:`record_scans` wrote.

    Parameters
    ----------
    path : Path
        The ``.rrd`` file.
    n_scans : int
        Scans logged.
    n_truth : int
        Scans logged with their ground truth.
    error : Exception or None
        The error that stopped reading (a damaged file), or None.
    counts : dict
        Over all scans, the number of each kind of feature (empty without features).
    stage_seconds : dict
        Over all scans, the seconds spent per pipeline stage (empty without features).
    moving_tracks : tuple
        With tracks: the ids of every track confirmed as moving, in order.
    """

    path: Path
    n_scans: int
    n_truth: int
    error: Exception | None
    counts: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)
    #: With tracks: the ids of every track confirmed as moving, in order.
    moving_tracks: tuple = ()

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
_TRACK_NOTES = {
    "world/tracks/points": "tracks (labkit.tracking): a colour per id, labelled; static ones grey",
    "world/tracks/trails": "each moving track's path over the last seconds",
    "world/tracks/velocity": "each moving track's velocity (the distance covered in half a second)",
    "tracks/events": "track births, confirmations and deletions",
    "metrics/count/tracks": "moving tracks per scan",
}
_MAP_NOTES = {
    "map/path": "the sensor's path (world frame)",
    "map/sensor": "the sensor's pose at the current scan (a transform); the scan and its features under it",
    "map/accumulated/*": f"what the scans saw so far, in the world frame: every {MAP_EVERY}th scan's points, one "
                         f"per {MAP_CELL_M * 100:g} cm cell, and its features (hover: which scan)",
}


def describe(title: str, *, source: str = "", config: Config | None = None, truth: bool = False,
             compare: dict[str, Config] | None = None, world_map: bool = False, tracks: bool = False) -> str:
    """The Markdown note logged with a recording: what each entity shows, and the config.

    Parameters
    ----------
    title : str
        The note's title.
    source : str
        A paragraph on where the scans come from.
    config : Config or None
        The configuration of the features shown; None: no features.
    truth : bool
        Describe the ground-truth entities.
    compare : dict of str to Config, or None
        ``{name: config}`` of features logged with ``log_features(..., name=name)``: the named
        layers and every config.
    world_map : bool
        Describe the map view's entities.
    tracks : bool
        Describe the tracks' entities.

    Returns
    -------
    str
        The note, Markdown.
    """
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
    if tracks:
        lines += [f"| `{entity}` | {note} |" for entity, note in _TRACK_NOTES.items()]
        if world_map:
            lines.append("| `map/tracks/*` | the tracks in the world frame |")
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
    tracks: bool = False,
) -> RecordSummary:
    """Write scans to an ``.rrd`` file with the default blueprint, as they come.

    The file is written while the scans are read (``RecordingStream.save`` before anything is
    logged, then ``send_columns`` in batches, each entity's columns gathered into chunks of up to
    4096 scans or 256 KiB: rerun keeps the file's footer, a list of every chunk, in memory until the
    file is closed), so memory grows little however long the recording (about 0.3 KiB a scan with
    the map, whose cause is not found; ``benchmarks/io.py``).
    If iterating ``scans`` raises :class:`labkit.CorruptFileError` (a damaged file), the ``.rrd``
    holds every scan that could be read, the error is logged to ``log`` and returned in the
    summary (not raised).

    When the scans' time stamps do not advance (at least 1 % of them no later than the scan
    before, as in the Radish ``infinite-corridor`` log), a :class:`StampsCollapsedWarning` says so:
    scrub the ``scan`` timeline, which the viewer then opens on.

    The file is written under a temporary name and renamed when complete. Interrupted (Ctrl-C),
    the recording so far is closed and kept as ``<name>.partial.rrd``. A write that fails (a full
    disk) raises ``OSError`` naming ``out``, and no file is left.

    Parameters
    ----------
    scans : iterable of Scan
        The scans, in order.
    out : str or Path
        The ``.rrd`` file.
    name : str
        The recording's name (the viewer's application id).
    truth : labkit.sim.GroundTruth or labkit.sim.TruthStream or None
        Ground truth to log beside the scans (a stream is read along with them; both in time order).
    labels : iterable of ndarray or None
        Without features: the range segments of each scan.
    features : iterable of Features or None
        One per scan, logged with it.
    config : Config or None
        Without ``features``: compute them here with this configuration; neither: only the scans
        and their range segments.
    segment_threshold_m : float or None
        Without features or labels: the floor of the adaptive range segmentation, metres.
    description : str or None
        The Markdown notes; None: :func:`describe` of what is logged.
    overwrite : bool
        Replace an existing ``.rrd`` (never any other kind of file).
    inputs : iterable of str or Path
        The files read, which the output may not be.
    with_map : bool or None
        Log the map view (the path, the sensor's pose per scan, the scan and its features in the
        world frame, and the accumulated map); None: when one of the first 256 scans has a pose.
    map_every : int
        Every so many scans with a pose add to the accumulated map (see the module docstring).
    map_cell_m : float
        The accumulated map keeps one point per grid cell of this size, metres.
    start_index : int
        The ``scan`` timeline's number of the first scan (a range of a recording).
    tracks : bool
        Also follow people and moving circles (:class:`labkit.tracking.Tracker` with
        ``config.tracking``) and log the tracks in the scan view and the map view (see
        :mod:`labkit.viz.rr.tracks`); needs features (``features`` or ``config``).

    Returns
    -------
    RecordSummary
        What was written.
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
    if tracks and features is None and config is None:
        raise ValueError("tracks need features: pass features or config")
    timeline = SEQUENCE if _Stamps.collapsed(first) else None
    scans = itertools.chain(first, scans if damage is None else _raise(damage))
    with safe_output(out, RRD_FILE, overwrite=overwrite, inputs=inputs) as tmp:
        return _record_scans(scans, tmp, Path(out), name=name, truth=truth, labels=labels, features=features,
                             config=config, segment_threshold_m=segment_threshold_m, description=description,
                             world_map=(map_every, map_cell_m) if with_map else None, start_index=start_index,
                             timeline=timeline, tracks=tracks)


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
        from ...sim import GroundTruth

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
                  description, world_map: tuple[int, float] | None = None, start_index: int = 0,
                  timeline: str | None = None, tracks: bool = False) -> RecordSummary:
    from ...tracking import Tracker

    # each entity's columns gathered into chunks of a few thousand scans: the file's footer, which rerun
    # keeps in memory until the file is closed, lists every chunk (see _Chunked)
    rec = cast(rr.RecordingStream, _Chunked(new_recording(name)))
    with_features = features is not None or config is not None
    rec.save(tmp, default_blueprint=blueprint(with_map=world_map is not None, with_times=with_features,
                                              timeline=timeline, with_tracks=tracks))
    log_static(rec, description)
    the_map = None
    if world_map is not None:
        every, cell_m = world_map
        the_map = _Map(rec, every, cell_m, features=with_features)
    feed = _TruthFeed(truth) if truth is not None else None
    tracker = Tracker(**(config or Config()).tracking.kwargs()) if tracks else None
    track_log = TrackLogger(rec, ("world", "map") if world_map is not None else ("world",)) if tracks else None
    tables: list = []  # the tracks of the scans of the batch being gathered (sent with it)
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
                if tracker is not None:
                    tables.append(tracker.step(f, pose=scan.pose))
                    seconds["tracking"] = seconds.get("tracking", 0.0) + tables[-1].seconds
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
        if track_log is not None:
            track_log.send(list(enumerate(tables[:len(batch)], start=first)))
            del tables[:len(batch)]
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
    moving = tuple(sorted(track_log.confirmed)) if track_log is not None else ()
    return RecordSummary(out, n, n_truth, error, counts, seconds, moving)

#: What :func:`record_scans` writes (see labkit._safe): how an existing recording is recognised.
RRD_FILE = OutputKind("a rerun recording (.rrd)", (".rrd",), starts_with(b"RRF"))
