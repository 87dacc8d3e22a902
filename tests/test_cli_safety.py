"""The command line never destroys data, never shows a traceback, and keeps every readable record.

Every case runs ``labkit`` as a user does (a subprocess of the installed command line) and
checks three things: the exit status documented in the README ("When things go wrong"), that
stderr holds no traceback, and what is on disk afterwards -- the sentinel file that must
survive, the input that must be byte-identical, the number of records kept against the
number of good records put in.

Writers: a folder of someone's files as the output with ``-f``, the input as the output, an
existing output without ``-f``, a read-only folder and an unreadable input (run as the
unprivileged user ``nobody``), a missing folder, Ctrl-C in the middle of a run, a full disk.
Readers: files cut at several offsets, garbled bytes, one malformed record in the middle,
empty files; the expected counts come from the test's own knowledge of what it put in (its
own CARMEN and JSON writers, rosbags' chunk index), not from labkit.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from rosbags import rosbag1, rosbag2

from labkit import Scan, read_scans, sim
from labkit.io import EmptyRecordingError, salvage
from tests.cli_here import in_process

# The installed command, as users run it. (`python -m labkit.app.cli` would do for most cases, but
# CPython run with -m sometimes ends with SIGINT although main() caught the Ctrl-C and returned 130.)
LABKIT = [str(Path(sys.executable).parent / "labkit")]
N = 30  # scans in every test recording
NOBODY = 65534


def labkit(*args, cwd=None, timeout=300, preexec=None, python=None) -> subprocess.CompletedProcess:
    """Run the command line; no case may show a traceback. In this process unless the case needs a
    process of its own (another folder, user, limit or interpreter): a fresh process costs seconds of
    imports per call, and what a process adds (Ctrl-C, pipes) is tested with real processes below."""
    if cwd is None and preexec is None and python is None:
        p = in_process(*args)
    else:
        cmd = [*(python or LABKIT), "-q", *map(str, args)]
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=timeout, preexec_fn=preexec)
    assert "Traceback" not in p.stderr, p.stderr
    return p


def one_error_line(p: subprocess.CompletedProcess) -> str:
    """The single ``labkit: error:`` line of a refused or damaged run."""
    errors = [ln for ln in p.stderr.splitlines() if ln.startswith("labkit: error:")]
    assert len(errors) == 1, p.stderr
    return errors[0]


def digest(path: Path) -> str:
    """A hash of a file, or of every file in a folder (names and contents)."""
    h = hashlib.sha1()
    for p in sorted([path] if path.is_file() else path.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(path.parent)).encode() + p.read_bytes())
    return h.hexdigest()


def leftovers(folder: Path) -> list[str]:
    """Temporary outputs labkit left behind (it must leave none)."""
    return [p.name for p in folder.rglob("*") if ".labkit-" in p.name]


# ---------------------------------------------------------------------------- recordings
def carmen_text(scans) -> str:
    """FLASER lines written by the test itself (CARMEN's old-style front laser message)."""
    lines = []
    for k, s in enumerate(scans):
        ranges = " ".join(f"{r:.3f}" for r in s.ranges)
        t = 100.0 + 0.1 * k
        lines.append(f"FLASER {s.n_beams} {ranges} 1.0 2.0 0.5 1.0 2.0 0.5 {t:.3f} testhost {t:.3f}\n")
    return "".join(lines)


def laser_message(ts, scan: Scan, ros1: bool, angle_increment=None):
    t = ts.types
    stamp = t["builtin_interfaces/msg/Time"](sec=scan.stamp_ns // 10**9, nanosec=scan.stamp_ns % 10**9)
    header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="laser", **({"seq": 0} if ros1 else {}))
    inc = scan.angle_increment if angle_increment is None else angle_increment
    return t["sensor_msgs/msg/LaserScan"](
        header=header, angle_min=float(scan.angles[0]), angle_max=float(scan.angles[-1]), angle_increment=inc,
        time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=float(scan.range_max),
        ranges=scan.ranges.astype(np.float32), intensities=np.zeros(0, np.float32))


def raw_bag(path: Path, fmt: str, scans, *, bad: int | None = None, chunk_bytes: int | None = None) -> Path:
    """A bag written with rosbags alone; message ``bad`` gets ``angle_increment`` 0 (impossible)."""
    ros1 = fmt == "ros1"
    ts = salvage.typestore(ros1)
    if ros1:
        writer = rosbag1.Writer(path)
        if chunk_bytes:
            writer.chunk_threshold = chunk_bytes
    else:
        plugin = rosbag2.StoragePlugin.MCAP if fmt == "mcap" else rosbag2.StoragePlugin.SQLITE3
        writer = rosbag2.Writer(path, version=9, storage_plugin=plugin)
    writer.open()
    conn = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
    for k, s in enumerate(scans):
        msg = laser_message(ts, s, ros1, 0.0 if k == bad else None)
        raw = ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan") if ros1 else ts.serialize_cdr(
            msg, "sensor_msgs/msg/LaserScan")
        writer.write(conn, s.stamp_ns, raw)
    writer.close()
    return path


