"""A damaged bag keeps every message that can be read, and the loss is counted in scans.

For each format -- ROS1 (uncompressed, bz2, lz4 chunks), MCAP (uncompressed, lz4, zstd chunks)
and ROS2 sqlite3 -- one small recording is written by the test (rosbags' and the ``mcap``
package's writers, several chunks each), then damaged: garbage of 64 B to 64 KiB at spread
positions, and truncation at spread offsets. What labkit reads is compared with what an
independent reading of the damaged file finds intact, written here and not using labkit's
reader:

- the test walks the *original* file (its own record walker for ROS1 and MCAP) and notes where
  every message record lies: in the file, or at an offset inside a chunk's decompressed data;
- a message is intact in the damaged copy when its record's bytes are all still there, unchanged:
  in the file for uncompressed storage; for a compressed chunk, in what the codec still decodes
  of the damaged chunk (bz2: ``bzip2recover``'s blocks, each placed in the original data; lz4 and
  zstd: what the decoder gives fed a little at a time, until it stops) -- a chunk whose header is
  hit is lost whole;
- ROS2 sqlite3: the rows sqlite itself reads one by one, and among them those whose data are the
  original's.

labkit must keep every intact scan and at most one more (the message the damage hits, when its
framing survives and only its float values are garbled: no ROS format has a checksum that would
tell); never invent or reorder a scan; raise CorruptFileError (exit 1) whenever the damage touches
more than one message's data bytes; and say exactly how many scans it kept and lost when the
file's index is intact (a lower bound otherwise). A few cases run the command line itself.
"""

from __future__ import annotations

import bz2
import re
import shutil
import sqlite3
import struct
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import lz4.frame
import numpy as np
import pytest
import zstandard
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags import rosbag1, rosbag2

from labkit.io import CorruptFileError, read_scans, salvage

N = 300  # scans per recording; an odometry message rides along every second scan
T0 = 100 * 10**9
SIZES = [64, 256, 1024, 4096, 16384, 65536]
FRACTIONS = [0.04 + 0.05 * k for k in range(19)]  # 19 positions from 4 % to 94 %, and the end below
CUTS = [0.03 + 0.05 * k for k in range(20)]
LABKIT = [str(Path(sys.executable).parent / "labkit")]


# ---------------------------------------------------------------------------- the recordings
def _messages(ros1: bool):
    """(topic, msgtype, receive_ns, raw) of the recording, in order: N LaserScans of 181 beams
    whose stamps number them, and odometry."""
    ts = salvage.typestore(ros1)
    t = ts.types
    out = []
    for k in range(N):
        stamp = T0 + k * 10**8
        time = t["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
        header = t["std_msgs/msg/Header"](stamp=time, frame_id="laser", **({"seq": k} if ros1 else {}))
        ranges = np.random.default_rng(k).uniform(0.5, 5.0, 181).astype(np.float32)
        scan = t["sensor_msgs/msg/LaserScan"](header=header, angle_min=-1.5, angle_max=1.5, angle_increment=3.0 / 180,
                                              time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=10.0,
                                              ranges=ranges, intensities=np.zeros(0, np.float32))
        out.append(("/scan", "sensor_msgs/msg/LaserScan", stamp, scan))
        if k % 2 == 0:
            point = t["geometry_msgs/msg/Point"](x=0.01 * k, y=0.0, z=0.0)
            pose = t["geometry_msgs/msg/Pose"](position=point, orientation=t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=0.0, w=1.0))
            zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
            odom = t["nav_msgs/msg/Odometry"](
                header=t["std_msgs/msg/Header"](stamp=time, frame_id="map", **({"seq": k} if ros1 else {})),
                child_frame_id="laser", pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose,
                                                                                      covariance=np.zeros(36)),
                twist=t["geometry_msgs/msg/TwistWithCovariance"](
                    twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))
            out.append(("/odom", "nav_msgs/msg/Odometry", stamp, odom))
    serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    return [(topic, msgtype, stamp, bytes(serialize(msg, msgtype))) for topic, msgtype, stamp, msg in out]


