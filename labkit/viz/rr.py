"""rerun recordings of scans and features: the only labkit module that knows rerun.

Layout of a labkit recording
----------------------------
Timelines
    ``ros_time`` (the scan's time stamp) and ``scan`` (its sequence number).
Entities
    ``world/scan/points`` valid beams, ``world/scan/invalid`` short grey rays where a beam
    returned nothing usable, ``world/sensor`` the sensor, ``world/segments`` the points
    coloured by range segment, ``world/truth/{walls,circles,arcs,legs}`` simulator ground
    truth, ``metrics/*`` per-scan counts as time series, ``log`` a text log, and
    ``description`` a Markdown note. ``world`` is the sensor frame, drawn with x to the
    right and y up, as in labkit's matplotlib figures (rerun's 2D views point y down, so
    ``world`` carries a static mirror transform).

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

from collections.abc import Iterable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import rerun as rr  # noqa: E402
import rerun.blueprint as rrb  # noqa: E402

from ..geometry import arc_points  # noqa: E402
from ..scan import Scan  # noqa: E402
from ..segmentation import segment_labels  # noqa: E402
from .style import COLORS, label_colors  # noqa: E402

__all__ = [
    "APP_ID",
    "TIME",
    "SEQUENCE",
    "blueprint",
    "new_recording",
    "log_static",
    "log_scans",
    "log_truth",
    "log_text",
    "record",
    "record_scans",
    "RecordSummary",
    "show_inline",
]

APP_ID = "labkit"
TIME = "ros_time"
SEQUENCE = "scan"
INVALID_RAY_M = 0.4  # length of the grey ray drawn for an invalid beam
# radii in UI points (negative in rerun): dots keep their size on screen at any zoom
POINT_RADIUS_UI = -1.5
SEGMENT_RADIUS_UI = -2.5
_BATCH = 256  # scans per send_columns call

# rerun's 2D views have y pointing down; mirror so that y points up as in matplotlib.
_Y_UP = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]


def blueprint() -> rrb.Blueprint:
    """The default layout: the scan view on the left; metrics, log and notes on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="/", contents="world/**", name="Scan (sensor frame)"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="metrics", name="Per-scan metrics"),
                rrb.TextLogView(origin="log", name="Log"),
                rrb.TextDocumentView(origin="description", name="About"),
                row_shares=[3, 1, 2],
            ),
            column_shares=[3, 2],
        ),
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


def log_text(rec: rr.RecordingStream, text: str, level: str = "INFO") -> None:
    """Append a line to the ``log`` entity at the current time."""
    rec.log("log", rr.TextLog(text, level=level))


def _time_columns(indices: np.ndarray, stamps: np.ndarray) -> list:
    return [
        rr.TimeColumn(SEQUENCE, sequence=indices),
        rr.TimeColumn(TIME, timestamp=stamps.astype("datetime64[ns]")),
    ]


def _invalid_rays(scan: Scan) -> list[np.ndarray]:
    a = scan.angles[~scan.valid]
    ends = INVALID_RAY_M * np.stack([np.cos(a), np.sin(a)], axis=1)
    return [np.array([[0.0, 0.0], e]) for e in ends]


def log_scans(
    rec: rr.RecordingStream,
    scans: Iterable[Scan],
    *,
    start_index: int = 0,
    segment_threshold_m: float | None = 0.08,
    labels: Iterable[np.ndarray] | None = None,
    show_invalid: bool = True,
) -> int:
    """Log scans in bulk (``send_columns``) on both timelines; return how many.

    Each scan is logged at ``scan = start_index + k`` and ``ros_time = scan.stamp_ns``.
    The points are also logged coloured by range segment (``world/segments``, with the
    segment count in ``metrics/segments``): from ``labels`` (one per-beam label array per
    scan, e.g. already computed by the caller) or else segmented here with
    ``segment_threshold_m`` (``None``: no segment layer). If iterating ``scans`` raises (a
    damaged file), every scan before the fault is sent, then the error propagates.
    """
    count = 0
    batch: list[tuple[Scan, np.ndarray | None]] = []

    def flush() -> None:
        nonlocal batch
        if batch:
            _send_batch(rec, batch, start_index + count - len(batch), show_invalid)
            batch = []

    def with_labels():
        if labels is not None:
            yield from zip(scans, labels, strict=False)
        elif segment_threshold_m is not None:
            for scan in scans:
                yield scan, segment_labels(scan, segment_threshold_m)
        else:
            for scan in scans:
                yield scan, None

    try:
        for item in with_labels():
            batch.append(item)
            count += 1
            if len(batch) >= _BATCH:
                flush()
    finally:
        flush()
    return count


def _send_batch(rec, items: list[tuple[Scan, np.ndarray | None]], first_index: int, show_invalid) -> None:
    batch = [scan for scan, _ in items]
    idx = np.arange(first_index, first_index + len(batch))
    stamps = np.array([s.stamp_ns for s in batch], dtype=np.int64)
    times = _time_columns(idx, stamps)
    lengths = [len(s.xy) for s in batch]
    pts = np.concatenate([s.xy for s in batch]) if sum(lengths) else np.zeros((0, 2))
    rec.send_columns(
        "world/scan/points",
        indexes=times,
        columns=rr.Points2D.columns(positions=pts, colors=np.tile(COLORS["points"], (len(pts), 1)),
                                    radii=np.full(len(pts), POINT_RADIUS_UI, dtype=np.float32)).partition(lengths),
    )
    n_valid = np.array(lengths, dtype=np.float64)
    rec.send_columns("metrics/valid_beams", indexes=times, columns=rr.Scalars.columns(scalars=n_valid))
    if show_invalid:
        rays = [_invalid_rays(s) for s in batch]
        rec.send_columns(
            "world/scan/invalid",
            indexes=times,
            columns=rr.LineStrips2D.columns(
                strips=[r for rs in rays for r in rs],
                colors=np.tile(COLORS["invalid"], (sum(map(len, rays)), 1)),
            ).partition([len(r) for r in rays]),
        )
    if items[0][1] is not None:
        colors, n_segments = [], []
        for s, beam_labels in items:
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
        rec.send_columns("metrics/segments", indexes=times,
                         columns=rr.Scalars.columns(scalars=np.array(n_segments)))


