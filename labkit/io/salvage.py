"""Reading bags record by record, through damage: ROS1 and MCAP walkers, and sqlite3 salvage.

Every ROS1 ``.bag`` and every MCAP file labkit reads is read by a walker of this module, front
to back, record by record (rosbags reads a bag through its index and skips what the index does
not lead it to; rosbags' MCAP reader passes over a garbled stretch of a chunk without a word).
A walker yields the raw bytes of every message it finds intact, and a :class:`Fault` for every
damaged place:

- A record whose framing does not hold (a garbled header, a length running past its chunk, an
  unknown record type inside a chunk) is a fault; the walker then **resynchronises**: it looks
  for the next offset at which a record starts whose header is valid and is followed by another
  valid record (or the end), and reads on from there. In uncompressed storage a stretch of
  garbage costs the messages it overlaps, no more.
- A compressed chunk that does not decompress is decompressed in pieces (:mod:`labkit.io._codecs`:
  bz2 block by block as ``bzip2recover`` does, lz4 and zstd as far as the decoder gets), and the
  records of each piece are read from the first intact one.
- A chunk cut off by the end of the file gives what is there.

Each walker also keeps the books: the messages it found per topic (:attr:`Walker.found`) and the
messages it knows were lost (:attr:`Walker.lost`: a record cut off, or what a chunk's own index
-- ROS1 index data records, MCAP message index records -- lists beyond what was found in it).
Whether the file reached its proper end is :attr:`Walker.complete`.

The MCAP walker decodes each record with the ``mcap`` package's record classes. Its loop is
written here rather than taken from ``mcap.stream_reader.StreamReader`` because that reader cannot
start again at an arbitrary offset after an error, passes silently over a record type it does not
know (so garbage that looks like one hides the records under it), and decompresses a chunk whole
or not at all.

A ROS2 sqlite3 database that rosbags cannot read is read row by row (:func:`salvage_sqlite3`).
"""

from __future__ import annotations

import contextlib
import io
import mmap
import re
import sqlite3
import struct
import tempfile
import zlib
from collections import Counter
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal, overload

from mcap import records as mcap_records
from mcap.data_stream import ReadDataStream
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from . import _codecs

LASERSCAN_TYPES = {"sensor_msgs/LaserScan", "sensor_msgs/msg/LaserScan"}
_MSGTYPE = "sensor_msgs/msg/LaserScan"
# The walk maps the input file (mmap) and reads it front to back; the pages it has walked past are let
# go every _LET_GO_EVERY bytes (madvise DONTNEED: they stay in the page cache, not in the process), so a
# long recording does not add its size to the reader's resident memory (3 KiB per 541-beam scan).
_LET_GO_EVERY = 8 << 20


def wanted(name: str, msgtype: str, topic: str | frozenset[str] | None) -> bool:
    """Whether a reader yields a message of topic ``name``: with ``topic`` a set of names, any
    message on them (poses, transforms); else a LaserScan message (on ``topic``, if one is named)."""
    if isinstance(topic, frozenset):
        return name in topic
    return msgtype in LASERSCAN_TYPES and (topic is None or name == topic)


def _let_go(buf, pos: int, done: int) -> int:
    """Let the pages of a mapped ``buf`` before ``pos`` go from this process (they are read again from
    the page cache if touched); returns the page-aligned offset reached (``done`` if ``buf`` is not a
    map or the system cannot)."""
    edge = pos - pos % mmap.PAGESIZE
    if not isinstance(buf, mmap.mmap) or not hasattr(mmap, "MADV_DONTNEED") or edge <= done:
        return done
    try:
        buf.madvise(mmap.MADV_DONTNEED, 0, edge)
    except OSError:
        return done
    return edge


@dataclass(frozen=True)
class Fault:
    """A damaged part of a file: where, what, and how many records it is known to have cost
    (``count``; 0 when it is not known here: the walkers keep their books in :class:`Walker`).
    ``open_end``: the file ends there, and what came after is unknown."""

    where: str
    reason: str
    count: int = 1
    open_end: bool = False


#: what :func:`salvage_sqlite3` yields (``(topic, receive_ns, raw)`` and faults) and returns (a last fault)
Salvage = Generator["tuple[str, int, bytes] | Fault", None, "Fault | None"]
#: the same with ``want_topics=True``: ``(topic, 0, message type)``
SalvagedTopics = Generator["tuple[str, int, str] | Fault", None, "Fault | None"]


