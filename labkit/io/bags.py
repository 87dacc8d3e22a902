"""ROS bags in and out: ROS1 ``.bag``, ROS2 sqlite3 folders and MCAP, through rosbags.

Reading: ROS1 bags and MCAP files are read front to back by labkit's walkers
(:mod:`labkit.io.salvage`), which keep every message that can be read and resynchronise past
damage; rosbags opens their index only to list the topics and how many messages each holds, the
count against which the scans read are checked (a scan the index lists but the walk did not find
is a scan lost, and said so). ROS2 sqlite3 folders are read through rosbags'
``AnyReader``; a database it cannot read is read row by row. Either way a damaged file yields
every scan that could be read and then raises :class:`~labkit.io.CorruptFileError` saying where
the damage is, how many scans were kept and how many were lost.
"""

from __future__ import annotations

import contextlib
import itertools
import shutil
import warnings
from collections import Counter
from collections.abc import Callable, Generator, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from rosbags import rosbag1, rosbag2
from rosbags.highlevel import AnyReader

from .._safe import OutputKind, safe_output, starts_with
from ..errors import RefusedError
from ..poses import quaternion_from_yaw
from ..scan import Scan
from . import salvage
from .faults import CorruptFileError, EmptyRecordingError, Faults

#: Where labkit's bag writers put the scans' poses, and the frame they are in (labkit.io.pose_topics reads them).
ODOM_TOPIC = "/odom"
ODOM_FRAME = "map"

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
    """The topics a damaged bag declares (with the messages found intact, for ROS1 and MCAP); a
    bag too damaged to declare any is a :class:`CorruptFileError` (0 scans read), not an empty bag."""
    if fmt in salvage.WALKERS:
        walker, faults = salvage.walk_topics(path, fmt)
        seen: dict[str, str] = {c.topic: c.msgtype for c in walker.connections.values()}
        if not seen and faults:
            raise CorruptFileError(path, faults[0].where, 0, faults[0].reason, lost_exact=False)
        return sorted((name, msgtype, None) for name, msgtype in seen.items())
    seen = {}
    gen = salvage.salvage_sqlite3(path, None, want_topics=True, known=_metadata_topics(path.parent))
    first_fault = None
    while True:
        try:
            item = next(gen)
        except StopIteration as stop:
            first_fault = first_fault or stop.value
            break
        if isinstance(item, salvage.Fault):
            first_fault = first_fault or item
        else:
            name, _stamp, msgtype = item
            seen.setdefault(name, msgtype)
    if not seen and first_fault is not None:
        raise CorruptFileError(path, first_fault.where, 0, first_fault.reason, lost_exact=False)
    return sorted((name, msgtype, None) for name, msgtype in seen.items())


def storage_file(path: Path, fmt: str) -> Path:
    """The file a salvage reader walks: the bag itself or the storage file in a folder."""
    if path.is_file():
        return path
    suffix = ".db3" if fmt == "ros2" else ".mcap"
    files = sorted(path.glob(f"*{suffix}"))
    if not files:
        raise ValueError(f"{path} holds no {suffix} file")
    return files[0]


def list_topics(path: str | Path, fmt: str) -> tuple[list[tuple[str, str, int | None]], bool]:
    """Topics ``(name, msgtype, count)`` of a bag and whether rosbags could open it. The counts
    are the index's (None when it cannot be read; a ROS2 folder's metadata.yaml says them even
    when its database is damaged)."""
    path = Path(path)
    try:
        return _topics_via_rosbags(path), True
    except Exception:  # noqa: BLE001 - any failure to open means: try the sequential reader
        topics = _topics_via_salvage(storage_file(path, fmt), fmt)
    counts = _metadata_counts(path) if path.is_dir() else {}
    return [(name, msgtype, counts.get(name)) for name, msgtype, _ in topics], False