def log_truth(rec: rr.RecordingStream, truths: Iterable, index_of: dict[int, int]) -> int:
    """Log simulator ground truth (:class:`labkit.sim.ScanTruth`) under ``world/truth``.

    ``index_of`` maps ``stamp_ns`` to the scan's sequence number; truths of stamps not in
    it are skipped. Returns how many were logged.
    """
    n = 0
    for tr in truths:
        k = index_of.get(tr.stamp_ns)
        if k is None:
            continue
        rec.set_time(SEQUENCE, sequence=k)
        rec.set_time(TIME, timestamp=np.datetime64(int(tr.stamp_ns), "ns"))
        rec.log("world/truth/walls", rr.LineStrips2D(
            [np.array([w.start, w.end]) for w in tr.walls], colors=[COLORS["truth"]] * len(tr.walls),
            labels=[w.name for w in tr.walls], show_labels=False, radii=[-1.0] * len(tr.walls)))
        rec.log("world/truth/arcs", rr.LineStrips2D(
            [arc_points(a.center, a.radius, a.start, a.end) for a in tr.arcs],
            colors=[COLORS["circles"]] * len(tr.arcs), labels=[a.name for a in tr.arcs], show_labels=False))
        for key, items, colour in [("circles", tr.circles, "circles"), ("legs", tr.legs, "legs")]:
            centers = [c.center for c in items]
            half = [(getattr(c, "radius", None) or c.diameter / 2,) * 2 for c in items]
            rec.log(f"world/truth/{key}", rr.Ellipses2D(centers=centers, half_sizes=half,
                                                         colors=[COLORS[colour]] * len(items)))
        n += 1
    return n


@dataclass(frozen=True)
class RecordSummary:
    """What :func:`record` wrote."""

    path: Path
    n_scans: int
    n_truth: int
    error: Exception | None


def record_scans(
    scans: Iterable[Scan],
    out: str | Path,
    *,
    name: str,
    truth=None,
    labels: Iterable[np.ndarray] | None = None,
    segment_threshold_m: float | None = 0.08,
    description: str | None = None,
) -> RecordSummary:
    """Write scans to an ``.rrd`` file with the default blueprint.

    ``truth`` is a :class:`labkit.sim.GroundTruth` to log beside the scans; ``labels``
    per-scan segment labels already computed (else segmented with ``segment_threshold_m``).
    If iterating ``scans`` raises ``ValueError``/``OSError`` (a damaged file), the ``.rrd``
    still holds every scan before the fault, the error is logged to ``log`` and returned in
    the summary (not raised).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = new_recording(name)
    rec.save(out, default_blueprint=blueprint())
    log_static(rec, description)
    stamps: list[int] = []

    def stamped():
        for s in scans:
            stamps.append(s.stamp_ns)
            yield s

    error: Exception | None = None
    try:
        n = log_scans(rec, stamped(), labels=labels, segment_threshold_m=segment_threshold_m)
    except (ValueError, OSError) as exc:  # CorruptFileError is a ValueError
        error, n = exc, len(stamps)
        rec.set_time(SEQUENCE, sequence=max(n - 1, 0))
        log_text(rec, f"reading stopped: {exc}", level="ERROR")
    n_truth = log_truth(rec, truth, {s: k for k, s in enumerate(stamps)}) if truth is not None else 0
    rec.set_time(SEQUENCE, sequence=0)
    log_text(rec, f"{n} scans from {name}" + (f", ground truth for {n_truth}" if n_truth else ""))
    rec.flush()
    rec.disconnect()
    return RecordSummary(out, n, n_truth, error)


def record(
    source,
    out: str | Path,
    *,
    topic: str | None = None,
    progress: bool = False,
    segment_threshold_m: float | None = 0.08,
    description: str | None = None,
) -> RecordSummary:
    """Write every scan of a recording (any format :func:`labkit.read_scans` reads) to an
    ``.rrd`` file with the default blueprint, plus its ground truth when a
    ``<name>.truth.jsonl`` lies beside it. See :func:`record_scans` for damaged inputs.
    """
    from ..io import read_scans
    from ..sim import read_truth, truth_path_for

    stream = read_scans(source, topic=topic)
    name = Path(source).name
    if description is None:
        description = (
            f"# {name}\n\nFormat: `{stream.format}`, topic: `{stream.topic}`.\n\n"
            "Grey rays mark beams without a valid return; colours in `world/segments` are range "
            f"segments ({segment_threshold_m} m threshold)."
        )
    scans = iter(stream)
    if progress:
        from tqdm.auto import tqdm

        scans = tqdm(scans, total=stream.count, unit="scan", desc=f"view {name}")
    truth_file = truth_path_for(source)
    truth = read_truth(truth_file) if truth_file.exists() else None
    return record_scans(scans, out, name=name, truth=truth, segment_threshold_m=segment_threshold_m,
                        description=description)


def show_inline(rec: rr.RecordingStream, *, width: int = 950, height: int = 600) -> None:
    """Show a recording in the notebook with the default blueprint (works offline)."""
    rec.notebook_show(width=width, height=height, blueprint=blueprint())
