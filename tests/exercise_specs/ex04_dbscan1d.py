"""Exercise 4: ``neighbourhood_bounds(x, eps)`` -> ``(L, U)`` and ``dbscan_sorted(x, eps, min_pts)`` -> labels,
DBSCAN in O(N) on sorted 1-D data (Meglicki 2021, Algorithms 1-4)."""

from . import ExerciseSpec

CHEATER = '''
from labkit.dbscan1d import dbscan1d


def neighbourhood_bounds(x, eps):
    x = np.asarray(x, dtype=np.float64)
    return np.searchsorted(x, x - eps, side="left"), np.searchsorted(x, x + eps, side="right") - 1


def dbscan_sorted(x, eps, min_pts):
    return dbscan1d(x, eps, min_pts)
'''

SPEC = ExerciseSpec(
    name="ex04_dbscan1d",
    solutions={"dbscan": "def neighbourhood_bounds(x, eps):\ndef dbscan_sorted(x, eps, min_pts):"},
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"dbscan": CHEATER},
    caught=r"labkit\.dbscan1d\.dbscan1d",
    mistakes={
        "neighbours strictly closer than eps (< instead of <=)": (
            "abs(xs[u] - xs[i]) <= eps", "abs(xs[u] - xs[i]) < eps"
        ),
        "the point itself not counted in its neighbourhood": (
            "size = (upper - lower + 1).tolist()", "size = (upper - lower).tolist()"
        ),
        "a border point between two clusters joins the later one": (
            "if labels[j] == noise:", "if labels[j] != not_visited:"
        ),
        "noise on the left of a cluster's first core point never becomes a border point": (
            "for j in range(lower[p], p):", "for j in range(p, p):"
        ),
    },
)