def write_ros1(path: Path, compression: str | None, monkeypatch) -> Path:
    ts = salvage.typestore(True)
    if compression == "bz2":  # bz2 level 1: 100 kB blocks, so that a chunk holds several
        import rosbags.rosbag1.writer as w1

        monkeypatch.setattr(w1, "bz2_compress", lambda data, _level: bz2.compress(data, 1))
    writer = rosbag1.Writer(path)
    writer.chunk_threshold = 150_000 if compression else 40_000
    if compression:
        writer.set_compression(getattr(rosbag1.Writer.CompressionFormat, compression.upper()))
    writer.open()
    conns = {}
    for topic, msgtype, stamp, raw in _messages(True):
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        writer.write(conns[topic], stamp, raw)
    writer.close()
    return path


def write_mcap(path: Path, compression: str) -> Path:
    ts = salvage.typestore(False)
    with open(path, "wb") as fh:
        writer = McapWriter(fh, chunk_size=40_000, compression={
            "none": CompressionType.NONE, "lz4": CompressionType.LZ4, "zstd": CompressionType.ZSTD}[compression])
        writer.start("ros2", "labkit tests")
        channels = {}
        for seq, (topic, msgtype, stamp, raw) in enumerate(_messages(False)):
            if topic not in channels:
                schema = writer.register_schema(msgtype, "ros2msg",
                                                ts.generate_msgdef(msgtype, ros_version=2)[0].encode())
                channels[topic] = writer.register_channel(topic, "cdr", schema)
            writer.add_message(channels[topic], stamp, raw, stamp, sequence=seq)
        writer.finish()
    return path


def write_ros2(path: Path) -> Path:
    ts = salvage.typestore(False)
    writer = rosbag2.Writer(path, version=9, storage_plugin=rosbag2.StoragePlugin.SQLITE3)
    writer.open()
    conns = {}
    for topic, msgtype, stamp, raw in _messages(False):
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        writer.write(conns[topic], stamp, raw)
    writer.close()
    return path


# ---------------------------------------------------------------------------- the test's own walkers
@dataclass
class Chunk:
    head: int  # file offset of the chunk record
    data: int  # file offset of its (compressed) data
    end: int  # end of its data
    compression: str
    plain: bytes  # its records, decompressed


@dataclass
class Msg:
    topic: str
    stamp: int
    chunk: int  # index into Layout.chunks
    start: int  # offset of the record in the chunk's decompressed data
    stop: int
    free: int  # from here on, a change may go unnoticed: the message's data (and MCAP's sequence and times)


@dataclass
class Layout:
    """Where every message record of an intact file lies."""

    chunks: list[Chunk] = field(default_factory=list)
    messages: list[Msg] = field(default_factory=list)
    index_start: int = 0  # the index (ROS1) or summary (MCAP) runs from here to the end


def ros1_layout(data: bytes) -> Layout:
    """Walk an intact ROS1 bag: chunks (op 5), their connection (7) and message (2) records."""
    layout, conns = Layout(), {}

    def records(buf, pos, end):
        while pos < end:
            hlen = int.from_bytes(buf[pos : pos + 4], "little")
            fields, p = {}, pos + 4
            while p < pos + 4 + hlen:
                n = int.from_bytes(buf[p : p + 4], "little")
                name, _, value = buf[p + 4 : p + 4 + n].partition(b"=")
                fields[name] = value
                p += 4 + n
            dlen = int.from_bytes(buf[p : p + 4], "little")
            yield pos, fields, p + 4, p + 4 + dlen
            pos = p + 4 + dlen

    for pos, fields, start, stop in records(data, 13, len(data)):
        if fields[b"op"] == b"\x03":
            layout.index_start = int.from_bytes(fields[b"index_pos"], "little")
        if fields[b"op"] != b"\x05":
            continue
        compression = fields[b"compression"].decode()
        raw = data[start:stop]
        plain = {"none": lambda b: b, "bz2": bz2.decompress, "lz4": lz4.frame.decompress}[compression](raw)
        layout.chunks.append(Chunk(pos, start, stop, compression, plain))
        for ipos, ifields, istart, istop in records(plain, 0, len(plain)):
            conn = int.from_bytes(ifields[b"conn"], "little")
            if ifields[b"op"] == b"\x07":
                conns[conn] = ifields[b"topic"].decode()
            elif ifields[b"op"] == b"\x02":
                sec, nsec = struct.unpack("<II", ifields[b"time"])
                layout.messages.append(Msg(conns[conn], sec * 10**9 + nsec, len(layout.chunks) - 1, ipos, istop,
                                           istart))  # the header (op, conn, time) and data length are framing
    return layout


