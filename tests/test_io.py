"""Reading and writing scans: round trips, damaged files, topic choice, CARMEN and JSON."""

from __future__ import annotations

import gzip
import shutil
from pathlib import Path

import numpy as np
import pytest
from rosbags import rosbag1
from rosbags.typesys import Stores, get_typestore

from labkit import Scan, convert, read_scans, sim, write_bag, write_scans
from labkit.io import CorruptFileError, detect_format, read_carmen, read_json_scan

N_SCANS = 40


@pytest.fixture(scope="module")
def office_scans():
    """Scans with NaN dropouts, max-range returns and a full-circle lidar."""
    return [s for s, _ in sim.simulate("office", seed=1, n_scans=N_SCANS)]


def assert_same_scans(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.ranges, y.ranges, equal_nan=True)
        assert np.array_equal(x.angles, y.angles)
        assert (x.stamp_ns, x.frame_id, x.range_min, x.range_max) == (y.stamp_ns, y.frame_id, y.range_min,
                                                                      y.range_max)


BAG_NAMES = {"ros1": "scans.bag", "mcap": "scans.mcap", "ros2": "scans_ros2", "mcap-folder": "scans_mcap"}


@pytest.mark.parametrize("kind", list(BAG_NAMES))
def test_bag_round_trip(tmp_path, office_scans, kind):
    fmt = "mcap" if kind.startswith("mcap") else kind
    path = tmp_path / BAG_NAMES[kind]
    assert write_bag(office_scans, path, fmt) == N_SCANS
    stream = read_scans(path)
    assert stream.format == fmt and stream.topic == "/scan" and stream.count == N_SCANS
    assert_same_scans(office_scans, list(stream))


def test_intensities_survive(tmp_path):
    s = Scan(ranges=[1.0, 2.0, 3.0], angles=[0.0, 0.1, 0.2], intensities=[5.0, 6.0, 7.0], range_max=10.0)
    write_bag([s], tmp_path / "i.bag")
    (back,) = read_scans(tmp_path / "i.bag")
    np.testing.assert_allclose(back.intensities, [5.0, 6.0, 7.0])


@pytest.mark.parametrize("kind", ["ros1", "mcap", "ros2"])
@pytest.mark.parametrize("fraction", [0.35, 0.8])
def test_truncated_bag_yields_every_scan_before_the_fault(tmp_path, office_scans, kind, fraction):
    path = tmp_path / BAG_NAMES[kind]
    write_bag(office_scans, path, kind)
    storage = next(path.glob("*.db3")) if path.is_dir() else path
    data = storage.read_bytes()
    storage.write_bytes(data[: int(len(data) * fraction)])
    got = []
    with pytest.raises(CorruptFileError) as info:
        for scan in read_scans(path):
            got.append(scan)
    err = info.value
    assert err.path == path and str(path) in str(err)
    assert err.n_read == len(got)
    assert ("byte" in err.where) or ("message" in err.where) or ("row" in err.where)
    # what was read is exactly the beginning of the recording
    assert 0 < len(got) < N_SCANS
    assert_same_scans(office_scans[: len(got)], got)
    # a truncated ROS1/MCAP file keeps all but the message that was cut (the messages are in
    # file order); sqlite pages are not, so only require most of what is there
    if kind != "ros2":
        assert len(got) >= int(fraction * N_SCANS) - 2


def _message_offsets(data: bytes) -> list[int]:
    """File offsets of the message records (op 2) of an uncompressed ROS1 bag, found by the
    test's own reading of the format: every record header holding the field ``op=\\x02``."""
    offsets, pos = [], 13
    while pos + 8 <= len(data):
        hlen = int.from_bytes(data[pos : pos + 4], "little")
        header = data[pos + 4 : pos + 4 + hlen]
        dlen = int.from_bytes(data[pos + 4 + hlen : pos + 8 + hlen], "little")
        if b"op=\x05" in header:  # a chunk: its records follow in the file (no compression)
            pos += 8 + hlen
            continue
        if b"op=\x02" in header:
            offsets.append(pos)
        pos += 8 + hlen + dlen
    return offsets


