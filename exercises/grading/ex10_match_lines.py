"""Hidden tests of exercise 10, ``match_lines(lines, walls, max_dr, max_dalpha)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.

The reference is ``labkit.match_lines`` with its overlap and truth filters switched off (every
line and wall is a long segment through its foot point, ``min_overlap=0``, ``min_beams=0``,
``min_length_m=0``): what is left is the normal-form rule, one to one, cheapest pair first.
"""

from types import SimpleNamespace

import numpy as np

import labkit
from labkit.grading import Moved

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
        assert isinstance(p, (list, tuple)) and len(p) == 2 and all(
            isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in p), (
            f"{setting}: every pair is (line index, wall index), two ints")
        pairs.append((int(p[0]), int(p[1])))
    return pairs


def _check(match_lines, lines, walls, setting, **kwargs):
    """The student's pairs against labkit's; the message counts what differs, never the pairs or the lines."""
    want = reference(lines, walls, **kwargs)
    limits = "random limits" if kwargs else "default limits"
    got = _as_pairs(match_lines(lines, walls, **kwargs), f"{setting} ({limits})")
    if got == want:
        return
    where = f"{setting} ({len(lines)} lines, {len(walls)} walls, {limits})"
    if sorted(got) == want:
        raise AssertionError(f"{where}: the right pairs in another order (sorted by line)")
    extra, missing = set(got) - set(want), set(want) - set(got)
    walls_used = [j for _, j in got]
    twice = " (a wall matched twice: one to one?)" if len(set(walls_used)) < len(walls_used) else ""
    raise AssertionError(f"{where}: {len(extra)} pairs too many and {len(missing)} missing against the reference"
                         f"{twice} (both limits, inclusive? the angle difference wrapped? the cheapest normalised "
                         "cost first?)")


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
    for trial in range(3):
        _check(match_lines, *_seam_case(rng), f"random scene across the seam {trial}")


#: Scenes whose answer is exact (lines, walls, limits): turned and scaled (max_dr with them) when graded.
EDGE_SCENES = [
    ([[1.0, 0.5], [1.25, 0.5]], [[1.25, 0.5], [1.0, 0.5]], {"max_dr": 0.25}),   # |dr| == max_dr counts
    ([[1.0, 0.3]], [[1.25, 0.3]], {"max_dr": 0.25}),                             # exactly on the limit
    ([[3.0, -3.14]], [[3.01, 3.14]], {}),                                        # across the seam
    ([[3.0, 0.0], [3.0, 0.0]], [[3.0, 0.0]], {}),                                # a tie: the lower line index
    ([[2.0, 0.0], [2.0, 0.02]], [[2.0, 0.01], [2.0, 0.0]], {}),                  # cheapest first, then the rest
    ([[2.0, 0.03], [3.0, 0.0]], [[2.01, 0.03], [3.0, 0.0]], {}),                 # taken 1 then 0: sorted by line
]


def test_hidden_edges(match_lines, rng):
    """No lines, no walls, lists, limits met exactly, the seam at +-pi, ties, greedy order (turned and scaled);
    integers; bad limits and rows."""
    assert _as_pairs(match_lines(np.empty((0, 2)), rng.uniform(0.5, 5.0, (3, 2))), "no lines") == [], \
        "no lines: no pairs"
    assert _as_pairs(match_lines(rng.uniform(0.5, 5.0, (3, 2)), np.empty((0, 2))), "no walls") == [], \
        "no walls: no pairs"
    assert _as_pairs(match_lines([], []), "empty lists") == [], "empty lists: no pairs"
    for k, (lines, walls, kwargs) in enumerate(EDGE_SCENES):
        scale = float(2.0 ** rng.integers(-1, 3))  # exact: a power of two keeps |dr| == max_dr
        turn = float(rng.choice([0.0, np.pi / 2, -np.pi / 2])) if k in (0, 1) else 0.0
        moved = Moved(rng, shift=False)
        if k in (0, 1, 2, 3):  # exact limits, the seam and ties: a quarter turn and a power of two only
            move = lambda r, a, s=scale, t=turn: (s * r, float(labkit.wrap_angle(a + t)))  # noqa: E731
        else:
            scale = moved.scale
            move = lambda r, a, m=moved: m.line(r, a)  # noqa: E731
        kwargs = dict(kwargs, max_dr=scale * kwargs.get("max_dr", 0.05))
        lines = np.array([move(*line) for line in lines])
        walls = np.array([move(*wall) for wall in walls])
        _check(match_lines, lines.tolist() if k % 2 else lines, walls.tolist() if k % 2 else walls,
               f"edge case {k}", **kwargs)
    lines, walls, limits = _units_case(rng)
    _check(match_lines, lines, walls, "limits in metres and radians", **limits)
    ints = rng.integers(1, 9, (3, 2))
    _check(match_lines, ints.tolist(), ints[rng.permutation(3)].tolist(), "integers in lists")
    for bad in ({"max_dr": 0.0}, {"max_dr": -float(rng.uniform(0.01, 1.0))}, {"max_dalpha": 0.0},
                {"max_dalpha": -float(rng.uniform(0.01, 1.0))}):
        try:
            match_lines(rng.uniform(0.5, 5.0, (2, 2)), rng.uniform(0.5, 5.0, (2, 2)), **bad)
        except ValueError:
            pass
        else:
            raise AssertionError(f"match_lines with {' and '.join(bad)} not positive: a limit must be positive, raise "
                                 "ValueError")
    try:
        match_lines(rng.uniform(0.5, 5.0, (2, 3)), rng.uniform(0.5, 5.0, (2, 2)))
    except ValueError:
        pass
    else:
        raise AssertionError("lines of three numbers: every line is (r, alpha), raise ValueError")


def _seam_case(rng):
    """Walls and lines either side of +-pi (the angle difference must be wrapped): each line near a wall."""
    n = int(rng.integers(2, 6))
    walls = np.column_stack([rng.uniform(0.5, 8.0, n), np.pi - rng.uniform(0.0, 0.02, n)])
    lines = walls + np.column_stack([rng.normal(0.0, 0.01, n), rng.uniform(0.01, 0.04, n)])
    lines[:, 1] = labkit.geometry.wrap_angle(lines[:, 1])  # past pi: just above -pi
    return lines, walls


def _units_case(rng):
    """One line and two walls: one off in r by half of max_dr, one off in angle by three quarters of max_dalpha,
    with limits of different sizes (metres and radians): only the costs normalised by the limits pick the first."""
    r, alpha = float(rng.uniform(0.5, 6.0)), float(rng.uniform(-3.0, 3.0))
    max_dr, max_dalpha = float(rng.uniform(0.1, 0.3)), float(rng.uniform(0.01, 0.03))
    walls = np.array([[r + 0.5 * max_dr, alpha], [r, alpha + 0.75 * max_dalpha]])[rng.permutation(2)]
    return np.array([[r, alpha]]), walls, {"max_dr": max_dr, "max_dalpha": max_dalpha}


def test_own_work(match_lines, rng):
    """Five more random scenes and two across the seam at +-pi: right answers where labkit cannot be imported."""
    checked = 0
    while checked < 5:
        lines, walls = _random_case(rng, 6, 8)
        if not _near_limit(lines, walls, 0.05, DEFAULT_DALPHA):
            _check(match_lines, lines, walls, f"own-work scene {checked}")
            checked += 1
    for trial in range(2):
        _check(match_lines, *_seam_case(rng), f"own-work scene across the seam {trial}")
    lines, walls, limits = _units_case(rng)
    _check(match_lines, lines, walls, "own-work scene, limits in metres and radians", **limits)


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
