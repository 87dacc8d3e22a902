"""The incremental (line-tracking) extractor against closed-form geometry and the simulator's
ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from labkit import Scan
from labkit.lines.incremental import incremental_lines
from labkit.noise import FIXED_INCREMENTAL
from tests.line_scans import wall_rates, wall_scan


# ---------------------------------------------------------------------------- closed form cases
@pytest.mark.parametrize("step_m, n_lines", [(0.02, 1), (0.04, 1), (0.08, 2), (0.15, 2)])
def test_the_line_condition_is_max_error_m(step_m, n_lines):
    """Two parallel walls x = 2 and x = 2 + step, met at the beam straight ahead: a step
    smaller than max_error_m (the fixed 0.05 m) keeps one line, a larger one starts a new line there."""
    theta = np.radians(np.arange(-30.0, 30.25, 0.5))
    ranges = np.where(theta < 0, 2.0, 2.0 + step_m) / np.cos(theta)
    lines = incremental_lines(Scan(ranges=ranges, angles=theta), **FIXED_INCREMENTAL)
    assert len(lines) == n_lines
    if n_lines == 2:
        assert [ln.r for ln in lines] == pytest.approx([2.0, 2.0 + step_m], abs=1e-9)
        assert (lines[0].last, lines[1].first) == (59, 60)


def test_a_smaller_max_error_splits_a_noisy_wall():
    """On a wall with 2 cm noise (points up to 6 cm off the line) the fixed 5 cm keeps few lines;
    a 1 cm tolerance, below the noise, shatters the wall."""
    scan = wall_scan(2.0, 0.3, fov=(-0.5, 1.1))
    rng = np.random.default_rng(5)
    scan = scan.replace(ranges=scan.ranges + rng.normal(0.0, 0.02, scan.n_beams))
    fixed = incremental_lines(scan, **FIXED_INCREMENTAL)
    assert len(incremental_lines(scan, **{**FIXED_INCREMENTAL, "max_error_m": 0.01}, min_length_m=0.0)) > 3 * len(fixed)


# ---------------------------------------------------------------------------- ground truth
@pytest.mark.parametrize("world, min_tp, max_fp", [
    ("office", 0.95, 0.08),
    ("corridor", 0.88, 0.25),
    ("random_polygons_1", 0.97, 0.08),
])
def test_walls_of_simulated_worlds_are_found(world, min_tp, max_fp):
    """Scored as split-and-merge is (``tests/test_split_merge.py::score``), 20 scans each.
    Measured, seeds 0 / 1 / 2 / 3: office (XV-11, 15 mm noise, 2 % dropouts) true positives
    0.993 / 0.993 / 0.986 / 1.000, false positives 0.017 / 0.017 / 0.029 / 0.028; corridor
    (LMS111) 0.926 / 0.916 / 0.926 / 0.947 and 0.162 / 0.174 / 0.167 / 0.143 -- the short
    sides of door recesses, seen end-on, lose or keep a beam of the next wall, which no
    line after them can take back; random_polygons_1 (LMS200) 1.000 every time, false
    positives 0.031 / 0.000 / 0.006 / 0.031. The bounds leave room for other seeds."""
    tp, fp, eligible = wall_rates(incremental_lines, world)
    assert eligible > 90
    assert tp >= min_tp
    assert fp <= max_fp