def _metadata_counts(folder: Path) -> dict[str, int]:
    """Messages per topic as a ROS2 bag folder's metadata.yaml lists them ({} if it cannot be read)."""
    return {name: count for name, _type, count in _metadata(folder)}


def _metadata_topics(folder: Path) -> list[tuple[str, str]]:
    return [(name, msgtype) for name, msgtype, _count in _metadata(folder)]


def _metadata(folder: Path) -> list[tuple[str, str, int]]:
    """``(topic, type, message count)`` as a ROS2 bag folder's metadata.yaml lists them, in its
    order ([] if it cannot be read)."""
    from ruamel.yaml import YAML  # rosbags reads metadata.yaml with it

    try:
        info = YAML(typ="safe").load((folder / "metadata.yaml").read_text(encoding="utf-8"))
        return [(t["topic_metadata"]["name"], t["topic_metadata"]["type"], int(t["message_count"]))
                for t in info["rosbag2_bagfile_information"]["topics_with_message_count"]]
    except Exception:  # noqa: BLE001 - a missing or damaged metadata.yaml: none
        return []


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
    if not topics:
        raise EmptyRecordingError(f"{path} is an empty bag: it has no topics and no messages")
    if not scans:
        raise ValueError(f"{path} has no sensor_msgs/LaserScan topic; its topics are: {listing}")
    if len(scans) > 1:
        names = ", ".join(t[0] for t in scans)
        raise RefusedError(f"{path} has several LaserScan topics ({names}); choose one with topic=...",
                           f"{path} has several LaserScan topics ({names}); choose one with --topic")
    return scans[0][0]


def _stamp_of(msg) -> int:
    """The header stamp of a ROS1 (``secs``/``nsecs``) or ROS2 (``sec``/``nanosec``) message, ns."""
    stamp = msg.header.stamp
    sec = getattr(stamp, "sec", None)
    nsec = getattr(stamp, "nanosec", None)
    return int(stamp.secs if sec is None else sec) * 1_000_000_000 + int(stamp.nsecs if nsec is None else nsec)


def _check_span(msg) -> None:
    """A LaserScan whose beam count disagrees with its angle span is refused (a skipped, counted
    record), not read with ``angle_max`` silently changed: ``angle_min + (n - 1) * angle_increment``
    must be ``angle_max`` to within one beam (drivers differ on whether ``angle_max`` is the last
    beam or the end of its sector)."""
    try:
        n, inc = len(msg.ranges), float(msg.angle_increment)
        span = float(msg.angle_max) - float(msg.angle_min)
    except (AttributeError, TypeError):
        return  # not a LaserScan: Scan.from_ros says so
    if n < 2 or inc == 0 or not np.isfinite(span) or not np.isfinite(inc):
        return  # Scan.from_ros refuses an impossible increment itself
    implied = span / inc + 1
    if abs(implied - n) > 1.001:
        raise ValueError(f"the scan has {n} ranges but its angles span {np.degrees(span):.6g} deg in steps of "
                         f"{np.degrees(inc):.6g} deg ({implied:.6g} beams)")


def _scan_from(msg, receive_ns: int, poses=None) -> Scan:
    """The scan of a LaserScan message the bag received at ``receive_ns``. A header stamp of 0
    (drivers that leave it empty) is replaced by the receive time. ``poses`` (see
    :func:`iter_bag`) gives the sensor's pose at the scan's stamp. A message whose beam count
    disagrees with its angle span is refused (:func:`_check_span`)."""
    _check_span(msg)
    if poses is None:
        scan = Scan.from_ros(msg, receive_ns=receive_ns)
        return scan.replace(stamp_ns=receive_ns) if scan.stamp_ns == 0 and receive_ns else scan
    try:
        stamp = _stamp_of(msg) or receive_ns
        pose = poses.pose_at(stamp, msg.header.frame_id)
    except AttributeError as exc:
        raise ValueError(f"msg is not a sensor_msgs/LaserScan message: {exc}") from None
    scan = Scan.from_ros(msg, pose=pose, receive_ns=receive_ns)
    return scan.replace(stamp_ns=receive_ns) if scan.stamp_ns == 0 and receive_ns else scan