def _unzstd(data: bytes) -> bytes:
    return zstandard.ZstdDecompressor().decompress(data, max_output_size=1 << 26)


def mcap_layout(data: bytes) -> Layout:
    """Walk an intact MCAP file: chunks (0x06), their channel (0x04) and message (0x05) records."""
    layout, channels = Layout(), {}

    def records(buf, pos, end):
        while pos + 9 <= end:
            op, length = buf[pos], int.from_bytes(buf[pos + 1 : pos + 9], "little")
            yield pos, op, pos + 9, pos + 9 + length
            pos += 9 + length

    for pos, op, start, stop in records(data, 8, len(data) - 8):
        if op == 0x0F:  # data end: the summary follows
            layout.index_start = pos
        if op != 0x06:
            continue
        n = int.from_bytes(data[start + 28 : start + 32], "little")
        compression = data[start + 32 : start + 32 + n].decode()
        dstart = start + 32 + n + 8
        raw = data[dstart:stop]
        plain = {"": lambda b: b, "lz4": lz4.frame.decompress,
                 "zstd": _unzstd}[compression](raw)
        layout.chunks.append(Chunk(pos, dstart, stop, compression or "none", plain))
        for ipos, iop, istart, istop in records(plain, 0, len(plain)):
            if iop == 0x04:
                cid = int.from_bytes(plain[istart : istart + 2], "little")
                tlen = int.from_bytes(plain[istart + 4 : istart + 8], "little")
                channels[cid] = plain[istart + 8 : istart + 8 + tlen].decode()
            elif iop == 0x05:
                cid = int.from_bytes(plain[istart : istart + 2], "little")
                stamp = int.from_bytes(plain[istart + 6 : istart + 14], "little")
                layout.messages.append(Msg(channels[cid], stamp, len(layout.chunks) - 1, ipos, istop, istart + 2))
    return layout


# ---------------------------------------------------------------------------- what survives, independently
def _bzip2recover(raw: bytes, tmp: Path) -> list[bytes]:
    """The blocks ``bzip2recover`` cuts out of damaged bz2 data that decompress."""
    folder = tmp / "bz2rec"
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    (folder / "chunk.bz2").write_bytes(raw)
    subprocess.run(["bzip2recover", "chunk.bz2"], cwd=folder, capture_output=True, check=False)
    pieces = []
    for p in sorted(folder.glob("rec*chunk.bz2")):
        try:
            pieces.append(bz2.decompress(p.read_bytes()))
        except (OSError, ValueError, EOFError):
            continue
    return pieces


def _decode_until_it_stops(raw: bytes, compression: str) -> bytes:
    decoder = lz4.frame.LZ4FrameDecompressor() if compression == "lz4" else \
        zstandard.ZstdDecompressor().decompressobj()
    out = []
    for i in range(0, len(raw), 16):  # small pieces: little output is lost with the call that fails
        try:
            out.append(decoder.decompress(raw[i : i + 16]))
        except Exception:  # noqa: BLE001 - each decoder raises its own
            break
    return b"".join(out)


@dataclass
class Truth:
    intact: list[int]  # stamps of the scans found intact
    maybe: int  # scans hit only past their framing (they may be read, garbled: no checksum tells)
    detectable: bool  # the damage touches more than one message's data bytes
    index_intact: bool