@lru_cache(maxsize=2)
def typestore(ros1: bool):
    """The rosbags typestore for ROS1 (Noetic) or ROS2 (Humble) messages, built once:
    rosbags generates ~175 message classes for each. rosbags' Noetic store lacks
    ``tf2_msgs/TFMessage`` (the ``/tf`` message): it is added, as ROS defines it."""
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in store.types:
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    return store


class _Bad(Exception):
    """No valid record starts here."""


@dataclass
class _ChunkHead:
    """Where a chunk's data lies and how it is compressed ("" or "none": not at all)."""

    compression: str
    size: int  # decompressed
    crc: int  # of the decompressed data; 0: none
    start: int
    stop: int


class _Cut(Exception):
    """A record starts here but runs past the end of its file or chunk.

    ``chunk``: the header of a chunk cut off (its ``stop`` is the end of the data), ``credible``
    when its lengths agree with each other (an uncompressed chunk); ``conn``: the connection of a
    message record cut off, when its header tells."""

    def __init__(self, reason: str, *, chunk: _ChunkHead | None = None, credible: bool = False,
                 conn: int | None = None) -> None:
        super().__init__(reason)
        self.chunk, self.credible, self.conn = chunk, credible, conn


@dataclass
class Connection:
    """A topic as the file declares it (a ROS1 connection record, an MCAP channel and its schema)."""

    id: int
    topic: str
    msgtype: str
    definition: str = ""
    encoding: str = ""  # of the definition: "ros1msg", "ros2msg", "ros2idl" ("" for ROS1 bags)
    md5sum: str = ""
    extra: dict | None = None  # ROS1 callerid/latching; MCAP channel metadata (QoS)


_SIZE_NAMES = {"b": 1, "h": 2, "i": 4, "q": 8}


