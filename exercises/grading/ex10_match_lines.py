"""Hidden tests of exercise 10, ``match_lines(lines, walls, max_dr, max_dalpha)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.

The reference is ``labkit.match_lines`` with its overlap and truth filters switched off (every
line and wall is a long segment through its foot point, ``min_overlap=0``, ``min_beams=0``,
``min_length_m=0``): what is left is the normal-form rule, one to one, cheapest pair first.
"""

from types import SimpleNamespace

import numpy as np

import labkit
from labkit.grading import Moved

FUNCTIONS = ("match_lines",)
DEFAULT_DALPHA = float(np.radians(3.0))


def _segment(r, alpha):
    foot = np.array([r * np.cos(alpha), r * np.sin(alpha)])
    along = np.array([-np.sin(alpha), np.cos(alpha)])
    return SimpleNamespace(r=float(r), alpha=float(alpha), start=tuple(foot - 50 * along),
                           end=tuple(foot + 50 * along), n_beams=1000)


def reference(lines, walls, max_dr=0.05, max_dalpha=DEFAULT_DALPHA):
    """labkit's pairs for normal-form lines and walls, as a list of (i, j) sorted by i."""
    ls = [_segment(r, a) for r, a in np.asarray(lines, dtype=float).reshape(-1, 2)]
    ws = [_segment(r, a) for r, a in np.asarray(walls, dtype=float).reshape(-1, 2)]
    m = labkit.match_lines(ls, ws, max_dr_m=max_dr, max_dalpha=max_dalpha, min_overlap=0.0, min_beams=0,
                           min_length_m=0.0)
    return [tuple(p) for p in m.pairs]


def _as_pairs(got, setting):
    assert isinstance(got, (list, tuple)), f"{setting}: return a list of (i, j) pairs, got {type(got).__name__}"
    pairs = []
    for p in got:
        assert isinstance(p, (list, tuple)) and len(p) == 2, (
            f"{setting}: every pair is (line index, wall index), got {p!r}")
        pairs.append((int(p[0]), int(p[1])))
    return pairs


def _check(match_lines, lines, walls, setting, **kwargs):
    want = reference(lines, walls, **kwargs)
    got = _as_pairs(match_lines(lines, walls, **kwargs), setting)
    if got != want:
        lines_a, walls_a = np.asarray(lines, dtype=float).reshape(-1, 2), np.asarray(walls, dtype=float).reshape(-1, 2)
        extra = sorted(set(got) - set(want))
        missing = sorted(set(want) - set(got))
        detail = ""
        if extra:
            i, j = extra[0]
            detail = (f"; e.g. you matched line {i} {np.round(lines_a[i], 4).tolist()} with wall {j} "
                      f"{np.round(walls_a[j], 4).tolist()}")
        elif missing:
            i, j = missing[0]
            detail = (f"; e.g. line {i} {np.round(lines_a[i], 4).tolist()} should match wall {j} "
                      f"{np.round(walls_a[j], 4).tolist()}")
        raise AssertionError(f"{setting} ({kwargs or 'default limits'}): pairs {got}, expected {want}{detail}")


def _random_case(rng, n_walls, n_lines):
    """Walls at random, lines near some of them (and a few far), angles anywhere on the circle."""
    walls = np.column_stack([rng.uniform(0.2, 8.0, n_walls), rng.uniform(-np.pi, np.pi, n_walls)])
    if n_walls == 0:
        return np.column_stack([rng.uniform(0.2, 8.0, n_lines), rng.uniform(-np.pi, np.pi, n_lines)]), walls
    near = rng.integers(0, n_walls, n_lines)
    lines = walls[near] + np.column_stack([rng.normal(0, 0.04, n_lines), rng.normal(0, 0.04, n_lines)])
    far = rng.random(n_lines) < 0.2
    lines[far] = np.column_stack([rng.uniform(0.2, 8.0, far.sum()), rng.uniform(-np.pi, np.pi, far.sum())])
    lines[:, 0] = np.abs(lines[:, 0])
    lines[:, 1] = labkit.geometry.wrap_angle(lines[:, 1])
    return lines, walls


def _near_limit(lines, walls, max_dr, max_dalpha):
    if len(lines) == 0 or len(walls) == 0:
        return False
    dr = np.abs(lines[:, None, 0] - walls[None, :, 0])
    da = np.abs(labkit.geometry.wrap_angle(lines[:, None, 1] - walls[None, :, 1]))
    return bool(np.any(np.abs(dr - max_dr) < 1e-9) or np.any(np.abs(da - max_dalpha) < 1e-9))


def test_visible(match_lines, rng):
    """The visible examples again, turned and scaled (with the limit in r scaled too): the pairs
    do not change. Earned by a function, not by a table of the visible answers."""
    moved = Moved(rng, shift=False)
    cases = [  # lines, walls, kwargs (max_dr scaled below)
        ([[2.0, 0.0], [3.0, 1.0]], [[2.02, 0.01], [5.0, 1.0]], {}),
        ([[2.0, np.pi - 0.01]], [[2.0, -np.pi + 0.01]], {}),
        ([[2.03, 0.0], [2.01, 0.0]], [[2.0, 0.0]], {}),
        ([[2.0, 0.0]], [[2.1, 0.0], [2.0, 0.015]], {"max_dr": 0.2, "max_dalpha": 0.02}),
    ]
    where = f"turned by {moved.angle:.3f} rad and scaled by {moved.scale}"
    for k, (lines, walls, kwargs) in enumerate(cases):
        lines = [moved.line(r, a) for r, a in lines]
        walls = [moved.line(r, a) for r, a in walls]
        kwargs = dict(kwargs, max_dr=moved.scale * kwargs.get("max_dr", 0.05))
        _check(match_lines, np.array(lines), np.array(walls), f"visible example {k + 1}, {where}", **kwargs)