def survivors(layout: Layout, original: bytes, damaged: bytes, tmp: Path) -> Truth:
    size = min(len(original), len(damaged))
    changed = np.flatnonzero(np.frombuffer(original[:size], np.uint8) != np.frombuffer(damaged[:size], np.uint8))
    cut = len(damaged) < len(original)
    first = int(changed[0]) if len(changed) else len(damaged)
    last = int(changed[-1]) + 1 if len(changed) else len(damaged)
    intact, hit = [], []  # hit: (message, bytes of it that changed all lie in its data part)
    for c, chunk in enumerate(layout.chunks):
        msgs = [m for m in layout.messages if m.chunk == c]
        touched = (chunk.head < last and first < chunk.end) or len(damaged) < chunk.end
        if not touched:
            intact.extend(msgs)
            continue
        if chunk.compression == "none":  # the records are in the file: compare them where they lie
            for m in msgs:
                a, b, d = chunk.data + m.start, chunk.data + m.stop, chunk.data + m.free
                if b <= len(damaged) and damaged[a:b] == original[a:b]:
                    intact.append(m)
                else:
                    bad = changed[(changed >= a) & (changed < b)]
                    hit.append((m, b <= len(damaged) and len(bad) > 0 and bad[0] >= d))
            continue
        if chunk.head < last and first < chunk.data or len(damaged) <= chunk.data:  # its header: lost whole
            hit.extend((m, False) for m in msgs)
            continue
        raw = damaged[chunk.data : chunk.end]
        if chunk.compression == "bz2":
            plain = bytearray(len(chunk.plain))
            known = np.zeros(len(chunk.plain), bool)
            for piece in _bzip2recover(raw, tmp):
                at = chunk.plain.find(piece)
                if at >= 0:
                    plain[at : at + len(piece)] = piece
                    known[at : at + len(piece)] = True
            for m in msgs:
                (intact.append(m) if known[m.start : m.stop].all() else hit.append((m, False)))
            continue
        plain = _decode_until_it_stops(raw, chunk.compression)
        for m in msgs:
            if plain[m.start : m.stop] == chunk.plain[m.start : m.stop]:
                intact.append(m)
            else:
                diff = [i for i in range(m.start, min(m.stop, len(plain))) if plain[i] != chunk.plain[i]]
                hit.append((m, len(plain) >= m.stop and bool(diff) and diff[0] >= m.free))
    # undetectable only when one message is hit, past its framing (no checksum tells)
    detectable = cut or len(hit) != 1 or not hit[0][1]
    maybe = sum(1 for m, data_only in hit if m.topic == "/scan" and data_only)
    return Truth(sorted(m.stamp for m in intact if m.topic == "/scan"), maybe, detectable,
                 last <= layout.index_start and not cut)


