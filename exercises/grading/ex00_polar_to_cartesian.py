"""Hidden tests of exercise 0, ``beams_to_points(ranges, angles, range_min, range_max)`` -> ``(points, indices)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, assert_beams_result, random_beams

FUNCTIONS = ("beams_to_points",)


def test_visible(beams_to_points, rng):
    """The visible examples again, turned and scaled (range_min and range_max with them): the same beams
    are valid, and the points turn and scale with the plane. Earned by a function, not by the answers."""
    moved = Moved(rng, shift=False)
    half = np.sqrt(0.5)
    examples = [
        ([1.0, 2.0], [0.0, np.pi / 2], 0.0, 10.0, [[1.0, 0.0], [0.0, 2.0]], [0, 1]),
        ([np.sqrt(2.0), 3.0], [np.pi / 4, np.pi], 0.0, 10.0, [[1.0, 1.0], [-3.0, 0.0]], [0, 1]),
        ([np.nan, 1.0, np.inf, 0.0, -1.0, 5.0, 0.05, 2.0], np.radians([-90, -45, 0, 30, 45, 90, 135, 180]), 0.1, 5.0,
         [[half, -half], [-2.0, 0.0]], [1, 7]),
        ([0.1, 5.0], [0.0, 1.0], 0.1, 5.0, [[0.1, 0.0]], [0]),
        ([np.nan, 0.0], [0.0, 1.0], 0.1, 5.0, np.zeros((0, 2)), []),
    ]
    for k, (ranges, angles, range_min, range_max, points, indices) in enumerate(examples):
        s = moved.scale
        result = beams_to_points(s * np.asarray(ranges), np.asarray(angles, dtype=float) + moved.angle,
                                 s * range_min, s * range_max)
        try:
            assert_beams_result(result, moved.points(points), np.asarray(indices, dtype=np.int64))
        except AssertionError as error:
            raise AssertionError(f"visible example {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}: "
                                 f"{error}") from None


def test_hidden_random(beams_to_points, rng):
    """50 random scans of up to 720 beams with every kind of invalid reading, against ``labkit.Scan``."""
    for trial in range(50):
        beams = random_beams(rng)
        reference = labkit.Scan(**beams)
        result = beams_to_points(beams["ranges"], beams["angles"], beams["range_min"], beams["range_max"])
        try:
            assert_beams_result(result, reference.xy, reference.valid_indices)
        except AssertionError as error:
            raise AssertionError(f"random scan {trial} ({beams['ranges'].size} beams): {error}") from None


def test_hidden_edges(beams_to_points, rng):
    """Empty scans, single beams, scans without a valid reading, lists, and mismatched lengths."""
    cases = [random_beams(rng, 0) for _ in range(2)]
    cases += [random_beams(rng, 1, invalid_fraction=f) for f in (0.0, 1.0) for _ in range(4)]
    cases += [random_beams(rng, invalid_fraction=1.0, max_beams=50) for _ in range(4)]
    for case, beams in enumerate(cases):
        reference = labkit.Scan(**beams)
        for as_list in (False, True):
            ranges, angles = beams["ranges"], beams["angles"]
            if as_list:
                ranges, angles = ranges.tolist(), angles.tolist()
            result = beams_to_points(ranges, angles, beams["range_min"], beams["range_max"])
            try:
                assert_beams_result(result, reference.xy, reference.valid_indices)
            except AssertionError as error:
                kind = "lists" if as_list else "arrays"
                raise AssertionError(f"edge case {case} ({len(ranges)} beams, {kind}): {error}") from None

    for n_ranges, n_angles in [(3, 2), (2, 3), (0, 1), (1, 0)]:
        try:
            beams_to_points(np.ones(n_ranges), np.linspace(0.0, 1.0, n_angles), 0.0, 10.0)
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError(f"{n_ranges} ranges and {n_angles} angles must raise ValueError")


def test_own_work(beams_to_points, rng):
    """Five more random scans: right answers where labkit cannot be imported."""
    for _ in range(5):
        beams = random_beams(rng)
        reference = labkit.Scan(**beams)
        result = beams_to_points(beams["ranges"], beams["angles"], beams["range_min"], beams["range_max"])
        assert_beams_result(result, reference.xy, reference.valid_indices)


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"beams_to_points": '''
import labkit


def beams_to_points(ranges, angles, range_min, range_max):
    scan = labkit.Scan(ranges=ranges, angles=angles, range_min=range_min, range_max=range_max)
    return scan.xy, scan.valid_indices
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "a reading of exactly range_max counts as a return": ("(ranges < range_max)", "(ranges <= range_max)"),
    "a reading exactly at range_min is dropped": ("(ranges >= range_min)", "(ranges > range_min)"),
}
