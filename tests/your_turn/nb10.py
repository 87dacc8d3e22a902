"""Fill-ins for notebooks/10_evaluation.ipynb (the normal-form test of the matching rule, the two rates) and
notebooks/10b_comparing_extractors.ipynb (the ray-axis error of one beam, the three-beam residual of the range
noise estimate): both notebooks start with "10", so both read this file."""

from tests.your_turn import Fill

_HEAD = ('def normal_form_match(line_r, line_alpha, wall_r, wall_alpha, max_dr_m=0.05, '
         'max_dalpha=math.radians(3)):\n')
_RATES = "def rates(n_truth, n_matched, n_scored):\n"
_RESIDUAL = "def three_beam_residual(r_prev, r_mid, r_next, dtheta):\n"
_RAY = "def ray_axis_error(range_m, angle, line_r, line_alpha):\n"

FILLS = {
    "ceb8ee6d": Fill(
        correct=_HEAD + ("    dalpha = labkit.angle_difference(line_alpha, wall_alpha)\n"
                         "    return bool(abs(line_r - wall_r) <= max_dr_m and abs(dalpha) <= max_dalpha)\n"),
        # the angle difference taken as it comes: 179.5 deg and -179.5 deg look 359 deg apart
        mistake=_HEAD + ("    dalpha = line_alpha - wall_alpha\n"
                         "    return bool(abs(line_r - wall_r) <= max_dr_m and abs(dalpha) <= max_dalpha)\n"),
        hint="wrap the angle difference",
    ),
    "00ef5576": Fill(
        correct=_RATES + "    return n_matched / n_truth, (n_scored - n_matched) / n_scored\n",
        # both rates over the walls: FalsePos with TruePos's denominator
        mistake=_RATES + "    return n_matched / n_truth, (n_scored - n_matched) / n_truth\n",
        hint="not by the walls",
    ),
    "e4b8d150": Fill(
        correct=_RESIDUAL + ("    u_prev, u_mid, u_next = 1 / r_prev, 1 / r_mid, 1 / r_next\n"
                             "    return r_mid ** 2 * (u_mid - (u_prev + u_next) / (2 * np.cos(dtheta)))\n"),
        # the neighbours' plain mean: on a wall the inverse ranges are a sinusoid, not a straight line
        mistake=_RESIDUAL + ("    u_prev, u_mid, u_next = 1 / r_prev, 1 / r_mid, 1 / r_next\n"
                             "    return r_mid ** 2 * (u_mid - (u_prev + u_next) / 2)\n"),
        hint="divide their sum by 2 cos(dtheta)",
    ),
    "a1f0c2d7": Fill(
        correct=_RAY + ("    c = math.cos(angle - line_alpha)\n"
                        "    return range_m - line_r / c if c > 0 else math.nan\n"),
        # the distance across the line (the perpendicular one), not along the beam's ray
        mistake=_RAY + "    return range_m * math.cos(angle - line_alpha) - line_r\n",
        hint="measure along the ray",
    ),
}
