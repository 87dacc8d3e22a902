"""Exercise 3: ``split_index(points, threshold_m, min_points)`` (IEPF split) and
``similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max)`` (the wrap-safe merge test)."""

from . import ExerciseSpec

CHEATER_SPLIT = '''
import labkit


def split_index(points, threshold_m, min_points):
    points = np.asarray(points, dtype=float)
    r, alpha = labkit.line_through_points(points[0], points[-1])
    distance = np.abs(labkit.geometry.signed_distance_to_line(points, r, alpha))
    keep = min_points // 2
    lo, hi = (keep, len(points) - keep) if len(points) > 2 * keep else (0, len(points))
    worst = lo + int(np.argmax(distance[lo:hi]))
    return worst if distance[worst] > threshold_m else None
'''

CHEATER_SIMILAR = '''
import labkit


def similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max):
    def line(r, alpha):
        return labkit.LineSegment(r=r, alpha=alpha, covariance=np.eye(2), start=np.zeros(2), end=np.ones(2),
                                  first=0, last=1, n_points=2, error=0.0, indices=np.arange(2))

    return labkit.lines_similar(line(r1, alpha1), line(r2, alpha2), merge_dr_m=dr_max, merge_dalpha=dalpha_max)[0]
'''

SPEC = ExerciseSpec(
    name="ex03_split_and_merge",
    solutions={
        "split_index": "def split_index(points, threshold_m, min_points):",
        "similar": "def similar(r1, alpha1, r2, alpha2, dr_max, dalpha_max):",
    },
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"split_index": CHEATER_SPLIT, "similar": CHEATER_SIMILAR},
    caught=r"labkit\.geometry\.line_through_points",
    mistakes={
        "the ends of the run are not protected": ("keep = min_points // 2", "keep = 0"),
        "angles compared without wrapping": ("dalpha = wrap(alpha2 - alpha1)", "dalpha = alpha2 - alpha1"),
        "normals never turned around": ("if abs(dalpha) > np.pi / 2:", "if False:"),
    },
)
