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
from contextlib import nullcontext
from pathlib import Path

from ..features import Features
from .errors import CorruptFileError

__all__ = ["write_features", "read_features"]


def _clean(obj):
    """JSON has no NaN or infinity: write them as null."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def write_features(features: Iterable[Features], out, *, overwrite: bool = False) -> int:
    """Write one JSON line per :class:`labkit.Features` to ``out`` (a path, ``"-"`` for
    standard output, or an open text file); returns how many were written.

    Each record also gets ``"scan"``, its place in the stream. Lines are flushed as they
    are written, so if iterating ``features`` raises (a damaged recording), every scan
    before the fault is in the file and the error propagates.
    """
    if isinstance(out, (str, Path)) and str(out) != "-":
        path = Path(out)
        if path.exists() and not overwrite:
            raise ValueError(f"{path} exists; pass overwrite=True (--force) to replace it")
        path.parent.mkdir(parents=True, exist_ok=True)
        ctx = open(path, "w", encoding="utf-8")  # noqa: SIM115 - closed by the with below
    else:
        ctx = nullcontext(sys.stdout if str(out) == "-" else out)
    n = 0
    with ctx as fh:
        try:
            for f in features:
                record = {"scan": n, **f.as_record()}
                fh.write(json.dumps(_clean(record), separators=(",", ":")) + "\n")
                n += 1
        finally:
            fh.flush()
    return n


def read_features(path: str | Path) -> Iterator[dict]:
    """The records of a features file, one dict per scan. A line that is not a JSON
    object raises :class:`labkit.CorruptFileError` after the records before it."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path} does not exist")
    n = 0
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                raise CorruptFileError(path, f"at line {lineno}", n, f"not JSON ({exc.msg})") from None
            if not isinstance(record, dict) or "features" not in record:
                raise CorruptFileError(path, f"at line {lineno}", n, "not a labkit features record")
            n += 1
            yield record
