"""ROS bags in and out: ROS1 ``.bag``, ROS2 sqlite3 folders and MCAP, through rosbags.

Reading goes through ``rosbags.highlevel.AnyReader``. When rosbags cannot open a file
(a recording cut short has no index, footer or intact database), labkit falls back to a
sequential reader (:mod:`labkit.io.salvage`) that recovers every complete scan and then
raises :class:`~labkit.io.CorruptFileError` saying where the file broke.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
from rosbags import rosbag1, rosbag2
from rosbags.highlevel import AnyReader

from ..scan import Scan
from . import salvage
from .errors import CorruptFileError

BAG_FORMATS = ("ros1", "ros2", "mcap")
_MSGTYPE = "sensor_msgs/msg/LaserScan"
_ANGLE_TOL = 1e-5  # rad: float32 angle_increment cannot represent uneven beams better


_typestore = salvage.typestore


# ============================================================================ reading
def _open(path: Path) -> AnyReader:
    reader = AnyReader([path], default_typestore=_typestore(ros1=False))
    reader.open()
    return reader


def _topics_via_rosbags(path: Path) -> list[tuple[str, str, int | None]]:
    reader = _open(path)
    try:
        return sorted({(c.topic, c.msgtype, c.msgcount) for c in reader.connections})
    finally:
        reader.close()


def _topics_via_salvage(path: Path, fmt: str) -> list[tuple[str, str, int | None]]:
    seen = {}
    for name, _stamp, msgtype in _salvager(fmt)(path, None, want_topics=True):
        seen.setdefault(name, msgtype)
    return sorted((name, msgtype, None) for name, msgtype in seen.items())


def _salvager(fmt: str):
    return {"ros1": salvage.salvage_ros1, "mcap": salvage.salvage_mcap, "ros2": salvage.salvage_sqlite3}[fmt]


def _storage_file(path: Path, fmt: str) -> Path:
    """The file a salvage reader walks: the bag itself or the storage file in a folder."""
    if path.is_file():
        return path
    suffix = ".db3" if fmt == "ros2" else ".mcap"
    files = sorted(path.glob(f"*{suffix}"))
    if not files:
        raise ValueError(f"{path} holds no {suffix} file")
    return files[0]


def list_topics(path: str | Path, fmt: str) -> tuple[list[tuple[str, str, int | None]], bool]:
    """Topics ``(name, msgtype, count)`` of a bag and whether rosbags could open it."""
    path = Path(path)
    try:
        return _topics_via_rosbags(path), True
    except Exception:  # noqa: BLE001 - any failure to open means: try the sequential reader
        return _topics_via_salvage(_storage_file(path, fmt), fmt), False


def resolve_topic(path: Path, topics, topic: str | None) -> str:
    """Pick the LaserScan topic to read, or raise a ValueError that lists the options."""
    scans = [t for t in topics if t[1] in salvage.LASERSCAN_TYPES]
    listing = ", ".join(f"{name} ({msgtype})" for name, msgtype, _ in topics) or "none"
    if topic is not None:
        if any(t[0] == topic for t in scans):
            return topic
        choices = ", ".join(t[0] for t in scans) or "none"
        raise ValueError(
            f"topic {topic!r} is not a sensor_msgs/LaserScan topic of {path}; LaserScan topics: {choices};"
            f" all topics: {listing}"
        )
    if not scans:
        raise ValueError(f"{path} has no sensor_msgs/LaserScan topic; its topics are: {listing}")
    if len(scans) > 1:
        names = ", ".join(t[0] for t in scans)
        raise ValueError(f"{path} has several LaserScan topics ({names}); choose one with topic=...")
    return scans[0][0]


def _scan_from(msg, bag_stamp_ns: int) -> Scan:
    scan = Scan.from_ros(msg)
    if scan.stamp_ns == 0 and bag_stamp_ns:
        scan = scan.replace(stamp_ns=bag_stamp_ns)  # drivers that leave header.stamp empty
    return scan


def iter_bag(path: Path, fmt: str, topic: str, readable: bool) -> Iterator[Scan]:
    """Yield the scans of ``topic``; raise CorruptFileError after the last good one."""
    n_read = 0
    if readable:
        reader = _open(path)
        try:
            conns = [c for c in reader.connections if c.topic == topic]
            try:
                for conn, stamp, raw in reader.messages(connections=conns):
                    msg = reader.deserialize(raw, conn.msgtype)
                    yield _scan_from(msg, stamp)
                    n_read += 1
            except Exception as exc:  # noqa: BLE001 - rosbags raises many kinds on damaged data
                raise CorruptFileError(path, f"after message {n_read} of {topic}", n_read,
                                       f"{type(exc).__name__}: {exc}") from exc
        finally:
            reader.close()
        return
    gen = _salvager(fmt)(_storage_file(path, fmt), topic)
    try:
        while True:
            _name, stamp, msg = next(gen)
            yield _scan_from(msg, stamp)
            n_read += 1
    except StopIteration as stop:
        where = stop.value or "somewhere"
    except Exception as exc:  # noqa: BLE001 - a garbled message that slipped through the framing
        where = f"in message {n_read + 1} ({type(exc).__name__}: {exc})"
    raise CorruptFileError(path, where, n_read, "rosbags could not open it; read sequentially")


# ============================================================================ writing
def _check_uniform(scan: Scan, index: int) -> float:
    if scan.n_beams < 2:
        return 0.0
    inc = scan.angle_increment
    expected = scan.angles[0] + inc * np.arange(scan.n_beams)
    if np.max(np.abs(scan.angles - expected)) > _ANGLE_TOL:
        raise ValueError(
            f"scans[{index}] has unevenly spaced angles; a sensor_msgs/LaserScan needs a constant "
            "angle_increment (resample the scan first)"
        )
    return inc


def _message(typestore, scan: Scan, seq: int, ros1: bool):
    t = typestore.types
    sec, nsec = divmod(int(scan.stamp_ns), 1_000_000_000)
    stamp = t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)
    header_kw = {"seq": seq} if ros1 else {}
    header = t["std_msgs/msg/Header"](stamp=stamp, frame_id=scan.frame_id, **header_kw)
    inc = _check_uniform(scan, seq)
    intensities = scan.intensities if scan.intensities is not None else np.zeros(0)
    return t[_MSGTYPE](
        header=header,
        angle_min=float(scan.angles[0]) if scan.n_beams else 0.0,
        angle_max=float(scan.angles[-1]) if scan.n_beams else 0.0,
        angle_increment=float(inc),
        time_increment=0.0,
        scan_time=0.0,
        range_min=float(scan.range_min),
        range_max=float(scan.range_max),
        ranges=np.asarray(scan.ranges, dtype=np.float32),
        intensities=np.asarray(intensities, dtype=np.float32),
    )


def write_bag(
    scans: Iterable[Scan],
    path: str | Path,
    format: str | None = None,
    *,
    topic: str = "/scan",
    overwrite: bool = False,
) -> int:
    """Write scans as ``sensor_msgs/LaserScan`` messages; return how many were written.

    Parameters
    ----------
    scans : iterable of Scan
        Scans with evenly spaced angles (a LaserScan stores ``angle_min`` and a constant
        ``angle_increment``). Each scan's ``stamp_ns`` is both the header stamp and the
        bag's receive time.
    path : str or Path
        ``.bag`` for ROS1; ``.mcap`` for a single MCAP file; any other name is a ROS2
        bag folder (sqlite3, or MCAP with ``format="mcap"``).
    format : {"ros1", "ros2", "mcap"}, optional
        Inferred from ``path`` when omitted.
    topic : str
        Topic name, default ``"/scan"``.
    overwrite : bool
        Replace an existing file or folder (rosbags refuses to by default).

    If iterating ``scans`` raises (a damaged input being converted), the bag is closed
    with every scan written so far and the error propagates.
    """
    path = Path(path)
    fmt = format or ("ros1" if path.suffix == ".bag" else "mcap" if path.suffix == ".mcap" else "ros2")
    if fmt not in BAG_FORMATS:
        raise ValueError(f"format must be one of {BAG_FORMATS}, got {format!r}")
    if not topic.startswith("/"):
        raise ValueError(f"topic must start with '/', got {topic!r}")
    if path.exists():
        if not overwrite:
            raise ValueError(f"{path} exists; pass overwrite=True to replace it")
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "ros1":
        return _write_ros1(scans, path, topic)
    if fmt == "mcap" and path.suffix == ".mcap":
        # rosbags writes MCAP inside a rosbag2 folder; a bare .mcap file is what most tools
        # (Foxglove, rosbags, `ros2 bag` with the MCAP plugin) open directly.
        with tempfile.TemporaryDirectory(prefix=".labkit-", dir=path.parent) as tmp:
            folder = Path(tmp) / path.stem
            try:
                return _write_ros2(scans, folder, topic, rosbag2.StoragePlugin.MCAP)
            finally:
                written = folder / f"{path.stem}.mcap"
                if written.exists():
                    written.replace(path)
    plugin = rosbag2.StoragePlugin.MCAP if fmt == "mcap" else rosbag2.StoragePlugin.SQLITE3
    return _write_ros2(scans, path, topic, plugin)


def _write_all(writer, conn, scans, serialize) -> int:
    """Write every scan; if the input fails part-way, close the bag properly (rosbags
    aborts a bag left by an exception) with what was written, then re-raise."""
    count = 0
    try:
        for scan in scans:
            writer.write(conn, int(scan.stamp_ns), serialize(scan, count))
            count += 1
    except BaseException:
        writer.close()
        raise
    writer.close()
    return count


def _write_ros1(scans, path: Path, topic: str) -> int:
    ts = _typestore(ros1=True)
    writer = rosbag1.Writer(path)
    writer.open()
    conn = writer.add_connection(topic, _MSGTYPE, typestore=ts)
    return _write_all(writer, conn, scans,
                      lambda scan, k: ts.serialize_ros1(_message(ts, scan, k, True), _MSGTYPE))


def _write_ros2(scans, path: Path, topic: str, plugin) -> int:
    ts = _typestore(ros1=False)
    writer = rosbag2.Writer(path, version=9, storage_plugin=plugin)
    writer.open()
    conn = writer.add_connection(topic, _MSGTYPE, typestore=ts)
    return _write_all(writer, conn, scans,
                      lambda scan, k: ts.serialize_cdr(_message(ts, scan, k, False), _MSGTYPE))
