"""The cases of the course notebooks' "your turn" checks, kept here so that a check cell stays short.

A check cell reads ``f = check(f, cases.NAME(), fallback=fallbacks.NAME)``: the cases below give inputs
whose answers follow from geometry worked out by hand (written beside each case), and a hint for each;
:func:`labkit.course.check` runs them. No answer is written here, only the values it must give.
"""

from __future__ import annotations

import math

from .course import Case

__all__ = ["ray_axis_error", "three_beam_residual"]


def ray_axis_error() -> list[Case]:
    """Notebook 10b: cases of ``ray_axis_error(range_m, angle, line_r, line_alpha)``.

    Returns
    -------
    list of Case
        A beam along the line's normal, two slanted beams (walls ``x = 2`` and ``x + y = 2 sqrt(2)``)
        and a beam pointing away from the line (NaN).
    """
    return [
        Case((2.5, 0.0, 2.0, 0.0), 0.5, "a beam along the line's normal: its error is the range minus r"),
        Case((4.1, math.radians(60), 2.0, 0.0), 0.1,
             "60 deg off the normal the ray reaches the wall x = 2 at (2, 2 tan 60 deg), 4 m away: "
             "measure along the ray"),
        Case((1.9, math.radians(90), 2.0, math.radians(45)), 1.9 - 2.0 * math.sqrt(2),
             "the wall x + y = 2 sqrt(2) meets the y axis at y = 2 sqrt(2): measure along the ray"),
        Case((3.0, math.radians(100), 2.0, 0.0), math.nan,
             "a ray 100 deg from the normal points away from the line: it never meets it ahead of the sensor (NaN)"),
    ]


def _wall_ranges(d: float, alpha: float, thetas) -> tuple[float, ...]:
    """The ranges of beams at the angles ``thetas`` on the wall ``x cos(alpha) + y sin(alpha) = d``."""
    return tuple(float(d / math.cos(t - alpha)) for t in thetas)


def three_beam_residual() -> list[Case]:
    """Notebook 10b: cases of ``three_beam_residual(r_prev, r_mid, r_next, dtheta)``.

    Returns
    -------
    list of Case
        Three beams on a wall (0), three on a wall 70 degrees off its normal (0), a 1 cm error on the
        middle range of the first (about -1 cm, exactly ``-0.01 r_mid' / r_mid``), and three equal ranges,
        on a circle about the sensor (``r (1 - 1 / cos(dtheta))``).
    """
    step = math.radians(0.5)
    near = _wall_ranges(2.0, 0.0, [math.radians(10) - step, math.radians(10), math.radians(10) + step])
    steep = _wall_ranges(3.0, math.radians(-60), [math.radians(9), math.radians(10), math.radians(11)])
    bumped = (near[0], near[1] + 0.01, near[2])
    return [
        Case((*near, step), 0.0, "three points on one wall give 0: the neighbours' inverse ranges add up to "
             "2 cos(dtheta) times the middle one's, so divide their sum by 2 cos(dtheta)", atol=1e-12),
        Case((*steep, math.radians(1)), 0.0, "0 on a wall at any incidence: divide by 2 cos(dtheta)", atol=1e-12),
        Case((*bumped, step), -0.01 * bumped[1] / near[1],
             "a 1 cm error on the middle range gives about -1 cm: multiply the inverse-range residual by r_mid**2"),
        Case((3.0, 3.0, 3.0, math.radians(1)), 3.0 * (1 - 1 / math.cos(math.radians(1))),
             "equal ranges lie on a circle, which bends away from the chord: s = r (1 - 1 / cos(dtheta))"),
    ]
