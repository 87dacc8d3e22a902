"""Fill-ins for notebooks/08_iav_circles.ipynb (the V-corner test, the middle point's offset, radius and centre
height) and notebooks/08b_legs.ipynb (two legs make a person): both notebooks start with "08", so both read this
file (see tests/your_turn/__init__.py)."""

from tests.your_turn import Fill

_MIDDLE_RATIO = '''
def middle_ratio(points, viewpoint=(0.0, 0.0)):
    p = np.asarray(points, dtype=float)
    v = np.asarray(viewpoint, dtype=float)
    d = p[-1] - p[0]
    m = p[len(p) // 2] - p[0]
    w = v - p[0]
    chord = np.hypot(*d)
    offset = (d[0] * m[1] - d[1] * m[0]) / chord          # > 0: left of the chord
    towards = np.sign(d[0] * w[1] - d[1] * w[0])           # +1: the viewpoint is left of the chord
    return float(offset * towards / {divide})
'''

_CIRCLE = '''
def radius_and_height(chord, mean_angle):
    theta = mean_angle - np.pi / 2
    return chord / 2 / np.cos(theta), {height} * np.tan(theta)
'''

FILLS = {
    "231fb21f": Fill(
        correct=_MIDDLE_RATIO.format(divide="chord"),
        mistake=_MIDDLE_RATIO.format(divide="1.0"),  # the offset in metres, not over the chord
        hint="chord length",
    ),
    "091e6ab3": Fill(
        correct=_CIRCLE.format(height="chord / 2"),
        mistake=_CIRCLE.format(height="chord"),  # the paper's slip: the whole chord times tan(theta)
        hint="half the chord",
    ),
}

_V_SHAPED = '''
def is_v_shaped(angles, n_neighbours=4, stride=1):
    a = np.asarray(angles, dtype=float)
    m = int(np.argmin(a))
    k = n_neighbours // 2
    step = {step}
    if m < k * step or m + k * step >= len(a):
        return False
    left, right = a[m - k * step:m + 1:step], a[m:m + k * step + 1:step]
    return bool(np.all(np.diff(left) < 0) and np.all(np.diff(right) > 0))
'''

FILLS["9de4f9a5"] = Fill(
    correct=_V_SHAPED.format(step="stride"),
    mistake=_V_SHAPED.format(step="1"),  # the neighbours taken next to each other, whatever the stride
    hint="stride angles apart",
)

_PAIR = '''
def pair_two_legs(centre_a, centre_b, max_distance_m=0.6):
    a, b = np.asarray(centre_a, dtype=float), np.asarray(centre_b, dtype=float)
    if {too_far}:
        return None
    return (a + b) / 2
'''

FILLS["e60922ca"] = Fill(
    correct=_PAIR.format(too_far="np.hypot(*(b - a)) > max_distance_m"),
    mistake=_PAIR.format(too_far="np.any(np.abs(b - a) > max_distance_m)"),  # x and y apart, each within the limit
    hint="the distance between the centres",
)
