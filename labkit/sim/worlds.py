"""The simulated worlds: walls, arcs, columns and the moving objects, and the bundled rooms.

:class:`Column` is a solid circle of a world; it is not :class:`labkit.Circle`, a circle
*detected* in a scan.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from .people import Mover, PathSpec, RollingCylinder, Walker

__all__ = ["Wall", "Arc", "Column", "World", "WORLDS", "make_world", "random_polygons", "crossing",
           "CROSSING_WALKERS"]


# ============================================================================ world
@dataclass(frozen=True)
class Wall:
    """A wall: the line segment from ``start`` to ``end`` (metres, world frame).

    Parameters
    ----------
    start : tuple of (float, float)
        One end.
    end : tuple of (float, float)
        The other end.
    name : str
        Its name in the ground truth.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    name: str = ""


@dataclass(frozen=True)
class Arc:
    """An arc of a circle, e.g. a rounded wall corner.

    The arc covers the directions (seen from ``center``) from ``start_angle``
    counter-clockwise to ``end_angle``. It reflects from both sides.

    Parameters
    ----------
    center : tuple of (float, float)
        The circle's centre, metres, world frame.
    radius : float
        Its radius, metres.
    start_angle : float
        Where the arc starts, radians.
    end_angle : float
        Where it ends, counter-clockwise from the start, radians.
    name : str
        Its name in the ground truth.
    """

    center: tuple[float, float]
    radius: float
    start_angle: float
    end_angle: float
    name: str = ""


@dataclass(frozen=True)
class Column:
    """A solid circle: a column, one foot of a bench, a box seen round.

    Parameters
    ----------
    center : tuple of (float, float)
        Its centre, metres, world frame.
    radius : float
        Its radius, metres.
    kind : str
        A free label carried into the ground truth (``"column"``, ``"bench"``).
    name : str
        Its name in the ground truth.
    """

    center: tuple[float, float]
    radius: float
    kind: str = "column"
    name: str = ""


@dataclass(frozen=True)
class World:
    """Static geometry plus moving objects.

    Object ids (as in ground truth ``hits``) number walls, then arcs, circles, rolling
    cylinders, then two legs per person.

    Parameters
    ----------
    name : str
        The world's name.
    walls : tuple of Wall
        Its walls.
    arcs : tuple of Arc
        Its arcs.
    circles : tuple of Column
        Its columns.
    cylinders : tuple of RollingCylinder
        The cylinders rolling through it.
    people : tuple of Walker
        The people walking through it.
    """

    name: str
    walls: tuple[Wall, ...] = ()
    arcs: tuple[Arc, ...] = ()
    circles: tuple[Column, ...] = ()
    cylinders: tuple[RollingCylinder, ...] = ()
    people: tuple[Walker, ...] = ()

    def objects(self) -> list[dict]:
        """The object table: one dict per id with ``kind`` and ``name``."""
        table: list[dict] = []
        for i, w in enumerate(self.walls):
            table.append({"kind": "wall", "name": w.name or f"wall{i}"})
        for i, a in enumerate(self.arcs):
            table.append({"kind": "arc", "name": a.name or f"arc{i}"})
        for i, c in enumerate(self.circles):
            table.append({"kind": c.kind, "name": c.name or f"{c.kind}{i}"})
        for cyl in self.cylinders:
            table.append({"kind": "cylinder", "name": cyl.name})
        for p in self.people:
            table.append({"kind": "leg", "name": f"{p.name}/left"})
            table.append({"kind": "leg", "name": f"{p.name}/right"})
        for oid, row in enumerate(table):
            row["id"] = oid
        return table

    def movers_at(self, t: float) -> tuple[Mover, ...]:
        """The moving objects at time ``t`` seconds, world frame: the rolling cylinders, then
        the walkers, with their ids in :meth:`objects` (a scan's ``hits`` say which beams saw them).

        >>> [(m.name, m.kind, m.object_ids) for m in make_world("hall").movers_at(0.0)]
        [('cylinder', 'cylinder', (13,)), ('student', 'person', (14, 15))]
        """
        first = len(self.walls) + len(self.arcs) + len(self.circles)
        out = []
        for k, c in enumerate(self.cylinders):
            out.append(Mover(c.name, "cylinder", (first + k,), _xy(c.center_at(t)), _xy(c.path.velocity(
                c.start_offset_m + c.speed_mps * t, c.speed_mps))))
        first += len(self.cylinders)
        for k, p in enumerate(self.people):
            out.append(Mover(p.name, "person", (first + 2 * k, first + 2 * k + 1), _xy(p.center_at(t)),
                             _xy(p.velocity_at(t))))
        return tuple(out)

    def to_dict(self) -> dict:
        return asdict(self)


