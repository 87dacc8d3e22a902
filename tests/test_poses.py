"""Poses: SE(2) geometry and interpolation (labkit.poses), and poses read from recordings
(labkit.io.poses): odometry, tf chains with a static mounting, CARMEN, labkit's own bags.

The truth each test compares with is independent of the code under test: closed-form motion
(a constant-velocity turn, which linear interpolation reproduces exactly), the simulator's exact
sensor poses, and bags written here with rosbags alone.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from rosbags import rosbag1, rosbag2

from labkit import CorruptFileError, Scan, convert, read_scans, sim, write_bag
from labkit.errors import RefusedError
from labkit.geometry import transform_points
from labkit.io import salvage
from labkit.poses import (
    FrameTree,
    GridThinning,
    PoseTrack,
    compose,
    interpolate_poses,
    inverse,
    quaternion_from_yaw,
    yaw_from_quaternion,
)

from .test_layering import LABKIT, imports_of

S = 1_000_000_000
finite = st.floats(-50, 50, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
pose_st = st.tuples(finite, finite, angle)


# ---------------------------------------------------------------------------- geometry
def test_poses_is_an_algorithm_module():
    """labkit/poses.py imports numpy and labkit's model only (as tests/test_layering.py asks of algorithms)."""
    from .test_layering import ALGORITHMS

    names = imports_of(LABKIT / "poses.py")
    assert all(n.split(".")[0] in sys.stdlib_module_names or n == "numpy" or
               (n.startswith("labkit.") and n.split(".")[1] in ALGORITHMS) for n in names), names


@given(pose_st, pose_st, st.lists(st.tuples(finite, finite), min_size=1, max_size=5))
def test_compose_is_applying_one_transform_after_the_other(a, b, points):
    pts = np.array(points)
    np.testing.assert_allclose(transform_points(pts, compose(a, b)), transform_points(transform_points(pts, b), a),
                               atol=1e-9)


