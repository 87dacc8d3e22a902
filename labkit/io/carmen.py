"""CARMEN log files (``.log``, ``.clf``, optionally gzipped), as in the Radish repository.

Laser messages understood (one per line, whitespace separated):

``FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp``
    Front laser, old style. ``RLASER`` is the same for the rear laser. The readings cover
    the 180 degrees in front of the laser starting at -90 degrees. The message does not
    store the angular step: labkit uses ``pi / n`` when ``n`` is even (180 or 360 beams:
    -90 deg up to one step short of +90 deg) and ``pi / (n - 1)`` when ``n`` is odd
    (181 or 361 beams: -90 to +90 deg inclusive), which is 1 or 0.5 degrees for every
    Radish log. Checked on the data: with the logs' corrected poses, consecutive
    180-beam scans of the Intel lab overlap best with a 1-degree step (see
    ``tests/test_io_real.py``).
``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fsd ssd turn ts host lts``
    New style, with its own angles and maximum range.
``RAWLASER1``..``RAWLASER4``
    Like ROBOTLASER1 without poses.

The pose stored on each :class:`~labkit.Scan` is the logged laser pose (``x y theta``).
Max-range readings mean "no return"; every log uses its own value (81.83 m, 81.91 m, 50 m,
~51.1 m, ~32.76 m in the Radish logs). Unless ``range_max`` is given, labkit finds it from
the data: the readings within 0.2 m of the log's largest reading are "no return" when
there are many of them (at least 10, and at least 0.1 % of all readings).
"""

from __future__ import annotations

import contextlib
import math
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..scan import Scan
from .faults import Faults

LASER_MESSAGES = ("FLASER", "RLASER", "ROBOTLASER1", "ROBOTLASER2", "RAWLASER1", "RAWLASER2",
                  "RAWLASER3", "RAWLASER4")
_DEFAULT_ORDER = ("FLASER", "ROBOTLASER1", "RAWLASER1")
SENTINEL_BAND_M = 0.2


def old_style_increment(n: int) -> float:
    """Angular step (radians) of an ``n``-beam FLASER/RLASER scan spanning 180 degrees."""
    return np.pi / (n - 1) if n % 2 else np.pi / n


_CHUNK = 1 << 16  # compressed bytes fed at a time
_PIECE = 256  # after a fault: feed this much at a time, to keep what decompresses before it


class _StreamFault(Exception):
    """The file could not be read on from here (a cut-off or garbled compressed stream)."""


def _inflate(d, data: bytes) -> bytes:
    """Decompress ``data`` with ``d``; if it holds a fault, what decompresses before the fault
    (fed again in small pieces from a copy of the decompressor) and then :class:`_StreamFault`."""
    backup = d.copy()
    try:
        return d.decompress(data)
    except zlib.error:
        pass
    d, out = backup, []
    for i in range(0, len(data), _PIECE):
        try:
            out.append(d.decompress(data[i : i + _PIECE]))
        except zlib.error as exc:
            raise _StreamFault(f"the compressed data is garbled ({exc})", b"".join(out)) from None
        if d.eof:
            break
    return b"".join(out)  # pragma: no cover - the whole block decompressed after all


def _gzip_blocks(fh) -> Iterator[bytes]:
    """Decompressed blocks of a gzip file, member after member; raise :class:`_StreamFault`
    where the stream is cut short or garbled (after yielding everything before it)."""
    d = zlib.decompressobj(wbits=31)
    while True:
        data = fh.read(_CHUNK)
        if not data:
            if not d.eof:
                raise _StreamFault("the compressed stream is cut short")
            return
        while data:
            try:
                out = _inflate(d, data)
            except _StreamFault as fault:
                if fault.args[1]:
                    yield fault.args[1]
                raise _StreamFault(fault.args[0]) from None
            if out:
                yield out
            if not d.eof:
                break
            data = d.unused_data
            if not data.strip(b"\0"):  # trailing zero padding ends the file, as gzip allows
                return
            d = zlib.decompressobj(wbits=31)  # the next gzip member


