"""Scans as JSON: one scan per ``.json`` file, or one per line in ``.jsonl``.

A ``.json`` scan is an object with ``ranges`` and ``bearings`` (the format of the
laser_line_extraction sample scans); ``angles`` is accepted for ``bearings``, and the
optional keys ``range_min``, ``range_max``, ``stamp_ns``, ``frame_id`` and ``pose`` are
read when present. ``null`` ranges are invalid beams. labkit writes the same keys.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..scan import Scan
from .errors import CorruptFileError


def scan_from_dict(d: dict, where: str = "scan") -> Scan:
    """Build a Scan from a JSON object (see the module docstring)."""
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be a JSON object with 'ranges' and 'bearings'")
    if "ranges" not in d or ("bearings" not in d and "angles" not in d):
        raise ValueError(f"{where} needs 'ranges' and 'bearings' (or 'angles'); it has {sorted(d)}")
    ranges = [np.nan if v is None else v for v in d["ranges"]]
    angles = d["bearings"] if "bearings" in d else d["angles"]
    kwargs = {k: d[k] for k in ("range_min", "stamp_ns", "frame_id", "pose") if d.get(k) is not None}
    if d.get("range_max") is not None:
        kwargs["range_max"] = d["range_max"]
    return Scan(ranges=ranges, angles=angles, **kwargs)


def scan_to_dict(scan: Scan) -> dict:
    """The JSON object for a scan (non-finite ranges become ``null``)."""
    r = scan.ranges
    return {
        "ranges": [float(v) if np.isfinite(v) else None for v in r],
        "bearings": [float(a) for a in scan.angles],
        "range_min": scan.range_min,
        "range_max": scan.range_max if np.isfinite(scan.range_max) else None,
        "stamp_ns": scan.stamp_ns,
        "frame_id": scan.frame_id,
        **({"pose": list(scan.pose)} if scan.pose is not None else {}),
    }


def read_json_scan(path: str | Path) -> Scan:
    """Read one scan from a ``.json`` file ``{"ranges": [...], "bearings": [...]}``."""
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise CorruptFileError(path, f"at line {exc.lineno} column {exc.colno}", 0, exc.msg) from None
    return scan_from_dict(d, where=str(path))


def read_json_lines(path: str | Path) -> Iterator[Scan]:
    """Yield scans from a ``.jsonl`` file, one JSON object per line."""
    path = Path(path)
    n = 0
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            try:
                scan = scan_from_dict(json.loads(line), where=f"{path}:{lineno}")
            except (json.JSONDecodeError, ValueError) as exc:
                raise CorruptFileError(path, f"at line {lineno}", n, str(exc)) from None
            yield scan
            n += 1


def write_json_scan(scan: Scan, path: str | Path) -> None:
    Path(path).write_text(json.dumps(scan_to_dict(scan)) + "\n", encoding="utf-8")


def write_json_lines(scans: Iterable[Scan], path: str | Path) -> int:
    """Write scans one per line; if ``scans`` raises, the lines written so far are kept."""
    n = 0
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        for scan in scans:
            fh.write(json.dumps(scan_to_dict(scan)) + "\n")
            n += 1
    return n
