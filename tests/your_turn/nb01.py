"""Fill-ins for notebooks/01_scans_and_segmentation.ipynb (see tests/your_turn/__init__.py)."""

from tests.your_turn import Fill

_CUT = '''def cut_points(scan, threshold_m=0.08):
    gaps = np.linalg.norm(np.diff(scan.points, axis=0), axis=1)
    return {test}
'''

_ADAPTIVE = '''def adaptive_threshold(r_a, r_b, dphi, threshold_m=0.08, incidence_deg=10.0, range_sigma_m=0.01):
    lam = np.radians(incidence_deg)
    r = {r}(r_a, r_b)
    d_max = r * np.sin(dphi) / np.sin(lam - dphi) + 3 * range_sigma_m
    return np.maximum(d_max, threshold_m)
'''

FILLS = {
    "c012": Fill(
        correct=_CUT.format(test="~(gaps < threshold_m)  # NaN gaps (invalid beams) cut too"),
        mistake=_CUT.format(test="gaps >= threshold_m  # NaN >= x is False: invalid beams do not cut"),
        hint="NaN >= threshold_m is False",
    ),
    "c022": Fill(
        correct=_ADAPTIVE.format(r="np.minimum"),
        mistake=_ADAPTIVE.format(r="np.maximum"),
        hint="the smaller of the two ranges",
    ),
}