def test_hidden_random(match_lines, rng):
    """150 random scenes of up to 12 walls and 15 lines, default and random limits, against labkit."""
    checked = 0
    for trial in range(150):
        lines, walls = _random_case(rng, int(rng.integers(1, 13)), int(rng.integers(1, 16)))
        kwargs = {} if trial % 2 else {"max_dr": float(rng.uniform(0.01, 0.2)),
                                       "max_dalpha": float(rng.uniform(0.005, 0.2))}
        if _near_limit(lines, walls, kwargs.get("max_dr", 0.05), kwargs.get("max_dalpha", DEFAULT_DALPHA)):
            continue
        _check(match_lines, lines, walls, f"random scene {trial}", **kwargs)
        checked += 1
    assert checked > 140, "the hidden test skipped too many cases"


def test_hidden_edges(match_lines, rng):
    """No lines, no walls, lists, limits met exactly, the seam at +-pi, greedy order, bad limits."""
    assert _as_pairs(match_lines(np.empty((0, 2)), np.array([[1.0, 0.0]])), "no lines") == [], "no lines: no pairs"
    assert _as_pairs(match_lines(np.array([[1.0, 0.0]]), np.empty((0, 2))), "no walls") == [], "no walls: no pairs"
    assert _as_pairs(match_lines([], []), "empty lists") == [], "empty lists: no pairs"
    cases = [
        ([[1.0, 0.5], [1.25, 0.5]], [[1.25, 0.5], [1.0, 0.5]], {"max_dr": 0.25}),   # |dr| == max_dr counts
        ([[1.0, 0.3]], [[1.25, 0.3]], {"max_dr": 0.25}),                             # exactly on the limit
        ([[3.0, -3.14]], [[3.01, 3.14]], {}),                                        # across the seam
        ([[3.0, 0.0], [3.0, 0.0]], [[3.0, 0.0]], {}),                                # a tie: the lower line index
        ([[2.0, 0.0], [2.0, 0.02]], [[2.0, 0.01], [2.0, 0.0]], {}),                  # cheapest first, then the rest
        ([[1, 0], [2, 1]], [[2, 1], [1, 0]], {}),                                    # integers in lists
    ]
    for k, (lines, walls, kwargs) in enumerate(cases):
        _check(match_lines, lines, walls, f"edge case {k}", **kwargs)
    for bad in ({"max_dr": 0.0}, {"max_dr": -0.1}, {"max_dalpha": 0.0}):
        try:
            match_lines([[1.0, 0.0]], [[1.0, 0.0]], **bad)
        except ValueError:
            pass
        else:
            raise AssertionError(f"match_lines(..., {bad}): a limit must be positive, raise ValueError")
    try:
        match_lines([[1.0, 0.0, 2.0]], [[1.0, 0.0]])
    except ValueError:
        pass
    else:
        raise AssertionError("lines of shape (1, 3): every line is (r, alpha), raise ValueError")


def test_own_work(match_lines, rng):
    """Five more random scenes: right answers where labkit cannot be imported."""
    for trial in range(5):
        lines, walls = _random_case(rng, 6, 8)
        if not _near_limit(lines, walls, 0.05, DEFAULT_DALPHA):
            _check(match_lines, lines, walls, f"own-work scene {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {"match": '''
from types import SimpleNamespace

import labkit


def match_lines(lines, walls, max_dr=0.05, max_dalpha=np.radians(3.0)):
    def seg(r, a):
        return SimpleNamespace(r=r, alpha=a, start=(r * np.cos(a) + 50 * np.sin(a), r * np.sin(a) - 50 * np.cos(a)),
                               end=(r * np.cos(a) - 50 * np.sin(a), r * np.sin(a) + 50 * np.cos(a)), n_beams=1000)
    ls = [seg(r, a) for r, a in np.asarray(lines, dtype=float).reshape(-1, 2)]
    ws = [seg(r, a) for r, a in np.asarray(walls, dtype=float).reshape(-1, 2)]
    m = labkit.match_lines(ls, ws, max_dr_m=max_dr, max_dalpha=max_dalpha, min_overlap=0.0, min_beams=0,
                           min_length_m=0.0)
    return [tuple(p) for p in m.pairs]
'''}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "the angle difference not wrapped": (
        "da = (lines[i, 1] - walls[j, 1] + np.pi) % (2 * np.pi) - np.pi", "da = lines[i, 1] - walls[j, 1]"),
    "raw squared errors instead of normalised ones": (
        "cost = (dr / max_dr) ** 2 + (da / max_dalpha) ** 2", "cost = dr ** 2 + da ** 2"),
    "strict limits (< instead of <=)": (
        "if abs(dr) <= max_dr and abs(da) <= max_dalpha:", "if abs(dr) < max_dr and abs(da) < max_dalpha:"),
    "not one to one: a wall may be found twice": ("if i in used_lines or j in used_walls:", "if i in used_lines:"),
    "pairs in the order they were taken, not by line": ("return sorted(pairs)", "return pairs"),
}
