"""Copying a whole bag into another bag format: every topic, its name kept.

``labkit convert run.bag run.mcap`` (and any other pair of ROS1 ``.bag``, ROS2 folder and MCAP)
carries every message of every topic through, under the topic names it had. Messages are
converted between the ROS1 and ROS2 wire formats by rosbags (``rosbags.convert``: the same
definitions in both, or a migration field by field, e.g. ``std_msgs/Header``'s ``seq``); a topic
whose message type cannot be converted is left out, named in a note and counted. The source is
read as every labkit reader reads it (:mod:`labkit.io.salvage` for ROS1 and MCAP): a damaged
source gives a complete copy of what could be read, and then the
:class:`~labkit.io.CorruptFileError` that counts the scans (and other records) lost.

``convert(..., only_scans=True)`` (``--only-scans``) is the scans-only copy instead: the LaserScan
topic as ``/scan`` and the scans' poses as ``/odom``.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import cast

from rosbags import rosbag1, rosbag2
from rosbags.highlevel import AnyReader
from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag1,
    ConnectionExtRosbag2,
    MessageDefinition,
    MessageDefinitionFormat,
)
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

from .._safe import safe_output
from . import bags, salvage
from .faults import Faults

__all__ = ["copy_bag", "TopicsSkippedWarning"]


class TopicsSkippedWarning(UserWarning):
    """A topic could not be carried into the output bag (its message type does not convert)."""


def _source(path: Path, fmt: str) -> tuple[list[Connection], object, Counter | None]:
    """The connections of a bag, the typestore that reads them, and the messages per topic its
    index lists (None when unknown). Through rosbags when it opens the bag; else from what
    labkit's walker finds (ROS1, MCAP) or metadata.yaml (ROS2)."""
    try:
        reader = AnyReader([path], default_typestore=salvage.typestore(fmt == "ros1"))
        reader.open()
    except Exception:  # noqa: BLE001 - a damaged index: see below
        reader = None
    if reader is not None:
        try:
            counts: Counter[str] = Counter()
            for c in reader.connections:
                counts[c.topic] += c.msgcount
            return list(reader.connections), reader.typestore, counts
        finally:
            reader.close()
    if fmt == "ros2":
        ts = salvage.typestore(False)
        conns = [Connection(k, name, msgtype, MessageDefinition(MessageDefinitionFormat.NONE, ""), "", count,
                            ConnectionExtRosbag2("cdr", []), None)
                 for k, (name, msgtype, count) in enumerate(bags._metadata(path), start=1)]
        return conns, ts, Counter({c.topic: c.msgcount for c in conns}) or None
    walker, _faults = salvage.walk_topics(bags.storage_file(path, fmt), fmt)
    types: dict = {}
    conns = []
    for found in walker.connections.values():
        msgtype = bags._typename(found.msgtype)
        with contextlib.suppress(Exception):  # no definition, or one that does not parse: the stock types
            if found.encoding in ("ros1msg", "ros2msg") and found.definition:
                types.update(get_types_from_msg(found.definition, msgtype))
            elif found.encoding == "ros2idl" and found.definition:
                types.update(get_types_from_idl(found.definition))
        extra = found.extra or {}
        ext = ConnectionExtRosbag1(extra.get("callerid"), int(extra.get("latching", 0) or 0)) \
            if fmt == "ros1" else ConnectionExtRosbag2("cdr", [])
        conns.append(Connection(found.id, found.topic, msgtype, MessageDefinition(MessageDefinitionFormat.NONE, ""),
                                "", 0, ext, None))
    ts = get_typestore(Stores.EMPTY)
    ts.register(salvage.typestore(fmt == "ros1").fielddefs)
    with contextlib.suppress(Exception):
        ts.register(types)
    return conns, ts, walker.index_counts


