"""Scan ranges (``read_scans(..., scans=slice(a, b))``, ``--scans A:B``, ``--time T0:T1``): the
same scans as Python's own slicing of the whole recording gives, numbered as in the whole
recording, read no further than the range's end, and a record skipped on the way still reported."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from labkit import CorruptFileError, Scan, read_scans, sim, write_scans
from labkit.app.data import write_simulation
from labkit.errors import RefusedError
from labkit.io import FileFormat, register_format, unregister_format

# Python's slices the readers must agree with (the oracle is list slicing of the whole read)
SLICES = [slice(3, 9), slice(0, 4), slice(7, None), slice(None, 5), slice(-4, None), slice(-6, -2), slice(9, 3),
          slice(5, 5), slice(0, 100), slice(40, 60), slice(None, None)]


def carmen_log(path: Path, n: int, bad_line: int | None = None, seed: int = 0) -> Path:
    """A CARMEN log written by hand: ``n`` FLASER lines of 180 readings (plus an ODOM line between
    them, which is not laser data); ``bad_line``: that FLASER line has one reading too few."""
    rng = np.random.default_rng(seed)
    lines = []
    for k in range(n):
        readings = rng.uniform(0.5, 8.0, 180)
        if k == bad_line:
            readings = readings[:-1]
        t = 100.0 + 0.2 * k
        lines.append(f"FLASER 180 {' '.join(f'{r:.3f}' for r in readings)} {k * 0.1:.3f} 0.0 0.0 "
                     f"{k * 0.1:.3f} 0.0 0.0 {t:.6f} host {t + 0.01:.6f}")
        lines.append(f"ODOM {k * 0.1:.3f} 0 0 0 0 0 {t:.6f} host {t:.6f}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("ranges")
    out = {}
    for name, fmt in (("s1.bag", "ros1"), ("s3.mcap", "mcap"), ("s2", "ros2")):
        out[fmt] = write_simulation("office", d / name, fmt, seed=4, n_scans=12)[0]
    out["carmen"] = carmen_log(d / "c.log", 12)
    scans = [s for s, _ in sim.simulate("hall", seed=2, n_scans=12)]
    write_scans(scans, d / "s.jsonl")
    out["jsonl"] = d / "s.jsonl"
    return out


@pytest.mark.parametrize("fmt", ["ros1", "mcap", "ros2", "carmen", "jsonl"])
def test_a_range_is_the_slice_of_the_whole_recording(recordings, fmt):
    path = recordings[fmt]
    whole = [s.stamp_ns for s in read_scans(path)]
    assert len(whole) == 12
    for sl in SLICES:
        if fmt == "jsonl" and any(e is not None and e < 0 for e in (sl.start, sl.stop)):
            with pytest.raises(RefusedError, match="does not say how many scans"):
                read_scans(path, scans=sl)
            continue
        stream = read_scans(path, scans=sl)
        got = [s.stamp_ns for s in stream]
        assert got == whole[sl], (fmt, sl)
        assert stream.first == range(12)[sl].start or not got  # where the range starts in the recording
        if stream.count is not None:
            assert stream.count == len(got), (fmt, sl)


def test_ranges_refuse_a_step_and_what_is_not_a_whole_number(recordings):
    for bad in (slice(0, 10, 2), slice(0.5, 3), slice("a", None), 5):
        with pytest.raises(ValueError, match="scans must be"):
            read_scans(recordings["ros1"], scans=bad)


@pytest.fixture
def counted(tmp_path):
    """A registered format whose reader counts the scans it was asked for and says when it was closed."""
    seen = {"pulled": 0, "closed": False}

    def read(stream):
        try:
            for k in range(1000):
                seen["pulled"] = k + 1
                yield Scan(ranges=[1.0, 2.0, 3.0], angles=[-0.1, 0.0, 0.1], stamp_ns=k)
        finally:
            seen["closed"] = True

    register_format(FileFormat("counted", (".counted",), "counted scans (.counted)", read=read,
                               count=lambda _p: 1000))
    (tmp_path / "x.counted").write_text("")
    try:
        yield tmp_path / "x.counted", seen
    finally:
        unregister_format("counted")


def test_reading_stops_after_the_range(counted):
    path, seen = counted
    got = [s.stamp_ns for s in read_scans(path, scans=slice(20, 25))]
    assert got == [20, 21, 22, 23, 24]
    assert seen["pulled"] == 25 and seen["closed"]  # no scan beyond the range was read; the reader was closed


def _damaged_jsonl(path: Path, bad_line: int, n: int = 20) -> list[int]:
    scans = [s for s, _ in sim.simulate("hall", seed=0, n_scans=n)]
    write_scans(scans, path)
    lines = path.read_text().splitlines()
    lines[bad_line - 1] = "garbage"
    path.write_text("\n".join(lines) + "\n")
    return [s.stamp_ns for k, s in enumerate(scans) if k != bad_line - 1]


@pytest.mark.parametrize("sl, reported", [(slice(0, 3), False), (slice(0, 10), True), (slice(10, 12), True),
                                          (slice(4, None), True)])
def test_a_record_skipped_on_the_way_is_reported(tmp_path, sl, reported):
    """Line 5 of a JSON-lines file is garbage: a range that stops before it reads cleanly; a range
    that reads past it (even one that starts after it) keeps its scans, then hears of the loss."""
    path = tmp_path / "d.jsonl"
    good = _damaged_jsonl(path, bad_line=5)
    got = []
    if reported:
        with pytest.raises(CorruptFileError, match="at line 5") as info:
            got.extend(s.stamp_ns for s in read_scans(path, scans=sl))
        assert info.value.n_skipped == 1
    else:
        got.extend(s.stamp_ns for s in read_scans(path, scans=sl))
    assert got == good[sl]


def test_a_damaged_carmen_log_in_ranges_strict_and_not(tmp_path):
    """The readable scans of a range are the slice of the readable scans, strict or not."""
    path = carmen_log(tmp_path / "d.log", 30, bad_line=12)
    for strict in (False, True):
        whole = []
        with pytest.raises(CorruptFileError):
            whole.extend(s.stamp_ns for s in read_scans(path, strict=strict))
        assert len(whole) == (12 if strict else 29)
        for sl in (slice(0, 5), slice(8, 20), slice(20, None)):
            got = []
            # FLASER k is line 2k + 1; the reader met it (it reads a whole log before its first scan)
            with pytest.raises(CorruptFileError, match=f"at line {2 * 12 + 1}"):
                got.extend(s.stamp_ns for s in read_scans(path, scans=sl, strict=strict))
            assert got == whole[sl]


def _read_all(path: Path, **kw) -> tuple[list[int], CorruptFileError | None]:
    got: list[int] = []
    try:
        got.extend(s.stamp_ns for s in read_scans(path, **kw))
    except CorruptFileError as error:
        return got, error
    return got, None


@pytest.fixture(scope="module")
def damaged_bags(recordings, tmp_path_factory):
    """The 12-scan ROS1 and MCAP bags (with odometry) with 4 KB of garbage at half their length
    (the framing of some scans is hit; the index at the end is intact), and the ROS2 folder with
    one scan's row garbled."""
    d = tmp_path_factory.mktemp("damaged")
    out = {}
    for fmt, name in (("ros1", "d1.bag"), ("mcap", "d2.mcap")):
        data = bytearray(recordings[fmt].read_bytes())
        at = len(data) // 2
        data[at:at + 4000] = np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes()
        out[fmt] = d / f"bad-{name}"
        out[fmt].write_bytes(bytes(data))
    out["ros2"] = d / "bad-s2"  # ROS2 sqlite3: the sixth scan's row holds 8 bytes that are no LaserScan
    shutil.copytree(recordings["ros2"], out["ros2"])
    with sqlite3.connect(next(out["ros2"].glob("*.db3"))) as db:
        (row,) = db.execute("SELECT id FROM messages WHERE topic_id = (SELECT id FROM topics WHERE name = '/scan') "
                            "ORDER BY timestamp LIMIT 1 OFFSET 5").fetchone()
        db.execute("UPDATE messages SET data = ? WHERE id = ?", (b"\x00\x01\x00\x00\xff\xff\xff\xff", row))
    db.close()
    return out


