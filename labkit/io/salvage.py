"""Sequential readers for damaged bags, used when rosbags cannot open a file.

rosbags opens a ROS1 bag through its index (at the end of the file), an MCAP file
through its footer, and a ROS2 sqlite3 database through sqlite, so a recording cut
short (a crashed recorder, an interrupted copy) does not open at all. These readers walk
the file from the start instead, record by record, yield every ``sensor_msgs/LaserScan``
message that is complete, and then report where the file broke.

Each reader yields ``(topic, receive_ns, raw_bytes)`` for every LaserScan message it finds
(or, given a set of topic names, every message on those: poses and transforms)
(the caller deserialises them, and skips a message that does not decode), and a
:class:`Fault` for every damaged part it skips: a chunk that does not decompress, a record
whose header is garbled, a database row sqlite cannot read. It goes on past a fault whenever
the file's framing lets it find the next record, and finally returns a :class:`Fault` saying
where the file ends early (or None when it reached a proper end). The caller counts them
(:class:`labkit.io.errors.Faults`).
"""

from __future__ import annotations

import bz2
import contextlib
import mmap
import sqlite3
import struct
import tempfile
from collections.abc import Generator
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import lz4.frame
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

try:  # the same zstd rosbags itself uses
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:  # Python < 3.14
    from backports import zstd  # type: ignore[import-not-found,no-redef]

LASERSCAN_TYPES = {"sensor_msgs/LaserScan", "sensor_msgs/msg/LaserScan"}
_MSGTYPE = "sensor_msgs/msg/LaserScan"


def wanted(name: str, msgtype: str, topic: str | frozenset[str] | None) -> bool:
    """Whether a reader yields a message of topic ``name``: with ``topic`` a set of names, any
    message on them (poses, transforms); else a LaserScan message (on ``topic``, if one is named)."""
    if isinstance(topic, frozenset):
        return name in topic
    return msgtype in LASERSCAN_TYPES and (topic is None or name == topic)



@dataclass(frozen=True)
class Fault:
    """A damaged part of a file: where, what, and how many records it cost (0: none lost)."""

    where: str
    reason: str
    count: int = 1


Salvage = Generator["tuple[str, int, bytes | str] | Fault", None, "Fault | None"]


@lru_cache(maxsize=2)
def typestore(ros1: bool):
    """The rosbags typestore for ROS1 (Noetic) or ROS2 (Humble) messages, built once:
    rosbags generates ~175 message classes for each. rosbags' Noetic store lacks
    ``tf2_msgs/TFMessage`` (the ``/tf`` message): it is added, as ROS defines it."""
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in store.types:
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    return store


def _decompress(data, compression: str, partial: bool) -> bytes:
    """Decompress a chunk; with ``partial``, as much of a cut-off chunk as possible."""
    data = bytes(data)
    if compression in ("", "none"):
        return data
    if compression == "bz2":
        return bz2.BZ2Decompressor().decompress(data) if partial else bz2.decompress(data)
    if compression == "lz4":
        return lz4.frame.LZ4FrameDecompressor().decompress(data) if partial else lz4.frame.decompress(data)
    if compression == "zstd":
        return zstd.ZstdDecompressor().decompress(data) if partial else zstd.decompress(data)
    raise ValueError(f"unknown chunk compression {compression!r}")


class _Truncated(Exception):
    def __init__(self, offset: int, what: str) -> None:
        super().__init__(what)
        self.offset = offset
        self.what = what


# ============================================================================ ROS1
_ROS1_MAGIC = b"#ROSBAG V2.0\n"


def _ros1_fields(header: bytes) -> dict[str, bytes]:
    fields, pos = {}, 0
    while pos < len(header):
        if pos + 4 > len(header):
            raise ValueError("header field length cut off")
        (n,) = struct.unpack_from("<I", header, pos)
        pos += 4
        if pos + n > len(header):
            raise ValueError("header field cut off")
        name, sep, value = header[pos : pos + n].partition(b"=")
        if not sep:
            raise ValueError("header field without '='")
        fields[name.decode("ascii", "replace")] = value
        pos += n
    return fields


