"""Rerun logging of notebook 08b: the people, the per-scan counts and times and the log lines of a leg detector.

The notebook logs the legs themselves (the ellipses labkit's layout expects on ``world/legs``) in a cell;
these helpers send the rest the same way, one ``send_columns`` call per entity, one batch per scan.
rerun is imported inside each function, after :mod:`labkit.viz.rr` (which must come first).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PERSON_COLOUR", "scan_times", "log_people_and_metrics"]

#: The colour of a person's point (orange).
PERSON_COLOUR = [255, 140, 0]


def scan_times(scans) -> list:
    """The two time columns of labkit's layout for a list of scans: scan number and stamp.

    Parameters
    ----------
    scans : sequence of labkit.Scan
        The scans, in order.

    Returns
    -------
    list of rerun.TimeColumn
        ``labkit.viz.rr.SEQUENCE`` (0, 1, ...) and ``labkit.viz.rr.TIME`` (the stamps).
    """
    from labkit.viz import rr as lkrr  # noqa: I001 (before rerun)
    import rerun as rr

    return [rr.TimeColumn(lkrr.SEQUENCE, sequence=np.arange(len(scans))),
            rr.TimeColumn(lkrr.TIME, timestamp=np.array([s.stamp_ns for s in scans]).astype("datetime64[ns]"))]


def log_people_and_metrics(rec, times, people, detections, detect_ms, missed, summary: str) -> None:
    """Log the people as points, the per-scan counts and times, a summary line and a line per missed leg.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    times : list of rerun.TimeColumn
        :func:`scan_times` of the scans.
    people : list of list of labkit.Person
        Per scan, the people (``world/people``, one point each).
    detections : list of list of labkit.Leg
        Per scan, the legs (their count goes to ``metrics/count/legs``).
    detect_ms : sequence of float
        Per scan, the detector's milliseconds (``metrics/time_ms/detect_legs``).
    missed : list of (int, (float, float))
        The scan number and centre of each detectable leg that was missed: a warning line each, at its scan.
    summary : str
        A line logged at scan 0.
    """
    from labkit.viz import rr as lkrr  # noqa: I001 (before rerun)
    import rerun as rr

    person_xy = np.array([p.center for ps in people for p in ps]).reshape(-1, 2)
    rec.send_columns("world/people", indexes=times, columns=rr.Points2D.columns(
        positions=person_xy, radii=np.full(len(person_xy), -6.0, dtype=np.float32),
        colors=np.tile(PERSON_COLOUR, (len(person_xy), 1))).partition([len(p) for p in people]))
    for path, values in [("metrics/count/legs", [len(f) for f in detections]),
                         ("metrics/count/people", [len(p) for p in people]),
                         ("metrics/time_ms/detect_legs", detect_ms)]:
        rec.send_columns(path, indexes=times, columns=rr.Scalars.columns(scalars=np.array(values, float)))
    rec.set_time(lkrr.SEQUENCE, sequence=0)
    lkrr.log_text(rec, summary)
    for k, centre in missed:
        rec.set_time(lkrr.SEQUENCE, sequence=k)
        lkrr.log_text(rec, f"scan {k}: missed the true leg at ({centre[0]:.2f}, {centre[1]:.2f}) m", level="WARN")
