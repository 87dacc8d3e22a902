"""Exercise 2: ``fit_line(rho, theta)`` -> ``(r, alpha)``, the weighted (w = 1/rho) least-squares line."""

from . import ExerciseSpec

CHEATER = '''
import labkit


def fit_line(rho, theta):
    fit = labkit.fit_line_polar(rho, theta)
    return fit.r, fit.alpha
'''

SPEC = ExerciseSpec(
    name="ex02_weighted_line_fit",
    solutions={"fit_line": "def fit_line(rho, theta):"},
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"fit_line": CHEATER},
    caught=r"labkit\.fitting\.fit_line_polar",
    mistakes={
        "unweighted fit": ("w = 1.0 / rho", "w = np.ones_like(rho)"),
        "r may come out negative": ("if r < 0:", "if False:"),
        "alpha is not wrapped into (-pi, pi]": ("alpha = np.pi - (np.pi - alpha) % (2 * np.pi)", "pass"),
    },
)
