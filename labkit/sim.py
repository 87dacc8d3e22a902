"""A 2D laser scan simulator with exact ground truth.

The simulator ray-casts a planar lidar into a *world* of wall segments, arcs (rounded
corners) and circles (columns, bench legs), plus moving objects: a rolling cylinder and
walking people whose two legs alternate like a real gait. For every scan it also returns
what the scan *should* contain: which object each beam hit, the visible portion of every
wall as a segment with its normal-form line ``(r, alpha)`` in the sensor frame, the
visible circles and arcs, the people's legs and the sensor pose. That ground truth is
what labkit's tests and evaluation compare extractors against.

Everything is deterministic for a given seed: noise and dropouts come from one
``numpy.random.Generator`` per run, drawn in a fixed order.

Quick start
-----------
>>> from labkit import sim
>>> scenario = sim.scenario("hall")
>>> scan, truth = next(iter(sim.simulate(scenario, seed=0)))
>>> scan.n_beams, len(truth.walls) > 0
(361, True)
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ._safe import OutputKind, first_json_line_with, safe_output
from .geometry import line_through_points, wrap_angle
from .scan import Scan

__all__ = [
    "Wall",
    "Arc",
    "Circle",
    "PathSpec",
    "RollingCylinder",
    "Person",
    "World",
    "Lidar",
    "LIDARS",
    "Trajectory",
    "Scenario",
    "VisibleWall",
    "VisibleCircle",
    "VisibleArc",
    "VisibleLeg",
    "ScanTruth",
    "GroundTruth",
    "WORLDS",
    "make_world",
    "random_polygons",
    "scenario",
    "simulate",
    "scan_at",
    "write_truth",
    "read_truth",
    "truth_path_for",
]

#: Time stamp of the first simulated scan: 2025-01-01T00:00:00Z, in nanoseconds.
EPOCH_NS = 1_735_689_600 * 1_000_000_000

_ROUND = 6  # decimals kept in ground-truth files (micrometres, micro-radians)


# ============================================================================ world
@dataclass(frozen=True)
class Wall:
    """A wall: the line segment from ``start`` to ``end`` (metres, world frame)."""

    start: tuple[float, float]
    end: tuple[float, float]
    name: str = ""


@dataclass(frozen=True)
class Arc:
    """An arc of a circle, e.g. a rounded wall corner.

    The arc covers the directions (seen from ``center``) from ``start_angle``
    counter-clockwise to ``end_angle`` (radians). It reflects from both sides.
    """

    center: tuple[float, float]
    radius: float
    start_angle: float
    end_angle: float
    name: str = ""


@dataclass(frozen=True)
class Circle:
    """A solid circle: a column, one foot of a bench, a box seen round.

    ``kind`` is a free label carried into the ground truth (``"column"``, ``"bench"``).
    """

    center: tuple[float, float]
    radius: float
    kind: str = "column"
    name: str = ""


@dataclass(frozen=True)
class PathSpec:
    """A polyline path for moving objects, walked at constant speed.

    ``mode="loop"`` closes the polyline and goes round; ``mode="bounce"`` walks to the
    end and back.
    """

    waypoints: tuple[tuple[float, float], ...]
    mode: str = "loop"

    def __post_init__(self) -> None:
        if len(self.waypoints) < 2:
            raise ValueError("waypoints must hold at least two points")
        if self.mode not in ("loop", "bounce"):
            raise ValueError(f"mode must be 'loop' or 'bounce', got {self.mode!r}")

    def _vertices(self) -> np.ndarray:
        pts = np.asarray(self.waypoints, dtype=np.float64)
        return np.vstack([pts, pts[:1]]) if self.mode == "loop" else pts

    @property
    def length(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self._vertices(), axis=0), axis=1)))

    def at(self, s: float, *, walking: bool = True) -> tuple[np.ndarray, float]:
        """Position (2,) and heading (radians) after walking ``s`` metres from the start.

        The heading is the walking direction; with ``walking=False`` it is the direction of
        the polyline itself (which does not turn round when a bounce path does).
        """
        verts = self._vertices()
        seg = np.diff(verts, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        total = lengths.sum()
        direction = 1.0
        if self.mode == "loop":
            s = s % total
        else:
            s = s % (2 * total)
            if s > total:
                s, direction = 2 * total - s, -1.0
        cum = np.concatenate([[0.0], np.cumsum(lengths)])
        k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1))
        u = (s - cum[k]) / lengths[k]
        pos = verts[k] + u * seg[k]
        if not walking:
            direction = 1.0
        heading = np.arctan2(direction * seg[k, 1], direction * seg[k, 0])
        return pos, float(heading)


@dataclass(frozen=True)
class RollingCylinder:
    """A cylinder pulled along a path at ``speed_mps`` (Xavier et al.'s mobile cylinder)."""

    radius: float
    path: PathSpec
    speed_mps: float
    name: str = "cylinder"
    start_offset_m: float = 0.0

    def center_at(self, t: float) -> np.ndarray:
        return self.path.at(self.start_offset_m + self.speed_mps * t)[0]


@dataclass(frozen=True)
class Person:
    """A person walking along a path; the laser sees two legs at knee height.

    Gait model: footfalls are ``step_length_m`` apart along the path, alternating
    between the two sides of the path at ``+-leg_separation_m / 2`` from it. While the
    body covers one step, the stance leg stays planted and the swing leg moves from its
    last footfall to the next at twice the walking speed, so the legs alternate as in real
    walking. Each leg keeps to its side of the path, also on the way back of a bounce
    path, so the legs never cross.
    """

    path: PathSpec
    speed_mps: float = 1.0
    leg_diameter_m: float = 0.14
    leg_separation_m: float = 0.25
    step_length_m: float = 0.4
    name: str = "person"
    start_offset_m: float = 0.0

    def __post_init__(self) -> None:
        if not 0.1 <= self.leg_diameter_m <= 0.25:
            raise ValueError(f"leg_diameter_m must be within 0.1-0.25 m, got {self.leg_diameter_m}")
        if self.leg_separation_m <= self.leg_diameter_m:
            raise ValueError("leg_separation_m must exceed leg_diameter_m (legs would overlap)")

    def _foot(self, s: float, side: float) -> np.ndarray:
        """A foot at ``s`` metres along the path, on the given side of it."""
        pos, heading = self.path.at(max(s, 0.0), walking=False)  # no footfalls before the start
        normal = np.array([-np.sin(heading), np.cos(heading)])
        return pos + side * 0.5 * self.leg_separation_m * normal

    def legs_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres (2,) of the left and right leg at time ``t`` seconds."""
        s = self.start_offset_m + self.speed_mps * t
        step = self.step_length_m
        k = int(np.floor(s / step + 0.5))  # the footfall the body is passing over
        u = s / step + 0.5 - k  # progress of the current step in [0, 1)
        stance_side = 1.0 if k % 2 == 0 else -1.0
        stance = self._foot(k * step, stance_side)
        # the swing leg travels along the path (not across a corner) from footfall k-1 to k+1
        swing = self._foot((k - 1 + 2 * u) * step, -stance_side)
        return (stance, swing) if stance_side > 0 else (swing, stance)

    def center_at(self, t: float) -> np.ndarray:
        return self.path.at(self.start_offset_m + self.speed_mps * t)[0]


@dataclass(frozen=True)
class World:
    """Static geometry plus moving objects. Object ids (as in ground truth ``hits``)
    number walls, then arcs, circles, rolling cylinders, then two legs per person."""

    name: str
    walls: tuple[Wall, ...] = ()
    arcs: tuple[Arc, ...] = ()
    circles: tuple[Circle, ...] = ()
    cylinders: tuple[RollingCylinder, ...] = ()
    people: tuple[Person, ...] = ()

    def objects(self) -> list[dict]:
        """The object table: one dict per id with ``kind`` and ``name``."""
        table: list[dict] = []
        for i, w in enumerate(self.walls):
            table.append({"kind": "wall", "name": w.name or f"wall{i}"})
        for i, a in enumerate(self.arcs):
            table.append({"kind": "arc", "name": a.name or f"arc{i}"})
        for i, c in enumerate(self.circles):
            table.append({"kind": c.kind, "name": c.name or f"{c.kind}{i}"})
        for c in self.cylinders:
            table.append({"kind": "cylinder", "name": c.name})
        for p in self.people:
            table.append({"kind": "leg", "name": f"{p.name}/left"})
            table.append({"kind": "leg", "name": f"{p.name}/right"})
        for oid, row in enumerate(table):
            row["id"] = oid
        return table

    def to_dict(self) -> dict:
        return asdict(self)


def _wall_loop(points: Sequence[tuple[float, float]], name: str, closed: bool = True) -> list[Wall]:
    pts = list(points) + ([points[0]] if closed else [])
    return [Wall(tuple(map(float, a)), tuple(map(float, b)), f"{name}{i}") for i, (a, b) in
            enumerate(zip(pts[:-1], pts[1:], strict=True))]


def _stadium(x0: float, x1: float, y: float, radius: float, n_arc: int = 12) -> tuple:
    """Waypoints of a running-track loop: straights at y +- radius joined by half circles."""
    right = [(x1 + radius * np.sin(a), y - radius * np.cos(a)) for a in np.linspace(0, np.pi, n_arc + 1)]
    left = [(x0 - radius * np.sin(a), y + radius * np.cos(a)) for a in np.linspace(0, np.pi, n_arc + 1)]
    return tuple((round(float(px), 6), round(float(py), 6)) for px, py in right + left)


def _hall() -> World:
    # A 12 m x 9 m hallway entrance (Xavier et al. 2005, static test): walls with an
    # entrance recess and a rounded corner, two columns, a bench made of two short
    # cylinders of the columns' radius, a cylinder pulled round the columns and a
    # student walking past the lower right corner.
    r = 0.25
    outline = [(0, 0), (12, 0), (12, 9), (7.5, 9), (7.5, 10), (5.0, 10), (5.0, 9), (0.8, 9)]
    walls = _wall_loop(outline, "hall", closed=False)
    walls.append(Wall((0.0, 8.2), (0.0, 0.0), "hall_left"))
    corner = Arc((0.8, 8.2), 0.8, np.pi / 2, np.pi, "rounded_corner")
    circles = (
        Circle((4.0, 5.0), r, "column", "column_left"),
        Circle((8.0, 5.0), r, "column", "column_right"),
        Circle((1.6, 7.6), r, "bench", "bench_a"),
        Circle((2.8, 7.6), r, "bench", "bench_b"),
    )
    loop = PathSpec(((2.5, 3.5), (9.5, 3.5), (9.5, 6.5), (2.5, 6.5)), "loop")
    cylinder = RollingCylinder(r, loop, 0.5, "cylinder")
    walker = Person(PathSpec(((8.0, 1.2), (11.2, 4.5)), "bounce"), speed_mps=0.9, name="student")
    return World("hall", tuple(walls), (corner,), circles, (cylinder,), (walker,))


def _corridor() -> World:
    # A 30 m corridor, 2.4 m wide, with door recesses (0.9 m wide, 0.3 m deep) on both
    # sides, a side branch at x = 24-26 m going up, and the corridor's end wall.
    half = 1.2
    walls: list[Wall] = []

    def side(y: float, sign: float, doors: list[float], x_end: float) -> None:
        pts: list[tuple[float, float]] = [(0.0, y)]
        for d in doors:
            pts += [(d, y), (d, y + sign * 0.3), (d + 0.9, y + sign * 0.3), (d + 0.9, y)]
        pts.append((x_end, y))
        walls.extend(_wall_loop(pts, "lower" if sign < 0 else "upper", closed=False))

    side(-half, -1.0, [3.0, 9.0, 15.0, 21.0], 30.0)
    side(half, 1.0, [6.0, 12.0, 18.0], 24.0)
    walls += [
        Wall((24.0, half), (24.0, 8.0), "branch_left"),
        Wall((26.0, 8.0), (26.0, half), "branch_right"),
        Wall((26.0, half), (30.0, half), "upper_end"),
        Wall((30.0, half), (30.0, -half), "end"),
        Wall((0.0, -half), (0.0, half), "start"),
        Wall((24.0, 8.0), (26.0, 8.0), "branch_end"),
    ]
    walker = Person(PathSpec(((28.0, 0.6), (14.0, 0.6)), "bounce"), speed_mps=1.1, name="walker",
                    leg_diameter_m=0.13)
    return World("corridor", tuple(walls), people=(walker,))


def _office() -> World:
    # Two rooms (6 x 5 m and 5 x 5 m) joined by a 1 m door, with boxes, a cabinet
    # recess and a round bin; a person walks around in the larger room.
    outer = [(0, 0), (11, 0), (11, 5), (0, 5)]
    walls = _wall_loop(outer, "outer")
    walls += [
        Wall((6.0, 0.0), (6.0, 2.0), "divider_low"),
        Wall((6.0, 3.0), (6.0, 5.0), "divider_high"),
    ]
    walls += _wall_loop([(1.5, 3.5), (2.3, 3.5), (2.3, 4.2), (1.5, 4.2)], "box_a")
    walls += _wall_loop([(8.5, 0.8), (9.7, 0.8), (9.7, 1.4), (8.5, 1.4)], "box_b")
    walls += _wall_loop([(7.0, 3.9), (7.6, 4.3), (6.8, 4.5)], "crate")
    bin_ = Circle((9.6, 4.0), 0.2, "bin", "bin")
    walker = Person(PathSpec(_stadium(1.3, 4.6, 1.1, 0.4), "loop"), speed_mps=0.8, name="colleague",
                    leg_diameter_m=0.15)
    return World("office", tuple(walls), circles=(bin_,), people=(walker,))


def random_polygons(
    seed: int = 0,
    *,
    n_obstacles: int = 6,
    room_size_m: tuple[float, float] = (12.0, 9.0),
    min_side_m: float = 0.4,
    max_side_m: float = 2.0,
) -> World:
    """A rectangular room with ``n_obstacles`` random convex polygons that do not overlap.

    For benchmarks: every wall is a straight segment, so the ground truth is pure lines.
    Obstacles keep 0.5 m from each other and from the room walls, and leave a 1.5 m
    clear disc around the room's centre for the robot.
    """
    if n_obstacles < 0:
        raise ValueError(f"n_obstacles must be >= 0, got {n_obstacles}")
    rng = np.random.default_rng(seed)
    w, h = room_size_m
    walls = _wall_loop([(0, 0), (w, 0), (w, h), (0, h)], "room")
    placed: list[tuple[np.ndarray, float]] = []
    centre = np.array([w / 2, h / 2])
    attempts = 0
    while len(placed) < n_obstacles and attempts < 1000:
        attempts += 1
        n_vertices = int(rng.integers(3, 7))
        radius = rng.uniform(min_side_m, max_side_m) / 2
        c = rng.uniform([radius + 0.5, radius + 0.5], [w - radius - 0.5, h - radius - 0.5])
        if np.linalg.norm(c - centre) < radius + 1.5:
            continue
        if any(np.linalg.norm(c - pc) < radius + pr + 0.5 for pc, pr in placed):
            continue
        angles = np.sort(rng.uniform(0, 2 * np.pi, n_vertices))
        gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * np.pi]))
        if gaps.min() < 0.3:  # avoid nearly coincident vertices
            continue
        verts = c + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        walls += _wall_loop([tuple(v) for v in verts.round(4)], f"poly{len(placed)}_")
        placed.append((c, radius))
    return World(f"random_polygons_{seed}", tuple(walls))


#: Named worlds. ``make_world(name)`` builds one.
WORLDS = {"hall": _hall, "corridor": _corridor, "office": _office}


def make_world(name: str) -> World:
    """Build a named world: ``hall``, ``corridor``, ``office`` or ``random_polygons[_SEED]``."""
    if name.startswith("random_polygons"):
        rest = name[len("random_polygons"):].lstrip("_")
        return random_polygons(int(rest) if rest else 0)
    try:
        return WORLDS[name]()
    except KeyError:
        raise ValueError(
            f"world must be one of {sorted(WORLDS) + ['random_polygons_<seed>']}, got {name!r}"
        ) from None


# ============================================================================ lidar
def _f32(x: float) -> float:
    """The float32 value nearest to x, as a Python float: what a ROS message stores."""
    return float(np.float32(x))


@dataclass(frozen=True)
class Lidar:
    """A planar lidar model.

    Beam ``i`` points at ``angle_min + i * angle_increment`` (sensor frame). Readings
    are the true range plus Gaussian noise (``noise_std_m``); a beam whose true range is
    beyond ``range_max`` reads exactly ``range_max`` (no return); each beam drops out
    with probability ``dropout_prob`` and then reads NaN. Angles and limits are rounded
    to float32, as a ``sensor_msgs/LaserScan`` stores them, so that simulated scans and
    scans read back from a bag are identical.
    """

    name: str
    angle_min: float
    angle_increment: float
    n_beams: int
    range_min: float = 0.05
    range_max: float = 30.0
    noise_std_m: float = 0.005
    dropout_prob: float = 0.0
    rate_hz: float = 10.0

    def __post_init__(self) -> None:
        if self.n_beams < 1:
            raise ValueError(f"n_beams must be >= 1, got {self.n_beams}")
        if not self.angle_increment > 0:
            raise ValueError(f"angle_increment must be > 0, got {self.angle_increment}")
        if self.noise_std_m < 0:
            raise ValueError(f"noise_std_m must be >= 0, got {self.noise_std_m}")
        if not 0 <= self.dropout_prob < 1:
            raise ValueError(f"dropout_prob must be in [0, 1), got {self.dropout_prob}")
        if not self.rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {self.rate_hz}")
        for name in ("angle_min", "angle_increment", "range_min", "range_max"):
            object.__setattr__(self, name, _f32(getattr(self, name)))

    @classmethod
    def from_fov(cls, name: str, fov_deg: float, step_deg: float, *, full_circle: bool = False,
                 **kwargs) -> Lidar:
        """A lidar centred on the x axis covering ``fov_deg`` in steps of ``step_deg``.

        For a full circle the last beam stops one step short of 360 degrees.
        """
        n = int(round(fov_deg / step_deg)) + (0 if full_circle else 1)
        angle_min = -np.radians(fov_deg) / 2 if not full_circle else -np.pi
        return cls(name, angle_min, np.radians(step_deg), n, **kwargs)

    @property
    def angles(self) -> np.ndarray:
        """Beam angles (N,), computed as a reader of the ROS message would."""
        return self.angle_min + self.angle_increment * np.arange(self.n_beams)

    @property
    def is_full_circle(self) -> bool:
        """True when the last beam is the first beam's neighbour (see :attr:`Scan.is_full_circle`)."""
        return self.n_beams >= 3 and self.n_beams * self.angle_increment + 0.5 * self.angle_increment >= 2 * np.pi

    def to_dict(self) -> dict:
        return asdict(self)


#: Sensor presets. SICK LMS200: 180 deg at 0.5 deg (361 beams), 5 mm noise; SICK LMS111:
#: 270 deg at 0.5 deg (541 beams), 20 m; Neato XV-11: 360 deg at 1 deg, 6 m, noisy, 5 Hz.
LIDARS = {
    "lms200": Lidar.from_fov("lms200", 180.0, 0.5, range_max=32.0, noise_std_m=0.005),
    "lms111": Lidar.from_fov("lms111", 270.0, 0.5, range_max=20.0, noise_std_m=0.008,
                             dropout_prob=0.002, rate_hz=10.0),
    "xv11": Lidar.from_fov("xv11", 360.0, 1.0, full_circle=True, range_min=0.06, range_max=6.0,
                           noise_std_m=0.015, dropout_prob=0.02, rate_hz=5.0),
}


# ============================================================================ trajectory
@dataclass(frozen=True)
class Trajectory:
    """Sensor poses over time: ``(t_s, x, y, theta)`` keyframes, linearly interpolated
    (theta along the shorter way round); constant before the first and after the last."""

    keyframes: tuple[tuple[float, float, float, float], ...]

    def __post_init__(self) -> None:
        k = np.asarray(self.keyframes, dtype=np.float64)
        if k.ndim != 2 or k.shape[1] != 4 or len(k) < 1:
            raise ValueError("keyframes must be a sequence of (t_s, x, y, theta)")
        if np.any(np.diff(k[:, 0]) <= 0):
            raise ValueError("keyframe times must be strictly increasing")

    @classmethod
    def static(cls, x: float, y: float, theta: float) -> Trajectory:
        return cls(((0.0, x, y, theta),))

    def pose_at(self, t: float) -> tuple[float, float, float]:
        k = np.asarray(self.keyframes, dtype=np.float64)
        if len(k) == 1 or t <= k[0, 0]:
            return tuple(float(v) for v in k[0, 1:])
        if t >= k[-1, 0]:
            return tuple(float(v) for v in k[-1, 1:])
        i = int(np.searchsorted(k[:, 0], t, side="right") - 1)
        u = (t - k[i, 0]) / (k[i + 1, 0] - k[i, 0])
        x = k[i, 1] + u * (k[i + 1, 1] - k[i, 1])
        y = k[i, 2] + u * (k[i + 1, 2] - k[i, 2])
        dtheta = wrap_angle(k[i + 1, 3] - k[i, 3])
        return float(x), float(y), float(wrap_angle(k[i, 3] + u * dtheta))


@dataclass(frozen=True)
class Scenario:
    """A world, a lidar, a trajectory and a duration: everything a recording needs."""

    world: World
    lidar: Lidar
    trajectory: Trajectory
    duration_s: float
    topic: str = "/scan"
    frame_id: str = "laser"

    @property
    def n_scans(self) -> int:
        return int(round(self.duration_s * self.lidar.rate_hz))


def scenario(name: str) -> Scenario:
    """The bundled scenarios behind ``data/``.

    ``hall``: static LMS200 near the bottom wall, 60 s at 10 Hz. ``corridor``: LMS111
    driving 22 m down the corridor then turning into the side branch, 40 s at 10 Hz.
    ``office``: XV-11 (360 deg) touring both rooms, 40 s at 5 Hz. ``random_polygons_<seed>``:
    static LMS200 in the room's centre, one scan.
    """
    if name == "hall":
        return Scenario(make_world("hall"), LIDARS["lms200"], Trajectory.static(6.0, 0.4, np.pi / 2), 60.0)
    if name == "corridor":
        traj = Trajectory(((0.0, 1.0, -0.4, 0.0), (32.0, 25.0, -0.4, 0.0), (36.0, 25.0, -0.4, np.pi / 2),
                           (40.0, 25.0, 2.0, np.pi / 2)))
        return Scenario(make_world("corridor"), LIDARS["lms111"], traj, 40.0)
    if name == "office":
        traj = Trajectory(((0.0, 3.0, 2.5, 0.0), (8.0, 5.2, 2.5, 0.0), (14.0, 8.0, 2.6, 0.5),
                           (22.0, 8.0, 3.8, 2.5), (26.0, 7.0, 2.5, np.pi), (30.0, 5.0, 2.5, np.pi),
                           (40.0, 2.8, 2.0, -2.0)))
        return Scenario(make_world("office"), LIDARS["xv11"], traj, 40.0)
    if name.startswith("random_polygons"):
        world = make_world(name)
        w, h = 12.0, 9.0
        return Scenario(world, LIDARS["lms200"], Trajectory.static(w / 2, h / 2, 0.0), 0.1)
    raise ValueError(f"scenario must be one of {sorted(WORLDS)} or random_polygons_<seed>, got {name!r}")


# ============================================================================ ray casting
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _cast_segments(origin, dirs, starts, ends) -> np.ndarray:
    """Distances (N, M) along unit rays to segments; inf where a ray misses."""
    if len(starts) == 0:
        return np.full((len(dirs), 0), np.inf)
    e = ends - starts  # (M, 2)
    ao = starts - origin  # (M, 2)
    denom = _cross(dirs[:, None, :], e[None, :, :])  # (N, M)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = _cross(ao[None, :, :], e[None, :, :]) / denom
        u = _cross(ao[None, :, :], dirs[:, None, :]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 1e-9) & (u >= 0.0) & (u <= 1.0)
    return np.where(hit, t, np.inf)


def _cast_circles(origin, dirs, centers, radii, arc_from=None, arc_to=None) -> np.ndarray:
    """Distances (N, K) along unit rays to circles (solid) or arcs (thin, both sides)."""
    if len(centers) == 0:
        return np.full((len(dirs), 0), np.inf)
    f = origin - centers  # (K, 2)
    b = dirs @ f.T  # (N, K)
    c = np.sum(f * f, axis=1) - radii**2  # (K,)
    disc = b * b - c[None, :]
    sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
    out = np.full(b.shape, np.inf)
    for t in (-b - sq, -b + sq):  # near root first
        ok = np.isfinite(t) & (t > 1e-9)
        if arc_from is not None:
            with np.errstate(invalid="ignore"):
                p = origin + t[..., None] * dirs[:, None, :]  # (N, K, 2)
                phi = np.arctan2(p[..., 1] - centers[:, 1], p[..., 0] - centers[:, 0])
            span = np.mod(arc_to - arc_from, 2 * np.pi)
            ok &= np.mod(phi - arc_from, 2 * np.pi) <= span
        else:
            ok &= c[None, :] > 0  # a solid circle: rays starting inside see nothing
        out = np.where(ok & ~np.isfinite(out), t, out)
        if arc_from is None:
            break  # solid circles: only the near side is visible
    return out


# ============================================================================ ground truth
@dataclass(frozen=True)
class VisibleWall:
    """The visible part of a wall in one scan, in the sensor frame.

    ``first``/``last`` are the first and last beam of the run of consecutive beams that
    hit the wall; ``start``/``end`` are those beams' true (noise-free) hit points. On a
    full-circle scan a run may cross the seam: then ``first > last``.
    """

    wall_id: int
    name: str
    r: float
    alpha: float
    start: tuple[float, float]
    end: tuple[float, float]
    first: int
    last: int
    n_beams: int

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))