def _ros1_records(buf, start: int, end: int, *, partial: bool = False):
    """Yield ``(offset, fields, data, complete)`` for the records in ``buf[start:end]``.

    With ``partial``, a last record whose data is cut off is still yielded (``complete``
    False, with the data that is there) before the truncation is raised.
    """
    pos = start
    while pos < end:
        if pos + 4 > end:
            raise _Truncated(pos, "a record header length is cut off")
        (hlen,) = struct.unpack_from("<I", buf, pos)
        if pos + 4 + hlen + 4 > end:
            raise _Truncated(pos, "a record header is cut off")
        try:
            fields = _ros1_fields(bytes(buf[pos + 4 : pos + 4 + hlen]))
        except ValueError as exc:
            raise _Truncated(pos, f"a record header is garbled ({exc})") from None
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        data_start = pos + 8 + hlen
        if data_start + dlen > end:
            if partial:
                yield pos, fields, buf[data_start:end], False
            raise _Truncated(pos, "a record's data is cut off")
        yield pos, fields, buf[data_start : data_start + dlen], True
        pos = data_start + dlen


def salvage_ros1(path: Path, topic: str | frozenset[str] | None, want_topics: bool = False) -> Salvage:
    """Walk a ROS1 bag's chunks in file order (see the ROS bag format 2.0)."""
    connections: dict[int, tuple[str, str]] = {}
    with open(path, "rb") as fh:
        size = Path(path).stat().st_size
        if size < len(_ROS1_MAGIC):
            return Fault("at byte 0", "the file is shorter than the bag magic")
        buf = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            if buf[: len(_ROS1_MAGIC)] != _ROS1_MAGIC:
                return Fault("at byte 0", "not a ROS1 bag (magic '#ROSBAG V2.0' missing)")
            indexed = False
            try:
                for offset, fields, data, complete in _ros1_records(buf, len(_ROS1_MAGIC), size, partial=True):
                    op = fields.get("op", b"\x00")[:1]
                    if op == b"\x05":  # chunk (the last one may be cut off: read what is there)
                        yield from _ros1_chunk(offset, fields, data, complete, connections, topic, want_topics)
                    elif op in (b"\x07", b"\x02") and complete:  # unchunked records (old bags)
                        yield from _ros1_record(offset, fields, data, connections, topic, want_topics)
                    elif op in (b"\x04", b"\x06"):  # index data, chunk info: the bag was closed properly
                        indexed = True
            except _Truncated as exc:
                return Fault(f"at byte {exc.offset}", exc.what)
            if indexed:
                return None
            return Fault(f"at byte {size}", "the file ends before its index (the recording was cut short)", 0)
        finally:
            buf.close()


_CHUNK_ERRORS = (OSError, ValueError, RuntimeError, EOFError, struct.error, UnicodeDecodeError)


def _chunk(offset: int, complete: bool, unpack, walk):
    """The records of one chunk (ROS1 or MCAP), with one rule for faults: a chunk that does not
    decompress, or whose records are garbled, is a :class:`Fault` and the walk goes on with the
    next chunk; a chunk cut off by the end of the file ends the walk (:class:`_Truncated`).

    ``unpack()`` returns ``(records, size)``: the decompressed records (as much as there is of a
    cut-off chunk) and the size the chunk header promises; ``walk(records)`` yields the items.
    """
    try:
        records, size = unpack()
    except _CHUNK_ERRORS as exc:
        if not complete:
            raise _Truncated(offset, f"the chunk at byte {offset} is cut off") from None
        yield Fault(f"at byte {offset}", f"a chunk does not decompress ({exc})")
        return
    try:
        yield from walk(records)
    except _Truncated as exc:
        if not complete or len(records) < size:
            raise _Truncated(offset, f"the chunk at byte {offset} is cut off") from None
        yield Fault(f"at byte {offset}", f"the chunk at byte {offset} is garbled ({exc.what})")


def _ros1_chunk(offset, fields, data, complete, connections, topic, want_topics):
    def unpack():
        (size,) = struct.unpack("<I", fields.get("size", b"\0\0\0\0")[:4])
        return _decompress(data, fields.get("compression", b"none").decode(), partial=not complete), size

    def walk(inner):
        for pos, ifields, idata, _ in _ros1_records(inner, 0, len(inner)):
            yield from _ros1_record(pos, ifields, idata, connections, topic, want_topics)

    return _chunk(offset, complete, unpack, walk)