class Walker:
    """Walks one bag file front to back (see the module docstring); a subclass per framing.

    Parameters
    ----------
    path : Path
        The file (a ROS1 ``.bag``, an ``.mcap``).
    topic : str, frozenset of str or None
        What :meth:`messages` yields (:func:`wanted`); every topic is counted regardless.

    Attributes
    ----------
    connections : dict
        Connection id -> :class:`Connection`, as declared so far.
    found, lost : Counter
        Per topic: messages found intact; messages known lost.
    index_counts : Counter or None
        Per topic: messages the file's index lists (None when it has none, or it is damaged).
    complete : bool
        The walk reached the file's proper end (its index, its footer).
    """

    magic = b""
    kind = ""
    _inner_ops: frozenset = frozenset()
    _top_ops: frozenset = frozenset()
    _candidate: re.Pattern

    def __init__(self, path: str | Path, topic: str | frozenset[str] | None = None) -> None:
        self.path = Path(path)
        self.topic = topic
        self.connections: dict[int, Connection] = {}
        self.found: Counter[str] = Counter()
        self.lost: Counter[str] = Counter()
        self.complete = False
        self.index_counts: Counter[str] | None = None  # messages per topic, as the file's index lists them
        self._chunk_found: Counter[int] = Counter()  # per connection, found in the current chunk
        self._chunk_cut: Counter[int] = Counter()  # per connection, counted lost as cut off in it
        self._after_index = False
        self._footer = False  # MCAP: the footer is read; what follows is the closing magic

    # -------------------------------------------------------------- the walk
    def messages(self) -> Generator[tuple[str, int, bytes, str] | Fault, None, None]:
        """``(topic, receive_ns, raw, where)`` for every wanted message found intact, in file order, and
        a :class:`Fault` for every damaged place (the last one, when the file ends early, with
        ``open_end``)."""
        with open(self.path, "rb") as fh:
            size = self.path.stat().st_size
            if size < len(self.magic):
                yield Fault("at byte 0", f"the file is shorter than the {self.kind} magic", 0, open_end=True)
                return
            buf = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
            ended = False  # a fault said where the file ends
            try:
                if buf[: len(self.magic)] != self.magic:
                    yield Fault("at byte 0", f"not a {self.kind} (its magic is missing)", 0, open_end=True)
                    return
                with contextlib.suppress(Exception):  # a damaged index: connections come as they are met
                    self._seed(buf, fh)
                for item in self._walk(buf, len(self.magic), size, base=0, inner=False):
                    ended = ended or (isinstance(item, Fault) and item.open_end)
                    yield item
                if not (self.complete or ended):
                    yield Fault(f"at byte {size}", self._missing_end, 0, open_end=True)
            finally:
                buf.close()

    _missing_end = "the file ends early"

    def _walk(self, buf, start: int, end: int, *, base: int | None, inner: bool, quiet: bool = False,
              where: str = "", resync_first: bool = False) -> Iterator:
        """What the records of ``buf[start:end]`` hold. ``base``: the file offset of ``buf[0]``
        (None for decompressed data, whose place is ``where``). ``quiet``: a fault was already
        reported for this stretch. ``resync_first``: the stretch starts in the middle of a record."""
        pos = start
        let_go = start  # the file offset up to which pages were let go (the outermost walk only)
        if resync_first:
            try:
                self._record(buf, pos, end, inner)
            except (_Bad, _Cut):
                resumed = self._resync(buf, pos + 1, end, inner)
                if resumed is None:
                    return
                pos = resumed
        while pos < end and not (self._footer and not inner):
            try:
                rec = self._record(buf, pos, end, inner)
            except _Bad as bad:
                if not quiet:
                    yield Fault(self._where(pos, base, where), f"{bad} (the walk resumed at the next intact record)", 0)
                nxt = self._resync(buf, pos + 1, end, inner)
                if nxt is None:
                    return
                pos = nxt
                continue
            except _Cut as cut:
                if cut.chunk is not None and not inner:  # a chunk running past the end of the file
                    nxt = None if cut.credible else self._resync(buf, cut.chunk.start, end, inner)
                    if nxt is None:  # the file was cut short in this chunk: what is there of it
                        yield from self._chunk(buf, pos, cut.chunk, base=base, cut=True)
                        return
                    yield Fault(self._where(pos, base, where), "a chunk header is garbled (its length runs past "
                                "the end of the file; the walk resumed at the next intact record)", 0)
                    cut.chunk.stop = nxt
                    yield from self._chunk(buf, pos, cut.chunk, base=base, cut=False, garbled=True)
                    pos = nxt
                    continue
                nxt = self._resync(buf, pos + 1, end, inner)
                if nxt is not None:  # a garbled length, not the end of the data
                    if not quiet:
                        yield Fault(self._where(pos, base, where), f"{cut} (the walk resumed at the next intact "
                                    "record)", 0)
                    pos = nxt
                    continue
                if cut.conn is not None:
                    self._cut_message(cut.conn)
                if not quiet:
                    yield Fault(self._where(pos, base, where), str(cut), 0, open_end=base is not None and not inner)
                return
            if rec[0] == self._message_op:  # most records: no generator of their own
                item = self._message_record(buf, pos, rec, base, where)
                if item is not None:
                    yield item
            else:
                yield from self._handle(buf, pos, rec, base=base, inner=inner, where=where)
            pos = rec[-1]
            if not inner and pos - let_go >= _LET_GO_EVERY:
                let_go = _let_go(buf, pos, let_go)

    def _where(self, pos: int, base: int | None, where: str) -> str:
        return f"at byte {base + pos}" if base is not None else where

    def _resync(self, buf, pos: int, end: int, inner: bool) -> int | None:
        """The next offset from ``pos`` at which a valid record starts that is followed by
        another valid record, a record cut off by the end, or the end itself."""
        for match in self._candidate.finditer(buf, pos, end):
            at = match.start()
            try:
                rec = self._record(buf, at, end, inner)
            except (_Bad, _Cut):
                continue
            nxt = rec[-1]
            if nxt >= end:
                return at
            try:
                self._record(buf, nxt, end, inner)
            except _Bad:
                continue
            except _Cut:
                pass
            return at
        return None

    # -------------------------------------------------------------- the books
    def _message(self, conn_id: int, stamp: int, buf, start: int, stop: int, pos: int, base, where: str):
        """Count a message found intact; ``(topic, stamp, raw, where)`` when it is wanted, else None."""
        conn = self.connections.get(conn_id)
        if self._after_index:  # the first record after a chunk's index: a new chunk's worth begins
            self._chunk_found.clear()
            self._chunk_cut.clear()
            self._after_index = False
        self._chunk_found[conn_id] += 1
        if conn is None:
            return None
        self.found[conn.topic] += 1
        if not wanted(conn.topic, conn.msgtype, self.topic):
            return None
        return conn.topic, stamp, bytes(buf[start:stop]), self._where(pos, base, where)

    def _cut_message(self, conn_id: int) -> None:
        conn = self.connections.get(conn_id)
        self._chunk_cut[conn_id] += 1
        if conn is not None:
            self.lost[conn.topic] += 1

    def _chunk_index(self, conn_id: int, count: int) -> None:
        """A chunk's own index says it held ``count`` messages of ``conn_id``."""
        self._after_index = True
        missing = count - self._chunk_found[conn_id] - self._chunk_cut[conn_id]
        conn = self.connections.get(conn_id)
        if missing > 0 and conn is not None:
            self.lost[conn.topic] += missing

    def _new_chunk(self) -> None:
        self._chunk_found.clear()
        self._chunk_cut.clear()
        self._after_index = False

    def _chunk(self, buf, pos: int, head: _ChunkHead, *, base, cut: bool, garbled: bool = False) -> Iterator:
        """The records of the chunk at ``pos`` (``cut``: cut off by the end of the file;
        ``garbled``: its header is damaged, ``head.stop`` is where the next intact record starts)."""
        self._new_chunk()
        compression = "" if head.compression == "none" else head.compression
        where = f"in the {compression or 'uncompressed'} chunk at byte {base + pos}"
        ends = (f"at byte {base + head.stop}", f"the file ends in the middle of the {compression or 'uncompressed'} "
                f"chunk at byte {base + pos}")
        if not compression:  # the records lie in the file itself: their offsets are exact
            if cut:
                yield Fault(*ends, 0, open_end=True)
            elif head.crc and zlib.crc32(buf[head.start : head.stop]) != head.crc:
                yield Fault(where, "its records fail their checksum", 0)
            yield from self._walk(buf, head.start, head.stop, base=base, inner=True, quiet=cut)
            return
        data = buf[head.start : head.stop]
        if not (cut or garbled):
            try:
                inner = _codecs.decompress(data, compression)
            except Exception:  # noqa: BLE001 - every codec raises its own kind
                inner = None
            if inner is not None and len(inner) == head.size:
                if head.crc and zlib.crc32(inner) != head.crc:
                    yield Fault(where, "its data decompress but fail their checksum (values in the messages read "
                                "from it may be garbled)", 0)
                yield from self._walk(inner, 0, len(inner), base=None, inner=True, where=where)
                return
        pieces, what = _codecs.salvage_chunk(data, compression)
        if cut:
            yield Fault(ends[0], f"{ends[1]}; {what}", 0, open_end=True)
        elif not garbled:
            yield Fault(where, what, 0)
        for k, piece in enumerate(pieces):
            yield from self._walk(piece, 0, len(piece), base=None, inner=True, quiet=True, where=where,
                                  resync_first=k > 0)

    # -------------------------------------------------------------- per framing
    def _seed(self, buf, fh) -> None:
        """Learn the connections from the file's index at its end, if it can be read, so that a
        message whose connection record is damaged still has a topic."""

    _message_op: object = None

    def _record(self, buf, pos: int, end: int, inner: bool) -> tuple:
        raise NotImplementedError

    def _message_record(self, buf, pos: int, rec: tuple, base, where: str):
        raise NotImplementedError

    def _handle(self, buf, pos: int, rec: tuple, *, base, inner: bool, where: str) -> Iterator:
        raise NotImplementedError


