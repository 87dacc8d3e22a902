"""The simulated lidar: beams, trajectories and scenarios, ray casting, and the scans with their truth."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import asdict, dataclass

import numpy as np

from ..geometry import line_through_points, wrap_angle
from ..scan import Scan
from .truth import ScanTruth, VisibleArc, VisibleCircle, VisibleLeg, VisibleWall, _run_len, _runs
from .worlds import WORLDS, World, make_world

__all__ = ["EPOCH_NS", "Lidar", "LIDARS", "Trajectory", "Scenario", "scenario", "scan_at", "simulate"]

#: Time stamp of the first simulated scan: 2025-01-01T00:00:00Z, in nanoseconds.
EPOCH_NS = 1_735_689_600 * 1_000_000_000


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

    Parameters
    ----------
    name : str
        The model's name (``"LMS200"``, ...).
    angle_min : float
        The first beam's angle, radians.
    angle_increment : float
        The angle between neighbouring beams, radians.
    n_beams : int
        The number of beams.
    range_min : float
        The shortest valid range, metres.
    range_max : float
        The longest range, metres.
    noise_std_m : float
        The standard deviation of the range noise, metres.
    dropout_prob : float
        The probability that a beam reads NaN.
    rate_hz : float
        Scans per second.
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
    """Sensor poses over time: keyframes, linearly interpolated.

    Theta is interpolated along the shorter way round; the pose is constant before the first
    keyframe and after the last.

    Parameters
    ----------
    keyframes : tuple of tuple of (float, float, float, float)
        ``(t_s, x, y, theta)``: time in seconds, position in metres, heading in radians.
    """

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
            return float(k[0, 1]), float(k[0, 2]), float(k[0, 3])
        if t >= k[-1, 0]:
            return float(k[-1, 1]), float(k[-1, 2]), float(k[-1, 3])
        i = int(np.searchsorted(k[:, 0], t, side="right") - 1)
        u = (t - k[i, 0]) / (k[i + 1, 0] - k[i, 0])
        x = k[i, 1] + u * (k[i + 1, 1] - k[i, 1])
        y = k[i, 2] + u * (k[i + 1, 2] - k[i, 2])
        dtheta = wrap_angle(k[i + 1, 3] - k[i, 3])
        return float(x), float(y), float(wrap_angle(k[i, 3] + u * dtheta))


@dataclass(frozen=True)
class Scenario:
    """A world, a lidar, a trajectory and a duration: everything a recording needs.

    Parameters
    ----------
    world : World
        What the lidar sees.
    lidar : Lidar
        The sensor.
    trajectory : Trajectory
        The sensor's poses over time.
    duration_s : float
        The recording's length, seconds.
    topic : str
        The scans' topic in a bag.
    frame_id : str
        The scans' frame.
    """

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
    static LMS200 in the room's centre, one scan. ``crossing`` (4 walkers) and ``crossing_<n>`` (1-6):
    the hall's static LMS200 watching people cross (:func:`labkit.sim.worlds.crossing`), 60 s at 10 Hz.

    Parameters
    ----------
    name : str
        One of the names above.

    Returns
    -------
    Scenario
        The scenario.
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
    if name == "crossing" or (name.startswith("crossing_") and name[len("crossing_"):].isdigit()):
        return Scenario(make_world(name), LIDARS["lms200"], Trajectory.static(6.0, 0.4, np.pi / 2), 60.0)
    if name.startswith("random_polygons"):
        world = make_world(name)
        w, h = 12.0, 9.0
        return Scenario(world, LIDARS["lms200"], Trajectory.static(w / 2, h / 2, 0.0), 0.1)
    raise ValueError(f"scenario must be one of {sorted(WORLDS)}, crossing_<n> or random_polygons_<seed>, got {name!r}")


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
    circ_c: list[tuple[float, float] | np.ndarray] = []
    circ_r: list[float] = []
    for c in world.circles:
        circ_c.append(c.center)
        circ_r.append(c.radius)
    for cyl in world.cylinders:
        circ_c.append(cyl.center_at(t))
        circ_r.append(cyl.radius)
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

    Parameters
    ----------
    world : World
        What the lidar sees.
    lidar : Lidar
        The sensor.
    pose : tuple of (float, float, float)
        The sensor's ``(x, y, theta)`` in the world, metres and radians.
    t : float
        The time, seconds, that places the moving objects.
    rng : numpy.random.Generator or None
        Draws the noise and dropouts; None: a noise-free scan without dropouts.
    stamp_ns : int or None
        The scan's time stamp, nanoseconds; None: ``t`` after the simulator's epoch (``EPOCH_NS``).
    frame_id : str
        The scan's frame.

    Returns
    -------
    scan : Scan
        The scan.
    truth : ScanTruth
        What it contains.
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
    circle_center_sensor = _to_sensor(frame.circ_center, pose)  # (0, 2) when there are none
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
            center = _pt(circle_center_sensor[k])
            radius = float(frame.circ_radius[k])
            if oid in people_leg_ids:
                legs.append(VisibleLeg(oid, people_leg_ids[oid].name, center, 2 * radius, first, last, count))
            else:
                circles.append(VisibleCircle(oid, objects[oid]["name"], objects[oid]["kind"], center, radius,
                                             first, last, count))
    x, y, theta = (float(v) for v in pose)
    return ScanTruth(stamp, (x, y, theta), hits, tuple(walls), tuple(circles),
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