def _ros1_record(offset, fields, data, connections, topic, want_topics):
    op = fields.get("op", b"\x00")[:1]
    try:
        if op == b"\x07":
            (conn,) = struct.unpack("<I", fields["conn"])
            conn_fields = _ros1_fields(bytes(data))
            connections[conn] = (fields["topic"].decode(), conn_fields.get("type", b"").decode())
            if want_topics:
                yield connections[conn][0], 0, connections[conn][1]
        elif op == b"\x02" and not want_topics:
            (conn,) = struct.unpack("<I", fields["conn"])
            name, msgtype = connections.get(conn, ("", ""))
            if wanted(name, msgtype, topic):
                sec, nsec = struct.unpack("<II", fields["time"])
                yield name, sec * 1_000_000_000 + nsec, bytes(data)
    except (KeyError, ValueError, struct.error, UnicodeDecodeError) as exc:
        yield Fault(f"in the record at byte {offset}", f"its header is garbled ({type(exc).__name__}: {exc})")


# ============================================================================ MCAP
_MCAP_MAGIC = b"\x89MCAP0\r\n"


def _mcap_str(buf, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, pos)
    return bytes(buf[pos + 4 : pos + 4 + n]).decode(), pos + 4 + n


def _mcap_records(buf, start: int, end: int, *, partial: bool = False):
    """Yield ``(offset, opcode, content, complete)``; see :func:`_ros1_records` for ``partial``."""
    pos = start
    while pos < end:
        if pos + 9 > end:
            raise _Truncated(pos, "a record header is cut off")
        op = buf[pos]
        (length,) = struct.unpack_from("<Q", buf, pos + 1)
        if pos + 9 + length > end:
            if partial:
                yield pos, op, buf[pos + 9 : end], False
            raise _Truncated(pos, "a record is cut off")
        yield pos, op, buf[pos + 9 : pos + 9 + length], True
        pos += 9 + length


def salvage_mcap(path: Path, topic: str | frozenset[str] | None, want_topics: bool = False) -> Salvage:
    """Walk an MCAP file's records in file order (see the MCAP specification)."""
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    with open(path, "rb") as fh:
        size = Path(path).stat().st_size
        if size < len(_MCAP_MAGIC):
            return Fault("at byte 0", "the file is shorter than the MCAP magic")
        buf = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        try:
            if buf[: len(_MCAP_MAGIC)] != _MCAP_MAGIC:
                return Fault("at byte 0", "not an MCAP file (magic missing)")

            def handle(offset, op, content):
                try:
                    if op == 0x03:  # schema
                        (sid,) = struct.unpack_from("<H", content, 0)
                        name, _ = _mcap_str(content, 2)
                        schemas[sid] = name
                    elif op == 0x04:  # channel
                        cid, sid = struct.unpack_from("<HH", content, 0)
                        name, _ = _mcap_str(content, 4)
                        channels[cid] = (name, schemas.get(sid, ""))
                        if want_topics:
                            yield name, 0, schemas.get(sid, "")
                    elif op == 0x05 and not want_topics:  # message
                        cid, _seq, log_time, _pub = struct.unpack_from("<HIQQ", content, 0)
                        name, msgtype = channels.get(cid, ("", ""))
                        if wanted(name, msgtype, topic):
                            yield name, log_time, bytes(content[22:])
                except (struct.error, UnicodeDecodeError) as exc:
                    yield Fault(f"in the record at byte {offset}", f"it is garbled ({exc})")

            try:
                for offset, op, content, complete in _mcap_records(buf, len(_MCAP_MAGIC), size, partial=True):
                    if op == 0x02:  # footer: the file is complete
                        return None
                    if op == 0x06:  # chunk (the last one may be cut off: read what is there)
                        yield from _mcap_chunk(offset, content, complete, handle)
                    elif complete:
                        yield from handle(offset, op, content)
            except _Truncated as exc:
                return Fault(f"at byte {exc.offset}", exc.what)
            return Fault(f"at byte {size}", "the file ends before its footer (the recording was cut short)", 0)
        finally:
            buf.close()