def _xy(v) -> tuple[float, float]:
    return (float(v[0]), float(v[1]))


def _wall_loop(points: Sequence[tuple[float, float]], name: str, closed: bool = True) -> list[Wall]:
    pts = list(points) + ([points[0]] if closed else [])
    return [Wall(_xy(a), _xy(b), f"{name}{i}") for i, (a, b) in
            enumerate(zip(pts[:-1], pts[1:], strict=True))]


def _stadium(x0: float, x1: float, y: float, radius: float, n_arc: int = 12) -> tuple:
    """Waypoints of a running-track loop: straights at y +- radius joined by half circles."""
    right = [(x1 + radius * np.sin(a), y - radius * np.cos(a)) for a in np.linspace(0, np.pi, n_arc + 1)]
    left = [(x0 - radius * np.sin(a), y + radius * np.cos(a)) for a in np.linspace(0, np.pi, n_arc + 1)]
    return tuple((round(float(px), 6), round(float(py), 6)) for px, py in right + left)


_HALL_LOOP = PathSpec(((2.5, 3.5), (9.5, 3.5), (9.5, 6.5), (2.5, 6.5)), "loop")  # round the columns


def _hall_room() -> tuple[tuple[Wall, ...], tuple[Arc, ...], tuple[Column, ...]]:
    """The hall's walls, rounded corner, columns and bench (static)."""
    r = 0.25
    outline = [(0, 0), (12, 0), (12, 9), (7.5, 9), (7.5, 10), (5.0, 10), (5.0, 9), (0.8, 9)]
    walls = _wall_loop(outline, "hall", closed=False)
    walls.append(Wall((0.0, 8.2), (0.0, 0.0), "hall_left"))
    corner = Arc((0.8, 8.2), 0.8, np.pi / 2, np.pi, "rounded_corner")
    circles = (
        Column((4.0, 5.0), r, "column", "column_left"),
        Column((8.0, 5.0), r, "column", "column_right"),
        Column((1.6, 7.6), r, "bench", "bench_a"),
        Column((2.8, 7.6), r, "bench", "bench_b"),
    )
    return tuple(walls), (corner,), circles


def _hall() -> World:
    # A 12 m x 9 m hallway entrance (Xavier et al. 2005, static test): walls with an
    # entrance recess and a rounded corner, two columns, a bench made of two short
    # cylinders of the columns' radius, a cylinder pulled round the columns and a
    # student walking past the lower right corner.
    walls, arcs, circles = _hall_room()
    cylinder = RollingCylinder(0.25, _HALL_LOOP, 0.5, "cylinder")
    walker = Walker(PathSpec(((8.0, 1.2), (11.2, 4.5)), "bounce"), speed_mps=0.9, name="student")
    return World("hall", walls, arcs, circles, (cylinder,), (walker,))


#: The walkers of the ``crossing`` worlds, in the order they join (``crossing_<n>`` has the first
#: n): name, the two ends of the straight line walked back and forth, the time of a round trip
#: (seconds) and where the walker starts, as a fraction of a round trip. The cylinder makes a lap
#: in 32 s, so every meeting repeats every 32 s, and the starts are chosen so that nobody walks into
#: anybody: anna and ben cross each other's paths at 0.59 m (centre to centre); carl and dora pass each
#: other in opposite directions on lanes 0.6 m apart in front of the others (the nearer hides the
#: farther from the lidar, and both hide the people behind); emil and fay walk to and from the ends
#: of those lanes, and pass carl and dora at 0.69-0.94 m; nobody comes within 0.72 m of the cylinder's
#: centre or 0.67 m of a column's. Everybody stays within 6 m of the lidar of the ``crossing``
#: scenario, where its 0.5 deg beams still put 3 or more on a leg.
CROSSING_WALKERS = (
    ("anna", ((3.0, 2.8), (9.0, 4.6)), 16.0, 0.0),
    ("ben", ((9.0, 2.8), (3.0, 4.6)), 16.0, 0.165),
    ("carl", ((2.0, 1.5), (10.0, 1.5)), 16.0, 0.052),
    ("dora", ((10.0, 2.1), (2.0, 2.1)), 16.0, 0.114),
    ("emil", ((10.6, 1.0), (10.6, 4.0)), 8.0, 0.964),
    ("fay", ((1.5, 0.9), (1.5, 4.0)), 8.0, 0.905),
)


