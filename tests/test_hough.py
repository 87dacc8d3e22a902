"""Hough transform line extraction against closed-form geometry and the simulator's ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit.lines.hough import hough_lines
from tests.line_scans import HEXAGON_ROOM, SQUARE_ROOM, check_room, key, polygon_scan, wall_rates, wall_scan


# ---------------------------------------------------------------------------- closed form cases
@pytest.mark.parametrize("r, alpha", [(3.0, 0.4), (2.0123, 0.3), (1.4567, -2.9), (2.5, math.pi)])
def test_one_wall_gives_one_exact_line_on_or_off_the_grid(r, alpha):
    """The peak cell is only near the line (cells are 5 cm and 1 deg; 2.0123 m, 0.3 rad and -2.9
    rad are not on the grid): the least-squares refinement makes it exact."""
    lo = alpha - 0.7
    scan = wall_scan(r, alpha, fov=(lo, lo + 1.4))
    (line,) = hough_lines(scan)
    assert line.r == pytest.approx(r, abs=1e-9)
    assert abs(math.remainder(line.alpha - alpha, 2 * math.pi)) < 1e-9 and -math.pi < line.alpha <= math.pi
    assert (line.first, line.last, line.n_points) == (0, scan.n_beams - 1, scan.n_beams)


@pytest.mark.parametrize("walls", [SQUARE_ROOM, HEXAGON_ROOM], ids=["square", "hexagon"])
def test_room_walls(walls):
    """Noiseless rooms (the fixtures of tests/test_ransac.py; the hexagon's wall normals point
    into all four quadrants). A line also takes the few points of the next wall within 3 cm
    of it past a corner. Measured: at most 0.26 mm and 0.06 deg off (hexagon), 0.16 mm and
    0.001 deg in the square room."""
    scan = polygon_scan(walls)
    check_room(hough_lines(scan), walls, scan.n_beams, 1e-3, math.radians(0.1))


def test_room_walls_exact_with_fine_cells_and_a_tight_band():
    """With 1 mm cells and a 0.5 mm band, no point of a neighbouring wall votes for a wall's
    peak or joins its line: the square room's walls come out exact, and every beam is used."""
    scan = polygon_scan(SQUARE_ROOM)
    lines = hough_lines(scan, r_step_m=0.001, threshold_m=5e-4)
    check_room(lines, SQUARE_ROOM, scan.n_beams, 1e-9, 1e-9)
    assert sum(ln.n_points for ln in lines) == scan.n_beams


def test_a_far_point_switches_to_the_sparse_accumulator():
    """One return 5 km away makes the dense accumulator 360 x 100,002 cells; only the cells that
    got votes are counted then. That point is on no line, so the lines are those of the scan
    where that beam returns from 20 m, past the wall as well (in both the wall is cut there: the
    beam saw through it). A return beyond 2^24 cells (839 km at 5 cm) takes no part at all: the
    lines are those of the scan without it."""
    ranges = polygon_scan(SQUARE_ROOM).ranges.copy()
    ranges[100] = np.nan
    scan = polygon_scan(SQUARE_ROOM).replace(ranges=ranges, range_max=np.inf)
    without = key(hough_lines(scan))
    check_room(hough_lines(scan), SQUARE_ROOM, scan.n_beams, 1e-3, math.radians(0.1))
    ranges[100] = 20.0
    through = key(hough_lines(scan.replace(ranges=ranges)))
    assert len(through) == len(without) + 1  # the wall it passes is cut in two
    for far, expected in ((5000.0, through), (1e9, without)):
        ranges[100] = far
        assert key(hough_lines(scan.replace(ranges=ranges))) == expected


# ---------------------------------------------------------------------------- ground truth
#: (world, least true-positive rate, most false-positive rate) over 20 scans of seed 0
WORLDS = [("office", 0.95, 0.06), ("corridor", 0.90, 0.15), ("random_polygons_1", 0.98, 0.03)]


@pytest.mark.parametrize("world, min_tp, max_fp", WORLDS)
def test_walls_of_simulated_worlds_are_found(world, min_tp, max_fp):
    """Scored as split-and-merge is (tests/test_split_merge.py ``score``: walls of >= 10 beams and
    >= 0.3 m, a match within 5 cm and 3 deg). Measured over 20 scans, true positives / false
    positives per line on a wall, for seeds 0 / 1 / 2:

    * office (XV-11, 15 mm noise): 0.993 / 0.017, 1.000 / 0.006, 0.986 / 0.023
    * corridor (LMS111): 0.989 / 0.034, 0.979 / 0.051, 0.947 / 0.102 -- the misses are the backs
      of door recesses (0.4 m, 10-15 beams), tilted by the first points of the recess's side
      wall, and a wall seen at grazing incidence 15 m away
    * random_polygons_1 (LMS200): 1.000 / 0.000 for all three

    (split-and-merge: 1.000 / 0.042, 1.000 / 0.121, 1.000 / 0.031 for seed 0.) The bounds leave
    the margin of the spread over seeds; the test runs seed 0.
    """
    tp, fp, eligible = wall_rates(hough_lines, world)
    assert eligible >= 90
    assert tp >= min_tp
    assert fp <= max_fp