def _mcap_chunk(offset, content, complete, handle):
    def unpack():
        (size,) = struct.unpack_from("<Q", content, 16)
        compression, rpos = _mcap_str(content, 28)
        (rlen,) = struct.unpack_from("<Q", content, rpos)
        return _decompress(content[rpos + 8 : rpos + 8 + rlen], compression, partial=not complete), size

    def walk(records):
        for pos, iop, icontent, _ in _mcap_records(records, 0, len(records)):
            yield from handle(offset + pos, iop, icontent)

    return _chunk(offset, complete, unpack, walk)


# ============================================================================ sqlite3
def salvage_sqlite3(path: Path, topic: str | frozenset[str] | None, want_topics: bool = False) -> Salvage:
    """Read the rows of a damaged rosbag2 sqlite3 database one by one.

    A truncated database file still carries its original page count; sqlite then refuses
    the whole file. A temporary copy with the page count set to what is really there opens,
    and each message row is then read on its own, so a garbled page costs only the rows on it.
    """
    data = Path(path).read_bytes()
    if len(data) < 100 or not data.startswith(b"SQLite format 3\x00"):
        return Fault("at byte 0", "not an sqlite3 database")
    page_size = int.from_bytes(data[16:18], "big") or 65536
    if page_size == 1:
        page_size = 65536
    n_pages = len(data) // page_size
    pages_stated = int.from_bytes(data[28:32], "big")
    with tempfile.TemporaryDirectory(prefix="labkit-salvage-") as tmp:
        copy = Path(tmp) / "salvage.db3"
        fixed = bytearray(data[: n_pages * page_size])
        fixed[28:32] = n_pages.to_bytes(4, "big")
        copy.write_bytes(bytes(fixed))
        con = sqlite3.connect(f"file:{copy}?mode=ro", uri=True)
        try:
            try:
                topics = {row[0]: (row[1], row[2]) for row in con.execute("SELECT id, name, type FROM topics")}
            except sqlite3.DatabaseError as exc:
                return Fault("in its topics table", str(exc))
            if want_topics:
                for name, msgtype in topics.values():
                    yield name, 0, msgtype
                return None
            chosen = {tid for tid, (name, msgtype) in topics.items()
                      if wanted(name, msgtype, topic)}
            yield from _rows_one_by_one(con, topics, chosen)
            if len(data) % page_size or pages_stated > n_pages:
                return Fault(f"at byte {len(data)}", f"the database is cut short ({n_pages} of its "
                             f"{max(pages_stated, n_pages + 1)} pages are there); rows on the missing pages are lost")
            return None
        finally:
            con.close()


_MISSES = 64  # ids tried past the last readable row before giving up on a table whose end is unreadable


def _rows_one_by_one(con: sqlite3.Connection, topics: dict, wanted: set):
    """Every readable LaserScan row, read by id; a row sqlite cannot read is a :class:`Fault`.

    The ids run to ``max(id)``; when even that is unreadable (a file cut short), to the last id
    a scan of the table reaches, and on until ``_MISSES`` ids in a row are missing or unreadable.
    """
    last = _last_row_id(con)
    end_known = last is not None
    if not end_known:
        last = 0
        with contextlib.suppress(sqlite3.DatabaseError):
            for (row_id,) in con.execute("SELECT id FROM messages"):
                last = max(last, row_id)
    row_id = misses = 0
    while row_id < last or (not end_known and misses < _MISSES):
        row_id += 1
        try:
            row = con.execute("SELECT topic_id, timestamp, data FROM messages WHERE id = ?", (row_id,)).fetchone()
        except sqlite3.DatabaseError as exc:
            if row_id <= last:
                yield Fault(f"in message row {row_id}", str(exc))
            else:
                misses += 1
            continue
        if row is None:
            misses += row_id > last
            continue
        misses = 0
        last = max(last, row_id)
        if row[0] in wanted:
            yield topics[row[0]][0], int(row[1]), bytes(row[2])


def _last_row_id(con: sqlite3.Connection) -> int | None:
    try:
        row = con.execute("SELECT max(id) FROM messages").fetchone()
    except sqlite3.DatabaseError:
        return None
    return int(row[0]) if row and row[0] is not None else 0