# ============================================================================ ROS1
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_ROS1_FIELDS = {  # op -> the header fields it must have, and their sizes (0: any)
    b"\x02": {"conn": 4, "time": 8},
    b"\x03": {"index_pos": 8, "conn_count": 4, "chunk_count": 4},
    b"\x04": {"ver": 4, "conn": 4, "count": 4},
    b"\x05": {"compression": 0, "size": 4},
    b"\x06": {"ver": 4, "chunk_pos": 8, "start_time": 8, "end_time": 8, "count": 4},
    b"\x07": {"conn": 4, "topic": 0},
}
_ROS1_HEADER_MAX = 1 << 16


_NAME_CHARS = b"abcdefghijklmnopqrstuvwxyz0123456789_"
_NAMES = {name.encode(): name for fields in _ROS1_FIELDS.values() for name in fields} | {
    b"op": "op", b"type": "type", b"md5sum": "md5sum", b"message_definition": "message_definition",
    b"callerid": "callerid", b"latching": "latching"}
_U32 = struct.Struct("<I")
# a message record's header of exactly the fields op (2), conn and time, each once, in any order
_MESSAGE_HEADER = re.compile(rb"(?s)(?:(\x04\x00\x00\x00op=\x02)|\x09\x00\x00\x00conn=(.{4})"
                             rb"|\x0d\x00\x00\x00time=(.{8})){3}")