@pytest.mark.parametrize("fmt", ["ros1", "mcap", "ros2"])
def test_a_range_of_a_damaged_bag_counts_its_losses_against_the_file(damaged_bags, fmt):
    """A range read to the file's end reports the loss the whole read reports (the index counts the
    file's scans, not the range's); a range that ends past the damage reports at least the scans
    noted lost, at the same place; one that ends before it reads cleanly."""
    whole, error = _read_all(damaged_bags[fmt])
    assert error is not None and error.lost_exact and error.n_lost >= 1 and len(whole) == 12 - error.n_lost
    if fmt == "ros2":
        assert error.n_lost == 1  # the one row the fixture garbled
    # a range no longer than the scans read: an index count taken for the range's would say "none lost"
    start = error.n_lost
    got, to_end = _read_all(damaged_bags[fmt], scans=slice(start, None))
    assert got == whole[start:] and to_end is not None
    assert (to_end.n_lost, to_end.lost_exact, to_end.where) == (error.n_lost, True, error.where)
    got, past = _read_all(damaged_bags[fmt], scans=slice(2, 10))
    assert got == whole[2:10] and past is not None
    assert past.where == error.where and 1 <= past.n_lost <= error.n_lost
    assert _read_all(damaged_bags[fmt], scans=slice(0, 3)) == (whole[:3], None)