def _lines(path: Path) -> Iterator[tuple[int, str]]:
    """``(line number, text)`` of every complete line of a plain or gzipped log.

    A gzipped log cut short or garbled yields every complete line before the fault and then
    raises :class:`_StreamFault` (the cut-off part of the last line is not yielded).
    """
    with open(path, "rb") as fh:
        if path.suffix.lower() != ".gz":
            for lineno, raw in enumerate(fh, start=1):
                yield lineno, raw.decode("latin-1")
            return
        pending, lineno = b"", 0
        for block in _gzip_blocks(fh):
            parts = (pending + block).split(b"\n")
            pending = parts.pop()
            for raw in parts:
                lineno += 1
                yield lineno, raw.decode("latin-1")
        if pending:
            yield lineno + 1, pending.decode("latin-1")


class _Record(NamedTuple):
    kind: str
    ranges: np.ndarray
    angle_min: float
    increment: float
    range_max: float | None  # stated by the message, or None (found from the data)
    pose: tuple[float, float, float] | None
    stamp_ns: int  # the message's (ipc) timestamp
    receive_ns: int  # when the logger received it (logger_timestamp)


def _parse(tokens: list[str]) -> _Record:
    kind = tokens[0]
    if kind in ("FLASER", "RLASER"):
        n = int(tokens[1])
        if n < 1 or len(tokens) != 2 + n + 9:
            raise ValueError(f"expected {2 + n + 9} fields for {n} readings, got {len(tokens)}")
        ranges = np.array(tokens[2 : 2 + n], dtype=np.float64)
        x, y, theta = (float(v) for v in tokens[2 + n : 5 + n])
        return _Record(kind, ranges, -np.pi / 2, old_style_increment(n), None, (x, y, theta),
                       _ns(tokens[2 + n + 6]), _ns(tokens[2 + n + 8]))
    # ROBOTLASERx / RAWLASERx
    start, _fov, res, max_range = (float(v) for v in tokens[2:6])
    n = int(tokens[8])
    ranges = np.array(tokens[9 : 9 + n], dtype=np.float64)
    m = int(tokens[9 + n])
    rest = tokens[10 + n + m :]
    pose: tuple[float, float, float] | None
    if kind.startswith("ROBOTLASER"):
        if len(rest) != 14:
            raise ValueError(f"expected 14 fields after the remissions, got {len(rest)}")
        x, y, theta = (float(v) for v in rest[0:3])
        pose = (x, y, theta)
        stamp, logged = rest[11], rest[13]
    else:
        if len(rest) != 3:
            raise ValueError(f"expected 3 fields after the remissions, got {len(rest)}")
        pose, stamp, logged = None, rest[0], rest[2]
    if len(ranges) != n:
        raise ValueError(f"expected {n} readings, got {len(ranges)}")
    return _Record(kind, ranges, start, res, max_range, pose, _ns(stamp), _ns(logged))


def _ns(seconds: str) -> int:
    """A CARMEN time stamp (seconds, as text) in integer nanoseconds."""
    value = float(seconds)
    if not math.isfinite(value):
        raise ValueError(f"time stamp {seconds!r} is not a finite number")
    return int(round(value * 1e9))


def default_message(counts: dict[str, int]) -> str | None:
    """The laser read when none is named: the front laser (FLASER, else ROBOTLASER1, else
    RAWLASER1), else the first type present; None for a log without laser messages."""
    return next((k for k in _DEFAULT_ORDER if k in counts), min(counts) if counts else None)


def carmen_message_types(path: str | Path) -> dict[str, int]:
    """Count the laser messages of each type in a log (a quick first look)."""
    counts: dict[str, int] = {}
    with contextlib.suppress(_StreamFault):  # read_carmen reports the fault
        for _lineno, line in _lines(Path(path)):
            kind = line.split(None, 1)[0] if line.strip() else ""
            if kind in LASER_MESSAGES:
                counts[kind] = counts.get(kind, 0) + 1
    return counts