@pytest.fixture(scope="module")
def rec(tmp_path_factory) -> SimpleNamespace:
    """One small recording in every format, and the scans it holds."""
    d = tmp_path_factory.mktemp("recordings")
    scans = [s for s, _ in sim.simulate("hall", seed=3, n_scans=N)]
    r = SimpleNamespace(dir=d, scans=scans)
    r.bag = raw_bag(d / "rec.bag", "ros1", scans, chunk_bytes=8_000)  # several chunks
    r.mcap = d / "rec.mcap"
    subprocess.run([*LABKIT, "-q", "convert", r.bag, r.mcap], check=True, capture_output=True)
    r.ros2 = raw_bag(d / "rec_ros2", "ros2", scans)
    r.jsonl = d / "rec.jsonl"
    subprocess.run([*LABKIT, "-q", "convert", r.bag, r.jsonl], check=True, capture_output=True)
    r.json = d / "one.json"
    r.json.write_text(json.dumps({"ranges": [1.0, 2.0, None], "bearings": [0.0, 0.1, 0.2]}))
    r.log = d / "rec.log"
    r.log.write_text(carmen_text(scans))
    r.gz = d / "rec.log.gz"
    r.gz.write_bytes(gzip.compress(r.log.read_bytes()))
    return r


@pytest.fixture(scope="module")
def big_bag(tmp_path_factory) -> Path:
    """A recording long enough (3000 scans) to be interrupted in the middle of any command."""
    d = tmp_path_factory.mktemp("big")
    base = [s for s, _ in sim.simulate("hall", seed=5, n_scans=300)]
    scans = [s.replace(stamp_ns=s.stamp_ns + 30 * 10**9 * rep) for rep in range(10) for s in base]
    return raw_bag(d / "big.bag", "ros1", scans)


def count_jsonl(path: Path) -> int:
    return sum(1 for line in path.read_text().splitlines() if line.strip()) if path.exists() else 0


# ---------------------------------------------------------------------------- writers
# name -> (arguments for an output path, the output's suffix, the inputs it reads)
WRITERS = {
    "convert-bag": (lambda r, o: ["convert", r.jsonl, o], ".bag", lambda r: [r.jsonl]),
    "convert-mcap": (lambda r, o: ["convert", r.bag, o], ".mcap", lambda r: [r.bag]),
    "convert-ros2": (lambda r, o: ["convert", r.bag, o], "", lambda r: [r.bag]),
    "convert-jsonl": (lambda r, o: ["convert", r.bag, o], ".jsonl", lambda r: [r.bag]),
    "convert-json": (lambda r, o: ["convert", r.json, o], ".json", lambda r: [r.json]),
    "extract": (lambda r, o: ["extract", r.bag, "-o", o], ".jsonl", lambda r: [r.bag]),
    "view": (lambda r, o: ["view", r.bag, "-o", o, "--no-features"], ".rrd", lambda r: [r.bag]),
    "simulate": (lambda r, o: ["simulate", "office", "-o", o, "--scans", "3"], ".bag", lambda r: []),
    "config": (lambda r, o: ["config", "-o", o], ".toml", lambda r: []),
    "evaluate": (lambda r, o: ["evaluate", r.jsonl, "--scans", "2", "--method", "incremental", "--json", o],
                 ".json", lambda r: [r.jsonl]),
}


@pytest.mark.parametrize("writer", list(WRITERS))
def test_force_replaces_no_folder_and_no_foreign_file(rec, tmp_path, writer):
    args, suffix, _ = WRITERS[writer]
    folder = tmp_path / f"thesis{suffix}"
    folder.mkdir()
    (folder / "chapter1.tex").write_text("two years of work")
    before = digest(folder)
    p = labkit(*args(rec, folder), "-f")
    assert p.returncode == 2, p.stderr
    assert "never another folder" in one_error_line(p) or "folder" in one_error_line(p)
    assert digest(folder) == before and (folder / "chapter1.tex").read_text() == "two years of work"
    # a file of another kind under the output's name is not labkit's to replace either
    other = tmp_path / f"notes{suffix or '.d'}"
    if suffix:
        other.write_text("my notes\n")
        p = labkit(*args(rec, other), "-f")
        assert p.returncode == 2 and "-f replaces only" in one_error_line(p)
        assert other.read_text() == "my notes\n"
    # the current folder
    p = labkit(*args(rec, "."), "-f", cwd=folder)
    assert p.returncode == 2 and digest(folder) == before
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("writer", [w for w in WRITERS if w not in ("simulate", "config")])
def test_the_input_is_never_the_output(rec, tmp_path, writer):
    args, suffix, inputs = WRITERS[writer]
    for source in inputs(rec):
        before = digest(source)
        for flags in ([], ["-f"]):
            p = labkit(*args(rec, source), *flags)
            assert p.returncode == 2, p.stderr
            one_error_line(p)
            assert digest(source) == before, f"{writer} changed its input {source.name}"
        if source.suffix == suffix:  # the same file under another name (a hard link)
            link = tmp_path / f"link{suffix}"
            os.link(source, link)
            p = labkit(*args(rec, link), "-f")
            assert p.returncode == 2 and "is the input" in one_error_line(p)
            assert digest(source) == before
    assert leftovers(rec.dir) == []


