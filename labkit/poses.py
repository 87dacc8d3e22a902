"""Poses in the plane: SE(2) composition, interpolation in time, frame trees, map thinning.

A pose ``(x, y, theta)`` (metres, metres, radians) places a frame in its parent: a point
``p`` of the frame is ``R(theta) p + (x, y)`` in the parent (:func:`labkit.geometry.transform_points`).
:attr:`labkit.Scan.pose` is the sensor's pose in a world frame (``map`` or ``odom``), so a
scan's points in the world are ``transform_points(scan.xy, scan.pose)``.

Recordings store poses at their own times (odometry at 50 Hz, tf at 100 Hz, a CARMEN log
beside each scan); :class:`PoseTrack` gives the pose at a scan's stamp by the rule of
:func:`interpolate_poses`:

1. between two poses at most ``max_gap_ns`` apart: linear in x and y, and in theta along the
   shorter way round the circle;
2. else, the nearest pose if it is at most ``tolerance_ns`` away (a scan just before the first
   or just after the last pose, or beside a gap in the poses);
3. else no pose (NaN, or ``None`` from :meth:`PoseTrack.at`): labkit never extrapolates further.

:class:`FrameTree` chains transforms as ROS's tf does (each frame has one parent; an edge is
static or a track over time) and gives a frame's pose in any of its ancestors.
:class:`GridThinning` keeps one point per grid cell, so that a map accumulated from thousands
of scans stays small (the rerun map view).

This module is an algorithm module: it imports numpy and labkit's model only.
"""

from __future__ import annotations

import bisect
import math
from array import array
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .geometry import wrap_angle

__all__ = [
    "DEFAULT_TOLERANCE_NS",
    "DEFAULT_MAX_GAP_NS",
    "compose",
    "inverse",
    "yaw_from_quaternion",
    "quaternion_from_yaw",
    "interpolate_poses",
    "PoseTrack",
    "FrameTree",
    "GridThinning",
]

#: A scan this close (ns) to a pose, but not between two poses, takes that pose (0.1 s).
DEFAULT_TOLERANCE_NS = 100_000_000
#: Two poses further apart than this (ns) are not interpolated between (1 s).
DEFAULT_MAX_GAP_NS = 1_000_000_000


def _as_poses(name: str, poses) -> np.ndarray:
    p = np.asarray(poses, dtype=np.float64)
    if p.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (3,) or (N, 3): (x, y, theta), got {p.shape}")
    return p


def compose(a, b) -> np.ndarray:
    """The pose ``a ∘ b``: frame ``b`` (given in frame ``a``) in ``a``'s parent.

    Parameters
    ----------
    a, b : array_like of shape (3,) or (N, 3)
        Poses ``(x, y, theta)``, metres and radians; broadcast against each other.

    Returns
    -------
    ndarray of shape (3,) or (N, 3)
        Theta wrapped to (-pi, pi].

    Examples
    --------
    >>> compose([1.0, 0.0, np.pi / 2], [1.0, 0.0, 0.0]).round(12)
    array([1.        , 1.        , 1.57079633])
    """
    a, b = _as_poses("a", a), _as_poses("b", b)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a) -> np.ndarray:
    """The pose ``a⁻¹`` with ``compose(a, inverse(a)) == (0, 0, 0)``; shape as ``a``.

    Parameters
    ----------
    a : array_like of shape (3,) or (N, 3)
        Poses ``(x, y, theta)``.

    Returns
    -------
    ndarray
        The inverse poses, the shape of ``a``.
    """
    a = _as_poses("a", a)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], wrap_angle(-a[..., 2])], axis=-1)


def yaw_from_quaternion(x, y, z, w):
    """The rotation about z (radians, (-pi, pi]) of a unit quaternion.

    The rotation about z (radians, (-pi, pi]) of a unit quaternion: the heading of a 3D orientation
    projected onto the plane (roll and pitch are dropped).

    Parameters
    ----------
    x, y, z, w : float or ndarray
        The quaternion.

    Returns
    -------
    float or ndarray
        The yaw, radians in (-pi, pi].
    """
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_from_yaw(theta: float) -> tuple[float, float, float, float]:
    """The unit quaternion ``(x, y, z, w)`` of a rotation by ``theta`` radians about z.

    Parameters
    ----------
    theta : float
        The yaw, radians.

    Returns
    -------
    tuple of float
        ``(x, y, z, w)``.
    """
    return 0.0, 0.0, float(np.sin(theta / 2.0)), float(np.cos(theta / 2.0))


