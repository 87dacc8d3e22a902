"""Rerun logging of notebook 00 (the tour): each scan's segmentation time and a log line a second.

The tour logs the scans and the ground truth itself (:func:`labkit.viz.rr.log_scans`,
:func:`labkit.viz.rr.log_truth`); this helper sends the rest where labkit's layout reads it: the stage
time of every scan in one ``send_columns`` call, and a line of text every few scans.
rerun is imported inside the function, after :mod:`labkit.viz.rr` (which must come first).
"""

from __future__ import annotations

import numpy as np

from labkit.viz.legs_rerun import scan_times

__all__ = ["log_segmentation_times"]


def log_segmentation_times(rec, scans, labels, segment_ms, *, t0: float, every: int = 10) -> int:
    """Log each scan's segmentation time, and every ``every`` scans a line with its segments and invalid beams.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    scans : sequence of labkit.Scan
        The scans, in order (scan ``k`` is at ``k`` on the ``scan`` timeline and at its stamp on ``ros_time``).
    labels : sequence of numpy.ndarray
        Per scan, the segment label of each beam (``labkit.segment_labels``; -1 for an invalid beam).
    segment_ms : sequence of float
        Per scan, the milliseconds its segmentation took (``metrics/time_ms/segmentation``).
    t0 : float
        The time, in seconds, that the log lines count from (e.g. the first scan's ``stamp_s``).
    every : int, optional
        A log line every this many scans, starting at scan 0 (10: once a second at 10 Hz).

    Returns
    -------
    int
        The number of log lines written.
    """
    from labkit.viz import rr as lkrr  # noqa: I001 (before rerun)
    import rerun as rr

    rec.send_columns("metrics/time_ms/segmentation", indexes=scan_times(scans),
                     columns=rr.Scalars.columns(scalars=np.asarray(segment_ms, dtype=float)))
    lines = range(0, len(scans), every)
    for k in lines:
        rec.set_time(lkrr.SEQUENCE, sequence=k)
        rec.set_time(lkrr.TIME, timestamp=np.datetime64(scans[k].stamp_ns, "ns"))
        lkrr.log_text(rec, f"t = {scans[k].stamp_s - t0:4.1f} s: {int(np.max(labels[k])) + 1} segments, "
                           f"{np.count_nonzero(~np.asarray(scans[k].valid))} invalid beams")
    return len(lines)