@dataclass(frozen=True)
class VisibleCircle:
    """A circle (column, bench foot, rolling cylinder) seen in one scan, sensor frame."""

    object_id: int
    name: str
    kind: str
    center: tuple[float, float]
    radius: float
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class VisibleArc:
    """An arc (rounded corner) seen in one scan: its circle and the true hit points of
    its first and last beams, in the sensor frame."""

    object_id: int
    name: str
    center: tuple[float, float]
    radius: float
    start: tuple[float, float]
    end: tuple[float, float]
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class VisibleLeg:
    """One leg of a person seen in one scan (sensor frame); ``diameter`` in metres."""

    object_id: int
    person: str
    center: tuple[float, float]
    diameter: float
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class ScanTruth:
    """What one simulated scan contains.

    ``hits`` is (N,) int: the object id each beam hit (see :meth:`World.objects`), -1
    where the beam hit nothing within range. ``pose`` is the sensor pose in the world.
    """

    stamp_ns: int
    pose: tuple[float, float, float]
    hits: np.ndarray = field(repr=False)
    walls: tuple[VisibleWall, ...] = ()
    circles: tuple[VisibleCircle, ...] = ()
    arcs: tuple[VisibleArc, ...] = ()
    legs: tuple[VisibleLeg, ...] = ()

    def to_json(self) -> dict:
        runs = _runs(self.hits, wrap=False)
        return {
            "stamp_ns": int(self.stamp_ns),
            "pose": [round(v, _ROUND) for v in self.pose],
            "hits": [[int(a), int(b), int(o)] for a, b, o in runs],
            "walls": [_rounded(asdict(w)) for w in self.walls],
            "circles": [_rounded(asdict(c)) for c in self.circles],
            "arcs": [_rounded(asdict(a)) for a in self.arcs],
            "legs": [_rounded(asdict(g)) for g in self.legs],
        }

    @classmethod
    def from_json(cls, d: dict, n_beams: int) -> ScanTruth:
        hits = np.full(n_beams, -1, dtype=np.int64)
        for a, b, o in d["hits"]:
            hits[a:b + 1] = o

        def tup(items, kind):
            out = []
            for it in items:
                it = dict(it)
                for k in ("start", "end", "center"):
                    if k in it:
                        it[k] = tuple(it[k])
                out.append(kind(**it))
            return tuple(out)

        return cls(
            stamp_ns=int(d["stamp_ns"]),
            pose=tuple(d["pose"]),
            hits=hits,
            walls=tup(d["walls"], VisibleWall),
            circles=tup(d["circles"], VisibleCircle),
            arcs=tup(d["arcs"], VisibleArc),
            legs=tup(d["legs"], VisibleLeg),
        )