def iter_bag(path: Path, fmt: str, topic: str, readable: bool, strict: bool = False, poses=None,
             expected: int | None = None) -> Iterator[Scan]:
    """Yield the scans of ``topic``; a message that does not decode or holds impossible
    fields (``angle_increment`` 0, ...) is skipped and counted; after the last good scan,
    raise :class:`CorruptFileError` if anything was skipped or lost (``strict``: stop at the
    first damage).

    ``expected`` is how many scans the bag's index lists (when it is intact): the scans lost are
    then counted exactly, and a scan the index lists that the walk did not find is a loss too.

    ``poses`` (a :class:`labkit.io.pose_topics.BagPoses`, read beforehand) gives every scan its
    sensor pose, and brings the faults met while reading the poses: they count with the
    scans' own (once each), and with ``strict`` reading stops at the first scan after the
    last pose read before a fault.
    """
    faults = Faults(path, strict, expected)
    n_read = 0
    messages = read_messages(path, fmt, {topic: _MSGTYPE}, readable, faults, lambda _t, stamp, msg: _scan_from(
        msg, stamp, poses), salvage_topic=topic)
    try:
        for scan in messages:
            if poses is not None and poses.stops_before(scan.stamp_ns):
                where, reason = poses.first_fault
                faults.skip(where, reason, count=0)
                break
            yield scan
            n_read += 1
    finally:
        messages.close()
    if poses is not None and poses.faults:
        faults.merge(poses.faults)
    faults.check(n_read)


def read_messages(path: Path, fmt: str, topics: dict[str, str], readable: bool, faults: Faults,
                  convert: Callable, *, salvage_topic: str | frozenset[str] | None = None
                  ) -> Generator[Any, None, None]:
    """``convert(topic, receive_ns, message)`` for every message on ``topics`` (name -> message
    type), in the bag's order; a message that does not decode, or that ``convert`` refuses (any
    exception), is skipped and noted in ``faults`` (whose strictness decides whether to read on),
    and so is every damaged place of the file.

    ROS1 and MCAP: labkit's walker (:mod:`labkit.io.salvage`), in file order. ROS2 sqlite3:
    rosbags, in time order; if rosbags stops part-way, the rest is read row by row
    (``salvage_topic`` tells it what to yield, by default the names of ``topics``), skipping what
    rosbags already gave.
    """
    what = next(iter(topics)) if len(topics) == 1 else ", ".join(sorted(topics))
    if fmt in salvage.WALKERS:
        yield from _walk_messages(path, fmt, topics, faults, convert, what,
                                  frozenset(topics) if salvage_topic is None else salvage_topic)
        return
    done: Counter[tuple[str, int]] = Counter()  # messages read through rosbags, not to be read twice
    if readable:
        reader = _open(path)
        failure = None
        try:
            messages = reader.messages(connections=[c for c in reader.connections if c.topic in topics])
            for k in itertools.count(1):
                try:
                    conn, stamp, raw = next(messages)
                except StopIteration:
                    break
                except Exception as exc:  # noqa: BLE001 - rosbags raises many kinds on damaged data
                    failure = f"after message {k - 1} of {what}", f"{type(exc).__name__}: {exc}"
                    break
                try:
                    item = convert(conn.topic, stamp, reader.deserialize(raw, conn.msgtype))
                except Exception as exc:  # noqa: BLE001 - a garbled message: skip it
                    if not faults.skip(f"in message {k} of {what}", _why(exc)):
                        return
                    continue
                yield item
                done[conn.topic, stamp] += 1
        finally:
            reader.close()
        if failure is None or not faults.skip(*failure, count=0, known=False):
            return
    gen = salvage.salvage_sqlite3(storage_file(path, fmt), frozenset(topics) if salvage_topic is None
                                  else salvage_topic, known=_metadata_topics(path) if path.is_dir() else ())
    k = 0
    try:
        while True:
            try:
                item = next(gen)
            except StopIteration as stop:
                if stop.value is not None:
                    faults.skip(stop.value.where, stop.value.reason, 0, open_end=stop.value.open_end, known=False)
                return
            if isinstance(item, salvage.Fault):
                if not faults.skip(item.where, item.reason, 0, known=False, open_end=item.open_end):
                    return
                continue
            name, stamp, raw = item
            k += 1
            if done[name, stamp]:
                done[name, stamp] -= 1
                continue
            try:
                item = convert(name, stamp, _deserialize(fmt, raw, topics.get(name, _MSGTYPE)))
            except Exception as exc:  # noqa: BLE001 - a garbled message that slipped through the framing
                if not faults.skip(f"in message {k} of {what}", _why(exc)):
                    return
                continue
            yield item
    finally:
        gen.close()


