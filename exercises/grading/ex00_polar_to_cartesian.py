"""Hidden tests of exercise 0, ``beams_to_points(ranges, angles, range_min, range_max)`` -> ``(points, indices)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import assert_beams_result, random_beams


def _check(beams_to_points, beams, what, as_list=False):
    reference = labkit.Scan(**beams)
    ranges, angles = beams["ranges"], beams["angles"]
    if as_list:
        ranges, angles = ranges.tolist(), angles.tolist()
    result = beams_to_points(ranges, angles, beams["range_min"], beams["range_max"])
    try:
        assert_beams_result(result, reference.xy, reference.valid_indices)
    except AssertionError as error:
        count = f"{len(ranges)} beam{'s' if len(ranges) != 1 else ''}{', as lists' if as_list else ''}"
        raise AssertionError(f"{what} ({count}): {error}") from None


def test_hidden_random(beams_to_points, rng):
    """50 random scans of up to 720 beams with every kind of invalid reading, against ``labkit.Scan``."""
    for trial in range(50):
        _check(beams_to_points, random_beams(rng), f"random scan {trial}")


def test_hidden_edges(beams_to_points, rng):
    """Empty scans, single beams, scans without a valid reading, lists, and mismatched lengths."""
    cases = [("an empty scan", random_beams(rng, 0)) for _ in range(2)]
    cases += [("a single valid beam" if f == 0.0 else "a single invalid beam", random_beams(rng, 1, invalid_fraction=f))
              for f in (0.0, 1.0) for _ in range(4)]
    cases += [("a scan without a valid reading", random_beams(rng, invalid_fraction=1.0, max_beams=50))
              for _ in range(4)]
    for _ in range(4):  # readings exactly at range_min (valid) and exactly at range_max (no return)
        beams = random_beams(rng, int(rng.integers(4, 40)), invalid_fraction=0.0)
        beams["range_min"] = max(beams["range_min"], 0.01)
        at = rng.permutation(beams["ranges"].size)
        beams["ranges"][at[:2]] = beams["range_min"]
        beams["ranges"][at[2:4]] = beams["range_max"]
        cases.append(("readings exactly at range_min and at range_max", beams))
    for what, beams in cases:
        for as_list in (False, True):
            _check(beams_to_points, beams, what, as_list)

    for _ in range(4):
        n_ranges, n_angles = (int(n) for n in rng.choice(6, size=2, replace=False))
        try:
            beams_to_points(np.ones(n_ranges), np.linspace(0.0, 1.0, n_angles), 0.0, 10.0)
        except ValueError:
            pass  # graded: the type (ValueError); naming the argument is good practice
        else:
            raise AssertionError("ranges and angles of different lengths must raise ValueError")


def test_own_work(beams_to_points, rng):
    """Five more random scans: right answers where labkit cannot be imported."""
    for trial in range(5):
        _check(beams_to_points, random_beams(rng), f"own-work scan {trial}")


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
