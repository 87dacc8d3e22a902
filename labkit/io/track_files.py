"""Tracks as a CSV table: one row per track per scan (:class:`labkit.tracking.TrackTable`).

The columns::

    scan,stamp_ns,frame,id,kind,status,x,y,vx,vy,hits

``scan`` is the scan's place in the recording, ``frame`` ``sensor`` or ``map`` (the frame of
``x, y, vx, vy``, metres and m/s), ``status`` ``tentative``, ``static``, ``confirmed`` or ``deleted``
(a track deleted at this scan, listed once with its last prediction). The moving targets are the
rows whose status is ``confirmed``. Any CSV reader takes it (``pandas.read_csv``, a spreadsheet);
:func:`read_tracks` gives the rows back as dicts.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Iterator
from pathlib import Path

from .._safe import OutputKind, safe_output, starts_with
from ..tracking import TrackTable

__all__ = ["TRACKS_FILE", "TRACK_COLUMNS", "write_tracks", "read_tracks"]

TRACK_COLUMNS = ("scan", "stamp_ns", "frame", "id", "kind", "status", "x", "y", "vx", "vy", "hits")
#: What :func:`write_tracks` writes (see labkit._safe): how an existing output is recognised.
TRACKS_FILE = OutputKind("a labkit tracks table (.csv)", (".csv",), starts_with(",".join(TRACK_COLUMNS).encode()))


def write_tracks(tables: Iterable[TrackTable], out: str | Path, *, overwrite: bool = False, inputs=(),
                 first_scan: int = 0) -> tuple[int, int]:
    """Write the rows of every :class:`~labkit.tracking.TrackTable` (one per scan, in order) to a CSV file.

    Written under a temporary name and renamed when complete: if iterating ``tables`` raises
    :class:`~labkit.io.CorruptFileError` (a damaged recording), the file holds every scan before
    it and the error propagates.

    Parameters
    ----------
    tables : iterable of labkit.tracking.TrackTable
        One per scan, in order.
    out : str or Path
        The CSV file.
    overwrite : bool
        Replace an existing tracks table.
    inputs : iterable of str or Path
        The recordings read, which the output may not be.
    first_scan : int
        The number of the first table's scan (a scan range keeps the recording's numbers).

    Returns
    -------
    scans : int
        The tables written.
    rows : int
        The rows written.
    """
    with safe_output(out, TRACKS_FILE, overwrite=overwrite, inputs=inputs) as tmp, \
            open(tmp, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(TRACK_COLUMNS)
        n_scans = n_rows = 0
        try:
            for table in tables:
                scan = first_scan + n_scans
                for k in range(len(table.ids)):
                    x, y, vx, vy = (repr(float(v)) for v in table.states[k])
                    writer.writerow((scan, table.stamp_ns, table.frame, int(table.ids[k]), table.kinds[k],
                                     table.status[k], x, y, vx, vy, int(table.hits[k])))
                    n_rows += 1
                n_scans += 1
        finally:
            fh.flush()
    return n_scans, n_rows


def read_tracks(path: str | Path) -> Iterator[dict]:
    """The rows of a tracks table written by :func:`write_tracks`, as dicts with typed values.

    A file whose columns are not a tracks table's raises ``ValueError``.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Yields
    ------
    dict
        One row: ``scan``, ``stamp_ns``, ``id`` and ``hits`` as int, ``x``, ``y``, ``vx``, ``vy``
        as float, the other columns as str.
    """
    ints, floats = {"scan", "stamp_ns", "id", "hits"}, {"x", "y", "vx", "vy"}
    with open(path, encoding="utf-8", newline="") as fh:
        reader = csv.DictReader(fh)
        if tuple(reader.fieldnames or ()) != TRACK_COLUMNS:
            raise ValueError(f"{path} is not a labkit tracks table (its columns: {reader.fieldnames})")
        for row in reader:
            yield {k: int(v) if k in ints else float(v) if k in floats else v for k, v in row.items()}