@given(pose_st)
def test_inverse_undoes_a_pose(a):
    np.testing.assert_allclose(compose(a, inverse(a)), [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(compose(inverse(a), a), [0.0, 0.0, 0.0], atol=1e-9)


@given(angle)
def test_quaternion_yaw_round_trip(theta):
    back = yaw_from_quaternion(*quaternion_from_yaw(theta))
    assert abs(math.remainder(back - theta, 2 * math.pi)) < 1e-12


def test_yaw_of_a_tilted_quaternion_is_its_heading():
    # 30 deg about z, then 10 deg pitch about the new y: the heading is still 30 deg
    z, y = math.radians(30), math.radians(10)
    q = (-math.sin(z / 2) * math.sin(y / 2), math.cos(z / 2) * math.sin(y / 2), math.sin(z / 2) * math.cos(y / 2),
         math.cos(z / 2) * math.cos(y / 2))
    assert yaw_from_quaternion(*q) == pytest.approx(z)


# ---------------------------------------------------------------------------- interpolation
def turning(t_s):
    """A robot driving at 1 m/s along x while turning at 0.5 rad/s about its own axis: x, y and
    theta are linear in time, so linear interpolation is exact (theta wrapped)."""
    t = np.asarray(t_s, dtype=float)
    return np.stack([1.0 * t, 0.2 * t - 1.0, np.angle(np.exp(1j * (0.5 * t + 2.9)))], axis=-1)


def test_interpolation_is_exact_for_motion_linear_in_time():
    stamps = np.arange(0, 10 * S + 1, S // 50)  # odometry at 50 Hz for 10 s
    track = PoseTrack.from_samples(stamps, turning(stamps / S))
    at = np.linspace(0, 10 * S, 777).astype(np.int64)  # scans anywhere in between
    got = track.at_many(at)
    want = turning(at / S)
    np.testing.assert_allclose(got[:, :2], want[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (got[:, 2] - want[:, 2]))), 0.0, atol=1e-9)  # crosses +-pi
    assert np.all(np.abs(got[:, 2]) <= math.pi)
    for k in (0, 100, 776):  # the scalar call gives the same
        assert track.at(int(at[k])) == tuple(got[k])


def test_angles_take_the_short_way_round():
    track = PoseTrack.from_samples([0, 10], [[0.0, 0.0, math.radians(170)], [0.0, 0.0, math.radians(-170)]])
    assert abs(math.degrees(track.at(5)[2])) == pytest.approx(180.0)
    assert math.degrees(track.at(2)[2]) == pytest.approx(174.0)


def test_no_extrapolation_beyond_the_tolerance_and_no_bridging_of_gaps():
    stamps = np.array([0, S // 10, 2 * S // 10, 5 * S, 51 * S // 10])  # a 2.8 s gap in the middle
    poses = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0], [4.0, 0, 0]])
    at = [-S // 20, -S, 3 * S // 10, 3 * S, 495 * S // 100, 52 * S // 10, 6 * S, S // 20, 48 * S // 10]
    got = interpolate_poses(stamps, poses, at, tolerance_ns=S // 10, max_gap_ns=S)
    assert got[0, 0] == 0.0  # 50 ms before the first: the first
    assert np.isnan(got[1]).all()  # 1 s before: none
    assert got[2, 0] == 2.0  # 100 ms after the last before the gap: that pose (the gap is not bridged)
    assert np.isnan(got[3]).all()  # in the middle of the gap: none
    assert got[4, 0] == 3.0  # 50 ms before the first pose after the gap: that pose
    assert got[5, 0] == 4.0  # 100 ms after the last
    assert np.isnan(got[6]).all()
    assert got[7, 0] == pytest.approx(0.5)  # between two poses 100 ms apart
    assert np.isnan(got[8]).all()  # 200 ms before the pose after the gap: too far


def test_samples_are_sorted_and_the_last_of_a_stamp_wins():
    track = PoseTrack.from_samples([30, 10, 20, 20, 40], [[3.0, 0, 0], [1, 0, 0], [9, 0, 0], [2, 0, 0], [np.nan, 0, 0]])
    assert track.stamps_ns.tolist() == [10, 20, 30] and track.poses[:, 0].tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="strictly increasing"):
        interpolate_poses([0, 0], [[0, 0, 0], [1, 0, 0]], [0])
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        PoseTrack.from_samples([0], [[1.0, 2.0]])


# ---------------------------------------------------------------------------- frame trees
MOUNT = (0.3, -0.1, 0.2)  # the laser on the robot: 30 cm ahead, 10 cm right, turned 0.2 rad


def test_a_frame_tree_composes_moving_and_static_links():
    stamps = np.arange(0, 4 * S + 1, S // 20)
    tree = FrameTree()
    tree.add_static("base_link", "laser", MOUNT)
    tree.add_track("odom", "base_link", PoseTrack.from_samples(stamps, turning(stamps / S)))
    tree.add_track("map", "odom", PoseTrack.from_samples(np.arange(9) * S // 2, np.tile([5.0, 1.0, 0.5], (9, 1))))
    assert tree.chain("laser") == ["laser", "base_link", "odom", "map"] and tree.root("laser") == "map"
    assert tree.moves("laser", "map") and not tree.moves("laser", "base_link") and not tree.moves("laser", "nowhere")
    t = 1_234_567_890
    want = compose([5.0, 1.0, 0.5], compose(turning(t / S), MOUNT))
    np.testing.assert_allclose(tree.pose_in("laser", "map", t), want, atol=1e-9)
    np.testing.assert_allclose(tree.pose_in("laser", "base_link", t), MOUNT)
    assert tree.pose_in("laser", "map", 10 * S) is None and tree.pose_in("laser", "elsewhere", t) is None


def test_grid_thinning_keeps_one_point_per_cell_over_calls():
    thin = GridThinning(0.5)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-5, 5, (2000, 2))
    kept = pts[thin.new(pts)]
    cells = {tuple(c) for c in np.floor(pts / 0.5).astype(int)}
    assert len(kept) == len(cells) == len(thin)
    assert len({tuple(c) for c in np.floor(kept / 0.5).astype(int)}) == len(kept)
    assert not thin.new(pts).any() and thin.new([[100.0, 100.0], [np.nan, 0.0]]).tolist() == [True, False]


# ---------------------------------------------------------------------------- bags written here
def _ros_msgs(ts):
    t = ts.types

    def header(stamp_ns, frame, seq):
        stamp = t["builtin_interfaces/msg/Time"](sec=stamp_ns // S, nanosec=stamp_ns % S)
        return t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame, **({"seq": seq} if "seq" in
                                        t["std_msgs/msg/Header"].__dataclass_fields__ else {}))

    def transform(pose):
        q = quaternion_from_yaw(pose[2])
        return t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=float(pose[0]), y=float(pose[1]), z=0.25),
            rotation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))

    def stamped(stamp_ns, parent, child, pose, seq=0):
        return t["geometry_msgs/msg/TransformStamped"](header=header(stamp_ns, parent, seq), child_frame_id=child,
                                                       transform=transform(pose))

    def tf(items):
        return t["tf2_msgs/msg/TFMessage"](transforms=items)

    def odometry(stamp_ns, parent, child, pose, seq=0):
        q = quaternion_from_yaw(pose[2])
        p = t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]),
                                                                              z=0.0),
                                        orientation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))
        zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        return t["nav_msgs/msg/Odometry"](
            header=header(stamp_ns, parent, seq), child_frame_id=child,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=t["geometry_msgs/msg/Twist"](linear=zero,
                                                                                               angular=zero),
                                                             covariance=np.zeros(36)))

    def laser(stamp_ns, frame, seq=0):
        return t["sensor_msgs/msg/LaserScan"](
            header=header(stamp_ns, frame, seq), angle_min=-1.0, angle_max=1.0, angle_increment=0.5,
            time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=10.0,
            ranges=np.full(5, 2.0, np.float32), intensities=np.zeros(0, np.float32))

    return stamped, tf, odometry, laser