def _walk_messages(path: Path, fmt: str, topics: dict[str, str], faults: Faults, convert: Callable, what: str,
                   chosen) -> Iterator:
    """:func:`read_messages` for ROS1 and MCAP: the walker's messages and faults, then its books."""
    walker = salvage.WALKERS[fmt](storage_file(path, fmt), chosen)
    k = 0
    messages = walker.messages()
    try:
        for item in messages:
            if isinstance(item, salvage.Fault):
                if not faults.skip(item.where, item.reason, item.count, known=False, open_end=item.open_end):
                    return
                continue
            name, stamp, raw, where = item
            k += 1
            try:
                item = convert(name, stamp, _deserialize(fmt, raw, topics.get(name, _MSGTYPE)))
            except Exception as exc:  # noqa: BLE001 - a garbled message that slipped through the framing
                if not faults.skip(f"{where} (message {k} of {what})", _why(exc)):
                    return
                continue
            yield item
    finally:
        messages.close()
    faults.lose(sum(walker.lost[name] for name in topics))
    if walker.index_counts is not None:  # the file's own index, as the walker read it (rosbags counts the
        faults.expected = sum(walker.index_counts[name] for name in topics)  # chunks it could open, if any)


def _why(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}" if not isinstance(exc, ValueError) else str(exc)


def _typename(msgtype: str) -> str:
    """The typestore's name of a message type: ``nav_msgs/Odometry`` -> ``nav_msgs/msg/Odometry``."""
    pkg, _, name = msgtype.rpartition("/")
    return msgtype if pkg.endswith("/msg") or not pkg else f"{pkg}/msg/{name}"


def _deserialize(fmt: str, raw: bytes, msgtype: str = _MSGTYPE):
    if fmt == "ros1":
        return _typestore(ros1=True).deserialize_ros1(raw, _typename(msgtype))
    return _typestore(ros1=False).deserialize_cdr(raw, _typename(msgtype))


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


# What each format's time fields hold, in nanoseconds: the header stamp (builtin_interfaces/Time:
# rosbags writes sec as int32 for ROS1 too, and ROS1 time is unsigned, so ROS1 keeps 0..2^31 s)
# and the receive time (ROS1 record time: uint32 s + uint32 ns; MCAP log_time: uint64 ns; the
# ROS2 sqlite3 column: int64 ns).
_S = 1_000_000_000
STAMP_RANGE_NS = {"ros1": (0, 2**31 * _S), "ros2": (-(2**31) * _S, 2**31 * _S), "mcap": (-(2**31) * _S, 2**31 * _S)}
RECEIVE_RANGE_NS = {"ros1": (0, 2**32 * _S), "ros2": (-(2**63), 2**63), "mcap": (0, 2**64)}
_FORMAT_NAMES = {"ros1": "a ROS1 bag", "ros2": "a ROS2 bag", "mcap": "an MCAP bag"}


