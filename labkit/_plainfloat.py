"""Plain-float copies of two :mod:`labkit.geometry` functions, for loops over a few lines (private).

For 2-vectors and single angles, Python's ``math`` is several times faster than numpy's
per-call overhead; :func:`labkit.find_corners` calls these once per pair of lines.
``tests/test_features.py`` checks that they give the same numbers as the numpy versions.
"""

from __future__ import annotations

import math


def wrap1(angle: float) -> float:
    """:func:`labkit.geometry.wrap_angle` of one float, in plain Python (the same arithmetic)."""
    return math.pi - (math.pi - angle) % (2 * math.pi)


def intersect1(r1: float, alpha1: float, r2: float, alpha2: float) -> tuple[float, float] | None:
    """:func:`labkit.geometry.intersect_lines` in plain floats: the 2x2 system
    ``[cos a1, sin a1; cos a2, sin a2] p = [r1, r2]`` solved by Gaussian elimination with
    partial pivoting, as ``np.linalg.solve`` does; ``None`` for (nearly) parallel lines."""
    c1, s1, c2, s2 = math.cos(alpha1), math.sin(alpha1), math.cos(alpha2), math.sin(alpha2)
    if abs(c2) > abs(c1):  # pivot: the row with the larger first coefficient goes first
        c1, s1, r1, c2, s2, r2 = c2, s2, r2, c1, s1, r1
    f = c2 * (1.0 / c1)  # eliminate the first unknown from the second row
    u = s2 - f * s1
    if abs(c1 * u) < 1e-12:  # the determinant
        return None
    y = (r2 - f * r1) / u
    return (r1 - s1 * y) / c1, y


