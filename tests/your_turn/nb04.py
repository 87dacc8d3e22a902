"""Fill-ins for notebooks/04_split_and_merge.ipynb: the chord distances and the IEPF recursion."""

from tests.your_turn import Fill

CHORD = '''def chord_distances(points):
    points = np.asarray(points, dtype=float)
    a, b = points[0], points[-1]
    cross = (b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0])
    return np.abs(cross) / {length}
'''

IEPF = '''def iepf(points, threshold_m=0.05, min_points=5):
    points = np.asarray(points, dtype=float)
    keep = min_points // 2
    accepted, stack = [], [(0, len(points))]
    while stack:
        a, b = stack.pop()
        if b - a < min_points:
            continue
        d = chord_distances(points[a:b])
        lo, hi = (keep, b - a - keep) if b - a > 2 * keep else (0, b - a)
        worst = a + lo + int(np.argmax(d[lo:hi]))
        if d[worst - a] > threshold_m:
            stack += {push}
            continue
        accepted.append((a, b))
    return accepted
'''

FILLS = {
    # the cross product not divided by the chord's length: right only for chords 1 m long
    "c004-yt-chord": Fill(correct=CHORD.format(length="np.hypot(*(b - a))"), mistake=CHORD.format(length="1.0"),
                          hint="divide the cross product by the chord's length"),
    # both halves pushed left first: the right half is popped first and the lines come out of scan order
    "c005": Fill(correct=IEPF.format(push="[(worst + 1, b), (a, worst + 1)]"),
                 mistake=IEPF.format(push="[(a, worst + 1), (worst + 1, b)]"),
                 hint="runs in scan order: push the right half first"),
}