def test_a_garbled_ros1_record_header_costs_that_message_only(tmp_path, office_scans):
    """A garbled record header (not just garbled float values, which no ROS1 reader can
    detect: the format has no checksums) costs that message; reading resumes at the next."""
    path = tmp_path / "g.bag"
    write_bag(office_scans, path, pose_topic=None)
    data = bytearray(path.read_bytes())
    offsets = _message_offsets(bytes(data))
    assert len(offsets) == N_SCANS
    target = offsets[N_SCANS // 2]
    data[target : target + 4] = b"\xff\xff\xff\x7f"  # an absurd header length
    path.write_bytes(bytes(data))
    got = []
    with pytest.raises(CorruptFileError, match=f"g.bag is damaged at byte {target}") as info:
        for scan in read_scans(path):
            got.append(scan)
    assert info.value.n_read == N_SCANS - 1 and info.value.n_lost == 1 and info.value.lost_exact
    assert f"{N_SCANS - 1} scans kept, 1 lost" in str(info.value)
    assert_same_scans([s for k, s in enumerate(office_scans) if k != N_SCANS // 2], got)


def test_convert_a_damaged_bag_keeps_every_readable_scan(tmp_path, office_scans):
    src = tmp_path / "cut.bag"
    write_bag(office_scans, src)
    src.write_bytes(src.read_bytes()[: int(src.stat().st_size * 0.5)])
    with pytest.raises(CorruptFileError):
        convert(src, tmp_path / "out.mcap")
    back = list(read_scans(tmp_path / "out.mcap"))  # the output is complete and readable
    assert 0 < len(back) < N_SCANS
    assert_same_scans(office_scans[: len(back)], back)


def _two_topic_bag(path: Path, topics):
    ts = get_typestore(Stores.ROS1_NOETIC)
    scan = sim.scan_at(sim.make_world("hall"), sim.LIDARS["lms200"], (6.0, 0.4, 1.57))[0]
    with rosbag1.Writer(path) as w:
        for topic, msgtype in topics:
            conn = w.add_connection(topic, msgtype, typestore=ts)
            if msgtype == "std_msgs/msg/String":
                raw = ts.serialize_ros1(ts.types[msgtype](data="hi"), msgtype)
            else:
                from labkit.io.bags import _message

                raw = ts.serialize_ros1(_message(ts, scan, 0, True), msgtype)
            w.write(conn, 1, raw)


def test_topic_choice_and_its_errors(tmp_path):
    two = tmp_path / "two.bag"
    _two_topic_bag(two, [("/front", "sensor_msgs/msg/LaserScan"), ("/rear", "sensor_msgs/msg/LaserScan"),
                         ("/chatter", "std_msgs/msg/String")])
    with pytest.raises(ValueError, match=r"several LaserScan topics \(/front, /rear\)"):
        read_scans(two)
    assert read_scans(two, topic="/rear").topic == "/rear"
    assert len(list(read_scans(two, topic="/rear"))) == 1
    with pytest.raises(ValueError, match="'/chatter' is not a sensor_msgs/LaserScan topic.*LaserScan topics: /front"):
        read_scans(two, topic="/chatter")
    none = tmp_path / "none.bag"
    _two_topic_bag(none, [("/chatter", "std_msgs/msg/String")])
    with pytest.raises(ValueError, match=r"no sensor_msgs/LaserScan topic; its topics are: /chatter \(std_msgs"):
        read_scans(none)


def test_detect_format(tmp_path):
    with pytest.raises(FileNotFoundError):
        detect_format(tmp_path / "missing.bag")
    (tmp_path / "x.txt").write_text("hi")
    with pytest.raises(ValueError, match="supported formats: ros1"):
        detect_format(tmp_path / "x.txt")
    (tmp_path / "empty_dir").mkdir()
    with pytest.raises(ValueError, match="not a ROS2 bag"):
        read_scans(tmp_path / "empty_dir")
    for name, fmt in [("a.log.gz", "carmen"), ("a.clf", "carmen"), ("a.json", "json"), ("a.jsonl", "jsonl")]:
        (tmp_path / name).write_text("")
        assert detect_format(tmp_path / name) == fmt


def test_writers_refuse_to_overwrite_and_uneven_angles(tmp_path, office_scans):
    write_bag(office_scans[:2], tmp_path / "a.bag")
    with pytest.raises(ValueError, match="exists; pass overwrite=True"):
        write_bag(office_scans[:2], tmp_path / "a.bag")
    assert write_bag(office_scans[:3], tmp_path / "a.bag", overwrite=True) == 3
    uneven = Scan(ranges=[1.0, 1.0, 1.0], angles=[0.0, 0.1, 0.3])
    with pytest.raises(ValueError, match=r"scans\[0\] has unevenly spaced angles"):
        write_bag([uneven], tmp_path / "u.bag")
    with pytest.raises(ValueError, match="format must be one of"):
        write_bag([uneven], tmp_path / "u.bag", "rosbag3")
    with pytest.raises(ValueError, match="does not write them"):
        write_scans([uneven], tmp_path / "u.log")


def test_json_and_jsonl_round_trip(tmp_path, office_scans):
    assert write_scans(office_scans[:5], tmp_path / "s.jsonl") == 5
    assert_same_scans(office_scans[:5], list(read_scans(tmp_path / "s.jsonl")))
    write_scans(office_scans[:1], tmp_path / "one.json")
    back = read_json_scan(tmp_path / "one.json")
    assert_same_scans(office_scans[:1], [back])
    assert back.pose == office_scans[0].pose
    with pytest.raises(ValueError, match="exactly one scan"):
        write_scans(office_scans[:2], tmp_path / "two.json")


def test_json_errors(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text('{"ranges": [1, 2]}')
    with pytest.raises(ValueError, match="needs 'ranges' and 'bearings'"):
        read_json_scan(p)
    p.write_text('{"ranges": [1, 2], "bearings": [0.0, ')
    with pytest.raises(CorruptFileError, match="line 1"):
        read_json_scan(p)
    p.write_text('{"ranges": [1, null], "bearings": [0.0, 0.1]}')
    assert read_json_scan(p).valid.tolist() == [True, False]
    lines = tmp_path / "bad.jsonl"
    lines.write_text('{"ranges": [1], "bearings": [0.0]}\n{"ranges": [1], "bearings": [0.0]}\nnot json\n')
    got = []
    with pytest.raises(CorruptFileError, match="at line 3") as info:
        for s in read_scans(lines):
            got.append(s)
    assert len(got) == 2 and info.value.n_read == 2


def test_a_json_scan_without_range_max_refuses_absurd_readings(tmp_path):
    """A reading of 1e30 m (a placeholder for "no return") is invalid; it counted as a wall."""
    from labkit.io.jsonscan import DEFAULT_RANGE_MAX_M

    p = tmp_path / "s.json"
    p.write_text('{"ranges": [1.0, 1e30, 999.0, 1001.0], "bearings": [0.0, 0.1, 0.2, 0.3]}')
    scan = read_json_scan(p)
    assert scan.range_max == DEFAULT_RANGE_MAX_M == 1000.0
    assert scan.valid.tolist() == [True, False, True, False]
    p.write_text('{"ranges": [1.0, 1e30], "bearings": [0.0, 0.1], "range_max": 2.0}')
    assert read_json_scan(p).valid.tolist() == [True, False]
    p.write_text('{"ranges": [1.0, 1e30], "bearings": [0.0, 0.1], "range_max": null}')  # null: no limit
    assert read_json_scan(p).valid.tolist() == [True, True]


def test_a_laserscan_whose_beams_disagree_with_its_span_is_skipped_and_counted(tmp_path):
    """20 LaserScans, one of which holds 90 ranges for a span of 181 beams: it is not read with its
    angle_max quietly changed, it is a lost scan of the error."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    t = ts.types
    path = tmp_path / "span.bag"
    with rosbag1.Writer(path) as writer:
        conn = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        for k in range(20):
            n = 90 if k == 7 else 181
            header = t["std_msgs/msg/Header"](seq=k, stamp=t["builtin_interfaces/msg/Time"](sec=10 + k, nanosec=0),
                                              frame_id="laser")
            msg = t["sensor_msgs/msg/LaserScan"](
                header=header, angle_min=-np.pi / 2, angle_max=np.pi / 2, angle_increment=np.pi / 180,
                time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=10.0,
                ranges=np.full(n, 2.0, np.float32), intensities=np.zeros(0, np.float32))
            writer.write(conn, (10 + k) * 10**9, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
    got = []
    with pytest.raises(CorruptFileError, match="has 90 ranges but its angles span 180 deg") as info:
        got.extend(read_scans(path))
    assert [s.stamp_ns // 10**9 for s in got] == [10 + k for k in range(20) if k != 7]
    assert info.value.n_lost == 1 and info.value.lost_exact and "19 scans kept, 1 lost" in str(info.value)
    assert all(s.n_beams == 181 and np.isclose(s.angles[-1], np.pi / 2) for s in got)


# ---------------------------------------------------------------- CARMEN
def _flaser(ranges, x=1.0, y=2.0, th=0.5, t=100.25):
    r = " ".join(f"{v:g}" for v in ranges)
    return f"FLASER {len(ranges)} {r} {x} {y} {th} {x} {y} {th} {t} host {t}\n"


def _robotlaser(ranges, start=-1.0, res=0.5, max_range=8.0, t=7.5):
    r = " ".join(f"{v:g}" for v in ranges)
    return (f"ROBOTLASER1 0 {start} {res * (len(ranges) - 1)} {res} {max_range} 0.01 0 {len(ranges)} {r} 0 "
            f"1 2 0.3 1 2 0.3 0 0 0.5 0.5 0 {t} host {t}\n")


def test_carmen_flaser_angles_pose_and_no_return(tmp_path):
    body = "# comment\nPARAM x 1\nODOM 1 2 3 0 0 0 1 host 1\n"
    scans = [[1.0] * 180, [2.0] * 179 + [81.83]] + [[3.0] * 170 + [81.83] * 10 for _ in range(3)]
    log = tmp_path / "x.log"
    log.write_text(body + "".join(_flaser(r, t=100.0 + k) for k, r in enumerate(scans)) + "NEFF 1 2 3\n")
    out = list(read_carmen(log))
    assert len(out) == 5
    s = out[1]
    assert np.isclose(s.angles[0], -np.pi / 2) and np.isclose(s.angle_increment, np.pi / 180)
    assert s.pose == (1.0, 2.0, 0.5) and s.stamp_ns == 101_000_000_000 and s.frame_id == "flaser"
    assert not s.valid[-1] and s.valid[:-1].all()  # 81.83 is "no return" in this log
    # odd beam counts span -90..+90 inclusive
    odd = tmp_path / "odd.log"
    odd.write_text(_flaser([1.0] * 181))
    (o,) = read_carmen(odd)
    assert np.isclose(o.angles[-1], np.pi / 2)


def test_carmen_robotlaser_and_message_choice(tmp_path):
    log = tmp_path / "r.log.gz"
    with gzip.open(log, "wt") as fh:
        fh.write(_flaser([1.0] * 180) + _robotlaser([1.0, 2.0, 9.0]) + _robotlaser([1.0, 2.0, 3.0]))
    assert len(list(read_scans(log))) == 1  # the front laser, FLASER, by default
    stream = read_scans(log, topic="ROBOTLASER1")
    assert stream.count == 2
    a, _ = list(stream)
    np.testing.assert_allclose(a.angles, [-1.0, -0.5, 0.0])
    assert a.range_max == 8.0 and a.valid.tolist() == [True, True, False]
    with pytest.raises(ValueError, match="no RLASER messages; laser messages found: FLASER"):
        read_scans(log, topic="RLASER")


def test_carmen_rear_laser(tmp_path):
    log = tmp_path / "rear.log"
    log.write_text(_flaser([1.0] * 180) + _flaser([2.0] * 180).replace("FLASER", "RLASER", 1))
    (rear,) = read_scans(log, topic="RLASER")
    assert rear.frame_id == "rlaser" and np.all(rear.ranges == 2.0) and rear.pose == (1.0, 2.0, 0.5)


def test_carmen_malformed_line_and_truncated_gzip(tmp_path):
    log = tmp_path / "m.log"
    log.write_text(_flaser([1.0] * 180) * 3 + "FLASER 180 1 2 3\n" + _flaser([1.0] * 180))
    got = []
    with pytest.raises(CorruptFileError, match="at line 4") as info:  # skipped, and reading goes on
        for s in read_carmen(log):
            got.append(s)
    assert len(got) == 4 and info.value.n_read == 4 and info.value.n_skipped == 1
    got = []
    with pytest.raises(CorruptFileError, match="at line 4") as info:  # strict: stops there
        for s in read_carmen(log, strict=True):
            got.append(s)
    assert len(got) == 3 and info.value.n_read == 3
    gz = tmp_path / "t.log.gz"
    with gzip.open(gz, "wt") as fh:
        fh.write(_flaser([1.0] * 180) * 200)
    gz.write_bytes(gz.read_bytes()[:-30])
    got = []
    with pytest.raises(CorruptFileError, match="cut short"):
        for s in read_carmen(gz):
            got.append(s)
    assert 150 < len(got) < 200


def test_shared_ros_bag_converts_to_every_format(tmp_path, shared_datasets):
    src = shared_datasets / "bags" / "Mapping1.bag"
    first = list(read_scans(src))[:50]
    small = tmp_path / "small.bag"
    write_bag(first, small)
    for name in ["a.mcap", "b_folder", "c.jsonl"]:
        convert(small, tmp_path / name)
        assert_same_scans(first, list(read_scans(tmp_path / name)))
    shutil.rmtree(tmp_path / "b_folder")
