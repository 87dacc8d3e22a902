"""Fill-ins for notebooks/03_line_uncertainty_and_weights.ipynb (see tests/your_turn/__init__.py)."""

from tests.your_turn import Fill

_JACOBIAN = '''def jacobian(rho, theta, w, h=1e-6):
    J = np.empty((2, len(rho)))
    for i in range(len(rho)):
        step = np.zeros(len(rho))
        step[i] = h
        up = labkit.fit_line_polar(rho + step, theta, {weights})
        down = labkit.fit_line_polar(rho - step, theta, {weights})
        J[0, i] = (up.r - down.r) / (2 * h)
        J[1, i] = labkit.angle_difference(up.alpha, down.alpha) / (2 * h)
    return J
'''

_WEIGHTS = '''def ideal_weights(sigma, theta, alpha):
    return {formula}
'''

FILLS = {
    "c030-yt": Fill(
        correct=_JACOBIAN.format(weights="w"),
        # the weights follow the nudged ranges (and ignore the w given): on this noise-free wall the fit's
        # derivative does not feel the weights to first order, so the uniform-weights case is what catches it
        mistake=_JACOBIAN.format(weights="1 / (rho + step)"),
        hint="use the weights w you are given",
    ),
    "c020-yt": Fill(
        correct=_WEIGHTS.format(formula="1 / (np.asarray(sigma) * np.cos(np.asarray(theta) - alpha)) ** 2"),
        mistake=_WEIGHTS.format(formula="1 / np.broadcast_to(np.asarray(sigma) ** 2, np.shape(theta))"),
        hint="Var(d) = sigma^2 cos^2(theta - alpha)",
    ),
}
