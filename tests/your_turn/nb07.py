"""Fill-ins for notebooks/07_angular_segmentation.ipynb: a triplet's direction, offsets of parallel walls."""

from tests.your_turn import Fill

_DIRECTION = '''
def triplet_direction(p0, p1, p2):
    """Direction in [0, pi) of the total least squares line through three points (x, y)."""
    d = np.array([p0, p1, p2], dtype=float)
    d = d - d.mean(axis=0)
    sxx, syy, sxy = (d[:, 0] ** 2).sum(), (d[:, 1] ** 2).sum(), (d[:, 0] * d[:, 1]).sum()
    return float(np.mod(0.5 * np.arctan2(2 * sxy, sxx - syy), np.pi))
'''

_OFFSETS = '''
def wall_offsets(points, direction):
    """Signed offset of every point (N, 2) from the line through the origin with this direction."""
    points = np.asarray(points, dtype=float)
    return -points[:, 0] * np.sin(direction) + points[:, 1] * np.cos(direction)
'''

FILLS = {
    "58a3937b": Fill(
        correct=_DIRECTION,
        # the typical slip: half of atan2 left in (-pi/2, pi/2], not taken modulo pi
        mistake=_DIRECTION.replace("np.mod(0.5 * np.arctan2(2 * sxy, sxx - syy), np.pi)",
                                   "0.5 * np.arctan2(2 * sxy, sxx - syy)"),
        hint="modulo pi, in [0, pi)",
    ),
    "d0eb91fa": Fill(
        correct=_OFFSETS,
        # the typical slip: the position along the line (direction vector) instead of across it (normal)
        mistake=_OFFSETS.replace("-points[:, 0] * np.sin(direction) + points[:, 1] * np.cos(direction)",
                                 "points[:, 0] * np.cos(direction) + points[:, 1] * np.sin(direction)"),
        hint="across the line, along its normal",
    ),
}
