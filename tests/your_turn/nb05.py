"""Fill-ins for notebooks/05_merge_and_corners.ipynb: the merge test and the corner of two lines."""

from tests.your_turn import Fill

SIMILAR = '''def similar_lines(a, b, dr_max_m=0.2, dalpha_max=MERGE_DALPHA):
    dalpha = {difference}
    dr = b.r - a.r
    if abs(dalpha) > math.pi / 2:
        dalpha = labkit.wrap_angle(dalpha - math.pi)
        dr = -b.r - a.r
    return bool(abs(dr) < dr_max_m and abs(dalpha) < dalpha_max)
'''

CORNER = '''def intersection(r1, alpha1, r2, alpha2):
    c1, s1, c2, s2 = math.cos(alpha1), math.sin(alpha1), math.cos(alpha2), math.sin(alpha2)
    det = c1 * s2 - s1 * c2
    if abs(det) < 1e-12:
        return None
    return np.array([(r1 * s2 - r2 * s1) / det, {y}])
'''

FILLS = {
    # the angle difference taken as it is: 178 and -179 degrees come out 357 degrees apart
    "n05-yt-similar": Fill(correct=SIMILAR.format(difference="labkit.wrap_angle(b.alpha - a.alpha)"),
                           mistake=SIMILAR.format(difference="b.alpha - a.alpha"), hint="angles wrap"),
    # Cramer's rule with the numerator of y turned round: y comes out with the wrong sign
    "n05-yt-corner": Fill(correct=CORNER.format(y="(r2 * c1 - r1 * c2) / det"),
                          mistake=CORNER.format(y="(r1 * c2 - r2 * c1) / det"), hint="check y"),
}