class StampRangeError(RefusedError):
    """A scan's time stamp does not fit the time fields of the bag format being written."""


class StampsChangedWarning(UserWarning):
    """A writer changed time stamps on purpose so that the output holds them (see ``plan_stamps``)."""


def stamps_fit(fmt: str, stamp_ns: int, receive_ns: int) -> bool:
    """Whether a bag of format ``fmt`` can hold these header and receive times."""
    (lo, hi), (rlo, rhi) = STAMP_RANGE_NS[fmt], RECEIVE_RANGE_NS[fmt]
    return lo <= stamp_ns < hi and rlo <= receive_ns < rhi


def plan_stamps(scans: Iterable[Scan], fmt: str) -> tuple[Callable[[Scan, int], Scan], str | None]:
    """How to stamp ``scans`` (one pass over them) so that a bag of format ``fmt`` holds them.

    Returns ``(restamp, note)``: ``restamp(scan, k)`` gives the scan to write as the ``k``-th,
    and ``note`` says what was changed (None when nothing was). The rule:

    1. every stamp (header and receive time) fits: nothing changes;
    2. else, if one offset added to every stamp makes them all fit: they are shifted so that the
       earliest is 0 s (the note gives the offset, so the original stamps can be recovered);
    3. else (they span more than the format's time fields hold, e.g. a log with garbage stamps):
       scan ``k`` is stamped ``k`` times the median positive step between the stamps (0.1 s when
       there is none; clipped to 1 ms..10 s), from 0 s; the note says so. The log's own stamps
       are not in that copy.
    """
    stamps, receives = [], []
    for scan in scans:
        stamps.append(int(scan.stamp_ns))
        receives.append(int(scan.receive_ns if scan.receive_ns is not None else scan.stamp_ns))
    if not stamps:
        return (lambda scan, k: scan), None
    what = _FORMAT_NAMES[fmt]
    if all(stamps_fit(fmt, s, r) for s, r in zip(stamps, receives, strict=True)):
        return (lambda scan, k: scan), None
    lo = min(min(stamps), min(receives))
    if all(stamps_fit(fmt, s - lo, r - lo) for s, r in zip(stamps, receives, strict=True)):
        def shifted(scan: Scan, k: int) -> Scan:
            receive = scan.receive_ns if scan.receive_ns is not None else scan.stamp_ns
            return scan.replace(stamp_ns=scan.stamp_ns - lo, receive_ns=receive - lo)

        return shifted, (f"the stamps do not fit {what} as they are: every stamp was shifted by {-lo / _S:+.9g} s "
                         f"(the earliest is now 0 s); subtract that to get the original stamps back")
    steps = np.diff(np.asarray(stamps, dtype=np.float64))
    step_ns = int(np.clip(np.median(steps[steps > 0]) if np.any(steps > 0) else 1e8, 1e6, 1e10))

    def renumbered(scan: Scan, k: int) -> Scan:
        return scan.replace(stamp_ns=k * step_ns, receive_ns=k * step_ns)

    span = (max(max(stamps), max(receives)) - lo) / _S
    return renumbered, (f"the stamps span {span:.6g} s, more than {what} can hold: scan k was stamped k x "
                        f"{step_ns / _S:g} s from 0 s; the original stamps are not in this copy")


def _check_stamps(fmt: str, scan: Scan, receive_ns: int, index: int) -> None:
    if not stamps_fit(fmt, scan.stamp_ns, receive_ns):
        (lo, hi), (rlo, rhi) = STAMP_RANGE_NS[fmt], RECEIVE_RANGE_NS[fmt]
        raise StampRangeError(
            f"scan {index} has stamp {scan.stamp_ns / _S:.9g} s (received {receive_ns / _S:.9g} s), which "
            f"{_FORMAT_NAMES[fmt]} cannot hold (stamps {lo / _S:g}..{hi / _S:g} s, receive times "
            f"{rlo / _S:g}..{rhi / _S:g} s); labkit.convert shifts or renumbers such stamps, or shift them yourself")


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
        time_increment=float(scan.time_increment),
        scan_time=float(scan.scan_time),
        range_min=float(scan.range_min),
        range_max=float(scan.range_max),
        ranges=np.asarray(scan.ranges, dtype=np.float32),
        intensities=np.asarray(intensities, dtype=np.float32),
    )


