"""Exercise 6: ``inscribed_angles(points)`` and ``is_circle(points, std_max, mean_range)``, the Inscribed Angle
Variance circle test (Xavier et al. 2005, Sec. II-B)."""

from . import ExerciseSpec

CHEATER = '''
import labkit


def inscribed_angles(points):
    return labkit.inscribed_angles(points)


def is_circle(points, std_max=0.15, mean_range=(np.pi / 2, 3 * np.pi / 4)):
    try:
        mean, std, _ = labkit.iav_stats(points)
    except ValueError:
        return False
    return bool(std < std_max and mean_range[0] <= mean <= mean_range[1])
'''

SPEC = ExerciseSpec(
    name="ex06_iav",
    solutions={
        "iav": "def inscribed_angles(points):\n"
        "def is_circle(points, std_max=0.15, mean_range=(np.pi / 2, 3 * np.pi / 4)):"
    },
    points={"test_visible": 2, "test_hidden_random": 4, "test_hidden_edges": 2, "test_own_work": 2},
    cheater={"iav": CHEATER},
    caught=r"labkit\.iav\.inscribed_angles",
    mistakes={
        "degrees instead of radians": (
            "return np.arccos(np.clip(cosine, -1.0, 1.0))", "return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))"
        ),
        "arccos without clipping the cosine (nan on straight lines)": ("np.clip(cosine, -1.0, 1.0)", "cosine"),
        "the ray from P_1 to P_i instead of P_i to P_1 (pi minus the angle)": ("a = p[0] - inner", "a = inner - p[0]"),
        "mean and standard deviation swapped": (
            "mean, std = angles.mean(), angles.std()", "std, mean = angles.mean(), angles.std()"
        ),
        "sample standard deviation (ddof=1) instead of the population one": ("angles.std()", "angles.std(ddof=1)"),
    },
)
