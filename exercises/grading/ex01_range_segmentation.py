"""Hidden tests of exercise 1, ``segment(ranges, angles, threshold_m, min_points)`` -> one label per beam.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.
"""

import numpy as np

import labkit
from labkit.grading import Moved, assert_labels_result, random_wall_beams

FUNCTIONS = ("segment",)


def test_visible(segment, rng):
    """The visible examples again, turned and scaled (the threshold with them): every gap scales as the
    threshold does, so the labels stay. Earned by a function, not by a table of the visible answers."""
    moved = Moved(rng, shift=False)
    walls, degrees = [1.0, 1.0, 1.0, 3.0, 3.0, np.nan, 2.0], np.radians(np.arange(7.0))
    holes = [1.0, 1.0, 0.0, 1.0, 1.0, np.inf, 1.0, -1.0, 1.0, 1.0]
    examples = [
        (walls, degrees, 0.08, 2, [0, 0, 0, 1, 1, -1, -1]),
        (walls, degrees, 0.08, 1, [0, 0, 0, 1, 1, -1, 2]),
        (walls, degrees, 0.08, 3, [0, 0, 0, -1, -1, -1, -1]),
        (walls, degrees, 0.04, 2, [0, 0, 0, -1, -1, -1, -1]),
        (holes, np.radians(np.arange(10.0)), 0.08, 2, [0, 0, -1, 1, 1, -1, -1, -1, 2, 2]),
    ]
    for k, (ranges, angles, threshold_m, min_points, labels) in enumerate(examples):
        s = moved.scale
        result = segment(s * np.asarray(ranges), angles + moved.angle, s * threshold_m, min_points)
        try:
            assert_labels_result(result, np.asarray(labels, dtype=np.int64))
        except AssertionError as error:
            raise AssertionError(f"visible example {k + 1}, turned by {moved.angle:.3f} rad and scaled by {s}: "
                                 f"{error}") from None


def test_hidden_random(segment, rng):
    """60 random scans of walls (thresholds 3 to 30 cm, min_points 1 to 6) against ``labkit.segment_labels``."""
    for trial in range(60):
        beams = random_wall_beams(rng)
        threshold_m = float(rng.uniform(0.03, 0.3))
        min_points = int(rng.integers(1, 7))
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m, min_points=min_points)
        ranges, angles = beams["ranges"], beams["angles"]
        result = segment(ranges, angles, threshold_m, min_points)
        try:
            assert_labels_result(result, reference)
        except AssertionError as error:
            setting = f"{ranges.size} beams, threshold_m={threshold_m:.3f}, min_points={min_points}"
            raise AssertionError(f"random scan {trial} ({setting}): {error}") from None


def test_hidden_edges(segment, rng):
    """Empty and one-beam scans, no valid beam, huge thresholds and min_points, lists, mismatched lengths."""
    cases = [({"ranges": np.zeros(0), "angles": np.zeros(0)}, 0.08, 2)]
    cases += [({"ranges": np.array([r]), "angles": np.array([0.3])}, 0.08, m) for r in (1.0, np.nan) for m in (1, 2)]
    cases += [({"ranges": np.array([1.0, np.nan, 1.0]), "angles": np.array([0.0, 0.001, 0.002])}, 0.08, 1)]
    cases += [(random_wall_beams(rng, n), 0.1, m) for n in (2, 2, 3, 3) for m in (1, 2)]
    cases += [(random_wall_beams(rng, invalid_fraction=1.0, max_beams=50), 0.1, 1) for _ in range(3)]
    cases += [(random_wall_beams(rng, max_beams=200), 1e9, 1) for _ in range(3)]
    cases += [(random_wall_beams(rng, max_beams=30), 0.5, 1000) for _ in range(2)]
    for case, (beams, threshold_m, min_points) in enumerate(cases):
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m, min_points=min_points)
        for as_list in (False, True):
            ranges, angles = beams["ranges"], beams["angles"]
            if as_list:
                ranges, angles = ranges.tolist(), angles.tolist()
            result = segment(ranges, angles, threshold_m, min_points)
            try:
                assert_labels_result(result, reference)
            except AssertionError as error:
                setting = f"{len(ranges)} beams as {'lists' if as_list else 'arrays'}, threshold_m={threshold_m}, " \
                    f"min_points={min_points}"
                raise AssertionError(f"edge case {case} ({setting}): {error}") from None

    for n_ranges, n_angles in [(3, 2), (2, 3), (0, 1), (1, 0)]:
        try:
            segment(np.ones(n_ranges), np.linspace(0.0, 1.0, n_angles), 0.08, 2)
        except ValueError as error:
            assert "ranges" in str(error) and "angles" in str(error), f"name ranges and angles: {error}"
        else:
            raise AssertionError(f"{n_ranges} ranges and {n_angles} angles must raise ValueError")


def test_own_work(segment, rng):
    """Five more random scans: right answers where labkit cannot be imported."""
    for _ in range(5):
        beams = random_wall_beams(rng)
        threshold_m, min_points = float(rng.uniform(0.03, 0.3)), int(rng.integers(1, 7))
        reference = labkit.segment_labels(labkit.Scan(**beams), threshold_m, min_points=min_points)
        args = beams["ranges"], beams["angles"], threshold_m, min_points
        assert_labels_result(segment(*args), reference)


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"segment": '''
import labkit


def segment(ranges, angles, threshold_m, min_points):
    scan = labkit.Scan(ranges=ranges, angles=angles)
    return labkit.segment_labels(scan, threshold_m, min_points=min_points)
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "rejected segments keep their numbers": ("number = np.cumsum(kept) - 1", "number = np.arange(kept.size)"),
    "a segment of exactly min_points beams is rejected": ("sizes >= min_points", "sizes > min_points"),
    "zero and negative readings count as valid": (
        "valid = np.isfinite(ranges) & (ranges > 0)", "valid = np.isfinite(ranges)"
    ),
}