def test_nothing_is_written_into_or_over_an_input_folder(rec, tmp_path):
    before = digest(rec.ros2)
    for out in (rec.ros2, rec.ros2 / "inside.jsonl"):
        p = labkit("convert", rec.ros2, out, "-f")
        assert p.returncode == 2, p.stderr
        one_error_line(p)
    # a folder that holds the input is not replaced either, even when it is a bag folder
    p = labkit("convert", rec.ros2 / "rec_ros2.db3", tmp_path / "x.jsonl")
    assert p.returncode == 2 and "pass its folder" in one_error_line(p)
    assert digest(rec.ros2) == before


@pytest.mark.parametrize("writer", list(WRITERS))
def test_existing_output_needs_f_and_f_replaces_only_its_own_kind(rec, tmp_path, writer):
    args, suffix, _ = WRITERS[writer]
    out = tmp_path / f"out{suffix}"
    assert labkit(*args(rec, out)).returncode == 0
    before = digest(out)
    p = labkit(*args(rec, out))
    assert p.returncode == 2 and "exists; pass -f to replace it" in one_error_line(p)
    assert digest(out) == before
    p = labkit(*args(rec, out), "-f")
    assert p.returncode == 0, p.stderr
    assert out.exists() and leftovers(tmp_path) == []


@pytest.mark.parametrize("writer", list(WRITERS))
def test_missing_folders_are_created(rec, tmp_path, writer):
    args, suffix, _ = WRITERS[writer]
    out = tmp_path / "new" / "deeper" / f"out{suffix}"
    assert labkit(*args(rec, out)).returncode == 0
    assert out.exists()


def test_folders_created_for_a_failed_write_are_removed(tmp_path):
    from labkit._safe import safe_output
    from labkit.io.jsonscan import JSON_LINES

    with pytest.raises(RuntimeError), safe_output(tmp_path / "a" / "b" / "x.jsonl", JSON_LINES) as tmp:
        tmp.write_text("{}\n")
        raise RuntimeError("the writer failed")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_another_writer_creates_at_the_same_moment_is_theirs(tmp_path, monkeypatch):
    """Parallel tasks writing into one new output folder (extract --workers): each sees it missing, one
    creates it first. The other's write must succeed (it failed with 'File exists' once, in the CI of
    test_parallel), and its clean-up after a failure must leave the other writer's folder alone."""
    import pathlib

    from labkit._safe import safe_output
    from labkit.io.jsonscan import JSON_LINES

    shared = tmp_path / "new" / "out"
    real_mkdir = pathlib.Path.mkdir

    def racing_mkdir(self, *args, **kwargs):
        if self == shared and not self.exists():
            real_mkdir(self)  # the other writer, between our exists() and our mkdir()
            (self / "theirs.jsonl").write_text("{}\n")
        return real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(pathlib.Path, "mkdir", racing_mkdir)
    with safe_output(shared / "mine.jsonl", JSON_LINES) as tmp:
        tmp.write_text('{"ranges": []}\n')
    assert sorted(p.name for p in shared.iterdir()) == ["mine.jsonl", "theirs.jsonl"]

    shutil.rmtree(tmp_path / "new")
    with pytest.raises(RuntimeError), safe_output(shared / "mine.jsonl", JSON_LINES) as tmp:
        (shared / "theirs.jsonl").unlink()  # the other writer is not done yet: its folder is empty for now
        raise RuntimeError("the writer failed")
    assert (tmp_path / "new").is_dir() and shared.is_dir()  # "new" was ours, but holds their folder


