"""``labkit convert`` between bags keeps the recording: every topic, its name, its messages.

A ROS1 bag written by the test holds a LaserScan topic, ``/tf``, a camera image and a message type
of its own (not in any stock typestore). It is converted in every direction between ROS1, ROS2
(sqlite3 folder) and MCAP, and every output is compared with the source as rosbags reads it
(an independent reader): the same topics under the same names, the same number of messages on
each, and the same field values message by message (ROS1's ``header.seq``, which ROS2 does not
have, aside). A topic whose message type cannot be converted is left out with a note and counted;
``--only-scans`` gives the scans-only copy.
"""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from rosbags import rosbag1
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from labkit.io import convert, salvage
from labkit.io.bagcopy import TopicsSkippedWarning

LABKIT = [str(Path(sys.executable).parent / "labkit")]
STATUS = "my_msgs/msg/Status"


def _source(path: Path) -> Path:
    ts = get_typestore(Stores.ROS1_NOETIC)
    ts.register(get_types_from_msg("string label\nint32 level\nfloat64[] values\ntime since", STATUS))
    ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    t = ts.types
    with rosbag1.Writer(path) as writer:
        conns = {name: writer.add_connection(name, msgtype, typestore=ts) for name, msgtype in [
            ("/base_scan", "sensor_msgs/msg/LaserScan"), ("/tf", "tf2_msgs/msg/TFMessage"),
            ("/camera/image", "sensor_msgs/msg/Image"), ("/status", STATUS)]}
        for k in range(30):
            ns = 10**9 + k * 10**8
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)

            def header(frame, k=k, stamp=stamp):
                return t["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=frame)

            scan = t["sensor_msgs/msg/LaserScan"](
                header=header("laser"), angle_min=-1.0, angle_max=1.0, angle_increment=0.1, time_increment=0.0,
                scan_time=0.1, range_min=0.1, range_max=8.0,
                ranges=np.random.default_rng(k).uniform(1, 5, 21).astype(np.float32),
                intensities=np.arange(21, dtype=np.float32))
            writer.write(conns["/base_scan"], ns, ts.serialize_ros1(scan, "sensor_msgs/msg/LaserScan"))
            tr = t["geometry_msgs/msg/TransformStamped"](
                header=header("odom"), child_frame_id="base_link",
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=0.1 * k, y=0.0, z=0.0),
                    rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
            writer.write(conns["/tf"], ns, ts.serialize_ros1(t["tf2_msgs/msg/TFMessage"](transforms=[tr]),
                                                             "tf2_msgs/msg/TFMessage"))
            if k % 3 == 0:
                image = t["sensor_msgs/msg/Image"](header=header("camera"), height=4, width=6, encoding="mono8",
                                                   is_bigendian=0, step=6,
                                                   data=np.arange(24, dtype=np.uint8) + k)
                writer.write(conns["/camera/image"], ns, ts.serialize_ros1(image, "sensor_msgs/msg/Image"))
            status = t[STATUS](label=f"step {k}", level=k - 10, values=np.linspace(0, 1, k % 4), since=stamp)
            writer.write(conns["/status"], ns, ts.serialize_ros1(status, STATUS))
    return path


def _plain(value):
    """A message as plain data: fields by name (ROS1's header.seq dropped), arrays as lists."""
    if hasattr(value, "__dataclass_fields__"):
        return {k: _plain(getattr(value, k)) for k in value.__dataclass_fields__ if k not in ("seq", "__msgtype__")}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _contents(path: Path) -> dict[str, list]:
    """Every topic's messages, as rosbags reads them, in the order of their time stamps."""
    with AnyReader([path], default_typestore=salvage.typestore(path.suffix == ".bag")) as reader:
        out: dict[str, list] = {c.topic: [] for c in reader.connections}
        for conn, stamp, raw in reader.messages():
            out[conn.topic].append((stamp, _plain(reader.deserialize(raw, conn.msgtype))))
    return {topic: sorted(msgs, key=lambda m: m[0]) for topic, msgs in out.items()}


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    path = _source(tmp_path_factory.mktemp("convert") / "src.bag")
    return path, _contents(path)


NAMES = {"ros1": "out.bag", "mcap": "out.mcap", "ros2": "out_ros2"}


@pytest.mark.parametrize("chain", [("mcap",), ("ros2",), ("mcap", "ros1"), ("ros2", "ros1"), ("mcap", "ros2"),
                                   ("ros2", "mcap")])
def test_every_topic_is_carried_through_with_its_name_and_messages(source, tmp_path, chain):
    src, expected = source
    counts = {topic: len(msgs) for topic, msgs in expected.items()}
    assert counts == {"/base_scan": 30, "/tf": 30, "/camera/image": 10, "/status": 30}
    current = src
    for k, fmt in enumerate(chain):
        out = tmp_path / f"{k}{NAMES[fmt]}"
        assert convert(current, out) == 30  # the scans
        got = _contents(out)
        assert {topic: len(msgs) for topic, msgs in got.items()} == counts, f"{current.name} -> {out.name}"
        for topic, msgs in expected.items():
            assert got[topic] == msgs, f"{topic} differs after {current.name} -> {out.name}"
        current = out


def test_a_type_that_does_not_convert_is_left_out_with_a_note_and_counted(tmp_path):
    """An MCAP file with a JSON-encoded channel beside its scans: into a ROS1 bag, the scans go
    and the JSON topic is named in a note with its 8 messages (exit 0: nothing was damaged)."""
    ts = salvage.typestore(False)
    t = ts.types
    src = tmp_path / "mixed.mcap"
    with open(src, "wb") as fh:
        writer = McapWriter(fh)
        writer.start("ros2", "labkit tests")
        schema = writer.register_schema("sensor_msgs/msg/LaserScan", "ros2msg",
                                        ts.generate_msgdef("sensor_msgs/msg/LaserScan", ros_version=2)[0].encode())
        scans = writer.register_channel("/scan", "cdr", schema)
        notes = writer.register_channel("/notes", "json", writer.register_schema("Note", "jsonschema", b"{}"))
        for k in range(8):
            msg = t["sensor_msgs/msg/LaserScan"](
                header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=k + 1, nanosec=0),
                                                frame_id="laser"),
                angle_min=-1.0, angle_max=1.0, angle_increment=0.5, time_increment=0.0, scan_time=0.0, range_min=0.0,
                range_max=5.0, ranges=np.ones(5, np.float32), intensities=np.zeros(0, np.float32))
            writer.add_message(scans, (k + 1) * 10**9, ts.serialize_cdr(msg, "sensor_msgs/msg/LaserScan"),
                               (k + 1) * 10**9)
            writer.add_message(notes, (k + 1) * 10**9, json.dumps({"k": k}).encode(), (k + 1) * 10**9)
        writer.finish()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert convert(src, tmp_path / "out.bag") == 8
    assert [str(w.message).split(":")[0] for w in caught if w.category is TopicsSkippedWarning] == [
        f"8 message(s) of /notes were not carried into {tmp_path / 'out.bag'}"]
    assert {topic: len(m) for topic, m in _contents(tmp_path / "out.bag").items()} == {"/scan": 8}
    p = subprocess.run([*LABKIT, "-q", "convert", str(src), str(tmp_path / "cli.bag")], capture_output=True, text=True)
    assert p.returncode == 0 and "labkit: note: 8 message(s) of /notes were not carried" in p.stderr, p.stderr


def test_only_scans_is_the_scans_alone(source, tmp_path):
    src, _ = source
    p = subprocess.run([*LABKIT, "-q", "convert", "--only-scans", str(src), str(tmp_path / "s.mcap")],
                       capture_output=True, text=True)
    assert p.returncode == 0 and "wrote 30 scans" in p.stdout, p.stderr
    got = _contents(tmp_path / "s.mcap")
    assert set(got) == {"/scan"} and len(got["/scan"]) == 30  # the source's /tf moves no laser frame
    p = subprocess.run([*LABKIT, "-q", "convert", str(src), str(tmp_path / "all.mcap")], capture_output=True,
                       text=True)
    assert p.returncode == 0 and "wrote 100 messages of 4 topics (30 scans)" in p.stdout, p.stderr
    p = subprocess.run([*LABKIT, "-q", "convert", "--topic", "/base_scan", str(src), str(tmp_path / "t.mcap")],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "--only-scans" in p.stderr