def test_convert_a_range_between_bags_is_a_scans_only_copy(recordings, tmp_path):
    """A whole-recording copy (every topic) has no scan range: refused before anything is written;
    with only_scans the range's scans are copied."""
    from labkit.io import convert

    bag = recordings["ros1"]
    with pytest.raises(RefusedError, match="only_scans"):
        convert(bag, tmp_path / "r.mcap", scans=slice(2, 5))
    assert not (tmp_path / "r.mcap").exists()
    assert convert(bag, tmp_path / "r.mcap", scans=slice(2, 5), only_scans=True) == 3
    assert [s.stamp_ns for s in read_scans(tmp_path / "r.mcap")] == [s.stamp_ns for s in read_scans(bag)][2:5]




def _records(path: Path) -> list[dict]:
    return [{k: v for k, v in json.loads(line).items() if k != "timings_ms"} for line in path.read_text().splitlines()]


def test_cli_extract_convert_and_evaluate_take_a_range(recordings, tmp_path, labkit_cli):
    bag = recordings["ros1"]
    assert labkit_cli("extract", bag, "-o", tmp_path / "all.jsonl").returncode == 0
    assert labkit_cli("extract", bag, "--scans", "3:8", "-o", tmp_path / "r.jsonl").returncode == 0
    whole, part = _records(tmp_path / "all.jsonl"), _records(tmp_path / "r.jsonl")
    assert part == whole[3:8] and [r["scan"] for r in part] == [3, 4, 5, 6, 7]
    p = labkit_cli("extract", bag, "--scans=-2:", "-o", tmp_path / "t.parquet")
    assert p.returncode == 0, p.stderr
    from labkit import read_table

    assert sorted(read_table(tmp_path / "t.parquet").scan.unique()) == [10, 11]
    p = labkit_cli("convert", bag, tmp_path / "c.jsonl", "--scans", "2:5")
    assert p.returncode == 0 and "wrote 3 scans" in p.stdout, p.stderr
    stamps = [s.stamp_ns for s in read_scans(bag)]
    assert [s.stamp_ns for s in read_scans(tmp_path / "c.jsonl")] == stamps[2:5]
    p = labkit_cli("evaluate", bag, "--scans", "4:10", "--method", "incremental")
    assert p.returncode == 0 and "scans 4:10 each" in p.stdout and "| incremental | 6 |" in p.stdout, p.stdout
    p = labkit_cli("evaluate", bag, "--scans", "5", "--method", "incremental")
    assert p.returncode == 0 and "first 5 scans each" in p.stdout and "| incremental | 5 |" in p.stdout, p.stdout
    p = labkit_cli("extract", bag, "--scans", "1:2:3")
    assert p.returncode == 2 and "expected N" in p.stderr


def test_cli_time_range(recordings, tmp_path, labkit_cli):
    """The office scenario scans at 5 Hz: 0.6 s to 1.4 s after the first scan are the scans 3 to 6."""
    bag = recordings["ros1"]
    stamps = np.array([s.stamp_ns for s in read_scans(bag)])
    t = (stamps - stamps[0]) / 1e9
    expected = [k for k in range(len(t)) if 0.6 <= t[k] < 1.4]
    assert expected == [3, 4, 5, 6]
    p = labkit_cli("extract", bag, "--time", "0.6:1.4", "-o", tmp_path / "t.jsonl")
    assert p.returncode == 0, p.stderr
    assert [r["scan"] for r in _records(tmp_path / "t.jsonl")] == expected
    p = labkit_cli("extract", bag, recordings["mcap"], "--time", "1:2", "-o", tmp_path / "two")
    assert p.returncode == 2 and "--time takes one recording" in p.stderr
    p = labkit_cli("extract", bag, "--time", "1:2", "--scans", "1:3")
    assert p.returncode == 2 and "not allowed with" in p.stderr