# -- as an unprivileged user: root reads and writes everything, so these run as `nobody`
def _as_nobody():
    """(python command, preexec) that run labkit as the user nobody, or skip."""
    if os.geteuid() != 0:
        return LABKIT, None
    system = Path(f"/usr/bin/python{sys.version_info.major}.{sys.version_info.minor}")
    if not system.exists() or not shutil.which("setpriv"):
        pytest.skip(f"running as root, and {system} (the same Python minor version, reachable by nobody) or "
                    "setpriv is missing: cannot test permissions")
    site = next(Path(sys.prefix).glob("lib/python*/site-packages"))
    code = (f"import site, sys; site.addsitedir({str(site)!r}); from labkit.app.cli import main; "
            "sys.exit(main(sys.argv[1:]))")
    return ["setpriv", f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups", str(system), "-c", code], None


@pytest.fixture()
def open_tmp(tmp_path):
    """tmp_path that the user nobody can enter."""
    for p in [tmp_path, *tmp_path.parents]:
        if p == Path("/tmp") or p == Path("/"):
            break
        p.chmod(p.stat().st_mode | 0o755)
    return tmp_path


@pytest.mark.parametrize("writer", ["convert-bag", "convert-ros2", "convert-jsonl", "extract", "view", "config",
                                    "evaluate", "simulate"])
def test_read_only_folder(rec, open_tmp, writer):
    python, _ = _as_nobody()
    args, suffix, _ = WRITERS[writer]
    for f in rec.dir.rglob("*"):
        f.chmod(f.stat().st_mode | 0o444 | (0o111 if f.is_dir() else 0))
    rec.dir.chmod(0o755)
    locked = open_tmp / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    p = labkit(*args(rec, locked / f"out{suffix}"), python=python)
    assert p.returncode == 3, p.stderr
    assert "Permission denied" in one_error_line(p) or "Read-only" in one_error_line(p)
    assert list(locked.iterdir()) == []


@pytest.mark.parametrize("command", ["convert", "extract", "view", "info", "bench", "evaluate", "demo", "config"])
def test_unreadable_input(rec, open_tmp, command):
    python, _ = _as_nobody()
    secret = open_tmp / ("secret.toml" if command == "config" else "secret.bag")
    if command == "config":
        secret.write_text("[lines]\n")
    else:
        shutil.copy(rec.bag, secret)
    secret.chmod(0o000)
    out = {"convert": [open_tmp / "o.jsonl"], "extract": ["-o", open_tmp / "o.jsonl"],
           "view": ["-o", open_tmp / "o.rrd"], "info": [], "bench": [], "evaluate": ["--scans", "2"],
           "demo": ["-o", open_tmp / "demo"], "config": []}[command]
    p = labkit(command, secret, *out, python=python)
    assert p.returncode == 3, p.stderr
    assert "Permission denied" in one_error_line(p)


DISK_FULL = {  # every writer of a recording or a table: arguments, given the output folder
    "convert-jsonl": lambda r, d: ["convert", r.bag, f"{d}/o.jsonl"],
    "convert-bag": lambda r, d: ["convert", r.mcap, f"{d}/o.bag"],
    "convert-mcap": lambda r, d: ["convert", r.bag, f"{d}/o.mcap"],
    "convert-ros2": lambda r, d: ["convert", r.bag, f"{d}/o_ros2"],
    "extract-jsonl": lambda r, d: ["extract", r.bag, "-o", f"{d}/o.jsonl"],
    "extract-parquet": lambda r, d: ["extract", r.bag, "-o", f"{d}/o.parquet"],
}


def test_disk_full_is_exit_3_with_one_line_and_leaves_nothing(rec, tmp_path):
    """Each writer on a full disk (a 24 KiB tmpfs, smaller than every output): exit 3, one line
    saying no space is left, no traceback, nothing left behind. A ROS2 folder gave exit 70 and
    sqlite's traceback ("database or disk is full")."""
    if os.geteuid() != 0 or not shutil.which("unshare"):
        pytest.skip("a full disk is made with a tiny tmpfs in a private mount namespace, which needs root")
    small = tmp_path / "small"
    small.mkdir()
    runs = "; ".join(f"echo '== {name}'; {' '.join(map(str, LABKIT))} -q {' '.join(map(str, args(rec, small)))}; "
                     f"echo rc=$?; ls -A {small} | wc -l" for name, args in DISK_FULL.items())
    script = f"mount -t tmpfs -o size=24k none {small} && {{ {runs}; }}"
    p = subprocess.run(["unshare", "--mount", "sh", "-c", script], capture_output=True, text=True, timeout=600)
    if "mount" in p.stderr and "rc=" not in p.stdout:
        pytest.skip(f"cannot mount a tmpfs here: {p.stderr.strip()}")
    assert "Traceback" not in p.stderr, p.stderr
    results = dict(part.split("\n", 1) for part in p.stdout.split("== ")[1:])
    assert set(results) == set(DISK_FULL)
    for name, out in results.items():
        assert out.split() == ["rc=3", "0"], f"{name}: {out} {p.stderr}"  # exit 3, and the folder is empty
    errors = [ln for ln in p.stderr.splitlines() if ln.startswith("labkit: error:")]
    assert len(errors) == len(DISK_FULL) and all("No space left on device" in ln for ln in errors), p.stderr


# -- Ctrl-C in the middle of a run
INTERRUPTIBLE = {
    "convert-bag": (lambda b, o: ["convert", b, o], ".bag"),
    "convert-mcap": (lambda b, o: ["convert", b, o], ".mcap"),
    "convert-ros2": (lambda b, o: ["convert", b, o], ""),
    "convert-jsonl": (lambda b, o: ["convert", b, o], ".jsonl"),
    "extract": (lambda b, o: ["extract", b, "-o", o], ".jsonl"),
    "view": (lambda b, o: ["view", b, "-o", o], ".rrd"),
}


def _interrupt(cmd: list, folder: Path) -> subprocess.CompletedProcess:
    """Run ``cmd`` and press Ctrl-C as soon as its temporary output exists."""
    proc = subprocess.Popen([*LABKIT, "-q", *map(str, cmd)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + 120
    while not leftovers(folder) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def _valid(path: Path, suffix: str) -> int:
    """How many records a finished output holds; fails if it is damaged."""
    if suffix == ".rrd":
        from rerun.chunk import RrdReader  # noqa: F401 - a real reader must open it
        out = subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "verify", str(path)],
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        return 1
    if suffix == ".jsonl" and '"features"' in path.read_text()[:10_000]:
        return sum(1 for line in path.read_text().splitlines() if json.loads(line)["features"] is not None)
    try:
        return sum(1 for _ in read_scans(path))  # raises CorruptFileError if damaged
    except EmptyRecordingError:  # interrupted before the first scan: a valid file that holds none
        return 0


@pytest.mark.parametrize("writer", list(INTERRUPTIBLE))
@pytest.mark.parametrize("existing", [False, True])
def test_interrupted_run_leaves_the_target_alone_and_a_valid_partial(big_bag, rec, tmp_path, writer, existing):
    args, suffix = INTERRUPTIBLE[writer]
    out = tmp_path / f"out{suffix}"
    before = None
    if existing:
        assert labkit(*args(rec.bag, out)).returncode == 0  # a finished output from the small recording
        before = digest(out)
    p = _interrupt([*args(big_bag, out), *(["-f"] if existing else [])], tmp_path)
    if p.returncode == 0:
        pytest.skip(f"{writer} finished before Ctrl-C arrived (a fast machine): nothing to check")
    assert "Traceback" not in p.stderr and p.returncode == 130, p.stderr
    assert "interrupted" in p.stderr and "was not changed" in p.stderr
    assert (digest(out) == before) if existing else not out.exists()
    partial = tmp_path / f"out.partial{suffix}"
    if partial.exists():
        assert f"what was written so far is in {partial}" in p.stderr
        assert _valid(partial, suffix) >= 0
    assert leftovers(tmp_path) == []


# ---------------------------------------------------------------------------- readers
FORMATS = {"ros1": "bag", "mcap": "mcap", "ros2": "ros2", "jsonl": "jsonl", "carmen": "log", "carmen-gz": "gz"}


def _storage(path: Path) -> Path:
    return next(path.glob("*.db3")) if path.is_dir() else path


def _copy(rec, fmt: str, tmp_path: Path) -> Path:
    src = getattr(rec, FORMATS[fmt])
    dst = tmp_path / src.name
    (shutil.copytree if src.is_dir() else shutil.copy)(src, dst)
    return dst


def _read_through_cli(path: Path, tmp_path: Path) -> tuple[subprocess.CompletedProcess, list]:
    """``labkit convert`` the file to JSON lines: the exit status and the scans kept."""
    out = tmp_path / "kept.jsonl"
    p = labkit("convert", path, out)
    kept = list(read_scans(out)) if out.exists() and out.stat().st_size else []  # 0 bytes: refused as empty
    return p, kept


def _assert_in_order(kept, scans, fmt="", garbled=0):
    """Every kept scan is one of the scans put in, in order (nothing invented, nothing reordered);
    returns their places. CARMEN logs hold the ranges the test wrote with three decimals. Bags
    carry no checksum, so a message whose float data was garbled decodes: up to ``garbled`` kept
    scans may differ from every scan put in."""
    put_in = [np.array([float(f"{r:.3f}") for r in s.ranges]) if fmt.startswith("carmen") else s.ranges
              for s in scans]
    ranges = [r.astype(np.float32).tobytes() for r in put_in]
    found = [k.ranges.astype(np.float32).tobytes() for k in kept]
    positions = [ranges.index(f) for f in found if f in ranges]
    assert len(kept) - len(positions) <= garbled, f"{len(kept) - len(positions)} scans were invented"
    assert positions == sorted(positions) and len(set(positions)) == len(positions)
    return positions


def _complete_lines(text_prefix: bytes) -> int:
    return text_prefix.count(b"\n")


@pytest.mark.parametrize("fmt", list(FORMATS))
@pytest.mark.parametrize("fraction", [0.3, 0.6, 0.9])
def test_cut_files_give_every_record_before_the_cut(rec, tmp_path, fmt, fraction):
    path = _copy(rec, fmt, tmp_path)
    storage = _storage(path)
    data = storage.read_bytes()
    cut = int(len(data) * fraction)
    if fmt in ("jsonl", "carmen"):  # cut inside a line, 50 bytes past its start
        cut = data.rfind(b"\n", 0, cut) + 51
    storage.write_bytes(data[:cut])
    p, kept = _read_through_cli(path, tmp_path)
    assert p.returncode == 1, p.stderr
    assert "is damaged" in one_error_line(p)
    positions = _assert_in_order(kept, rec.scans, fmt)
    assert positions == list(range(len(kept)))  # a prefix of the recording
    if fmt in ("jsonl", "carmen"):
        assert len(kept) == _complete_lines(data[:cut])
    elif fmt == "carmen-gz":
        readable = zlib.decompressobj(wbits=31).decompress(data[:cut])
        assert len(kept) == _complete_lines(readable)
    elif fmt == "ros1":  # at least every chunk that ends before the cut (from rosbags' index)
        reader = rosbag1.Reader(rec.bag)
        reader.open()
        infos = list(reader.chunk_infos)
        reader.close()
        assert len(infos) >= 4  # the test bag has several chunks
        ends = [info.pos for info in infos[1:]] + [len(data)]
        whole = sum(sum(info.connection_counts.values()) for info, end in zip(infos, ends, strict=True)
                    if end <= cut)
        assert whole <= len(kept) < N
    else:
        assert 0 < len(kept) < N if fraction > 0.3 else len(kept) < N


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_one_malformed_record_costs_that_record_only(rec, tmp_path, fmt):
    bad = 14
    if fmt in ("ros1", "mcap", "ros2"):  # a LaserScan message with angle_increment 0
        path = raw_bag(tmp_path / {"ros1": "m.bag", "mcap": "m_mcap", "ros2": "m"}[fmt], fmt, rec.scans, bad=bad)
    elif fmt == "jsonl":
        lines = rec.jsonl.read_text().splitlines(keepends=True)
        lines[bad] = '{"ranges": [1.0, 2.0], "bearings": [0.0]}\n'
        path = tmp_path / "m.jsonl"
        path.write_text("".join(lines))
    else:
        lines = carmen_text(rec.scans).splitlines(keepends=True)
        lines[bad] = "FLASER 361 1.0 2.0 3.0\n"
        text = "".join(lines).encode()
        path = tmp_path / ("m.log.gz" if fmt == "carmen-gz" else "m.log")
        path.write_bytes(gzip.compress(text) if fmt == "carmen-gz" else text)
    p, kept = _read_through_cli(path, tmp_path)
    assert p.returncode == 1, p.stderr
    line = one_error_line(p)
    assert f"{N - 1} scans kept, 1 lost" in line
    assert len(kept) == N - 1
    assert _assert_in_order(kept, rec.scans, fmt) == [k for k in range(N) if k != bad]
    p = labkit("convert", path, tmp_path / "strict.jsonl", "--strict")
    assert p.returncode == 1 and count_jsonl(tmp_path / "strict.jsonl") == bad


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_garbled_bytes_cost_only_the_records_they_hit(rec, tmp_path, fmt):
    path = _copy(rec, fmt, tmp_path)
    storage = _storage(path)
    data = bytearray(storage.read_bytes())
    if fmt in ("jsonl", "carmen"):  # garble the middle of line 10
        start = [i for i, b in enumerate(data) if b == 10][9] + 40
        data[start : start + 30] = bytes(range(200, 230))
        lost = {10}
    elif fmt == "ros2":  # a page of the database in the middle
        page = int.from_bytes(data[16:18], "big")
        first = (len(data) // page // 2) * page
        data[first + 8 : first + page] = b"\xa5" * (page - 8)
        lost = None
    else:  # 64 bytes in the middle of the compressed stream or of a chunk
        middle = len(data) // 2
        data[middle : middle + 64] = bytes(64)
        lost = None
    storage.write_bytes(bytes(data))
    p, kept = _read_through_cli(path, tmp_path)
    assert p.returncode in (0, 1), p.stderr  # garbled floats in a bag can decode: no checksum to tell
    if p.returncode == 1:
        one_error_line(p)
    positions = _assert_in_order(kept, rec.scans, fmt, garbled=2 if lost is None and fmt != "carmen-gz" else 0)
    if lost is not None:
        assert p.returncode == 1 and positions == [k for k in range(N) if k not in lost]
    elif fmt == "ros2":  # exactly the rows sqlite itself can still read one by one
        con = sqlite3.connect(f"file:{storage}?mode=ro", uri=True)
        readable = []
        for row_id in range(1, N + 1):
            try:
                readable.append(con.execute("SELECT id FROM messages WHERE id = ?", (row_id,)).fetchone() is not None)
            except sqlite3.DatabaseError:
                readable.append(False)
        con.close()
        assert not all(readable) and positions == [k for k in range(N) if readable[k]]
        assert p.returncode == 1 and f"{sum(readable)} scans kept, {N - sum(readable)} lost" in one_error_line(p)
    elif fmt == "carmen-gz":  # every line before the garbled bytes
        before = zlib.decompressobj(wbits=31).decompress(bytes(data[: len(data) // 2]))
        assert len(kept) >= _complete_lines(before) - 1 and positions == list(range(len(kept)))
    else:  # the messages around the garbled bytes at most; the chunk they are in at worst
        assert len(kept) >= N // 3, f"{fmt}: only {len(kept)} of {N} scans kept"


@pytest.mark.parametrize("name", ["e.bag", "e.mcap", "e.jsonl", "e.json", "e.log", "e.log.gz", "blank.jsonl"])
def test_empty_inputs_are_refused_with_one_status(tmp_path, name):
    """An input that holds no scan at all is exit 2, whatever its format (it was 0 for .jsonl,
    1 for bags and .json, 2 for logs)."""
    path = tmp_path / name
    path.write_bytes(b"\n\n" if name.startswith("blank") else b"")
    p, kept = _read_through_cli(path, tmp_path)
    assert p.returncode == 2, p.stderr
    assert kept == [] and not (tmp_path / "kept.jsonl").exists()
    line = one_error_line(p)
    assert "empty" in line or "no scans" in line or "no laser messages" in line, line


def test_an_empty_bag_says_it_is_empty(tmp_path):
    writer = rosbag1.Writer(tmp_path / "empty.bag")
    writer.open()
    writer.close()
    p = labkit("info", tmp_path / "empty.bag")
    assert p.returncode == 2 and "is an empty bag" in one_error_line(p)  # as every command says it
    p = labkit("convert", tmp_path / "empty.bag", tmp_path / "x.jsonl")
    assert p.returncode == 2 and "is an empty bag" in one_error_line(p)


# ---------------------------------------------------------------------------- the rest of the list
def test_version():
    p = labkit("--version")
    assert p.returncode == 0 and p.stdout.startswith("labkit ")


def test_messages_name_the_flags(rec, tmp_path):
    two = tmp_path / "two.bag"
    ts = salvage.typestore(True)
    writer = rosbag1.Writer(two)
    writer.open()
    conns = [writer.add_connection(t, "sensor_msgs/msg/LaserScan", typestore=ts) for t in ("/front", "/rear")]
    for c in conns:
        writer.write(c, rec.scans[0].stamp_ns, ts.serialize_ros1(laser_message(ts, rec.scans[0], True),
                                                                  "sensor_msgs/msg/LaserScan"))
    writer.close()
    p = labkit("convert", two, tmp_path / "x.jsonl")
    assert p.returncode == 2 and "--topic" in one_error_line(p) and "topic=" not in p.stderr
    p = labkit("convert", rec.bag, tmp_path / "x.bag", "--format", "mcap")
    assert p.returncode == 2 and "--format mcap" in one_error_line(p)
    p = labkit("extract", rec.log, "--topic", "/scan")
    assert p.returncode == 2 and "--topic" in one_error_line(p)


def test_bench_streams_and_stops_after_its_scans(rec, tmp_path):
    cut = tmp_path / "cut.jsonl"
    lines = rec.jsonl.read_text().splitlines(keepends=True)
    cut.write_text("".join(lines[:10]) + lines[10][:40])  # damaged after scan 10
    p = labkit("bench", cut, "--scans", "5")
    assert p.returncode == 0 and "5 scans of 361 beams" in p.stdout  # never read as far as the damage
    p = labkit("bench", cut)
    assert p.returncode == 1 and "10 scans of 361 beams" in p.stdout and "cut.jsonl is damaged" in p.stderr


def test_evaluate_writes_strict_json_takes_topic_and_scores_damaged_files(rec, tmp_path):
    cut = tmp_path / "cut.jsonl"
    lines = rec.jsonl.read_text().splitlines(keepends=True)
    cut.write_text("".join(lines[:6]) + "not json\n" + "".join(lines[6:12]))
    out = tmp_path / "eval.json"
    p = labkit("evaluate", cut, rec.bag, "--topic", "/scan", "--scans", "20", "--method", "IAV lines",
               "--json", out)
    assert p.returncode == 2 and "--topic does not apply" in one_error_line(p)  # a JSON file has no topics
    p = labkit("evaluate", cut, "--scans", "20", "--method", "IAV lines", "--method", "incremental",
               "--json", out)
    assert p.returncode == 1 and "cut.jsonl is damaged at line 7" in one_error_line(p)

    def no_constants(name):
        raise AssertionError(f"{name} is not strict JSON")

    report = json.loads(out.read_text(), parse_constant=no_constants)
    rows = report["recordings"]
    assert {r["method"] for r in rows} == {"IAV lines", "incremental"} and all(r["scans"] == 12 for r in rows)
    p = labkit("evaluate", rec.bag, "--topic", "/scan", "--scans", "3", "--method", "incremental")
    assert p.returncode == 0 and "| rec.bag | incremental |" in p.stdout


def test_json_lines_keep_intensities_infinity_nan_and_the_receive_time(tmp_path):
    ts = salvage.typestore(True)
    bag = tmp_path / "in.bag"
    writer = rosbag1.Writer(bag)
    writer.open()
    conn = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
    t = ts.types
    ranges = np.array([1.0, np.inf, np.nan, -np.inf, 0.0, 2.5], np.float32)
    msg = t["sensor_msgs/msg/LaserScan"](
        header=t["std_msgs/msg/Header"](seq=7, stamp=t["builtin_interfaces/msg/Time"](sec=100, nanosec=5),
                                        frame_id="front"),
        angle_min=-0.5, angle_max=0.5, angle_increment=0.2, time_increment=1e-4, scan_time=0.025,
        range_min=0.1, range_max=30.0, ranges=ranges, intensities=np.array([9, 8, 7, 6, 5, 4], np.float32))
    receive = 100 * 10**9 + 20_000_000  # received 20 ms after the stamp
    writer.write(conn, receive, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
    writer.close()
    assert labkit("convert", bag, tmp_path / "mid.jsonl").returncode == 0
    text = (tmp_path / "mid.jsonl").read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in a strict JSON file"))
    assert labkit("convert", tmp_path / "mid.jsonl", tmp_path / "out.bag").returncode == 0
    reader = rosbag1.Reader(tmp_path / "out.bag")
    reader.open()
    ((c, got_receive, raw),) = list(reader.messages())
    back = ts.deserialize_ros1(raw, c.msgtype)
    reader.close()
    assert got_receive == receive
    assert (back.header.stamp.sec, back.header.stamp.nanosec, back.header.frame_id) == (100, 5, "front")
    assert back.ranges.tobytes() == ranges.tobytes()  # inf, NaN, -inf and 0 where they were, bit for bit
    assert back.intensities.tolist() == [9, 8, 7, 6, 5, 4]
    f32 = np.float32
    assert (back.time_increment, back.scan_time, back.range_min, back.range_max) == (
        f32(msg.time_increment), f32(msg.scan_time), f32(msg.range_min), f32(msg.range_max))
    assert np.float32(back.angle_min) == np.float32(-0.5) and np.float32(back.angle_increment) == np.float32(0.2)


# ---------------------------------------------------------------------------- real logs
RADISH = ["intel", "aces", "csail", "freiburg-079", "infinite-corridor", "orebro"]
OUT_FORMATS = ["x.bag", "x.mcap", "x_ros2", "x.jsonl"]
# Every format on the two logs whose stamps need a note (intel's go back in time, infinite-corridor's are
# garbage), and every other log once, each into another format: every writer and reader meets real logs and
# every log is converted, in 12 conversions instead of 24 (freiburg, the largest, alone was 2 minutes of
# make test in four formats).
CONVERSIONS = [(log, out) for log in ("intel", "infinite-corridor") for out in OUT_FORMATS] + [
    ("aces", "x.mcap"), ("csail", "x_ros2"), ("freiburg-079", "x.bag"), ("orebro", "x.jsonl")]
assert {log for log, _ in CONVERSIONS} == set(RADISH) and {out for _, out in CONVERSIONS} == set(OUT_FORMATS)


@pytest.mark.shared
@pytest.mark.parametrize(("log", "out"), CONVERSIONS)
def test_every_radish_log_converts_and_back(shared_datasets, tmp_path, log, out):
    from labkit.io import read_carmen

    src = shared_datasets / "carmen" / f"{log}-corrected.log.gz"
    p = labkit("convert", src, tmp_path / out)
    assert p.returncode == 0, p.stderr
    original = list(read_carmen(src))
    back = list(read_scans(tmp_path / out))
    assert len(back) == len(original)
    note = p.stderr
    for k, (a, b) in enumerate(zip(original, back, strict=True)):
        if out.endswith(".jsonl"):
            assert np.array_equal(a.ranges, b.ranges, equal_nan=True) and np.array_equal(a.angles, b.angles)
            assert (a.stamp_ns, a.receive_ns, a.pose) == (b.stamp_ns, b.receive_ns, b.pose)
            continue
        assert np.array_equal(a.ranges.astype(np.float32), b.ranges.astype(np.float32), equal_nan=True), k
        np.testing.assert_allclose(b.angles, a.angles, atol=2e-6)
        assert b.range_max == np.float32(a.range_max) or not np.isfinite(a.range_max)
        if "stamped k x" in note:  # garbage stamps: renumbered, and the note says so
            step = float(note.split("stamped k x ")[1].split(" s")[0])
            assert b.stamp_ns == round(k * step * 1e9)
        else:
            assert b.stamp_ns == a.stamp_ns
    bag = not out.endswith(".jsonl")
    assert ("stamped k x" in note) == (log == "infinite-corridor" and bag), note
    assert ("went back in time" in note) == (log == "intel" and bag), note
