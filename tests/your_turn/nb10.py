"""Fill-ins for notebooks/10_evaluation.ipynb: the normal-form test of the matching rule, the two rates."""

from tests.your_turn import Fill

_HEAD = ('def normal_form_match(line_r, line_alpha, wall_r, wall_alpha, max_dr_m=0.05, '
         'max_dalpha=math.radians(3)):\n')
_RATES = "def rates(n_truth, n_matched, n_scored):\n"

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
}