def _messages(path: Path, fmt: str, topics: frozenset[str], faults: Faults,
              walked: list[salvage.Walker]) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, receive_ns, raw)`` of every message on ``topics``; damage noted in ``faults``. A
    walker (ROS1, MCAP) is appended to ``walked`` when its walk is complete (its books then hold)."""
    if fmt in salvage.WALKERS:
        walker = salvage.WALKERS[fmt](bags.storage_file(path, fmt), topics)
        for item in walker.messages():
            if isinstance(item, salvage.Fault):
                if not faults.skip(item.where, item.reason, item.count, known=False, open_end=item.open_end):
                    return
                continue
            yield item[:3]
        walked.append(walker)
        return
    done: Counter = Counter()
    try:
        reader = AnyReader([path], default_typestore=salvage.typestore(False))
        reader.open()
    except Exception:  # noqa: BLE001 - the database: row by row below
        reader = None
    if reader is not None:
        try:
            for conn, stamp, raw in reader.messages(connections=[c for c in reader.connections
                                                                 if c.topic in topics]):
                yield conn.topic, stamp, bytes(raw)
                done[conn.topic, stamp] += 1
            return
        except Exception as exc:  # noqa: BLE001 - rosbags stops at a damaged page: read on row by row
            if not faults.skip("in its database", f"{type(exc).__name__}: {exc}", 0, known=False):
                return
        finally:
            reader.close()
    gen = salvage.salvage_sqlite3(bags.storage_file(path, fmt), topics, known=bags._metadata_topics(path))
    while True:
        try:
            row = next(gen)
        except StopIteration as stop:
            if stop.value is not None:
                faults.skip(stop.value.where, stop.value.reason, 0, known=False, open_end=stop.value.open_end)
            return
        if isinstance(row, salvage.Fault):
            if not faults.skip(row.where, row.reason, 0, known=False, open_end=row.open_end):
                return
            continue
        name, stamp, raw = row
        if done[name, stamp]:
            done[name, stamp] -= 1
            continue
        yield name, stamp, raw


def copy_bag(src: Path, src_fmt: str, dst: Path, dst_fmt: str, *, overwrite: bool = False, strict: bool = False,
             progress: bool = False) -> tuple[int, int, Counter]:
    """Copy every topic of a bag into another bag (see the module docstring).

    Raises :class:`~labkit.io.CorruptFileError` after the copy is complete when ``src`` is
    damaged (the scans are the messages of its LaserScan topics; the other topics' losses are
    counted as other records).

    Parameters
    ----------
    src : Path
        The bag to copy.
    src_fmt : str
        Its format: ``"ros1"``, ``"ros2"`` or ``"mcap"``.
    dst : Path
        The bag to write.
    dst_fmt : str
        Its format.
    overwrite : bool
        Replace an existing bag at ``dst``.
    strict : bool
        Stop at the first record that cannot be read.
    progress : bool
        Show a progress bar.

    Returns
    -------
    scans : int
        The LaserScan messages copied.
    messages : int
        All messages copied.
    written : collections.Counter
        The messages written per topic.
    """
    from rosbags.convert.converter import create_connections_converters

    connections, src_ts, listed = _source(src, src_fmt)
    scan_topics = {c.topic for c in connections if c.msgtype in salvage.LASERSCAN_TYPES}
    expected = sum(listed[t] for t in scan_topics) if listed is not None else None
    faults = Faults(src, strict, expected)
    walked: list[salvage.Walker] = []  # the source's walker, once its walk is complete
    written: Counter = Counter()
    skipped: Counter = Counter()
    reasons: dict[str, str] = {}
    with safe_output(dst, bags.output_kind(dst, dst_fmt), overwrite=overwrite, inputs=[src]) as tmp, \
            bags._system_errors(dst):
        target = tmp.parent / dst.stem if dst_fmt == "mcap" and dst.name.lower().endswith(".mcap") else tmp
        writer: rosbag1.Writer | rosbag2.Writer
        if dst_fmt == "ros1":
            writer = rosbag1.Writer(target)
        else:
            plugin = rosbag2.StoragePlugin.MCAP if dst_fmt == "mcap" else rosbag2.StoragePlugin.SQLITE3
            writer = rosbag2.Writer(target, version=9, storage_plugin=plugin)
        writer.open()
        try:
            # rosbags reads only the reader's typestore and is2 (rosbags.convert.converter): a stand-in
            # for the source, which may be a walker's findings rather than an AnyReader
            standin = cast(AnyReader, SimpleNamespace(typestore=src_ts, is2=src_fmt != "ros1"))
            by_topic: dict[str, tuple] = {}
            for conn in connections:
                if conn.topic in by_topic:
                    continue
                notes = io.StringIO()
                try:
                    with contextlib.redirect_stdout(notes):
                        connmap, convmap = create_connections_converters([conn], None, standin, writer)
                    by_topic[conn.topic] = (connmap[(conn.id, conn.owner)], convmap[conn.msgtype])
                except Exception as exc:  # noqa: BLE001 - a type rosbags cannot carry over: skip the topic
                    reasons[conn.topic] = f"{conn.msgtype}: {type(exc).__name__}: {exc}"
            messages = _messages(src, src_fmt, frozenset(c.topic for c in connections), faults, walked)
            if progress:
                from tqdm.auto import tqdm

                messages = tqdm(messages, total=sum(listed.values()) if listed else None, unit="msg",
                                desc=f"convert {src.name}")
            for topic, stamp, raw in messages:
                if topic not in by_topic:
                    skipped[topic] += 1
                    continue
                conn, conv = by_topic[topic]
                try:
                    data = conv(raw)
                except Exception as exc:  # noqa: BLE001 - a message that does not convert: skipped, counted
                    if topic in scan_topics:
                        if not faults.skip(f"in a message of {topic}", f"it does not convert ({exc})"):
                            break
                    else:
                        skipped[topic] += 1
                        reasons.setdefault(topic, f"a message does not convert ({exc})")
                    continue
                with bags.whole_writes():
                    writer.write(conn, stamp, data)
                written[topic] += 1
        finally:
            writer.close()
            if target != tmp:
                made = target / f"{dst.stem}.mcap"
                if made.exists():
                    made.replace(tmp)
        for topic, n in sorted(skipped.items()):
            warnings.warn(f"{n} message(s) of {topic} were not carried into {dst}: {reasons.get(topic, '?')}",
                          TopicsSkippedWarning, stacklevel=2)
        n_scans = sum(written[t] for t in scan_topics)
        walker = walked[0] if walked else None
        if walker is not None and walker.index_counts is not None:  # the file's own index, as the walker read
            listed = walker.index_counts  # it (rosbags counts what the chunks it could open say)
            faults.expected = sum(listed[t] for t in scan_topics)
        others = [t for t in {c.topic for c in connections} if t not in scan_topics]
        if listed is not None:
            faults.other = sum(max(listed[t] - written[t] - skipped[t], 0) for t in others)
        elif walker is not None:
            faults.other = sum(walker.lost[t] for t in others)
        if walker is not None:
            faults.lose(sum(walker.lost[t] for t in scan_topics))
        faults.check(n_scans)
    return n_scans, sum(written.values()), written
