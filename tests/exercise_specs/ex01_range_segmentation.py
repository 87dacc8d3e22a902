"""Exercise 1: ``segment(ranges, angles, threshold_m, min_points)`` -> labels per beam."""

from . import ExerciseSpec

CHEATER = '''
import labkit


def segment(ranges, angles, threshold_m, min_points):
    scan = labkit.Scan(ranges=ranges, angles=angles)
    return labkit.segment_labels(scan, threshold_m, min_points=min_points)
'''

SPEC = ExerciseSpec(
    name="ex01_range_segmentation",
    solutions={"segment": "def segment(ranges, angles, threshold_m, min_points):"},
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"segment": CHEATER},
    caught=r"labkit\.segmentation\.segment_labels",
    mistakes={
        "rejected segments keep their numbers": ("number = np.cumsum(kept) - 1", "number = np.arange(kept.size)"),
        "a segment of exactly min_points beams is rejected": ("sizes >= min_points", "sizes > min_points"),
        "zero and negative readings count as valid": (
            "valid = np.isfinite(ranges) & (ranges > 0)", "valid = np.isfinite(ranges)"
        ),
    },
)