def crossing(n_walkers: int = 4) -> World:
    """The hall with people crossing and passing close, and the cylinder rolling round the columns.

    The hall keeps its walls, columns and bench: a world for tracking. The walkers of
    :data:`CROSSING_WALKERS` walk straight lines back and forth (0.75-1.0 m/s), through each
    other's paths; the cylinder goes round the columns at 0.625 m/s, a lap in 32 s. Named
    ``crossing`` (4 walkers) or ``crossing_<n>`` in :func:`make_world`.

    Parameters
    ----------
    n_walkers : int
        How many of the walkers, 1-6.

    Returns
    -------
    World
        The world.

    Examples
    --------
    >>> [p.name for p in crossing(2).people]
    ['anna', 'ben']
    """
    if isinstance(n_walkers, bool) or not isinstance(n_walkers, (int, np.integer)) or not \
            1 <= n_walkers <= len(CROSSING_WALKERS):
        raise ValueError(f"n_walkers must be a whole number in 1..{len(CROSSING_WALKERS)}, got {n_walkers!r}")
    walls, arcs, circles = _hall_room()
    loop_length = _HALL_LOOP.length
    cylinder = RollingCylinder(0.25, _HALL_LOOP, loop_length / 32.0, "cylinder", start_offset_m=0.963 * loop_length)
    people = []
    for name, (a, b), round_trip_s, start in CROSSING_WALKERS[:n_walkers]:
        length = float(np.hypot(b[0] - a[0], b[1] - a[1]))
        people.append(Walker(PathSpec((a, b), "bounce"), speed_mps=2 * length / round_trip_s, name=name,
                             start_offset_m=start * 2 * length))
    name = "crossing" if n_walkers == 4 else f"crossing_{n_walkers}"
    return World(name, walls, arcs, circles, (cylinder,), tuple(people))


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
    walker = Walker(PathSpec(((28.0, 0.6), (14.0, 0.6)), "bounce"), speed_mps=1.1, name="walker",
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
    bin_ = Column((9.6, 4.0), 0.2, "bin", "bin")
    walker = Walker(PathSpec(_stadium(1.3, 4.6, 1.1, 0.4), "loop"), speed_mps=0.8, name="colleague",
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
    """A rectangular room with random convex polygons that do not overlap.

    For benchmarks: every wall is a straight segment, so the ground truth is pure lines.
    Obstacles keep 0.5 m from each other and from the room walls, and leave a 1.5 m
    clear disc around the room's centre for the robot.

    Parameters
    ----------
    seed : int
        The seed of the room.
    n_obstacles : int
        How many polygons.
    room_size_m : tuple of (float, float)
        The room's width and depth, metres.
    min_side_m : float
        The smallest size of a polygon (the diameter of the circle its corners lie on), metres.
    max_side_m : float
        The largest size of a polygon, metres.

    Returns
    -------
    World
        The room.
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
WORLDS = {"hall": _hall, "corridor": _corridor, "office": _office, "crossing": crossing}


def make_world(name: str) -> World:
    """Build a named world.

    Parameters
    ----------
    name : str
        ``hall``, ``corridor``, ``office``, ``crossing[_N]`` (N walkers, 1-6; 4 without) or
        ``random_polygons[_SEED]``.

    Returns
    -------
    World
        The world.
    """
    if name.startswith("random_polygons"):
        rest = name[len("random_polygons"):].lstrip("_")
        return random_polygons(int(rest) if rest else 0)
    if name.startswith("crossing_") and name[len("crossing_"):].isdigit():
        return crossing(int(name[len("crossing_"):]))
    try:
        return WORLDS[name]()
    except KeyError:
        raise ValueError(
            f"world must be one of {sorted(WORLDS) + ['crossing_<n>', 'random_polygons_<seed>']}, got {name!r}"
        ) from None