def _ros1_fields(header: bytes) -> dict[str, bytes]:
    """The ``name=value`` fields of a ROS1 record header (ValueError if they do not hold)."""
    fields, pos, n_bytes = {}, 0, len(header)
    unpack = _U32.unpack_from
    while pos < n_bytes:
        if pos + 4 > n_bytes:
            raise ValueError("a header field length is cut off")
        (n,) = unpack(header, pos)
        pos += 4
        end = pos + n
        if end > n_bytes:
            raise ValueError("a header field runs past its header")
        eq = header.find(b"=", pos, end)
        name = header[pos:eq]
        if eq < 0 or not name or len(name) > 32 or name.strip(_NAME_CHARS):
            raise ValueError("a header field is garbled")
        fields[_NAMES.get(name) or name.decode("ascii")] = header[eq + 1 : end]
        pos = end
    return fields


class Ros1Walker(Walker):
    """The ROS bag format 2.0: records of a header (``name=value`` fields, ``op`` the record
    type) and data; chunks (op 5) hold connection (7) and message (2) records, each chunk is
    followed by its index data (4), and the index at the end holds connections and chunk infos (6)."""

    magic = _ROS1_MAGIC
    kind = "ROS1 bag"
    _inner_ops = frozenset({b"\x02", b"\x07"})
    _top_ops = frozenset(_ROS1_FIELDS)
    # a record: header length < 64 KiB, its first field's length < 256 and the field's name
    _candidate = re.compile(rb"(?s)..\x00\x00.\x00\x00\x00[a-z0-9_]{1,32}=")
    _missing_end = "the file ends before its index (the recording was cut short)"

    def _record(self, buf, pos: int, end: int, inner: bool) -> tuple:
        """``(op, fields, data_start, data_end)`` of the record at ``pos``."""
        if pos + 8 > end:
            raise _Cut("a record header is cut off")
        (hlen,) = struct.unpack_from("<I", buf, pos)
        if not 6 <= hlen <= _ROS1_HEADER_MAX:
            raise _Bad("a record header is garbled (impossible length)")
        if pos + 8 + hlen > end:
            raise _Cut("a record header is cut off")
        fast = _MESSAGE_HEADER.fullmatch(buf, pos + 4, pos + 4 + hlen) if hlen == 38 else None
        if fast is not None and fast[1]:  # the usual message header: op, conn and time, in any order
            fields = {"op": b"\x02", "conn": fast[2], "time": fast[3]}
        else:
            try:
                fields = _ros1_fields(buf[pos + 4 : pos + 4 + hlen])
            except ValueError as exc:
                raise _Bad(f"a record header is garbled ({exc})") from None
        op = fields.get("op", b"")
        allowed = self._inner_ops if inner else self._top_ops
        if op not in allowed:
            raise _Bad("a record header is garbled (no known op)" if op not in _ROS1_FIELDS else
                       f"a record of type {op[0]} inside a chunk")
        for name, n in _ROS1_FIELDS[op].items():
            if name not in fields or (n and len(fields[name]) != n):
                raise _Bad(f"a record header is garbled (its {name} field)")
        if op == b"\x05" and fields["compression"] not in (b"none", b"bz2", b"lz4"):
            raise _Bad("a chunk header is garbled (unknown compression)")
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        start = pos + 8 + hlen
        if op == b"\x04" and dlen != 12 * struct.unpack("<I", fields["count"])[0]:
            raise _Bad("an index data record is garbled")
        if op == b"\x06" and dlen != 8 * struct.unpack("<I", fields["count"])[0]:
            raise _Bad("a chunk info record is garbled")
        if op == b"\x05":
            compression = fields["compression"].decode()
            (size,) = struct.unpack("<I", fields["size"])
            if compression == "none" and size != dlen:
                raise _Bad("a chunk header is garbled (its lengths disagree)")
            head = _ChunkHead(compression, size, 0, start, min(start + dlen, end))
            if start + dlen > end:
                raise _Cut("the file ends in the middle of a chunk", chunk=head, credible=compression == "none")
            return op, head, start, start + dlen
        if start + dlen > end:
            raise _Cut("a record runs past the end" if inner else "the file ends in the middle of a record",
                       conn=struct.unpack("<I", fields["conn"])[0] if op == b"\x02" else None)
        if op == b"\x07":
            try:
                conn = _ros1_fields(buf[start : start + dlen])
            except ValueError as exc:
                raise _Bad(f"a connection record is garbled ({exc})") from None
            if "type" not in conn:
                raise _Bad("a connection record is garbled (no type)")
        return op, fields, start, start + dlen

    def _seed(self, buf, fh) -> None:
        op, fields, _start, _stop = self._record(buf, len(_ROS1_MAGIC), len(buf), False)
        if op != b"\x03":
            return
        (pos,) = struct.unpack("<Q", fields["index_pos"])
        counts: Counter[int] = Counter()
        while pos and pos < len(buf):
            op, fields, start, stop = self._record(buf, pos, len(buf), False)
            if op == b"\x07":
                self._connection(fields, buf[start:stop])
            elif op == b"\x06":
                for conn, n in struct.iter_unpack("<II", buf[start:stop]):
                    counts[conn] += n
            pos = stop
        if pos == len(buf) and counts:
            self.index_counts = Counter({self.connections[c].topic: n for c, n in counts.items()})

    _message_op = b"\x02"

    def _message_record(self, buf, pos: int, rec: tuple, base, where: str):
        _op, fields, start, stop = rec
        (conn,) = struct.unpack("<I", fields["conn"])
        sec, nsec = struct.unpack("<II", fields["time"])
        return self._message(conn, sec * 1_000_000_000 + nsec, buf, start, stop, pos, base, where)

    def _handle(self, buf, pos: int, rec: tuple, *, base, inner: bool, where: str) -> Iterator:
        op, fields, start, stop = rec
        if op == b"\x07":
            self._connection(fields, buf[start:stop])
        elif op == b"\x05":
            yield from self._chunk(buf, pos, fields, base=base, cut=False)
        elif op == b"\x04":
            conn, count = struct.unpack("<I", fields["conn"])[0], struct.unpack("<I", fields["count"])[0]
            self._chunk_index(conn, count)
        elif op == b"\x06":
            self.complete = True  # the index at the end of the file is reached

    def _connection(self, fields: dict, data) -> None:
        (cid,) = struct.unpack("<I", fields["conn"])
        conn = _ros1_fields(data)
        extra = {k: conn[k].decode("utf-8", "replace") for k in ("callerid", "latching") if k in conn}
        self.connections[cid] = Connection(
            cid, fields["topic"].decode("utf-8", "replace"), conn["type"].decode("utf-8", "replace"),
            conn.get("message_definition", b"").decode("utf-8", "replace"), "ros1msg",
            conn.get("md5sum", b"").decode("ascii", "replace"), extra)


