"""Fill-ins for notebooks/06_dbscan1d.ipynb: core points from the bounds, and the border rule."""

from tests.your_turn import Fill

_CORE = '''
def is_core(L, U, min_pts):
    """True where point i is a core point."""
    return (np.asarray(U) - np.asarray(L) + 1) >= min_pts
'''

_BORDER = '''
def is_border(L, U, core):
    """True where point i is a border point."""
    core = np.asarray(core, dtype=bool)
    return np.array([not core[i] and core[lo:up + 1].any() for i, (lo, up) in enumerate(zip(L, U))], dtype=bool)
'''

FILLS = {
    "9e30f7d2": Fill(
        correct=_CORE,
        # the typical slip: U - L counts the neighbours without the point itself
        mistake=_CORE.replace("np.asarray(U) - np.asarray(L) + 1", "np.asarray(U) - np.asarray(L)"),
        hint="U - L + 1 points, the point itself included",
    ),
    "6b20c7ef": Fill(
        correct=_BORDER,
        # the typical slip: a point with a core neighbour is "border", core points included
        mistake=_BORDER.replace("not core[i] and ", ""),
        hint="a core point is never a border point",
    ),
}