def sqlite_survivors(original_rows: dict[int, bytes], db: Path, tmp: Path) -> tuple[list[int], int]:
    """Rows sqlite reads one by one in the damaged copy (after the test fixes the page count of a
    file cut short): ids whose data is the original's, and how many it reads with other data."""
    data = db.read_bytes()
    page = int.from_bytes(data[16:18], "big")
    whole = len(data) // page * page
    fixed = bytearray(data[:whole])
    if len(fixed) >= 100:
        fixed[28:32] = (whole // page).to_bytes(4, "big")
    copy = tmp / "oracle.db3"
    copy.write_bytes(bytes(fixed))
    same, other = [], 0
    try:
        con = sqlite3.connect(f"file:{copy}?mode=ro", uri=True)
    except sqlite3.DatabaseError:
        return [], 0
    for row_id, raw in original_rows.items():
        try:
            row = con.execute("SELECT data FROM messages WHERE id = ?", (row_id,)).fetchone()
        except sqlite3.DatabaseError:
            continue
        if row is not None:
            if bytes(row[0]) == raw:
                same.append(row_id)
            else:
                other += 1
    con.close()
    return same, other


# ---------------------------------------------------------------------------- fixtures
KINDS = ["ros1-none", "ros1-bz2", "ros1-lz4", "mcap-none", "mcap-lz4", "mcap-zstd"]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("salvage")
    out = {}
    with pytest.MonkeyPatch.context() as mp:
        for kind in KINDS:
            fmt, compression = kind.split("-")
            path = d / f"{kind}.{'bag' if fmt == 'ros1' else 'mcap'}"
            if fmt == "ros1":
                write_ros1(path, None if compression == "none" else compression, mp)
            else:
                write_mcap(path, compression)
            data = path.read_bytes()
            layout = ros1_layout(data) if fmt == "ros1" else mcap_layout(data)
            assert len(layout.chunks) >= 3 and sum(m.topic == "/scan" for m in layout.messages) == N
            out[kind] = (path, data, layout)
    return out


def _read(path: Path):
    """What labkit reads, and its error (without the pose pass, for speed: the command line cases
    below read the poses too)."""
    got, error = [], None
    try:
        for scan in read_scans(path, poses=False):
            got.append(scan)
    except CorruptFileError as exc:
        error = exc
    return got, error


def _check(got, error, truth: Truth, label: str) -> None:
    stamps = [s.stamp_ns for s in got]
    originals = {T0 + k * 10**8 for k in range(N)}
    foreign = [s for s in stamps if s not in originals]
    genuine = [s for s in stamps if s in originals]
    assert len(foreign) <= truth.maybe, f"{label}: {len(foreign)} scans that are not in the recording"
    assert genuine == sorted(set(genuine)), f"{label}: scans reordered or repeated"
    counts = f"{len(got)} read, {len(truth.intact)} intact"
    assert set(truth.intact) <= set(genuine), f"{label}: {len(set(truth.intact) - set(genuine))} intact lost ({counts})"
    assert len(got) <= len(truth.intact) + truth.maybe, f"{label}: {counts}"
    if truth.detectable:
        assert error is not None, f"{label}: damaged, but no error ({len(got)} of {N} read)"
    if error is not None:
        assert error.n_read == len(got)
        if truth.index_intact:
            assert error.lost_exact and error.n_lost == N - len(got), f"{label}: {error}"
            assert f"{len(got)} scans kept, {N - len(got) or 'none'} lost" in str(error)
        else:
            assert error.n_lost <= N - len(got), f"{label}: {error}"


def _garbage(n: int, seed: int) -> bytes:
    return np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes()


# ---------------------------------------------------------------------------- the tests
@pytest.mark.parametrize("kind", KINDS)
def test_garbage_costs_only_what_the_format_cannot_recover(recordings, kind, tmp_path):
    path, original, layout = recordings[kind]
    target = tmp_path / path.name
    for k, fraction in enumerate([*FRACTIONS, 0.999]):
        size = SIZES[k % len(SIZES)]
        at = min(int(len(original) * fraction), len(original) - size)
        damaged = bytearray(original)
        damaged[at : at + size] = _garbage(size, k)
        target.write_bytes(bytes(damaged))
        got, error = _read(target)
        _check(got, error, survivors(layout, original, bytes(damaged), tmp_path), f"{kind} {size} B at {at}")


@pytest.mark.parametrize("kind", KINDS)
def test_a_file_cut_short_keeps_every_whole_message(recordings, kind, tmp_path):
    path, original, layout = recordings[kind]
    target = tmp_path / path.name
    for fraction in CUTS:
        cut = int(len(original) * fraction)
        target.write_bytes(original[:cut])
        got, error = _read(target)
        truth = survivors(layout, original, original[:cut], tmp_path)
        _check(got, error, truth, f"{kind} cut at {cut}")
        assert error is not None and not error.lost_exact  # what came after the cut is unknown


@pytest.fixture(scope="module")
def ros2(tmp_path_factory):
    d = tmp_path_factory.mktemp("salvage2")
    folder = write_ros2(d / "rec")
    db = next(folder.glob("*.db3"))
    con = sqlite3.connect(db)
    topics = dict(con.execute("SELECT id, name FROM topics"))
    rows = {row_id: (topics[tid], bytes(raw))
            for row_id, tid, raw in con.execute("SELECT id, topic_id, data FROM messages")}
    con.close()
    return folder, db.read_bytes(), rows


def test_ros2_sqlite_keeps_every_row_sqlite_can_read(ros2, tmp_path):
    folder, original, rows = ros2
    scans = {row_id: raw for row_id, (topic, raw) in rows.items() if topic == "/scan"}
    cases = [("garbage", f, SIZES[k % len(SIZES)]) for k, f in enumerate(FRACTIONS[::2])] + \
        [("cut", f, 0) for f in CUTS[::2]]
    for k, (how, fraction, size) in enumerate(cases):
        target = tmp_path / f"case{k}"
        shutil.copytree(folder, target)
        db = next(target.glob("*.db3"))
        at = int(len(original) * fraction)
        if how == "cut":
            db.write_bytes(original[:at])
        else:
            damaged = bytearray(original)
            damaged[at : at + size] = _garbage(size, k)
            db.write_bytes(bytes(damaged))
        same, other = sqlite_survivors(scans, db, tmp_path)
        got, error = _read(target)
        label = f"ros2 {how} {size} at {at}"
        assert len(same) <= len(got) <= len(same) + other, f"{label}: {len(got)} read, {len(same)} intact"
        if error is not None:
            assert error.n_read == len(got)
            assert error.lost_exact and error.n_lost == N - len(got), f"{label}: {error}"  # metadata.yaml says N
        if len(same) + other < N:  # rows sqlite cannot read (rows it reads with other data may decode)
            assert error is not None, f"{label}: rows lost, no error"


# ---------------------------------------------------------------------------- the command line
def test_the_command_line_never_exits_0_and_says_what_was_lost(recordings, tmp_path):
    """A handful of cases through ``labkit convert``: exit 1, one line naming the file, the
    first damage's byte offset, the scans kept and lost; the output holds the scans kept."""
    for kind, fraction, size in [("ros1-bz2", 0.5, 4096), ("mcap-none", 0.4, 4096)]:
        path, original, layout = recordings[kind]
        damaged = bytearray(original)
        at = int(len(original) * fraction)
        damaged[at : at + size] = _garbage(size, 7)
        target = tmp_path / path.name
        target.write_bytes(bytes(damaged))
        truth = survivors(layout, original, bytes(damaged), tmp_path)
        out = tmp_path / f"{kind}.jsonl"
        p = subprocess.run([*LABKIT, "-q", "convert", str(target), str(out)], capture_output=True, text=True)
        assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr
        (line,) = [ln for ln in p.stderr.splitlines() if ln.startswith("labkit: error:")]
        kept = len(out.read_text().splitlines())
        assert len(truth.intact) <= kept <= len(truth.intact) + truth.maybe
        assert f"{target} is damaged" in line and f"{kept} scans kept, {N - kept} lost" in line, line
        where = int(re.search(r"at byte (\d+)", line).group(1))
        chunk = next(c for c in layout.chunks if c.head <= at < c.end)
        assert chunk.head <= where <= at + size, line
        if kind.startswith("mcap"):  # --strict stops at the damage (it did not fire for MCAP); info counts the same
            p = subprocess.run([*LABKIT, "-q", "convert", "--strict", str(target), str(out), "-f"],
                               capture_output=True, text=True)
            assert p.returncode == 1 and "reading stopped there (strict)" in p.stderr, p.stderr
            assert len(out.read_text().splitlines()) < kept
            p = subprocess.run([*LABKIT, "info", str(target)], capture_output=True, text=True)
            assert p.returncode == 1 and f"{kept} scans kept, {N - kept} lost" in p.stderr, p.stderr
            assert f"scans (/scan): {kept} kept, {N - kept} lost" in p.stdout, p.stdout


# ---------------------------------------------------------------------------- memory
def _file_pages_kib() -> int:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith("RssFile:"))


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux's /proc/self/status (RssFile)")
@pytest.mark.parametrize("let_go", [True, False])
def test_a_long_recording_does_not_stay_in_the_readers_memory(tmp_path, monkeypatch, let_go):
    """The walk maps the file; the pages it walked past are let go as it goes, so reading a recording
    costs the process the same memory whatever its length (a 10,000-scan bag once added its 30 MB to
    `labkit view`'s resident memory). Measured as the resident file pages (RssFile) while an 8 MB
    uncompressed bag is walked; without letting go (the other case, checking that the measure sees
    the mapping at all) they grow by about the file's size."""
    ts = salvage.typestore(True)
    t = ts.types
    stamp = t["builtin_interfaces/msg/Time"](sec=100, nanosec=0)
    scan = t["sensor_msgs/msg/LaserScan"](
        header=t["std_msgs/msg/Header"](stamp=stamp, frame_id="laser", seq=0), angle_min=-1.5, angle_max=1.5,
        angle_increment=3.0 / 1999, time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=10.0,
        ranges=np.full(2000, 2.0, np.float32), intensities=np.zeros(0, np.float32))
    raw = bytes(ts.serialize_ros1(scan, "sensor_msgs/msg/LaserScan"))
    path = tmp_path / "long.bag"
    writer = rosbag1.Writer(path)
    writer.open()
    conn = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
    for k in range(1000):
        writer.write(conn, T0 + k * 10**8, raw)
    writer.close()
    size_kib = path.stat().st_size // 1024
    monkeypatch.setattr(salvage, "_LET_GO_EVERY", (256 << 10) if let_go else (1 << 40))
    walk = salvage.Ros1Walker(path, "/scan").messages()
    for _ in range(50):  # past the first records (and whatever their decoding first loads)
        next(walk)
    before = most = _file_pages_kib()
    for k, _ in enumerate(walk):
        if k % 50 == 0:
            most = max(most, _file_pages_kib())
    grew = most - before
    if let_go:
        assert grew < size_kib / 4, f"resident file pages grew by {grew} KiB reading a {size_kib} KiB file"
    else:
        assert grew > size_kib / 2, f"the measure does not see the mapping ({grew} KiB for {size_kib} KiB)"