def _rounded(d):
    if isinstance(d, float):
        return round(d, _ROUND)
    if isinstance(d, dict):
        return {k: _rounded(v) for k, v in d.items()}
    if isinstance(d, list | tuple):
        return [_rounded(v) for v in d]
    if isinstance(d, np.generic):
        return _rounded(d.item())
    return d


def _runs(labels: np.ndarray, wrap: bool) -> list[tuple[int, int, int]]:
    """Runs ``(first, last, label)`` of equal consecutive labels, -1 labels skipped.

    With ``wrap`` a run touching both ends of the array is joined across the seam and
    reported with ``first > last``.
    """
    n = len(labels)
    if n == 0:
        return []
    change = np.flatnonzero(np.diff(labels) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change - 1, [n - 1]])
    runs = [(int(a), int(b), int(labels[a])) for a, b in zip(starts, ends, strict=True)]
    if wrap and len(runs) > 1 and runs[0][2] == runs[-1][2]:
        first, last = runs[0], runs[-1]
        runs = runs[1:-1] + [(last[0], first[1], first[2])]
    return [r for r in runs if r[2] >= 0]


def _run_len(first: int, last: int, n: int) -> int:
    return last - first + 1 if last >= first else n - first + last + 1


# ============================================================================ simulation
@dataclass
class _Frame:
    """The world's geometry at one instant, flattened to arrays for ray casting."""

    seg_start: np.ndarray
    seg_end: np.ndarray
    arc_center: np.ndarray
    arc_radius: np.ndarray
    arc_from: np.ndarray
    arc_to: np.ndarray
    circ_center: np.ndarray
    circ_radius: np.ndarray
    n_walls: int
    circle_ids: np.ndarray  # object id of each circle (static, cylinders, legs)


