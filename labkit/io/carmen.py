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

import gzip
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..scan import Scan
from .errors import CorruptFileError

LASER_MESSAGES = ("FLASER", "RLASER", "ROBOTLASER1", "ROBOTLASER2", "RAWLASER1", "RAWLASER2",
                  "RAWLASER3", "RAWLASER4")
_DEFAULT_ORDER = ("FLASER", "ROBOTLASER1", "RAWLASER1")
SENTINEL_BAND_M = 0.2


def old_style_increment(n: int) -> float:
    """Angular step (radians) of an ``n``-beam FLASER/RLASER scan spanning 180 degrees."""
    return np.pi / (n - 1) if n % 2 else np.pi / n


def _open_text(path: Path):
    if path.suffix == ".gz":
        return gzip.open(path, "rt", encoding="latin-1")
    return open(path, encoding="latin-1")


class _Record(NamedTuple):
    kind: str
    ranges: np.ndarray
    angle_min: float
    increment: float
    range_max: float | None  # stated by the message, or None (found from the data)
    pose: tuple[float, float, float] | None
    stamp_ns: int


def _parse(tokens: list[str]) -> _Record:
    kind = tokens[0]
    if kind in ("FLASER", "RLASER"):
        n = int(tokens[1])
        if n < 1 or len(tokens) != 2 + n + 9:
            raise ValueError(f"expected {2 + n + 9} fields for {n} readings, got {len(tokens)}")
        ranges = np.array(tokens[2 : 2 + n], dtype=np.float64)
        x, y, theta = (float(v) for v in tokens[2 + n : 5 + n])
        stamp = float(tokens[2 + n + 6])
        return _Record(kind, ranges, -np.pi / 2, old_style_increment(n), None, (x, y, theta),
                       int(round(stamp * 1e9)))
    # ROBOTLASERx / RAWLASERx
    start, _fov, res, max_range = (float(v) for v in tokens[2:6])
    n = int(tokens[8])
    ranges = np.array(tokens[9 : 9 + n], dtype=np.float64)
    m = int(tokens[9 + n])
    rest = tokens[10 + n + m :]
    if kind.startswith("ROBOTLASER"):
        if len(rest) != 14:
            raise ValueError(f"expected 14 fields after the remissions, got {len(rest)}")
        pose = tuple(float(v) for v in rest[0:3])
        stamp = float(rest[11])
    else:
        if len(rest) != 3:
            raise ValueError(f"expected 3 fields after the remissions, got {len(rest)}")
        pose, stamp = None, float(rest[0])
    if len(ranges) != n:
        raise ValueError(f"expected {n} readings, got {len(ranges)}")
    return _Record(kind, ranges, start, res, max_range, pose, int(round(stamp * 1e9)))


def default_message(counts: dict[str, int]) -> str | None:
    """The laser read when none is named: the front laser (FLASER, else ROBOTLASER1, else
    RAWLASER1), else the first type present; None for a log without laser messages."""
    return next((k for k in _DEFAULT_ORDER if k in counts), min(counts) if counts else None)


def carmen_message_types(path: str | Path) -> dict[str, int]:
    """Count the laser messages of each type in a log (a quick first look)."""
    counts: dict[str, int] = {}
    with _open_text(Path(path)) as fh:
        for line in fh:
            kind = line.split(" ", 1)[0]
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

    Raises
    ------
    ValueError
        ``message`` names no laser message of the log.
    CorruptFileError
        After yielding every scan before a malformed line or a truncated gzip stream.
    """
    path = Path(path)
    if message is not None and message not in LASER_MESSAGES:
        raise ValueError(f"message must be one of {LASER_MESSAGES}, got {message!r}")
    records: list[_Record] = []
    seen: dict[str, int] = {}
    fault: tuple[str, str] | None = None
    lineno = 0
    try:
        with _open_text(path) as fh:
            for lineno, line in enumerate(fh, start=1):  # noqa: B007 - lineno is used after the loop
                tokens = line.split()
                if not tokens or tokens[0] not in LASER_MESSAGES:
                    continue
                seen[tokens[0]] = seen.get(tokens[0], 0) + 1
                if message is not None and tokens[0] != message:
                    continue
                try:
                    records.append(_parse(tokens))
                except (ValueError, IndexError) as exc:
                    fault = (f"at line {lineno}", f"malformed {tokens[0]} message ({exc})")
                    break
    except (EOFError, OSError, gzip.BadGzipFile) as exc:
        fault = (f"after line {lineno}", f"the compressed stream is cut short ({exc})")
    except UnicodeDecodeError as exc:
        fault = (f"after line {lineno}", f"not a text log ({exc})")

    if message is None:
        records = [r for r in records if r.kind == default_message(seen)]
    elif message not in seen and fault is None:
        found = ", ".join(f"{k} ({v})" for k, v in sorted(seen.items())) or "none"
        raise ValueError(f"{path} has no {message} messages; laser messages found: {found}")

    auto_max = _auto_range_max([r for r in records if r.range_max is None])
    for rec in records:
        limit = range_max if range_max is not None else (rec.range_max if rec.range_max else auto_max)
        yield Scan.from_angle_increment(
            rec.ranges, rec.angle_min, rec.increment, range_min=0.0, range_max=limit,
            stamp_ns=rec.stamp_ns, frame_id=rec.kind.lower(), pose=rec.pose,
        )
    if fault is not None:
        raise CorruptFileError(path, fault[0], len(records), fault[1])