def write_raw_bag(path: Path, fmt: str, messages) -> Path:
    """A bag written with rosbags alone from ``(topic, msgtype, receive_ns, message)``."""
    ros1 = fmt == "ros1"
    ts = salvage.typestore(ros1)
    writer = rosbag1.Writer(path) if ros1 else rosbag2.Writer(
        path, version=9, storage_plugin=rosbag2.StoragePlugin.MCAP if fmt == "mcap" else rosbag2.StoragePlugin.SQLITE3)
    writer.open()
    conns = {}
    for topic, msgtype, receive, msg in sorted(messages, key=lambda m: m[2]):
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        raw = ts.serialize_ros1(msg, msgtype) if ros1 else ts.serialize_cdr(msg, msgtype)
        writer.write(conns[topic], receive, raw)
    writer.close()
    return path


SCAN_STAMPS = np.arange(S // 7, 8 * S, S // 10)  # 10 Hz, between the odometry's 50 Hz stamps
T0 = 100 * S  # bags start at 100 s


def robot_bag(path: Path, fmt: str, *, tf_chain: bool = False, odometry=("/odom",), end_s: float = 8.0,
              frame="laser") -> Path:
    ts = salvage.typestore(fmt == "ros1")
    stamped, tf, odometry_msg, laser = _ros_msgs(ts)
    msgs = []
    odo = np.arange(0, int(end_s * S) + 1, S // 50)
    for k, s in enumerate(SCAN_STAMPS):
        msgs.append(("/scan", "sensor_msgs/msg/LaserScan", T0 + int(s) + 5_000_000, laser(T0 + int(s), frame, k)))
    for topic in odometry:
        for k, s in enumerate(odo):
            msgs.append((topic, "nav_msgs/msg/Odometry", T0 + int(s), odometry_msg(T0 + int(s), "odom", "base_link",
                                                                                  turning(s / S), k)))
    msgs.append(("/tf_static", "tf2_msgs/msg/TFMessage", T0, tf([stamped(T0, "base_link", frame, MOUNT)])))
    if tf_chain:
        for k, s in enumerate(odo[::2]):  # odom -> base_link at 25 Hz, and map -> odom drifting slowly
            msgs.append(("/tf", "tf2_msgs/msg/TFMessage", T0 + int(s), tf([
                stamped(T0 + int(s), "odom", "base_link", turning(s / S), k),
                stamped(T0 + int(s), "/map", "odom", (0.5 + 0.01 * s / S, -0.2, 0.1), k)])))
    return write_raw_bag(path, fmt, msgs)


@pytest.mark.parametrize("fmt, name", [("ros1", "r.bag"), ("mcap", "r_mcap"), ("ros2", "r")])
def test_odometry_and_a_static_mounting_give_the_lasers_pose(tmp_path, fmt, name):
    bag = robot_bag(tmp_path / name, fmt)
    stream = read_scans(bag)
    assert stream.poses == "odometry /odom (its mounting from tf /tf_static)" or stream.poses.startswith("tf")
    scans = list(stream)
    assert len(scans) == len(SCAN_STAMPS)
    want = compose(turning(SCAN_STAMPS / S), MOUNT)
    np.testing.assert_allclose([s.pose for s in scans], want, atol=1e-9)
    assert "mounting base_link -> laser" in stream.pose_sources["laser"]


def test_a_tf_chain_is_preferred_and_composed(tmp_path):
    bag = robot_bag(tmp_path / "tf.bag", "ros1", tf_chain=True)
    stream = read_scans(bag)
    scans = list(stream)
    t = SCAN_STAMPS / S
    want = compose(np.stack([0.5 + 0.01 * t, np.full_like(t, -0.2), np.full_like(t, 0.1)], axis=1),
                   compose(turning(t), MOUNT))
    np.testing.assert_allclose([s.pose for s in scans], want, atol=1e-9)
    assert stream.pose_sources["laser"] == "tf: map -> odom -> base_link -> laser"
    # naming the odometry topic: its poses (in odom), with the mounting from the transforms
    np.testing.assert_allclose([s.pose for s in read_scans(bag, poses="/odom")], compose(turning(t), MOUNT),
                               atol=1e-9)
    assert all(s.pose is None for s in read_scans(bag, poses=False))


def test_no_pose_past_the_odometry(tmp_path):
    bag = robot_bag(tmp_path / "short.bag", "ros1", end_s=4.0)
    scans = list(read_scans(bag))
    for s in scans:
        t = s.stamp_ns - T0
        assert (s.pose is None) == (t > 4 * S + 100_000_000), t


def test_choosing_among_several_odometry_topics(tmp_path):
    bag = robot_bag(tmp_path / "two.bag", "ros1", odometry=("/odom", "/ground_truth"))
    with pytest.raises(RefusedError, match="several odometry topics") as info:
        read_scans(bag)
    assert "--poses TOPIC" in info.value.cli and "/ground_truth" in str(info.value)
    assert read_scans(bag, poses="/ground_truth").poses.startswith("odometry /ground_truth")
    with pytest.raises(RefusedError, match="not a pose topic.*ground_truth"):
        read_scans(bag, poses="/scan")


def test_a_bad_pose_record_is_counted_with_the_scans(tmp_path):
    ts = salvage.typestore(True)
    _, _, odometry_msg, laser = _ros_msgs(ts)
    msgs = [("/scan", "sensor_msgs/msg/LaserScan", T0 + k * S // 10, laser(T0 + k * S // 10, "laser")) for k in
            range(20)]
    msgs += [("/odom", "nav_msgs/msg/Odometry", T0 + k * S // 10,
              odometry_msg(T0 + k * S // 10, "odom", "laser", (np.nan if k == 12 else k, 0.0, 0.0))) for k in range(20)]
    bag = write_raw_bag(tmp_path / "nan.bag", "ros1", msgs)
    got = []
    with pytest.raises(CorruptFileError, match=r"message 13 of /odom\): the pose is not finite") as info:
        got.extend(read_scans(bag))
    assert len(got) == 20 and info.value.n_skipped == 1 and info.value.n_read == 20
    assert got[12].pose == (12.0, 0.0, 0.0)  # interpolated across the lost record
    strict = []
    with pytest.raises(CorruptFileError):
        strict.extend(read_scans(bag, strict=True))
    assert len(strict) == 12  # up to the last pose read before the bad one


# ---------------------------------------------------------------------------- labkit's own bags
@pytest.fixture(scope="module")
def corridor():
    return list(sim.simulate("corridor", seed=0, n_scans=60))


@pytest.mark.parametrize("name", ["c.bag", "c.mcap", "c_ros2"])
def test_written_bags_keep_the_simulators_exact_poses(tmp_path, corridor, name):
    write_bag([s for s, _ in corridor], tmp_path / name)
    stream = read_scans(tmp_path / name)
    assert stream.poses == "odometry /odom"
    back = list(stream)
    np.testing.assert_allclose([s.pose for s in back], [tr.pose for _, tr in corridor], atol=1e-12)
    assert stream.pose_sources == {"laser": "odometry /odom (map -> laser)"}


def test_a_cut_bag_keeps_its_poses_and_reports_the_damage_once(tmp_path, corridor):
    bag = tmp_path / "cut.bag"
    write_bag([s for s, _ in corridor], bag)
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size * 2 // 3])
    got = []
    with pytest.raises(CorruptFileError) as info:
        got.extend(read_scans(bag))
    assert 20 < len(got) < 60 and info.value.n_read == len(got)
    assert info.value.n_skipped <= 1  # one cut, not one per pass
    truth = {tr.stamp_ns: tr.pose for _, tr in corridor}
    assert all(s.pose is not None for s in got[:-1])
    np.testing.assert_allclose([s.pose for s in got[:-1]], [truth[s.stamp_ns] for s in got[:-1]], atol=1e-12)


def carmen_lines(poses) -> str:
    return "".join(f"FLASER 5 1.0 2.0 3.0 2.0 1.0 {x:.6f} {y:.6f} {th:.6f} 0 0 0 {100 + 0.1 * k:.3f} host "
                   f"{100 + 0.1 * k:.3f}\n" for k, (x, y, th) in enumerate(poses))


def test_carmen_poses_survive_conversion_to_a_bag(tmp_path):
    poses = [(1.0 + 0.1 * k, -2.0, 0.3 * k - 3.0) for k in range(25)]
    log = tmp_path / "run.log"
    log.write_text(carmen_lines(poses))
    stream = read_scans(log)
    assert stream.poses == "the log's laser poses"
    np.testing.assert_allclose([s.pose for s in stream], poses)
    assert all(s.pose is None for s in read_scans(log, poses=False))
    with pytest.raises(RefusedError, match="names a bag topic"):
        read_scans(log, poses="/odom")
    convert(log, tmp_path / "run.mcap")
    back = np.array([s.pose for s in read_scans(tmp_path / "run.mcap")])
    np.testing.assert_allclose(back[:, :2], np.array(poses)[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (back[:, 2] - np.array(poses)[:, 2]))), 0.0, atol=1e-12)


def test_scans_without_poses_write_no_odometry(tmp_path):
    write_bag([Scan(ranges=[1.0, 2.0], angles=[0.0, 0.1], stamp_ns=S)], tmp_path / "p.bag")
    stream = read_scans(tmp_path / "p.bag")
    assert stream.poses is None and next(iter(stream)).pose is None


@pytest.mark.shared
def test_mapping1_poses_are_its_ground_truth_odometry(shared_datasets):
    """Mapping1.bag's /base_pose_ground_truth, read here with rosbags alone, at each scan's stamp."""
    from rosbags.highlevel import AnyReader

    bag = shared_datasets / "bags" / "Mapping1.bag"
    truth = {}
    with AnyReader([bag], default_typestore=salvage.typestore(False)) as reader:
        conns = [c for c in reader.connections if c.topic == "/base_pose_ground_truth"]
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            o = msg.pose.pose.orientation
            truth[msg.header.stamp.sec * S + msg.header.stamp.nanosec] = (
                msg.pose.pose.position.x, msg.pose.pose.position.y, math.atan2(2 * (o.w * o.z + o.x * o.y),
                                                                              1 - 2 * (o.y ** 2 + o.z ** 2)))
    scans = list(read_scans(bag))
    on_stamp = [s for s in scans if s.stamp_ns in truth]
    assert len(on_stamp) > 0.9 * len(scans)
    np.testing.assert_allclose([s.pose for s in on_stamp], [truth[s.stamp_ns] for s in on_stamp], atol=1e-12)


def test_one_pose_at_a_time_gives_the_same_numbers_as_many():
    """PoseTrack.at (plain floats, once per scan) against interpolate_poses (arrays), bit for bit:
    random times, every stamp, and one nanosecond either side of it."""
    rng = np.random.default_rng(1)
    stamps = np.sort(rng.choice(10 * S, 400, replace=False))
    poses = np.column_stack([rng.normal(size=400), rng.normal(size=400), rng.uniform(-math.pi, math.pi, 400)])
    track = PoseTrack.from_samples(stamps, poses)
    times = np.concatenate([rng.integers(-S, 11 * S, 5000), stamps, stamps + 1, stamps - 1])
    many = track.at_many(times)
    for t, want in zip(times, many, strict=True):
        got = track.at(int(t))
        assert (got is None and np.isnan(want).all()) or got == tuple(want), (t, got, want)