def _frame(world: World, t: float) -> _Frame:
    circ_c, circ_r = [], []
    for c in world.circles:
        circ_c.append(c.center)
        circ_r.append(c.radius)
    for c in world.cylinders:
        circ_c.append(c.center_at(t))
        circ_r.append(c.radius)
    for p in world.people:
        left, right = p.legs_at(t)
        circ_c += [left, right]
        circ_r += [p.leg_diameter_m / 2] * 2
    n_walls, n_arcs = len(world.walls), len(world.arcs)
    return _Frame(
        seg_start=np.array([w.start for w in world.walls], dtype=np.float64).reshape(-1, 2),
        seg_end=np.array([w.end for w in world.walls], dtype=np.float64).reshape(-1, 2),
        arc_center=np.array([a.center for a in world.arcs], dtype=np.float64).reshape(-1, 2),
        arc_radius=np.array([a.radius for a in world.arcs], dtype=np.float64),
        arc_from=np.array([a.start_angle for a in world.arcs], dtype=np.float64),
        arc_to=np.array([a.end_angle for a in world.arcs], dtype=np.float64),
        circ_center=np.array(circ_c, dtype=np.float64).reshape(-1, 2),
        circ_radius=np.array(circ_r, dtype=np.float64),
        n_walls=n_walls,
        circle_ids=np.arange(len(circ_r)) + n_walls + n_arcs,
    )


