"""Scans as JSON: one scan per ``.json`` file, or one per line in ``.jsonl``.

A ``.json`` scan is an object with ``ranges`` and ``bearings`` (the format of the
laser_line_extraction sample scans); ``angles`` is accepted for ``bearings``, and the
optional keys ``range_min``, ``range_max``, ``stamp_ns``, ``receive_ns``, ``frame_id``,
``pose``, ``intensities``, ``time_increment`` and ``scan_time`` are read when present.
labkit writes the same keys, so bag -> JSON -> bag loses nothing.

Without a ``range_max`` key, a reading beyond :data:`DEFAULT_RANGE_MAX_M` (1000 m: no 2D laser
scanner measures that far) is invalid, like a bag's reading beyond its ``range_max``, so that a
placeholder such as ``1e30`` is not taken for a wall. ``"range_max": null`` means no limit (how
labkit writes an infinite one).

JSON has no NaN or infinity, and the two mean different things in a scan: NaN is "no
reading", +inf is "no return" (REP 117). labkit writes a NaN range (or intensity) as ``null``
and an infinite one as the string ``"inf"`` or ``"-inf"``, and reads them back the same way
(``"nan"`` is read as NaN too), so the files stay strict JSON that any parser accepts.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from .._safe import OutputKind, first_json_line_with, json_object_with, safe_output
from ..scan import Scan
from .faults import CorruptFileError, EmptyRecordingError, Faults

#: The range limit of a JSON scan that does not give its own ``range_max`` (metres).
DEFAULT_RANGE_MAX_M = 1000.0

_FROM_JSON = {None: np.nan, "inf": np.inf, "+inf": np.inf, "-inf": -np.inf, "nan": np.nan}


def _values_from_json(values, name: str, where: str) -> np.ndarray:
    if not isinstance(values, list):
        raise ValueError(f"{where}: {name} must be a list of numbers")
    try:
        numbers = [v if isinstance(v, (int, float)) and not isinstance(v, bool) else _FROM_JSON[v] for v in values]
    except (KeyError, TypeError):
        bad = next(v for v in values if not isinstance(v, (int, float)) and v not in _FROM_JSON)
        raise ValueError(f"{where}: {name} holds {bad!r}; a value is a number, null (NaN), \"inf\" or \"-inf\"") \
            from None
    return np.array(numbers, dtype=np.float64)


def _values_to_json(values: np.ndarray) -> list:
    out = values.tolist()
    if not np.all(np.isfinite(values)):
        for i in np.flatnonzero(~np.isfinite(values)):
            v = out[i]
            out[i] = None if v != v else "inf" if v > 0 else "-inf"
    return out


def scan_from_dict(d: object, where: str = "scan") -> Scan:
    """Build a Scan from a JSON object (see the module docstring)."""
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be a JSON object with 'ranges' and 'bearings'")
    if "ranges" not in d or ("bearings" not in d and "angles" not in d):
        raise ValueError(f"{where} needs 'ranges' and 'bearings' (or 'angles'); it has {sorted(d)}")
    ranges = _values_from_json(d["ranges"], "ranges", where)
    angles = d["bearings"] if "bearings" in d else d["angles"]
    kwargs = {k: d[k] for k in ("range_min", "stamp_ns", "receive_ns", "frame_id", "pose", "time_increment",
                                "scan_time") if d.get(k) is not None}
    if "range_max" not in d:
        kwargs["range_max"] = DEFAULT_RANGE_MAX_M
    elif d["range_max"] is not None:
        kwargs["range_max"] = d["range_max"]
    if d.get("intensities") is not None:
        kwargs["intensities"] = _values_from_json(d["intensities"], "intensities", where)
    return Scan(ranges=ranges, angles=angles, **kwargs)


def scan_to_dict(scan: Scan) -> dict:
    """The JSON object for a scan (see the module docstring for NaN and infinity)."""
    d = {
        "ranges": _values_to_json(scan.ranges),
        "bearings": scan.angles.tolist(),
        "range_min": scan.range_min,
        "range_max": scan.range_max if np.isfinite(scan.range_max) else None,
        "stamp_ns": scan.stamp_ns,
        "frame_id": scan.frame_id,
    }
    if scan.receive_ns is not None:
        d["receive_ns"] = scan.receive_ns
    if scan.pose is not None:
        d["pose"] = list(scan.pose)
    if scan.intensities is not None:
        d["intensities"] = _values_to_json(scan.intensities)
    if scan.time_increment or scan.scan_time:
        d["time_increment"], d["scan_time"] = scan.time_increment, scan.scan_time
    return d


def read_json_scan(path: str | Path) -> Scan:
    """Read one scan from a ``.json`` file ``{"ranges": [...], "bearings": [...]}``.

    Parameters
    ----------
    path : str or Path
        The ``.json`` file.

    Returns
    -------
    Scan
        The scan it holds.
    """
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise CorruptFileError(path, f"at line {exc.lineno} column {exc.colno}", 0, exc.msg, n_skipped=1) from None
    except UnicodeDecodeError as exc:
        raise CorruptFileError(path, f"at byte {exc.start}", 0, "not UTF-8 text", n_skipped=1) from None
    try:
        return scan_from_dict(d, where=str(path))
    except ValueError as exc:
        raise CorruptFileError(path, "in its only scan", 0, str(exc), n_skipped=1) from None


def json_lines(path: Path, faults: Faults) -> Iterator[tuple[int, object]]:
    """``(line number, JSON value)`` of every line of a JSON-lines file that parses; a line
    that does not (bad JSON, not UTF-8, cut off) is noted in ``faults`` and skipped (in strict
    mode reading stops there). Blank lines are passed over."""
    with open(path, "rb") as fh:
        for lineno, raw in enumerate(fh, start=1):
            if not raw.strip():
                continue
            try:
                value = json.loads(raw)
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                reason = f"not JSON ({exc.msg})" if isinstance(exc, json.JSONDecodeError) else "not UTF-8 text"
                if not faults.skip(f"at line {lineno}", reason):
                    return
                continue
            yield lineno, value


def read_json_lines(path: str | Path, *, strict: bool = False) -> Iterator[Scan]:
    """Yield scans from a ``.jsonl`` file, one JSON object per line.

    A line that is not a scan is skipped and counted; after the last good scan a
    :class:`~labkit.io.CorruptFileError` says how many and where the first was.

    Parameters
    ----------
    path : str or Path
        The file.
    strict : bool
        Stop reading at the first bad line.

    Yields
    ------
    Scan
        Each scan, in file order.
    """
    path = Path(path)
    faults = Faults(path, strict)
    n = 0
    for lineno, value in json_lines(path, faults):
        try:
            scan = scan_from_dict(value, where=f"line {lineno}")
        except ValueError as exc:
            if not faults.skip(f"at line {lineno}", str(exc).removeprefix(f"line {lineno}: ")):
                break
            continue
        yield scan
        n += 1
    if n == 0 and not faults:
        raise EmptyRecordingError(f"{path} holds no scans (no JSON line in it)")
    faults.check(n)


#: What the JSON writers write (see labkit._safe): how an existing output is recognised.
JSON_LINES = OutputKind("a labkit scans file (.jsonl)", (".jsonl",), first_json_line_with("ranges"))
JSON_SCAN = OutputKind("a JSON scan (.json)", (".json",), json_object_with("ranges"))


def write_json_scan(scan: Scan, path: str | Path, *, overwrite: bool = False, inputs=()) -> None:
    """Write one scan to a ``.json`` file (under a temporary name, then renamed).

    Parameters
    ----------
    scan : Scan
        The scan.
    path : str or Path
        The file to write.
    overwrite : bool
        Replace an existing file of this kind.
    inputs : iterable of str or Path
        The files read, which the output may not be.
    """
    with safe_output(path, JSON_SCAN, overwrite=overwrite, inputs=inputs) as tmp:
        tmp.write_text(json.dumps(scan_to_dict(scan), allow_nan=False) + "\n", encoding="utf-8")


def write_json_lines(scans: Iterable[Scan], path: str | Path, *, overwrite: bool = False, inputs=()) -> int:
    """Write scans to a ``.jsonl`` file, one per line (under a temporary name, then renamed).

    If iterating ``scans`` raises :class:`~labkit.io.CorruptFileError`, the file holds every scan
    before it and the error propagates.

    Parameters
    ----------
    scans : iterable of Scan
        The scans.
    path : str or Path
        The file to write.
    overwrite : bool
        Replace an existing file of this kind.
    inputs : iterable of str or Path
        The files read, which the output may not be.

    Returns
    -------
    int
        How many scans were written.
    """
    n = 0
    with safe_output(path, JSON_LINES, overwrite=overwrite, inputs=inputs) as tmp, \
            open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        for scan in scans:
            fh.write(json.dumps(scan_to_dict(scan), allow_nan=False) + "\n")
            n += 1
    return n