def _auto_range_max(records: list[_Record]) -> float:
    if not records:
        return float("inf")
    all_r = np.concatenate([r.ranges for r in records])
    all_r = all_r[np.isfinite(all_r)]
    if all_r.size == 0:
        return float("inf")
    top = float(all_r.max())
    band = int(np.count_nonzero(all_r >= top - SENTINEL_BAND_M))
    if top > SENTINEL_BAND_M and band >= max(10, 0.001 * all_r.size):
        return top - SENTINEL_BAND_M
    return float("inf")


def read_carmen(
    path: str | Path,
    message: str | None = None,
    *,
    range_max: float | None = None,
    strict: bool = False,
) -> Iterator[Scan]:
    """Yield the scans of one laser in a CARMEN log.

    Parameters
    ----------
    path : str or Path
        A ``.log``/``.clf`` file, gzipped or not.
    message : str, optional
        Which laser message to read (``"FLASER"``, ``"RLASER"``, ``"ROBOTLASER1"``, ...).
        Default: the front laser, ``FLASER`` if the log has it, else ``ROBOTLASER1``, else
        ``RAWLASER1``.
    range_max : float, optional
        Readings at or beyond this range (metres) are "no return". Default: the maximum
        range a ROBOTLASER/RAWLASER message states, or the value found from the data for
        FLASER/RLASER (see the module docstring).
    strict : bool
        Stop at the first malformed line instead of skipping it.

    Raises
    ------
    ValueError
        ``message`` names no laser message of the log.
    CorruptFileError
        After yielding every good scan, when lines were malformed (each is skipped and
        counted; with ``strict``, reading stops at the first) or a gzipped log is cut short or
        garbled (every complete line before the fault is read).
    """
    path = Path(path)
    if message is not None and message not in LASER_MESSAGES:
        raise ValueError(f"message must be one of {LASER_MESSAGES}, got {message!r}")
    faults = Faults(path, strict)
    records: list[tuple[int, _Record]] = []
    seen: dict[str, int] = {}
    lineno = 0
    try:
        for lineno, line in _lines(path):  # noqa: B007 - lineno is used after the loop
            tokens = line.split()
            if not tokens or tokens[0] not in LASER_MESSAGES:
                continue
            seen[tokens[0]] = seen.get(tokens[0], 0) + 1
            if message is not None and tokens[0] != message:
                continue
            try:
                records.append((lineno, _parse(tokens)))
            except (ValueError, IndexError) as exc:
                if not faults.skip(f"at line {lineno}", f"malformed {tokens[0]} message ({exc})"):
                    break
    except _StreamFault as exc:
        faults.skip(f"after line {lineno}", str(exc))

    if message is None:
        wanted = default_message(seen)
        records = [(n, r) for n, r in records if r.kind == wanted]
    elif message not in seen and not faults:
        found = ", ".join(f"{k} ({v})" for k, v in sorted(seen.items())) or "none"
        raise ValueError(f"{path} has no {message} messages; laser messages found: {found}")

    auto_max = _auto_range_max([r for _, r in records if r.range_max is None])
    n_read = 0
    for lineno, rec in records:
        limit = range_max if range_max is not None else (rec.range_max if rec.range_max else auto_max)
        try:
            scan = Scan.from_angle_increment(
                rec.ranges, rec.angle_min, rec.increment, range_min=0.0, range_max=limit,
                stamp_ns=rec.stamp_ns, frame_id=rec.kind.lower(), pose=rec.pose, receive_ns=rec.receive_ns,
            )
        except ValueError as exc:
            if not faults.skip(f"at line {lineno}", f"impossible {rec.kind} message ({exc})"):
                break
            continue
        yield scan
        n_read += 1
    faults.check(n_read)
