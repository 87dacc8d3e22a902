"""Where the sensor was: poses read from bags (``nav_msgs/Odometry``, ``tf2_msgs/TFMessage``).

:func:`labkit.read_scans` gives every scan the sensor's pose in a world frame
(:attr:`labkit.Scan.pose`) when the recording has poses:

- **CARMEN logs** carry the corrected laser pose on every laser line (:mod:`labkit.io.carmen`);
  JSON scans carry a ``pose`` field when they have one.
- **Bags**: the poses are read first (one pass over the pose topics only), then the scans
  stream as before and each gets the pose at its header stamp, interpolated by the rule of
  :mod:`labkit.poses` (linear between poses at most 1 s apart, angles the short way round;
  the nearest pose within 0.1 s otherwise; no pose further out -- ``pose=None``).

Which topics, with ``poses=None`` (auto):

1. ``/tf`` (and ``/tf_static``: every ``tf2_msgs/TFMessage`` topic) when its transforms link the
   scan's ``frame_id`` to a root frame through at least one moving link: the sensor's pose in
   that root (``map`` or ``odom``), the laser's mounting included;
2. else the bag's one ``nav_msgs/Odometry`` topic: the pose of its ``child_frame_id`` (the
   robot's base) in its ``header.frame_id``, composed with the laser's mounting when the
   transforms link the scan's frame to that child frame (a static transform from
   ``/tf_static``), else taken as the laser's own pose (the laser at the base's origin);
3. else no poses. Several odometry topics and no ``/tf`` (``/tf_static`` alone moves nothing):
   refused, with the list (choose one).

``poses="/topic"`` names an odometry or tf topic; ``poses=False`` reads none. 3D transforms
are projected onto the plane (x, y and the heading; z, roll and pitch are dropped).

labkit's own bag writers store a scan's pose as ``nav_msgs/Odometry`` on ``/odom`` (frame
``map``, child frame the scan's ``frame_id``) at the scan's stamp, so a CARMEN log converted to
a bag keeps its poses and the simulator's bags carry the exact sensor poses.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RefusedError
from ..poses import FrameTree, PoseTrack, compose, yaw_from_quaternion
from .bags import ODOM_FRAME, ODOM_TOPIC, read_messages
from .faults import Faults

__all__ = ["ODOMETRY_TYPES", "TF_TYPES", "ODOM_TOPIC", "ODOM_FRAME", "PosePlan", "BagPoses", "plan_poses",
           "read_bag_poses"]

ODOMETRY_TYPES = frozenset({"nav_msgs/Odometry", "nav_msgs/msg/Odometry"})
TF_TYPES = frozenset({"tf2_msgs/TFMessage", "tf2_msgs/msg/TFMessage", "tf/tfMessage", "tf/msg/tfMessage"})


@dataclass(frozen=True)
class PosePlan:
    """Which topics of a bag hold its poses (see the module docstring).

    Parameters
    ----------
    odometry : str or None
        The ``nav_msgs/Odometry`` topic read.
    tf : tuple of str
        The ``tf2_msgs/TFMessage`` topics read (``/tf``, ``/tf_static``).
    prefer_tf : bool
        Whether the transforms come first (auto, or a tf topic named); False when an odometry
        topic was named (the transforms then give only the laser's mounting).
    msgtypes : dict
        Message type of every topic read.
    """

    odometry: str | None
    tf: tuple[str, ...]
    prefer_tf: bool
    msgtypes: dict = field(default_factory=dict, repr=False)

    def describe(self) -> str:
        """``"tf /tf, /tf_static, else odometry /odom"``: what is read, in the order it is used."""
        tf = f"tf {', '.join(self.tf)}" if self.tf else ""
        odometry = f"odometry {self.odometry}" if self.odometry else ""
        if not (tf and odometry):
            return tf or odometry
        return f"{tf}, else {odometry}" if self.prefer_tf else f"{odometry} (its mounting from {tf})"


def _choices(odometry: list[str], tf: list[str]) -> str:
    return ", ".join([f"{t} (nav_msgs/Odometry)" for t in odometry] + [f"{t} (tf2_msgs/TFMessage)" for t in tf]) \
        or "none"


def plan_poses(path: Path, topics, poses: str | bool | None) -> PosePlan | None:
    """The topics to read the poses of a bag from.

    Raises :class:`~labkit.errors.RefusedError` for a topic that holds no poses, and for several
    odometry topics without ``/tf`` when none is named.

    Parameters
    ----------
    path : Path
        The bag (for messages).
    topics : iterable of tuple of (str, str, int)
        The bag's topics: ``(name, msgtype, count)``.
    poses : str, bool or None
        None or True: whatever the bag has; False: none; a topic's name: that topic.

    Returns
    -------
    PosePlan or None
        The plan; None for no poses.
    """
    if poses is False:
        return None
    odometry = sorted(name for name, msgtype, _ in topics if msgtype in ODOMETRY_TYPES)
    tf = sorted(name for name, msgtype, _ in topics if msgtype in TF_TYPES)
    msgtypes = {name: msgtype for name, msgtype, _ in topics if name in odometry or name in tf}
    if isinstance(poses, str):
        if poses in odometry:
            return PosePlan(poses, tuple(tf), False, {k: v for k, v in msgtypes.items() if k == poses or k in tf})
        if poses in tf:
            return PosePlan(None, tuple(tf), True, {k: v for k, v in msgtypes.items() if k in tf})
        raise RefusedError(f"poses={poses!r} is not a pose topic of {path}; pose topics: {_choices(odometry, tf)}",
                           f"--poses {poses} is not a pose topic of {path}; pose topics: {_choices(odometry, tf)}")
    if len(odometry) > 1 and all(t.endswith("tf_static") for t in tf):  # no tf that could move the laser
        raise RefusedError(f"{path} has several odometry topics ({', '.join(odometry)}); choose one with "
                           "poses='/topic', or poses=False for none",
                           f"{path} has several odometry topics ({', '.join(odometry)}); choose one with "
                           "--poses TOPIC, or --poses none")
    chosen = odometry[0] if len(odometry) == 1 else None
    if chosen is None and not tf:
        return None
    return PosePlan(chosen, tuple(tf), True, {k: v for k, v in msgtypes.items() if k == chosen or k in tf})


def _frame(name: str) -> str:
    return name.lstrip("/")  # ROS1's tf_prefix style "/base_link" names the same frame


def _planar(position, orientation) -> tuple[float, float, float]:
    pose = (float(position.x), float(position.y),
            float(yaw_from_quaternion(orientation.x, orientation.y, orientation.z, orientation.w)))
    if not all(map(math.isfinite, pose)):
        raise ValueError(f"the pose is not finite: {pose}")
    return pose


def _stamp(header, receive_ns: int) -> int:
    stamp = header.stamp
    sec = getattr(stamp, "sec", None)
    nsec = getattr(stamp, "nanosec", None)
    ns = int(stamp.secs if sec is None else sec) * 1_000_000_000 + int(stamp.nsecs if nsec is None else nsec)
    return ns or receive_ns


class BagPoses:
    """The poses of one bag, read by :func:`read_bag_poses`, and the faults met while reading them.

    It gives the sensor pose of any scan frame at any stamp (:meth:`BagPoses.pose_at`).

    Parameters
    ----------
    plan : PosePlan
        The pose topics read (:func:`plan_poses`).
    tree : labkit.poses.FrameTree
        Every transform read (tf and tf_static).
    odometry : tuple of (str, str, labkit.poses.PoseTrack) or None
        The odometry read: parent frame, child frame and the poses; None without odometry.
    faults : labkit.io.faults.Faults
        Records of the pose topics that could not be read.
    last_good_ns : int or None
        With ``strict``: the stamp of the last pose read before the first bad record; scans
        after it get no pose. None: no bad record.

    Attributes
    ----------
    sources : dict
        For every scan frame met so far, how its pose is found (for messages and notes).
    """

    def __init__(self, plan: PosePlan, tree: FrameTree, odometry, faults: Faults, last_good_ns: int | None) -> None:
        self.plan, self.tree, self.odometry, self.faults = plan, tree, odometry, faults
        self._last_good_ns = last_good_ns
        self._rules: dict[str, Callable[[int], tuple | None]] = {}
        self.sources: dict[str, str] = {}

    @property
    def first_fault(self) -> tuple[str, str]:
        """Where and why the first pose record could not be read (asked only when one could not)."""
        if self.faults.first is None:
            raise ValueError("every pose record was read: there is no first fault")
        return self.faults.first

    def stops_before(self, stamp_ns: int) -> bool:
        """Strict reading: whether a scan at ``stamp_ns`` lies past the first bad pose record
        (after the last pose read before it)."""
        return bool(self.faults.strict and self.faults) and (self._last_good_ns is None
                                                              or stamp_ns > self._last_good_ns)

    def pose_at(self, stamp_ns: int, frame_id: str) -> tuple[float, float, float] | None:
        """The pose of the sensor frame ``frame_id`` at ``stamp_ns`` (module docstring), or None."""
        rule = self._rules.get(frame_id)
        if rule is None:
            rule = self._rules[frame_id] = self._rule(frame_id)
        return rule(stamp_ns)

    def _rule(self, frame_id: str) -> Callable[[int], tuple | None]:
        frame, tree = _frame(frame_id), self.tree
        root = tree.root(frame)
        if self.plan.prefer_tf and tree.moves(frame, root):
            self.sources[frame_id] = f"tf: {' -> '.join(reversed(tree.chain(frame)))}"
            return lambda t: tree.pose_in(frame, root, t)
        if self.odometry is None:
            self.sources[frame_id] = "none: no transform links it to a moving frame"
            return lambda t: None
        parent, child, track = self.odometry
        chain = tree.chain(frame)
        if child and child != frame and child in chain:
            mount = " -> ".join(reversed(chain[: chain.index(child) + 1]))
            self.sources[frame_id] = f"odometry {self.plan.odometry} ({parent} -> {child}), mounting {mount}"

            def with_mount(t: int):
                base, mount = track.at(t), tree.pose_in(frame, child, t)
                if base is None or mount is None:
                    return None
                p = compose(base, mount)
                return float(p[0]), float(p[1]), float(p[2])

            return with_mount
        how = "" if child == frame else " (the laser at the base's origin: no transform links them)"
        self.sources[frame_id] = f"odometry {self.plan.odometry} ({parent} -> {child or '?'}){how}"
        return track.at


def read_bag_poses(path: Path, fmt: str, plan: PosePlan, readable: bool, strict: bool = False,
                   expected: int | None = None) -> BagPoses:
    """Read every pose and transform ``plan`` names, in one pass over those topics of the bag.

    A record that cannot be read is skipped and counted in the ``faults`` of :class:`BagPoses` (with
    ``strict``, reading stops there); ``labkit.io.bags.iter_bag`` reports them with the scans'.

    Parameters
    ----------
    path : Path
        The bag.
    fmt : str
        Its format: ``"ros1"``, ``"ros2"`` or ``"mcap"``.
    plan : PosePlan
        The topics to read (:func:`plan_poses`).
    readable : bool
        Whether rosbags could open the bag's index; False: read it record by record.
    strict : bool
        Stop at the first bad record.
    expected : int or None
        How many pose messages the bag's index lists, to count the lost ones exactly.

    Returns
    -------
    BagPoses
        The poses and the faults met.
    """
    faults = Faults(path, strict, expected)
    odometry: dict[tuple[str, str], tuple[list, list]] = {}
    static: dict[str, tuple[str, tuple]] = {}
    moving: dict[tuple[str, str], tuple[list, list]] = {}
    last_good: list[int] = []

    def convert(topic: str, receive_ns: int, msg) -> None:
        if topic == plan.odometry:
            pose = _planar(msg.pose.pose.position, msg.pose.pose.orientation)
            stamps, poses = odometry.setdefault((_frame(msg.header.frame_id), _frame(msg.child_frame_id)), ([], []))
            stamps.append(_stamp(msg.header, receive_ns))
            poses.append(pose)
            last_good.append(stamps[-1])
            return
        links = [(_stamp(tr.header, receive_ns), _frame(tr.header.frame_id), _frame(tr.child_frame_id),
                  _planar(tr.transform.translation, tr.transform.rotation)) for tr in msg.transforms]
        for stamp, parent, child, pose in links:  # all or none: a message with a bad transform is skipped whole
            if topic.endswith("tf_static"):
                static[child] = (parent, pose)
            else:
                ts, ps = moving.setdefault((parent, child), ([], []))
                ts.append(stamp)
                ps.append(pose)
            last_good.append(stamp)

    faults.done = 0
    for _ in read_messages(path, fmt, plan.msgtypes, readable, faults, convert):
        faults.done += 1
    tree = FrameTree()
    for child, (parent, pose) in static.items():
        tree.add_static(parent, child, pose)
    by_child: dict[str, tuple[str, list, list]] = {}
    for (parent, child), (ts, ps) in moving.items():  # a child with several parents: the one it has most
        if child not in by_child or len(ts) > len(by_child[child][1]):
            by_child[child] = (parent, ts, ps)
    for child, (parent, ts, ps) in by_child.items():
        tree.add_track(parent, child, PoseTrack.from_samples(ts, ps))
    odom = None
    if odometry:
        (parent, child), (ts, ps) = max(odometry.items(), key=lambda kv: len(kv[1][0]))
        odom = (parent, child, PoseTrack.from_samples(ts, ps))
    last = int(np.max(last_good)) if last_good else None
    return BagPoses(plan, tree, odom, faults, last)
