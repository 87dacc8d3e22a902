"""A recording file to a rerun ``.rrd``: read it, run the pipeline on every scan, log what it finds.

What :command:`labkit view` runs; :mod:`labkit.viz.rr` is the logging it builds on.
"""

from __future__ import annotations

from pathlib import Path

from labkit._safe import check_output
from labkit.io import read_scans
from labkit.pipeline import Config
from labkit.sim import TruthStream, truth_path_for
from labkit.viz.rr import RRD_FILE, RecordSummary, describe, record_scans

__all__ = ["record"]


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
    tracks: bool = False,
) -> RecordSummary:
    """Write every scan of a recording and its features to an ``.rrd`` file with the default blueprint.

    The ground truth is logged too when a ``<name>.truth.jsonl`` lies beside the recording (read
    along with the scans). See :func:`labkit.viz.rr.record_scans` for damaged inputs, for
    ``overwrite`` and for memory. When the recording has poses, the map view is logged too (see
    :mod:`labkit.viz.rr`).

    Parameters
    ----------
    source : str or Path
        The recording (any format :func:`labkit.read_scans` reads).
    out : str or Path
        The ``.rrd`` file to write.
    topic : str or None
        The scan topic of a bag; None: the only one.
    config : Config or None
        The pipeline's configuration; None: ``Config()``.
    features : bool
        Log the pipeline's features; False: scans and range segments only.
    progress : bool
        Show a progress bar.
    segment_threshold_m : float or None
        The range-jump threshold of the segments logged without features, metres.
    description : str or None
        The text shown in the viewer's description panel; None: a generated one.
    overwrite : bool
        Replace an existing ``.rrd`` file.
    strict : bool
        Stop reading at the first bad record.
    poses : str, bool or None
        Where to read poses from, as in :func:`labkit.read_scans`.
    scans : slice or None
        Only this range of scans (as :func:`labkit.read_scans` takes it), numbered on the ``scan``
        timeline as in the whole recording.
    tracks : bool
        Also follow people and moving circles (``config.tracking``) and log the tracks, their
        trails, velocities and life-cycle events (:mod:`labkit.viz.rr.tracks`); needs features.

    Returns
    -------
    RecordSummary
        What was written: counts of scans and features, and the error of a damaged recording.
    """
    if tracks and not features:
        raise ValueError("tracks need features: features=False logs scans and range segments only")
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
                               world_map=stream.poses is not None, tracks=tracks)
    items = iter(stream)
    if progress:
        from tqdm.auto import tqdm

        items = tqdm(items, total=stream.count, unit="scan", desc=f"view {name}")
    inputs = [source, truth_file] if truth is not None else [source]
    return record_scans(items, out, name=name, truth=truth, config=config if features else None,
                        segment_threshold_m=segment_threshold_m, description=description, overwrite=overwrite,
                        inputs=inputs, with_map=None if stream.poses is not None else False,
                        start_index=stream.first, tracks=tracks)