def interpolate_poses(stamps_ns, poses, at_ns, *, tolerance_ns: int = DEFAULT_TOLERANCE_NS,
                      max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> np.ndarray:
    """Poses at the times ``at_ns`` from poses known at ``stamps_ns`` (rule in the module docstring).

    Parameters
    ----------
    stamps_ns : array_like of shape (M,), int, nanoseconds
        Strictly increasing.
    poses : array_like of shape (M, 3)
        ``(x, y, theta)`` at each stamp.
    at_ns : array_like of shape (N,), int, nanoseconds
        The times asked for.
    tolerance_ns, max_gap_ns : int, nanoseconds
        See the module docstring.

    Returns
    -------
    ndarray of shape (N, 3)
        NaN rows where there is no pose. A time equal to a stamp gets that pose exactly.

    Examples
    --------
    >>> interpolate_poses([0, 10], [[0.0, 0.0, 3.0], [1.0, 2.0, -3.0]], [2, 10**9]).round(6)  # the short way round
    array([[0.2     , 0.4     , 3.056637],
           [     nan,      nan,      nan]])
    """
    t = np.asarray(stamps_ns, dtype=np.int64)
    p = _as_poses("poses", poses).reshape(-1, 3)
    q = np.atleast_1d(np.asarray(at_ns, dtype=np.int64))
    if t.ndim != 1 or len(t) != len(p):
        raise ValueError(f"stamps_ns must have shape (M,) with one stamp per pose, got {t.shape} and {p.shape}")
    if len(t) > 1 and not np.all(np.diff(t) > 0):
        raise ValueError("stamps_ns must be strictly increasing")
    out = np.full((len(q), 3), np.nan)
    if len(t) == 0:
        return out
    i = np.searchsorted(t, q, side="right") - 1  # the last pose at or before each time
    inside = (i >= 0) & (i < len(t) - 1)
    lo, hi = np.clip(i, 0, len(t) - 1), np.clip(i + 1, 0, len(t) - 1)
    gap = t[hi] - t[lo]
    between = inside & (gap <= max_gap_ns)
    if np.any(between):
        k = np.flatnonzero(between)
        u = ((q[k] - t[lo[k]]) / gap[k].astype(np.float64))[:, None]
        a, b = p[lo[k]], p[hi[k]]
        xy = a[:, :2] + u * (b[:, :2] - a[:, :2])
        theta = np.where(u[:, 0] == 0, a[:, 2], wrap_angle(a[:, 2] + u[:, 0] * wrap_angle(b[:, 2] - a[:, 2])))
        out[k] = np.column_stack([xy, theta])
    exact = (i >= 0) & (t[lo] == q)  # a stamp of the track: its own pose, however far its neighbours
    out[exact] = p[lo[exact]]
    rest = np.flatnonzero(~between & ~exact)
    if len(rest):
        before = np.where(i[rest] >= 0, q[rest] - t[lo[rest]], np.iinfo(np.int64).max)
        after = np.where(i[rest] + 1 < len(t), t[np.clip(i[rest] + 1, 0, len(t) - 1)] - q[rest],
                         np.iinfo(np.int64).max)
        nearest = np.where(before <= after, lo[rest], np.clip(i[rest] + 1, 0, len(t) - 1))
        close = np.minimum(before, after) <= tolerance_ns
        out[rest[close]] = p[nearest[close]]
    return out


@dataclass(frozen=True, eq=False)
class PoseTrack:
    """Poses of one frame over time, ready to interpolate.

    Build one with :meth:`from_samples`, which sorts the samples and keeps the last of equal stamps.

    Parameters
    ----------
    stamps_ns : ndarray of shape (M,), int64
        Strictly increasing.
    poses : ndarray of shape (M, 3)
        ``(x, y, theta)``.

    Examples
    --------
    >>> track = PoseTrack.from_samples([20, 0, 10], [[2.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    >>> track.at(15)
    (1.5, 0.0, 0.0)
    >>> track.at(10**9) is None
    True
    """

    stamps_ns: np.ndarray
    poses: np.ndarray

    @classmethod
    def from_samples(cls, stamps_ns, poses) -> PoseTrack:
        t = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
        p = _as_poses("poses", poses).reshape(-1, 3)
        if len(t) != len(p):
            raise ValueError(f"one stamp per pose: got {len(t)} stamps and {len(p)} poses")
        good = np.all(np.isfinite(p), axis=1)
        t, p = t[good], p[good]
        order = np.argsort(t, kind="stable")
        t, p = t[order], p[order]
        if len(t) > 1:
            last = np.append(t[1:] != t[:-1], True)  # the last sample of every stamp
            t, p = t[last], p[last]
        t.setflags(write=False)
        p.setflags(write=False)
        return cls(t, p)

    def __len__(self) -> int:
        return len(self.stamps_ns)

    def at_many(self, at_ns, *, tolerance_ns: int = DEFAULT_TOLERANCE_NS,
                max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> np.ndarray:
        """Poses (N, 3) at the times ``at_ns`` (N,), NaN rows where there is none."""
        return interpolate_poses(self.stamps_ns, self.poses, at_ns, tolerance_ns=tolerance_ns, max_gap_ns=max_gap_ns)

    @cached_property
    def _lists(self) -> tuple[array, array]:
        # flat machine arrays, 32 bytes a pose: bisect reads them as Python ints and floats, fast, where a
        # list of tuples costs some 190 bytes a pose (a 100,000-scan recording's odometry: 18 MiB)
        return array("q", self.stamps_ns.tobytes()), array("d", self.poses.tobytes())

    def _pose(self, i: int) -> tuple[float, float, float]:
        p = self._lists[1]
        return p[3 * i], p[3 * i + 1], p[3 * i + 2]

    def at(self, stamp_ns: int, *, tolerance_ns: int = DEFAULT_TOLERANCE_NS,
           max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> tuple[float, float, float] | None:
        """The pose at one time, or None (see the module docstring). The same numbers as
        :meth:`at_many`, with plain floats (a reader asks once per scan: 2 us, not 400)."""
        t = self._lists[0]
        q = int(stamp_ns)
        i = bisect.bisect_right(t, q) - 1
        if i >= 0 and t[i] == q:
            return self._pose(i)
        if 0 <= i < len(t) - 1 and t[i + 1] - t[i] <= max_gap_ns:
            (x0, y0, a0), (x1, y1, a1) = self._pose(i), self._pose(i + 1)
            u = (q - t[i]) / float(t[i + 1] - t[i])
            return x0 + u * (x1 - x0), y0 + u * (y1 - y0), float(wrap_angle(a0 + u * wrap_angle(a1 - a0)))
        before = q - t[i] if i >= 0 else math.inf
        after = t[i + 1] - q if i + 1 < len(t) else math.inf
        if min(before, after) > tolerance_ns:
            return None
        return self._pose(i) if before <= after else self._pose(i + 1)


@dataclass
class FrameTree:
    """Frames linked as in ROS tf: each frame has one parent, through a static pose or a pose track.

    The parent's link is a static pose or a :class:`PoseTrack` over time.

    ``add_static(parent, child, pose)`` and ``add_track(parent, child, track)`` link a child
    to its parent (a later link of the same child replaces an earlier one; a frame with both a
    static and a moving link uses the moving one). :meth:`chain` walks from a frame up to
    its root; :meth:`pose_in` composes the links at a time.

    Parameters
    ----------
    static : dict of str to tuple of (str, tuple of (float, float, float))
        Child frame -> its parent and its static pose ``(x, y, theta)`` in it; empty by default.
    tracks : dict of str to tuple of (str, PoseTrack)
        Child frame -> its parent and its poses in it over time; empty by default.

    Examples
    --------
    >>> tree = FrameTree()
    >>> tree.add_static("base_link", "laser", (0.2, 0.0, 0.0))
    >>> tree.add_track("odom", "base_link", PoseTrack.from_samples([0, 10], [[0.0, 0, 0], [1.0, 0, 0]]))
    >>> tree.root("laser"), tree.moves("laser", "odom")
    ('odom', True)
    >>> tree.pose_in("laser", "odom", 5)
    (0.7, 0.0, 0.0)
    """

    static: dict[str, tuple[str, tuple[float, float, float]]] = field(default_factory=dict)
    tracks: dict[str, tuple[str, PoseTrack]] = field(default_factory=dict)

    def add_static(self, parent: str, child: str, pose) -> None:
        values = tuple(float(v) for v in _as_poses("pose", pose))
        self.static[child] = (parent, (values[0], values[1], values[2]))

    def add_track(self, parent: str, child: str, track: PoseTrack) -> None:
        self.tracks[child] = (parent, track)

    def parent(self, frame: str) -> str | None:
        if frame in self.tracks:
            return self.tracks[frame][0]
        return self.static[frame][0] if frame in self.static else None

    def chain(self, frame: str) -> list[str]:
        """``[frame, its parent, ..., the root]`` (a loop in the links ends the walk)."""
        out = [frame]
        while (up := self.parent(out[-1])) is not None and up not in out:
            out.append(up)
        return out

    def root(self, frame: str) -> str:
        """The topmost ancestor of ``frame`` (``frame`` itself when it has no parent)."""
        return self.chain(frame)[-1]

    def moves(self, frame: str, ancestor: str) -> bool:
        """Whether a link between ``frame`` and ``ancestor`` is a track (changes over time)."""
        chain = self.chain(frame)
        if ancestor not in chain:
            return False
        return any(f in self.tracks for f in chain[: chain.index(ancestor)])

    def pose_in(self, frame: str, ancestor: str, stamp_ns: int, *, tolerance_ns: int = DEFAULT_TOLERANCE_NS,
                max_gap_ns: int = DEFAULT_MAX_GAP_NS) -> tuple[float, float, float] | None:
        """The pose of ``frame`` in ``ancestor`` at ``stamp_ns``; None when ``ancestor`` is not
        above ``frame`` or a moving link has no pose then (:meth:`PoseTrack.at`)."""
        chain = self.chain(frame)
        if ancestor not in chain:
            return None
        pose = np.zeros(3)
        for f in chain[: chain.index(ancestor)]:  # child to parent: pose = link ∘ pose
            if f in self.tracks:
                link = self.tracks[f][1].at(stamp_ns, tolerance_ns=tolerance_ns, max_gap_ns=max_gap_ns)
                if link is None:
                    return None
            else:
                link = self.static[f][1]
            pose = compose(link, pose)
        return float(pose[0]), float(pose[1]), float(pose[2])


class GridThinning:
    """Keep one point per square cell of a grid, over many calls.

    A map accumulated from many scans so holds each patch of wall once.

    Parameters
    ----------
    cell_m : float, metres
        Side of a cell (> 0).

    Examples
    --------
    >>> thin = GridThinning(0.1)
    >>> thin.new(np.array([[0.01, 0.0], [0.02, 0.01], [0.5, 0.5]])).tolist()
    [True, False, True]
    >>> thin.new(np.array([[0.03, 0.03], [1.0, 1.0]])).tolist(), len(thin)
    ([False, True], 3)
    """

    def __init__(self, cell_m: float) -> None:
        if not cell_m > 0:
            raise ValueError(f"cell_m must be > 0 (metres), got {cell_m!r}")
        self.cell_m = float(cell_m)
        self._seen: set[int] = set()

    def __len__(self) -> int:
        return len(self._seen)

    def new(self, points) -> np.ndarray:
        """Mask (N,) of the points ``(N, 2)`` that fall in a cell no earlier point fell in
        (the first point of each new cell); their cells count as seen from now on."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        mask = np.zeros(len(pts), dtype=bool)
        finite = np.flatnonzero(np.all(np.isfinite(pts), axis=1))
        if not len(finite):
            return mask
        cells = np.floor(pts[finite] / self.cell_m).astype(np.int64)
        keys = (cells[:, 0] << 32) ^ (cells[:, 1] & 0xFFFFFFFF)
        _, first = np.unique(keys, return_index=True)
        for j in np.sort(first):
            key = int(keys[j])
            if key not in self._seen:
                self._seen.add(key)
                mask[finite[j]] = True
        return mask