_BAG_FILES = ("metadata.yaml", ".db3", ".db3-shm", ".db3-wal", ".db3-journal", ".mcap")


def _is_bag_folder(path: Path) -> bool:
    """A ROS2 bag folder and nothing else: metadata.yaml plus storage files, no other entry."""
    try:
        meta = (path / "metadata.yaml").read_text(encoding="utf-8", errors="replace")
        entries = list(path.iterdir())
    except OSError:
        return False
    return "rosbag2_bagfile_information" in meta and all(
        e.is_file() and not e.is_symlink() and (e.name == "metadata.yaml" or e.name.endswith(_BAG_FILES[1:]))
        for e in entries)


#: What each bag writer writes (see labkit._safe): how an existing output is recognised.
ROS1_BAG = OutputKind("a ROS1 bag (.bag)", (".bag",), starts_with(salvage._ROS1_MAGIC))
MCAP_FILE = OutputKind("an MCAP file (.mcap)", (".mcap",), starts_with(salvage._MCAP_MAGIC))
BAG_FOLDER = OutputKind("a ROS2 bag folder", (), _is_bag_folder, folder=True,
                        avoid=(".bag", ".mcap", ".json", ".jsonl", ".rrd", ".log", ".gz", ".clf", ".toml", ".db3",
                               ".png", ".csv", ".parquet", ".txt"))


def output_kind(path: Path, fmt: str) -> OutputKind:
    """The kind of output ``write_bag`` writes for ``path`` in format ``fmt``."""
    if fmt == "ros1":
        return ROS1_BAG
    return MCAP_FILE if fmt == "mcap" and path.name.lower().endswith(".mcap") else BAG_FOLDER


def bag_format(path: str | Path, format: str | None = None) -> str:
    """The bag format written for ``path``: ``format``, else from the name (``.bag`` ROS1,
    ``.mcap`` MCAP, anything else a ROS2 sqlite3 folder). A ``format`` that contradicts the
    name (``.bag`` with ``"mcap"``) is refused."""
    path = Path(path)
    name = path.name.lower()
    guess = "ros1" if name.endswith(".bag") else "mcap" if name.endswith(".mcap") else "ros2"
    if format is None:
        return guess
    if format not in BAG_FORMATS:
        raise ValueError(f"format must be one of {BAG_FORMATS}, got {format!r}")
    if (name.endswith(".bag") and format != "ros1") or (format == "ros1" and not name.endswith(".bag")) or (
            name.endswith(".mcap") and format != "mcap"):
        raise RefusedError(f"{path}: the name says {_FORMAT_NAMES[guess]} but format={format!r}; name a ROS1 bag "
                           "*.bag, an MCAP file *.mcap and a ROS2 bag folder without a suffix",
                           f"{path}: the name says {_FORMAT_NAMES[guess]} but --format {format}; name a ROS1 bag "
                           "*.bag, an MCAP file *.mcap and a ROS2 bag folder without a suffix")
    return format