# ============================================================================ MCAP
_MCAP_MAGIC = b"\x89MCAP0\r\n"
# opcode -> mcap's record class (None: a chunk, read here); Any: the classes share no typed read()
# (a message's read() also takes its length)
_MCAP_RECORDS: dict[int, Any] = {
    0x01: mcap_records.Header, 0x02: mcap_records.Footer, 0x03: mcap_records.Schema,
    0x04: mcap_records.Channel, 0x05: mcap_records.Message, 0x06: None, 0x07: mcap_records.MessageIndex,
    0x08: mcap_records.ChunkIndex, 0x09: mcap_records.Attachment, 0x0A: mcap_records.AttachmentIndex,
    0x0B: mcap_records.Statistics, 0x0C: mcap_records.Metadata, 0x0D: mcap_records.MetadataIndex,
    0x0E: mcap_records.SummaryOffset, 0x0F: mcap_records.DataEnd,
}
_CHUNK_HEAD = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length


class McapWalker(Walker):
    """The MCAP format: records of an opcode, a length and content; chunks (0x06) hold schema,
    channel and message records, each chunk followed by its message indexes (0x07); a footer
    (0x02) and the magic end the file."""

    magic = _MCAP_MAGIC
    kind = "MCAP file"
    _inner_ops = frozenset({0x03, 0x04, 0x05})
    _top_ops = frozenset(_MCAP_RECORDS)
    # a record: an opcode of the specification and a length below 4 GiB
    _candidate = re.compile(rb"(?s)[\x01-\x0f]....\x00\x00\x00\x00")
    _missing_end = "the file ends before its footer (the recording was cut short)"

    def __init__(self, path: str | Path, topic: str | frozenset[str] | None = None) -> None:
        super().__init__(path, topic)
        self.schemas: dict[int, mcap_records.Schema] = {}

    def _record(self, buf, pos: int, end: int, inner: bool) -> tuple:
        """``(opcode, record, content_start, record_end)``; a chunk's record is its header fields
        ``(compression, uncompressed size, crc, data_start, data_end)``."""
        if pos + 9 > end:
            raise _Cut("a record header is cut off")
        op = buf[pos]
        (length,) = struct.unpack_from("<Q", buf, pos + 1)
        if op not in (self._inner_ops if inner else self._top_ops):
            raise _Bad(f"an unknown record type 0x{op:02x}" if op not in _MCAP_RECORDS else
                       f"a record of type 0x{op:02x} inside a chunk")
        start, stop = pos + 9, pos + 9 + length
        if op == 0x06:
            return op, self._chunk_head(buf, start, stop, end), start, stop
        if stop > end:
            conn = struct.unpack_from("<H", buf, start)[0] if op == 0x05 and start + 2 <= end else None
            raise _Cut("a record runs past the end" if inner else "the file ends in the middle of a record",
                       conn=conn if conn in self.connections else None)
        stream = ReadDataStream(io.BytesIO(buf[start:stop]))
        try:
            record = _MCAP_RECORDS[op].read(stream, length) if op == 0x05 else _MCAP_RECORDS[op].read(stream)
        except Exception as exc:  # noqa: BLE001 - struct.error, UnicodeDecodeError, EndOfFile...
            raise _Bad(f"a record of type 0x{op:02x} is garbled ({type(exc).__name__})") from None
        if stream.count != length and op != 0x05:
            raise _Bad(f"a record of type 0x{op:02x} is garbled (its length)")
        if op == 0x05 and record.channel_id not in self.connections:
            raise _Bad("a message record is garbled (unknown channel)")
        if op == 0x04 and record.schema_id and record.schema_id not in self.schemas:
            raise _Bad("a channel record is garbled (unknown schema)")
        if op == 0x07 and len(record.records) and record.channel_id not in self.connections:
            raise _Bad("a message index record is garbled (unknown channel)")
        return op, record, start, stop

    def _seed(self, buf, fh) -> None:
        from mcap.reader import make_reader

        summary = make_reader(fh).get_summary()
        if summary is None:
            return
        self.schemas.update(summary.schemas)
        for channel in summary.channels.values():
            self._channel(channel)
        if summary.statistics is not None:
            self.index_counts = Counter({self.connections[c].topic: n
                                         for c, n in summary.statistics.channel_message_counts.items()})

    def _channel(self, record) -> None:
        schema = self.schemas.get(record.schema_id)
        self.connections[record.id] = Connection(
            record.id, record.topic, schema.name if schema else "", schema.data.decode("utf-8", "replace")
            if schema else "", schema.encoding if schema else "", "", dict(record.metadata))

    def _chunk_head(self, buf, start: int, stop: int, end: int) -> _ChunkHead:
        head_end = start + _CHUNK_HEAD.size
        if head_end > end:
            raise _Cut("a chunk header is cut off")
        _t0, _t1, size, crc, n = _CHUNK_HEAD.unpack_from(buf, start)
        if n > 16 or head_end + n + 8 > end:
            raise _Bad("a chunk header is garbled")
        compression = bytes(buf[head_end : head_end + n])
        if compression not in (b"", b"lz4", b"zstd"):
            raise _Bad("a chunk header is garbled (unknown compression)")
        (dlen,) = struct.unpack_from("<Q", buf, head_end + n)
        data_start = head_end + n + 8
        if data_start + dlen != stop or size > 1 << 40 or (not compression and size != dlen):
            raise _Bad("a chunk header is garbled (its lengths disagree)")
        head = _ChunkHead(compression.decode(), size, crc, data_start, min(stop, end))
        if stop > end:
            raise _Cut("the file ends in the middle of a chunk", chunk=head, credible=not compression)
        return head

    _message_op = 0x05

    def _message_record(self, buf, pos: int, rec: tuple, base, where: str):
        record = rec[1]
        return self._message(record.channel_id, record.log_time, record.data, 0, len(record.data), pos, base, where)

    def _handle(self, buf, pos: int, rec: tuple, *, base, inner: bool, where: str) -> Iterator:
        op, record, _start, _stop = rec
        if op == 0x03:
            self.schemas[record.id] = record
        elif op == 0x04:
            self._channel(record)
        elif op == 0x06:
            yield from self._chunk(buf, pos, record, base=base, cut=False)
        elif op == 0x07:
            self._chunk_index(record.channel_id, len(record.records))
        elif op == 0x02:  # the footer, and the magic after it: the file is whole
            self._footer = True
            self.complete = bytes(buf[rec[-1] : rec[-1] + len(_MCAP_MAGIC)]) == _MCAP_MAGIC


