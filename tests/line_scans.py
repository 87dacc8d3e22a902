"""Scans and checks shared by the tests of the line extractors (``tests/test_line_extractors.py``
and the tests of each extractor)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit import Scan
from labkit.sim import Lidar, Wall, World, scan_at, scenario, simulate
from tests.test_split_merge import room_scan, score, wall_scan

__all__ = ["HEXAGON_ROOM", "ROOM", "SQUARE_ROOM", "check_room", "doorway_scan", "key", "noiseless", "polygon_scan",
           "room_scan", "rounded", "score", "wall_of", "wall_scan"]

#: The 6 x 4 m room of ``room_scan``, its walls y = -2, x = 3, y = 2 and x = -3.
ROOM = (Wall((-3, -2), (3, -2)), Wall((3, -2), (3, 2)), Wall((3, 2), (-3, 2)), Wall((-3, 2), (-3, -2)))

#: A square room around the sensor (not centred on it): walls as (r m, alpha rad).
SQUARE_ROOM = ((2.3, 0.0), (1.7, math.pi / 2), (2.9, math.pi), (1.2, -math.pi / 2))

#: A hexagonal room whose wall normals point into all four quadrants (20, 75, 140, -160,
#: -100 and -40 degrees), so lines of every orientation and both signs of cos and sin occur.
HEXAGON_ROOM = tuple((r, math.radians(a)) for r, a in
                     ((2.0, 20.0), (1.5, 75.0), (2.5, 140.0), (1.8, -160.0), (2.2, -100.0), (1.6, -40.0)))


def rounded(lines) -> list[tuple[float, float, int, int]]:
    """(r, alpha in degrees, first, last) of every line, rounded (r to 1e-5 m: the simulator
    stores ranges as float32)."""
    return [(round(ln.r, 5), round(math.degrees(ln.alpha), 4) + 0.0, ln.first, ln.last) for ln in lines]


def key(lines):
    """Every line exactly: (r, alpha, beam indices)."""
    return [(ln.r, ln.alpha, ln.indices.tolist()) for ln in lines]


def noiseless(world: World, fov_deg: float = 180.0, step_deg: float = 0.5, full_circle: bool = False):
    """``(scan, truth)`` of a noise-free lidar at the origin in ``world``."""
    lidar = Lidar.from_fov("test", fov_deg, step_deg, full_circle=full_circle, range_max=20.0, noise_std_m=0.0)
    return scan_at(world, lidar, (0.0, 0.0, 0.0), 0.0)


def polygon_scan(walls, n: int = 720) -> Scan:
    """A noiseless full-circle scan of ``n`` beams from inside a convex room given by its walls'
    normal forms ``(r, alpha)``: each beam ends on the first wall it meets, at range
    ``r / cos(theta - alpha)`` (the smallest over the walls it points towards)."""
    angles = -math.pi + 2 * math.pi / n * np.arange(n)
    r = np.array([w[0] for w in walls])
    alpha = np.array([w[1] for w in walls])
    c = np.cos(angles[:, None] - alpha[None, :])
    ranges = np.where(c > 1e-12, r / np.where(c > 1e-12, c, 1.0), np.inf).min(axis=1)
    return Scan(ranges=ranges, angles=angles, range_max=100.0)


def doorway_scan(width_m: float) -> Scan:
    """The wall y = 2 m, seen from the origin, with a doorway of ``width_m`` centred on x = 0
    (its beams see nothing: NaN)."""
    theta = np.radians(np.arange(30.0, 150.25, 0.25))
    ranges = 2.0 / np.sin(theta)
    ranges[np.abs(2.0 / np.tan(theta)) < width_m / 2] = np.nan
    return Scan(ranges=ranges, angles=theta)


def wall_of(line, walls) -> int:
    """Index of the wall ``(r, alpha)`` nearest to ``line`` (|dr| + |dalpha| in m and rad)."""
    return int(np.argmin([abs(line.r - r) + abs(math.remainder(line.alpha - a, 2 * math.pi)) for r, a in walls]))


def check_room(lines, walls, n_beams: int, r_tol: float, alpha_tol: float) -> None:
    """Every wall found, every line on a wall within the tolerances, lines in scan order with
    disjoint beams; the wall seen across the seam (direction pi) is cut there into two segments."""
    assert [ln.first for ln in lines] == sorted(ln.first for ln in lines)
    found = [wall_of(ln, walls) for ln in lines]
    assert sorted(set(found)) == list(range(len(walls)))
    assert len(lines) == len(walls) + 1  # one wall seen across the seam: two segments
    for ln, k in zip(lines, found, strict=True):
        r, alpha = walls[k]
        assert ln.r == pytest.approx(r, abs=r_tol)
        assert abs(math.remainder(ln.alpha - alpha, 2 * math.pi)) <= alpha_tol
        assert -math.pi < ln.alpha <= math.pi
        assert np.all(np.diff(ln.indices) > 0) and ln.first == ln.indices[0] and ln.last == ln.indices[-1]
    beams = np.concatenate([ln.indices for ln in lines])
    assert len(set(beams.tolist())) == beams.size  # no beam in two lines
    assert lines[0].first == 0 and lines[-1].last == n_beams - 1
    assert found[0] == found[-1] and abs(walls[found[0]][1]) > 2.5  # the wall behind, across the seam


def wall_rates(extract, world: str, n_scans: int = 20, seed: int = 0) -> tuple[float, float, int]:
    """(true-positive rate, false-positive rate, walls scored) of ``extract(scan)`` over
    ``n_scans`` scans of a bundled scenario, scored by ``tests.test_split_merge.score``."""
    n_walls = len(scenario(world).world.walls)
    tp = eligible = fp = on_walls = 0
    for scan, truth in simulate(world, seed, n_scans=n_scans):
        a, b, c, d = score(extract(scan), truth, n_walls)
        tp, eligible, fp, on_walls = tp + a, eligible + b, fp + c, on_walls + d
    return tp / eligible, fp / max(on_walls, 1), eligible