def write_bag(
    scans: Iterable[Scan],
    path: str | Path,
    format: str | None = None,
    *,
    topic: str = "/scan",
    overwrite: bool = False,
    inputs: Iterable[str | Path] = (),
    pose_topic: str | None = "/odom",
) -> int:
    """Write scans as ``sensor_msgs/LaserScan`` messages; return how many were written.

    Parameters
    ----------
    scans : iterable of Scan
        Scans with evenly spaced angles (a LaserScan stores ``angle_min`` and a constant
        ``angle_increment``). Each scan's ``stamp_ns`` is the header stamp; the bag's receive
        time is its ``receive_ns`` (its stamp when None), raised where it would go back in
        time so that readers, which order a bag by receive time, keep the scans in order
        (a :class:`StampsChangedWarning` says how many). A stamp the format cannot hold is
        refused (``StampRangeError``; :func:`labkit.io.convert` shifts such stamps).
    path : str or Path
        ``.bag`` for ROS1; ``.mcap`` for a single MCAP file; any other name is a ROS2
        bag folder (sqlite3, or MCAP with ``format="mcap"``).
    format : {"ros1", "ros2", "mcap"}, optional
        Inferred from ``path`` when omitted.
    topic : str
        Topic name, default ``"/scan"``.
    overwrite : bool
        Replace an existing bag (only a bag: see ``labkit._safe`` for the rules).
    inputs : iterable of paths
        Files being read to make ``scans``: the output may not be one of them.
    pose_topic : str or None
        Where the pose of every scan that has one goes, as ``nav_msgs/Odometry`` at the scan's
        stamp (frame ``map``, child frame the scan's ``frame_id``: the sensor itself, so no
        mounting transform is needed); default ``/odom``. None: poses are not written.

    Returns
    -------
    int
        The number of scans written.

    Notes
    -----
    The bag is written under a temporary name beside ``path`` and renamed when complete.
    If iterating ``scans`` raises :class:`~labkit.io.CorruptFileError` (a damaged input
    being converted), the bag holds every scan before it and the error propagates.
    """
    path = Path(path)
    fmt = bag_format(path, format)
    for name, value in (("topic", topic), ("pose_topic", pose_topic or "/")):
        if not value.startswith("/"):
            raise ValueError(f"{name} must start with '/', got {value!r}")
    if pose_topic == topic:
        raise ValueError(f"pose_topic and topic must differ, both are {topic!r}")
    with safe_output(path, output_kind(path, fmt), overwrite=overwrite, inputs=inputs) as tmp, _system_errors(path):
        if fmt == "ros1":
            return _write_ros1(scans, tmp, topic, pose_topic)
        if fmt == "mcap" and path.name.lower().endswith(".mcap"):
            # rosbags writes MCAP inside a rosbag2 folder; a bare .mcap file is what most tools
            # (Foxglove, rosbags, `ros2 bag` with the MCAP plugin) open directly.
            folder = tmp.parent / path.stem  # the name rosbags records inside the file
            try:
                return _write_ros2(scans, folder, topic, rosbag2.StoragePlugin.MCAP, fmt, pose_topic)
            finally:
                written = folder / f"{path.stem}.mcap"
                if written.exists():
                    written.replace(tmp)
        plugin = rosbag2.StoragePlugin.MCAP if fmt == "mcap" else rosbag2.StoragePlugin.SQLITE3
        return _write_ros2(scans, tmp, topic, plugin, fmt, pose_topic)