WALKERS: dict[str, type[Walker]] = {"ros1": Ros1Walker, "mcap": McapWalker}


def walk_topics(path: Path, fmt: str) -> tuple[Walker, list[Fault]]:
    """Walk a whole bag file, counting every topic's messages (none is yielded); the walker
    (its connections and books) and the faults met."""
    walker = WALKERS[fmt](path, frozenset())
    faults = [item for item in walker.messages() if isinstance(item, Fault)]
    return walker, faults


# ============================================================================ sqlite3
@overload
def salvage_sqlite3(path: Path, topic: str | frozenset[str] | None, want_topics: Literal[False] = False,
                    known: Sequence[tuple[str, str]] = ()) -> Salvage: ...


@overload
def salvage_sqlite3(path: Path, topic: str | frozenset[str] | None, want_topics: Literal[True],
                    known: Sequence[tuple[str, str]] = ()) -> SalvagedTopics: ...


def salvage_sqlite3(path: Path, topic: str | frozenset[str] | None, want_topics: bool = False,
                    known: Sequence[tuple[str, str]] = ()
                    ) -> Generator[tuple[str, int, bytes] | tuple[str, int, str] | Fault, None, Fault | None]:
    """Read the rows of a damaged rosbag2 sqlite3 database one by one.

    A truncated database file still carries its original page count; sqlite then refuses
    the whole file. A temporary copy with the page count set to what is really there opens,
    and each message row is then read on its own, so a garbled page costs only the rows on it.
    ``known``: the topics ``(name, type)`` the folder's metadata.yaml lists, in order; when the
    topics table itself is unreadable, topic ids 1, 2, ... are taken to be those (the order in
    which rosbag2 writers number them; a row given a wrong type does not decode and is counted).
    """
    data = Path(path).read_bytes()
    if len(data) < 100 or not data.startswith(b"SQLite format 3\x00"):
        return Fault("at byte 0", "not an sqlite3 database", 0, open_end=True)
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
                if not known:
                    return Fault("in its topics table", str(exc), 0, open_end=True)
                topics = {k: (name, msgtype) for k, (name, msgtype) in enumerate(known, start=1)}
                yield Fault("in its topics table", f"{exc} (the topics are taken from metadata.yaml)", 0)
            if want_topics:
                for name, msgtype in topics.values():
                    yield name, 0, msgtype
                return None
            chosen = {tid for tid, (name, msgtype) in topics.items()
                      if wanted(name, msgtype, topic)}
            yield from _rows_one_by_one(con, topics, chosen)
            if len(data) % page_size or pages_stated > n_pages:
                return Fault(f"at byte {len(data)}", f"the database is cut short ({n_pages} of its "
                             f"{max(pages_stated, n_pages + 1)} pages are there); rows on the missing pages are lost",
                             0, open_end=True)
            return None
        finally:
            con.close()


_MISSES = 64  # ids tried past the last readable row before giving up on a table whose end is unreadable


def _rows_one_by_one(con: sqlite3.Connection, topics: dict, chosen: set):
    """Every readable row of the ``chosen`` topics, read by id; a row sqlite cannot read is a
    :class:`Fault` (of a topic that cannot be told: counted 0).

    The ids run to ``max(id)``; when even that is unreadable (a file cut short), to the last id
    a scan of the table reaches, and on until ``_MISSES`` ids in a row are missing or unreadable.
    """
    found = _last_row_id(con)
    end_known = found is not None
    last = 0 if found is None else found
    if not end_known:
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
                yield Fault(f"in message row {row_id}", str(exc), 0)
            else:
                misses += 1
            continue
        if row is None:
            misses += row_id > last
            continue
        misses = 0
        last = max(last, row_id)
        if row[0] in chosen:
            yield topics[row[0]][0], int(row[1]), bytes(row[2])


def _last_row_id(con: sqlite3.Connection) -> int | None:
    try:
        row = con.execute("SELECT max(id) FROM messages").fetchone()
    except sqlite3.DatabaseError:
        return None
    return int(row[0]) if row and row[0] is not None else 0


Walk = Callable[..., Iterator]
