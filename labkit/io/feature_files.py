"""Features as JSON lines: one record per scan (:meth:`labkit.Features.as_record`).

Each line is a JSON object::

    {"scan": 0, "stamp_ns": ..., "n_beams": 361,
     "counts": {"segments": 14, "lines": 9, "corners": 4, ...},
     "timings_ms": {"segmentation": 0.12, ..., "total": 1.3},
     "features": [{"type": "line", "first": 3, "last": 57, "r": ..., "alpha": ...,
                   "start": [x, y], "end": [x, y], "n_points": 55, "error": ...}, ...]}

``type`` is ``line``, ``corner``, ``circle``/``arc-like``, ``arc``, ``leg`` or ``person``,
with the fields of the Player "laser feature 2D" record: first/last beam index, endpoints
or centre, radius, IAV mean and std, point count, fit error. Any JSON reader takes it;
:func:`read_features` gives the records back as dicts.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .._safe import OutputKind, first_json_line_with, safe_output
from ..features import Features
from .faults import Faults
from .jsonscan import json_lines

__all__ = ["write_features", "read_features", "json_safe"]


def json_safe(obj):
    """A copy of ``obj`` that strict JSON can hold: NaN and infinity become null ("no value").

    Parameters
    ----------
    obj : object
        Dicts, lists, tuples, numbers and strings, nested.

    Returns
    -------
    object
        The same structure, tuples as lists, with every non-finite float replaced by None.
    """
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


#: What :func:`write_features` writes (see labkit._safe): how an existing output is recognised.
FEATURES_FILE = OutputKind("a labkit features file (.jsonl)", (".jsonl",), first_json_line_with("features"))


def write_features(features: Iterable[Features], out, *, overwrite: bool = False, inputs=(),
                   first_scan: int = 0) -> int:
    """Write one JSON line per :class:`labkit.Features`; return how many were written.

    Write one JSON line per :class:`labkit.Features` to ``out`` (a path, ``"-"`` for standard
    output, or an open text file); returns how many were written.

    Each record also gets ``"scan"``, its place in the recording: ``first_scan`` (where the
    stream starts, e.g. a scan range's first scan) plus its place in the stream. A path is written under a
    temporary name and renamed when complete (see ``labkit._safe``): if iterating
    ``features`` raises :class:`~labkit.io.CorruptFileError` (a damaged recording), the file
    holds every scan before it and the error propagates. ``inputs``: the recordings read,
    which the output may not be.

    Parameters
    ----------
    features : iterable of Features
        The features of each scan, in recording order.
    out : str, Path or text file
        A path, ``"-"`` for standard output, or an open text file.
    overwrite : bool, default False
        Replace an existing features file.
    inputs : iterable of str or Path
        The recordings read, which the output may not be.
    first_scan : int, default 0
        The place in the recording of the stream's first scan.

    Returns
    -------
    int
        The number of records written.
    """
    if isinstance(out, (str, Path)) and str(out) != "-":
        with safe_output(out, FEATURES_FILE, overwrite=overwrite, inputs=inputs) as tmp, \
                open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            return _write_records(features, fh, first_scan)
    return _write_records(features, sys.stdout if str(out) == "-" else out, first_scan)


def _json_line(record: dict) -> str:
    """``record`` as one line of strict JSON, non-finite floats as null (:func:`json_safe`).

    Most records hold only finite Python numbers: the encoder takes them as they are (it refuses NaN,
    infinity and numpy's non-float scalars), and only a record it refuses is copied through
    :func:`json_safe` (a third of ``labkit extract``'s writing time when every record was)."""
    try:
        return json.dumps(record, separators=(",", ":"), allow_nan=False)
    except (ValueError, TypeError):
        return json.dumps(json_safe(record), separators=(",", ":"), allow_nan=False)


def _write_records(features: Iterable[Features], fh, first_scan: int = 0) -> int:
    n = 0
    try:
        for f in features:
            fh.write(_json_line({"scan": first_scan + n, **f.as_record()}) + "\n")
            n += 1
    finally:
        fh.flush()
    return n


def read_features(path: str | Path, *, strict: bool = False) -> Iterator[dict]:
    """The records of a features file, one dict per scan.

    The records of a features file, one dict per scan. A line that is not a features record is
    skipped and counted; after the last good record :class:`labkit.CorruptFileError` says how many
    and where the first was (``strict``: reading stops at the first).

    Parameters
    ----------
    path : str or Path
        A features file (``labkit extract``'s ``.jsonl``).
    strict : bool, default False
        Stop at the first line that is not a features record.

    Yields
    ------
    dict
        One record per scan.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path} does not exist")
    faults = Faults(path, strict)
    n = 0
    for lineno, record in json_lines(path, faults):
        if not isinstance(record, dict) or "features" not in record:
            if not faults.skip(f"at line {lineno}", "not a labkit features record"):
                break
            continue
        n += 1
        yield record
    faults.check(n)