@contextlib.contextmanager
def whole_writes() -> Iterator[None]:
    """Ctrl-C waits until the message being written is written whole: rosbags notes a message in
    the bag's index before it writes its data, so an interruption in between leaves a partial
    bag whose index lists a message that is not there (readers then count it lost)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pressed: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: pressed.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        raise KeyboardInterrupt


@contextlib.contextmanager
def _system_errors(path: Path):
    """What the system refused while a bag was written, as the OSError it is: sqlite says "database
    or disk is full" (a ROS2 folder on a full disk), rosbags wraps an OSError in its WriterError.
    The command line then exits 3 with one line, and safe_output removes the temporary output."""
    import errno
    import sqlite3

    try:
        yield
    except sqlite3.Error as exc:
        text = str(exc).lower()
        if "full" in text:
            raise OSError(errno.ENOSPC, "No space left on device", str(path)) from exc
        if "readonly" in text or "read-only" in text or "unable to open" in text or "disk i/o" in text:
            raise OSError(errno.EIO, f"the database could not be written ({exc})", str(path)) from exc
        raise
    except (rosbag1.WriterError, rosbag2.WriterError) as exc:
        cause = exc.__cause__ or exc.__context__
        if isinstance(cause, OSError):
            raise cause from exc
        raise


def _odometry(typestore, scan: Scan, seq: int, ros1: bool):
    """The scan's pose as a ``nav_msgs/Odometry`` message: the sensor frame (child) in ``map``."""
    t = typestore.types
    sec, nsec = divmod(int(scan.stamp_ns), 1_000_000_000)
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                      frame_id=ODOM_FRAME, **({"seq": seq} if ros1 else {}))
    if scan.pose is None:
        raise ValueError("a scan without a pose has no odometry")
    x, y, theta = scan.pose
    qx, qy, qz, qw = quaternion_from_yaw(theta)
    pose = t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                       orientation=t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw))
    zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return t[_ODOMETRY](
        header=header, child_frame_id=scan.frame_id,
        pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                                                         covariance=np.zeros(36)))


_ODOMETRY = "nav_msgs/msg/Odometry"


def _write_all(writer, conn, scans, typestore, serialize, fmt: str, pose_topic: str | None) -> int:
    """Write every scan (and, on ``pose_topic``, the pose of each scan that has one); if the
    input fails part-way, close the bag properly (rosbags aborts a bag left by an exception)
    with what was written, then re-raise."""
    ros1 = fmt == "ros1"
    count = raised = 0
    last = None
    poses = None  # the odometry connection, added with the first pose
    try:
        for scan in scans:
            receive = int(scan.receive_ns if scan.receive_ns is not None else scan.stamp_ns)
            if last is not None and receive < last:
                receive, raised = last, raised + 1
            _check_stamps(fmt, scan, receive, count)
            message = serialize(_message(typestore, scan, count, ros1), _MSGTYPE)
            with whole_writes():
                writer.write(conn, receive, message)
            if scan.pose is not None and pose_topic is not None:
                if poses is None:
                    poses = writer.add_connection(pose_topic, _ODOMETRY, typestore=typestore)
                message = serialize(_odometry(typestore, scan, count, ros1), _ODOMETRY)
                with whole_writes():
                    writer.write(poses, receive, message)
            last = receive
            count += 1
    except BaseException:
        writer.close()
        raise
    writer.close()
    if raised:
        warnings.warn(f"{raised} of {count} receive times went back in time and were raised to the one before, so "
                      "that readers keep the scans in order", StampsChangedWarning, stacklevel=3)
    return count


def _open_writer(writer, path: Path, topic: str, typestore):
    """Open a rosbags writer and add the LaserScan connection. Interrupted (or failing) before
    that is done, the half-made bag is removed: there is nothing in it to keep."""
    try:
        writer.open()
        return writer.add_connection(topic, _MSGTYPE, typestore=typestore)
    except BaseException:
        with contextlib.suppress(Exception):
            writer.close()
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
        raise


def _write_ros1(scans, path: Path, topic: str, pose_topic: str | None) -> int:
    ts = _typestore(ros1=True)
    writer = rosbag1.Writer(path)
    conn = _open_writer(writer, path, topic, ts)
    return _write_all(writer, conn, scans, ts, ts.serialize_ros1, "ros1", pose_topic)


def _write_ros2(scans, path: Path, topic: str, plugin, fmt: str, pose_topic: str | None) -> int:
    ts = _typestore(ros1=False)
    writer = rosbag2.Writer(path, version=9, storage_plugin=plugin)
    conn = _open_writer(writer, path, topic, ts)
    return _write_all(writer, conn, scans, ts, ts.serialize_cdr, fmt, pose_topic)