def _true_ranges(frame: _Frame, pose, angles) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free range (N,) and hit object id (N,) for beams at ``angles`` from ``pose``."""
    x, y, theta = pose
    origin = np.array([x, y])
    phi = theta + angles
    dirs = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    d = np.concatenate(
        [
            _cast_segments(origin, dirs, frame.seg_start, frame.seg_end),
            _cast_circles(origin, dirs, frame.arc_center, frame.arc_radius, frame.arc_from, frame.arc_to),
            _cast_circles(origin, dirs, frame.circ_center, frame.circ_radius),
        ],
        axis=1,
    )
    if d.shape[1] == 0:
        return np.full(len(angles), np.inf), np.full(len(angles), -1, dtype=np.int64)
    k = np.argmin(d, axis=1)
    rng_true = d[np.arange(len(angles)), k]
    ids = np.where(np.isfinite(rng_true), k, -1).astype(np.int64)
    return rng_true, ids


def scan_at(
    world: World,
    lidar: Lidar,
    pose: tuple[float, float, float],
    t: float = 0.0,
    *,
    rng: np.random.Generator | None = None,
    stamp_ns: int | None = None,
    frame_id: str = "laser",
) -> tuple[Scan, ScanTruth]:
    """Simulate one scan from ``pose`` at time ``t`` (moving objects placed at ``t``).

    Without ``rng`` the scan is noise-free and has no dropouts.
    """
    frame = _frame(world, t)
    angles = lidar.angles
    true_r, hits = _true_ranges(frame, pose, angles)
    in_range = true_r < lidar.range_max
    hits = np.where(in_range, hits, -1)
    ranges = np.where(in_range, true_r, lidar.range_max)
    if rng is not None:
        noise = rng.standard_normal(lidar.n_beams) * lidar.noise_std_m
        drop = rng.random(lidar.n_beams) < lidar.dropout_prob
        ranges = np.where(in_range, ranges + noise, ranges)
        ranges = np.where(drop, np.nan, ranges)
    ranges = ranges.astype(np.float32).astype(np.float64)  # what a LaserScan message holds
    stamp = EPOCH_NS + int(round(t * 1e9)) if stamp_ns is None else int(stamp_ns)
    scan = Scan(ranges=ranges, angles=angles, range_min=lidar.range_min, range_max=lidar.range_max,
                stamp_ns=stamp, frame_id=frame_id, pose=pose)
    truth = _truth(world, lidar, frame, pose, angles, true_r, hits, stamp)
    return scan, truth


def _to_sensor(points: np.ndarray, pose) -> np.ndarray:
    x, y, theta = pose
    c, s = np.cos(theta), np.sin(theta)
    d = np.asarray(points, dtype=np.float64) - np.array([x, y])
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


def _pt(p) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _truth(world, lidar, frame, pose, angles, true_r, hits, stamp) -> ScanTruth:
    n = lidar.n_beams
    full_circle = lidar.is_full_circle
    objects = world.objects()
    hit_xy = np.stack([true_r * np.cos(angles), true_r * np.sin(angles)], axis=1)
    n_walls, n_arcs = frame.n_walls, len(world.arcs)
    walls, circles, arcs, legs = [], [], [], []
    circle_center_sensor = _to_sensor(frame.circ_center, pose) if len(frame.circ_center) else None
    people_leg_ids = {}
    base = n_walls + n_arcs + len(world.circles) + len(world.cylinders)
    for j, p in enumerate(world.people):
        people_leg_ids[base + 2 * j] = p
        people_leg_ids[base + 2 * j + 1] = p
    for first, last, oid in _runs(hits, wrap=full_circle):
        count = _run_len(first, last, n)
        if oid < n_walls:
            w = world.walls[oid]
            ends = _to_sensor(np.array([w.start, w.end]), pose)
            r, alpha = line_through_points(ends[0], ends[1])
            walls.append(VisibleWall(oid, objects[oid]["name"], r, alpha, _pt(hit_xy[first]),
                                     _pt(hit_xy[last]), first, last, count))
        elif oid < n_walls + n_arcs:
            a = world.arcs[oid - n_walls]
            c = _to_sensor(np.array(a.center), pose)
            arcs.append(VisibleArc(oid, objects[oid]["name"], _pt(c), float(a.radius), _pt(hit_xy[first]),
                                   _pt(hit_xy[last]), first, last, count))
        else:
            k = oid - n_walls - n_arcs
            c = _pt(circle_center_sensor[k])
            radius = float(frame.circ_radius[k])
            if oid in people_leg_ids:
                legs.append(VisibleLeg(oid, people_leg_ids[oid].name, c, 2 * radius, first, last, count))
            else:
                circles.append(VisibleCircle(oid, objects[oid]["name"], objects[oid]["kind"], c, radius,
                                             first, last, count))
    return ScanTruth(stamp, tuple(float(v) for v in pose), hits, tuple(walls), tuple(circles),
                     tuple(arcs), tuple(legs))


def simulate(
    scenario_or_name: Scenario | str,
    seed: int = 0,
    *,
    n_scans: int | None = None,
) -> Iterator[tuple[Scan, ScanTruth]]:
    """Yield ``(scan, truth)`` for every scan of a scenario, deterministically per seed.

    Parameters
    ----------
    scenario_or_name : Scenario or str
        A :class:`Scenario` or the name of a bundled one (see :func:`scenario`).
    seed : int
        Seed of the noise and dropout generator.
    n_scans : int, optional
        Stop after this many scans (default: the scenario's duration times its rate).
    """
    sc = scenario(scenario_or_name) if isinstance(scenario_or_name, str) else scenario_or_name
    rng = np.random.default_rng(seed)
    total = sc.n_scans if n_scans is None else int(n_scans)
    period_ns = int(round(1e9 / sc.lidar.rate_hz))
    for k in range(total):
        t_ns = k * period_ns
        t = t_ns * 1e-9
        yield scan_at(sc.world, sc.lidar, sc.trajectory.pose_at(t), t, rng=rng,
                      stamp_ns=EPOCH_NS + t_ns, frame_id=sc.frame_id)


# ============================================================================ truth files
def truth_path_for(bag_path: str | Path) -> Path:
    """Where the ground truth of a recording lives: ``<name>.truth.jsonl`` beside it."""
    p = Path(bag_path)
    stem = p.name[: -len(p.suffix)] if p.suffix in (".bag", ".mcap", ".db3") else p.name
    return p.with_name(f"{stem}.truth.jsonl")


@dataclass(frozen=True)
class GroundTruth:
    """The ground truth of a whole recording: a header and one :class:`ScanTruth` per
    scan, looked up by stamp (``truth[stamp_ns]``)."""

    header: dict
    scans: dict[int, ScanTruth]

    def __getitem__(self, stamp_ns: int) -> ScanTruth:
        return self.scans[int(stamp_ns)]

    def __contains__(self, stamp_ns: object) -> bool:
        return stamp_ns in self.scans

    def __len__(self) -> int:
        return len(self.scans)

    def __iter__(self):
        return iter(self.scans.values())

    @property
    def objects(self) -> list[dict]:
        return self.header["objects"]


#: What :func:`write_truth` writes (see labkit._safe): how an existing one is recognised.
TRUTH_FILE = OutputKind("a labkit ground-truth file (.truth.jsonl)", (".truth.jsonl",),
                        first_json_line_with("labkit_truth"))


def write_truth(path: str | Path, sc: Scenario, truths, *, seed: int, overwrite: bool = False) -> int:
    """Write ``truths`` (an iterable of :class:`ScanTruth`) as JSON lines; returns the count.

    Line 1 is a header (format version, world, lidar, object table, seed); every further
    line is one scan's truth keyed by ``stamp_ns``. Written under a temporary name and
    renamed when complete; ``overwrite`` replaces only a ground-truth file.
    """
    header = {
        "labkit_truth": 1,
        "world": _rounded(sc.world.to_dict()),
        "lidar": _rounded(sc.lidar.to_dict()),
        "objects": sc.world.objects(),
        "seed": int(seed),
        "topic": sc.topic,
        "frame_id": sc.frame_id,
    }
    count = 0
    with safe_output(path, TRUTH_FILE, overwrite=overwrite) as tmp, \
            open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(json.dumps(header, separators=(",", ":")) + "\n")
        for tr in truths:
            fh.write(json.dumps(tr.to_json(), separators=(",", ":")) + "\n")
            count += 1
    return count


def read_truth(path: str | Path) -> GroundTruth:
    """Read a ground-truth JSON-lines file written by :func:`write_truth`."""
    path = Path(path)
    with open(path, encoding="utf-8") as fh:
        try:
            header = json.loads(fh.readline())
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: line 1 is not a labkit ground-truth header: {exc}") from None
        if not isinstance(header, dict) or header.get("labkit_truth") != 1:
            raise ValueError(f"{path}: line 1 is not a labkit ground-truth header")
        n = int(header["lidar"]["n_beams"])
        scans = {}
        for lineno, line in enumerate(fh, start=2):
            if not line.strip():
                continue
            try:
                tr = ScanTruth.from_json(json.loads(line), n)
            except (json.JSONDecodeError, KeyError, TypeError) as exc:
                raise ValueError(f"{path}: line {lineno} is not a scan record: {exc}") from None
            scans[tr.stamp_ns] = tr
    return GroundTruth(header, scans)
