"""The laser scan model every other part of labkit consumes.

A :class:`Scan` is one sweep of a planar range finder: a range per beam, the beam's
angle in the sensor frame, and the limits that say which readings are real returns.
Invalid readings (NaN, inf, zero, negative, outside the range limits, the "no return"
max-range value) are *data*: they stay in :attr:`Scan.ranges` and are masked by
:attr:`Scan.valid`, never raised. Only a malformed scan (lengths that disagree,
angles that do not increase, negative limits) is an error.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

__all__ = ["Scan", "polar_to_cartesian"]


def polar_to_cartesian(ranges, angles) -> np.ndarray:
    """Convert beams ``(range, angle)`` to points ``(x, y)`` in the sensor frame.

    Parameters
    ----------
    ranges : array_like of shape (N,)
        Ranges, metres.
    angles : array_like of shape (N,)
        Bearings, radians, counter-clockwise from the sensor's x axis.

    Returns
    -------
    ndarray of shape (N, 2), float64
        ``x = r cos(theta)``, ``y = r sin(theta)``. No masking: invalid ranges give
        non-finite or meaningless points; use :attr:`Scan.xy` for the valid ones.

    Examples
    --------
    >>> polar_to_cartesian([1.0, 2.0], [0.0, np.pi / 2]).round(12)
    array([[1., 0.],
           [0., 2.]])
    """
    r = np.asarray(ranges, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64)
    if r.shape != a.shape:
        raise ValueError(f"ranges and angles must have the same shape, got {r.shape} and {a.shape}")
    with np.errstate(invalid="ignore"):
        return np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)


def _as_1d_float(name: str, values) -> np.ndarray:
    try:
        arr = np.array(values, dtype=np.float64)  # a copy: the scan owns its arrays
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a sequence of numbers: {exc}") from None
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    arr.setflags(write=False)
    return arr


def _as_ns(name: str, value) -> int:
    try:
        return int(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be an integer (nanoseconds), got {value!r}") from None


def _as_limit(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if np.isnan(v) or v < 0:
        raise ValueError(f"{name} must be >= 0 (metres), got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Scan:
    """One planar laser scan.

    Parameters
    ----------
    ranges : array_like of shape (N,), metres
        One reading per beam. NaN, inf, zero, negative and out-of-limit readings are
        kept and masked by :attr:`valid`.
    angles : array_like of shape (N,), radians
        Beam angles in the sensor frame, strictly increasing. A full-circle scan spans at most 2 pi.
    range_min, range_max : float, metres
        Readings ``r`` with ``range_min <= r < range_max`` are returns. A reading equal to
        (or beyond) ``range_max`` is the sensor's "no return" value and is invalid, as in
        ROS (REP 117) and CARMEN logs. Defaults: 0 and infinity.
    stamp_ns : int
        Time stamp, integer nanoseconds (ROS time). Default 0.
    frame_id : str
        Sensor frame name. Default ``"laser"``.
    intensities : array_like of shape (N,) or None
        Optional per-beam intensities, carried through I/O unchanged.
    pose : (x, y, theta) or None
        The sensor's pose in a world frame when the source knows it (CARMEN logs record
        it; the simulator knows it exactly). Metres and radians.
    receive_ns : int or None
        When the recorder received the scan (a bag's receive/log time, a CARMEN log's
        ``logger_timestamp``), integer nanoseconds; None when the source does not say.
        ``stamp_ns`` is the sensor's own time stamp (the message header).
    time_increment, scan_time : float, seconds
        As in ``sensor_msgs/LaserScan``: time between beams and between scans (0 when
        unknown), carried through I/O unchanged.

    Examples
    --------
    >>> s = Scan(ranges=[1.0, np.nan, 2.0, 30.0], angles=[0.0, 0.1, 0.2, 0.3], range_max=30.0)
    >>> s.valid
    array([ True, False,  True, False])
    >>> s.valid_indices
    array([0, 2])
    >>> s.xy.shape
    (2, 2)
    """

    ranges: np.ndarray
    angles: np.ndarray
    range_min: float = 0.0
    range_max: float = float("inf")
    stamp_ns: int = 0
    frame_id: str = "laser"
    intensities: np.ndarray | None = field(default=None, repr=False)
    pose: tuple[float, float, float] | None = None
    receive_ns: int | None = field(default=None, repr=False)
    time_increment: float = field(default=0.0, repr=False)
    scan_time: float = field(default=0.0, repr=False)

    def __post_init__(self) -> None:
        ranges = _as_1d_float("ranges", self.ranges)
        angles = _as_1d_float("angles", self.angles)
        if ranges.shape != angles.shape:
            raise ValueError(
                f"ranges and angles must have the same length, got {ranges.size} and {angles.size}"
            )
        if not np.all(np.isfinite(angles)):
            raise ValueError("angles must be finite (radians)")
        if angles.size > 1 and not np.all(np.diff(angles) > 0):
            bad = int(np.argmin(np.diff(angles) > 0))
            raise ValueError(
                f"angles must be strictly increasing, but angles[{bad + 1}] = {float(angles[bad + 1]):g}"
                f" <= angles[{bad}] = {float(angles[bad]):g}"
            )
        if angles.size > 1 and angles[-1] - angles[0] > 2 * np.pi + 1e-6:
            raise ValueError(
                f"angles must span at most 2 pi, got {float(angles[-1] - angles[0]):g} rad"
            )
        range_min = _as_limit("range_min", self.range_min)
        range_max = _as_limit("range_max", self.range_max)
        if not range_max > range_min:
            raise ValueError(f"range_max must be > range_min, got {range_max:g} <= {range_min:g}")
        stamp_ns = _as_ns("stamp_ns", self.stamp_ns)
        receive_ns = None if self.receive_ns is None else _as_ns("receive_ns", self.receive_ns)
        timing = []
        for name in ("time_increment", "scan_time"):
            try:
                value = float(getattr(self, name))
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be a number (seconds), got {getattr(self, name)!r}") from None
            timing.append(value)
        if not isinstance(self.frame_id, str):
            raise ValueError(f"frame_id must be a string, got {type(self.frame_id).__name__}")
        intensities = self.intensities
        if intensities is not None:
            intensities = _as_1d_float("intensities", intensities)
            if intensities.shape != ranges.shape:
                raise ValueError(
                    f"intensities must have one value per beam ({ranges.size}), got {intensities.size}"
                )
        pose = self.pose
        if pose is not None:
            try:
                numbers = tuple(float(v) for v in pose)
            except (TypeError, ValueError):
                raise ValueError(f"pose must be (x, y, theta), got {self.pose!r}") from None
            if len(numbers) != 3 or not all(np.isfinite(numbers)):
                raise ValueError(f"pose must be three finite numbers (x, y, theta), got {self.pose!r}")
            pose = (numbers[0], numbers[1], numbers[2])
        for name, checked in [
            ("ranges", ranges),
            ("angles", angles),
            ("range_min", range_min),
            ("range_max", range_max),
            ("stamp_ns", stamp_ns),
            ("intensities", intensities),
            ("pose", pose),
            ("receive_ns", receive_ns),
            ("time_increment", timing[0]),
            ("scan_time", timing[1]),
        ]:
            object.__setattr__(self, name, checked)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_angle_increment(
        cls, ranges, angle_min: float, angle_increment: float, **kwargs: Any
    ) -> Scan:
        """Build a scan whose beam ``i`` points at ``angle_min + i * angle_increment``.

        A negative ``angle_increment`` (a sensor sweeping clockwise) is accepted: the
        beams are reversed so that angles increase, and beam index 0 is then the
        beam at the smallest angle. Other keyword arguments go to :class:`Scan`.

        >>> Scan.from_angle_increment([1.0, 1.0, 1.0], -0.1, 0.1).angles.round(3)
        array([-0.1,  0. ,  0.1])
        """
        r = _as_1d_float("ranges", ranges)
        try:
            a0, da = float(angle_min), float(angle_increment)
        except (TypeError, ValueError):
            raise ValueError("angle_min and angle_increment must be numbers (radians)") from None
        if not np.isfinite(a0):
            raise ValueError(f"angle_min must be finite, got {float(angle_min):g}")
        if not np.isfinite(da) or da == 0:
            raise ValueError(f"angle_increment must be finite and non-zero, got {float(angle_increment):g}")
        with np.errstate(over="ignore", invalid="ignore"):
            angles = a0 + da * np.arange(r.size)
        if not np.all(np.isfinite(angles)):
            raise ValueError(
                f"angle_min + i * angle_increment overflows for {r.size} beams "
                f"(angle_min={a0:g}, angle_increment={da:g}); the angles must be finite radians"
            )
        intensities = kwargs.pop("intensities", None)
        if da < 0:
            r, angles = r[::-1], angles[::-1]
            if intensities is not None:
                intensities = np.asarray(intensities)[::-1]
        return cls(ranges=r, angles=angles, intensities=intensities, **kwargs)

    @classmethod
    def from_ros(cls, msg: Any, *, pose=None, receive_ns: int | None = None) -> Scan:
        """Build a scan from a ``sensor_msgs/LaserScan`` message (ROS1 or ROS2).

        Any object with the message's fields works (a rosbags message, a rospy or rclpy
        message). ``header.stamp`` becomes ``stamp_ns``; ROS1 stamps (``secs``/``nsecs``)
        and ROS2 stamps (``sec``/``nanosec``) are both understood. Empty intensities
        become ``None``. ``receive_ns`` is the bag's receive time, when known.
        """
        try:
            header = msg.header
            stamp = header.stamp
            sec = getattr(stamp, "sec", None)
            if sec is None:
                sec = stamp.secs
            nsec = getattr(stamp, "nanosec", None)
            if nsec is None:
                nsec = stamp.nsecs
            ranges = msg.ranges
            intensities = msg.intensities if len(msg.intensities) else None
            angle_min, angle_increment = msg.angle_min, msg.angle_increment
            range_min, range_max = msg.range_min, msg.range_max
            frame_id = header.frame_id
            timing = {k: getattr(msg, k, 0.0) for k in ("time_increment", "scan_time")}
        except AttributeError as exc:
            raise ValueError(f"msg is not a sensor_msgs/LaserScan message: {exc}") from None
        if intensities is not None and len(intensities) != len(ranges):
            intensities = None  # some drivers publish a stale or partial intensity array
        return cls.from_angle_increment(
            ranges,
            angle_min,
            angle_increment,
            range_min=range_min,
            range_max=range_max,
            stamp_ns=int(sec) * 1_000_000_000 + int(nsec),
            frame_id=frame_id,
            intensities=intensities,
            pose=pose,
            receive_ns=receive_ns,
            **timing,
        )

    # ------------------------------------------------------------------ derived data
    @property
    def n_beams(self) -> int:
        """Number of beams N, valid or not."""
        return int(self.ranges.size)

    def __len__(self) -> int:
        return self.n_beams

    @cached_property
    def valid(self) -> np.ndarray:
        """Boolean mask of shape (N,): finite, > 0 and ``range_min <= r < range_max``."""
        if (fast := _engine_beams(self)) is not None:
            return fast[0]
        r = self.ranges
        with np.errstate(invalid="ignore"):
            mask = np.isfinite(r) & (r > 0) & (r >= self.range_min) & (r < self.range_max)
        mask.setflags(write=False)
        return mask

    @cached_property
    def valid_indices(self) -> np.ndarray:
        """Beam indices of the valid beams, shape (M,), increasing; row ``k`` of
        :attr:`xy` is beam ``valid_indices[k]``."""
        idx = np.flatnonzero(self.valid)
        idx.setflags(write=False)
        return idx

    @cached_property
    def xy(self) -> np.ndarray:
        """Points of the valid beams, shape (M, 2), metres, in the sensor frame."""
        idx = self.valid_indices
        pts = polar_to_cartesian(self.ranges[idx], self.angles[idx])
        pts.setflags(write=False)
        return pts

    @cached_property
    def points(self) -> np.ndarray:
        """Every beam's point, shape (N, 2), metres; rows of invalid beams are NaN.

        Row ``i`` is beam ``i``, which keeps neighbourhoods in beam order.
        """
        if (fast := _engine_beams(self)) is not None:
            return fast[1]
        pts = polar_to_cartesian(self.ranges, self.angles)
        pts[~self.valid] = np.nan
        pts.setflags(write=False)
        return pts

    @property
    def angle_min(self) -> float:
        return float(self.angles[0]) if self.n_beams else float("nan")

    @property
    def angle_max(self) -> float:
        return float(self.angles[-1]) if self.n_beams else float("nan")

    @property
    def angle_increment(self) -> float:
        """Mean angular step between beams (radians); NaN for fewer than 2 beams."""
        if self.n_beams < 2:
            return float("nan")
        return float((self.angles[-1] - self.angles[0]) / (self.n_beams - 1))

    @property
    def is_full_circle(self) -> bool:
        """True when the beams cover the whole circle, so that the last beam is the
        first beam's neighbour (within half a step)."""
        if self.n_beams < 3:
            return False
        span = self.angles[-1] - self.angles[0]
        return bool(span + 1.5 * self.angle_increment >= 2 * np.pi)

    @property
    def stamp_s(self) -> float:
        """Time stamp in seconds (float)."""
        return self.stamp_ns * 1e-9

    def replace(self, **changes: Any) -> Scan:
        """A copy with some fields replaced (validated again)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise ValueError(f"unknown Scan fields: {sorted(unknown)}")
        return dataclasses.replace(self, **changes)

    def __repr__(self) -> str:
        n_valid = int(self.valid.sum())
        span = np.degrees(self.angle_max - self.angle_min) if self.n_beams else 0.0
        return (
            f"Scan({self.n_beams} beams, {n_valid} valid, {span:.1f} deg, "
            f"range {self.range_min:g}..{self.range_max:g} m, stamp_ns={self.stamp_ns}, "
            f"frame_id={self.frame_id!r})"
        )


def _engine_beams(scan: Scan) -> tuple[np.ndarray, np.ndarray] | None:
    """:attr:`Scan.valid` and :attr:`Scan.points` in one compiled pass
    (``labkit._segmentation_engine.beams``: the same comparisons, the same C library ``cos`` and
    ``sin`` as numpy's, bit for bit, ``tests/test_engine.py``), both kept in the scan's cache; once
    a first extraction has loaded the engines (a process that only reads scans never imports
    numba for this). None before that, under ``LABKIT_NO_JIT=1``, and for arrays a Scan did not make
    read-only (an unpickled one's)."""
    engine = sys.modules.get("labkit._segmentation_engine")
    r, a = scan.ranges, scan.angles
    if engine is None or r.flags.writeable or a.flags.writeable:  # (the kind of array compiled for: a Scan's own)
        return None
    valid, points = engine.beams(scan.ranges, scan.angles, float(scan.range_min), float(scan.range_max))
    valid.setflags(write=False)
    points.setflags(write=False)
    cache = scan.__dict__
    return cache.setdefault("valid", valid), cache.setdefault("points", points)
