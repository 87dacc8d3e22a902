"""Exercise 0: ``beams_to_points(ranges, angles, range_min, range_max)`` -> ``(points, indices)``."""

from . import ExerciseSpec

CHEATER = '''
import labkit


def beams_to_points(ranges, angles, range_min, range_max):
    scan = labkit.Scan(ranges=ranges, angles=angles, range_min=range_min, range_max=range_max)
    return scan.xy, scan.valid_indices
'''

LOOPER = '''
def beams_to_points(ranges, angles, range_min, range_max):
    while True:
        pass
'''

SPEC = ExerciseSpec(
    name="ex00_polar_to_cartesian",
    solutions={"beams_to_points": "def beams_to_points(ranges, angles, range_min, range_max):"},
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"beams_to_points": CHEATER},
    caught=r"labkit\.scan\.Scan",
    mistakes={
        "a reading of exactly range_max counts as a return": ("(ranges < range_max)", "(ranges <= range_max)"),
        "a reading exactly at range_min is dropped": ("(ranges >= range_min)", "(ranges > range_min)"),
    },
    looper={"beams_to_points": LOOPER},
)
