"""Fill-ins for notebooks/02_weighted_line_fitting.ipynb (see tests/your_turn/__init__.py)."""

from tests.your_turn import Fill

_ALPHA = '''def closed_form_alpha(rho, theta, w):
    W = w.sum()
    sum_x, sum_y = np.sum(w * rho * np.cos(theta)), np.sum(w * rho * np.sin(theta))
    two_s_uv = np.sum(w * rho**2 * np.sin(2 * theta)) - 2 / W * sum_x * sum_y
    s_uu_minus_s_vv = np.sum(w * rho**2 * np.cos(2 * theta)) - (sum_x**2 - sum_y**2) / W
    return {angle} + np.pi / 2
'''

_NORMAL = '''def normal_form(r, alpha):
    if r < 0:
        r, alpha = -r, {turned}
    return r, np.pi - (np.pi - alpha) % (2 * np.pi)
'''

FILLS = {
    "c008": Fill(
        correct=_ALPHA.format(angle="0.5 * np.arctan2(two_s_uv, s_uu_minus_s_vv)"),
        mistake=_ALPHA.format(angle="0.5 * np.arctan(two_s_uv / s_uu_minus_s_vv)"),
        hint="atan loses the quadrant",
    ),
    "c008-normal": Fill(
        correct=_NORMAL.format(turned="alpha + np.pi"),
        mistake=_NORMAL.format(turned="alpha"),
        hint="turn the normal around, (-r, alpha + pi)",
    ),
}
