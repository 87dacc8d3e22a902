"""Hidden tests of exercise 11, ``to_map(points, pose)`` and ``interpolate_pose(stamps, poses, t)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` function holds the hidden tests of
the graded cell with that grade id; it gets the student's functions (calls into their sandboxed
worker) and ``rng``, a generator seeded per submission. See exercises/README.md.

Two references for every answer: labkit (``labkit.geometry.transform_points``,
``labkit.poses.interpolate_poses`` with no tolerance beyond the stamps and no gap limit) and the
closed form with homogeneous 3 x 3 matrices built here (a point is ``H(pose) @ (x, y, 1)``; the
turn between two headings is the angle of the rotation block of ``H(p0)^-1 H(p1)``, which is the
short way round by construction). The two must agree before a student's answer is compared.
"""

import numpy as np

import labkit
from labkit.grading import Moved

FUNCTIONS = ("to_map", "interpolate_pose")
NO_GAP_LIMIT = np.iinfo(np.int64).max


# ---------------------------------------------------------------------------- references
def homogeneous(pose):
    x, y, theta = (float(v) for v in pose)
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def map_points_by_matrix(points, pose):
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    return (homogeneous(pose) @ np.column_stack([pts, np.ones(len(pts))]).T).T[:, :2]


def reference_to_map(points, pose):
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    want = labkit.geometry.transform_points(pts, pose).reshape(-1, 2)
    assert np.allclose(want, map_points_by_matrix(pts, pose), atol=1e-9), "the two references disagree"
    return want


def pose_by_matrix(stamps, poses, t):
    """Closed form: find the pair of stamps around t; x, y linear; the turn from the relative rotation."""
    stamps = [int(s) for s in stamps]
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    if t in stamps:
        return poses[stamps.index(t)]
    i = max(k for k, s in enumerate(stamps) if s < t)
    u = (t - stamps[i]) / (stamps[i + 1] - stamps[i])
    relative = np.linalg.inv(homogeneous(poses[i])) @ homogeneous(poses[i + 1])
    turn = np.arctan2(relative[1, 0], relative[0, 0])
    heading = homogeneous((0.0, 0.0, poses[i, 2] + u * turn))
    return np.array([*(poses[i, :2] + u * (poses[i + 1, :2] - poses[i, :2])),
                     np.arctan2(heading[1, 0], heading[0, 0])])


def reference_pose(stamps, poses, t):
    want = labkit.poses.interpolate_poses(np.asarray(stamps, dtype=np.int64), poses, [t], tolerance_ns=0,
                                          max_gap_ns=NO_GAP_LIMIT)[0]
    closed = pose_by_matrix(stamps, poses, t)
    assert np.allclose(want[:2], closed[:2], atol=1e-9) and abs(labkit.wrap_angle(want[2] - closed[2])) < 1e-9, (
        "the two references disagree")
    return want


# ---------------------------------------------------------------------------- comparisons
def assert_points(got, want, where, atol=1e-9):
    try:
        got = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: return an array of shape (N, 2), got {type(got).__name__}") from None
    want = np.asarray(want, dtype=float).reshape(-1, 2)
    assert got.shape == want.shape, f"{where}: expected shape {want.shape}, got {got.shape}"
    if len(want):
        k = int(np.argmax(np.abs(got - want).max(axis=1)))
        assert np.allclose(got, want, rtol=0, atol=atol), (
            f"{where}: point {k} is at {np.round(got[k], 6).tolist()}, expected {np.round(want[k], 6).tolist()}. "
            "R(theta) @ p + (x, y): rotate first, then translate, counter-clockwise by theta?")


def assert_pose(got, want, where, atol=1e-9):
    try:
        got = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: return (x, y, theta), got {type(got).__name__}") from None
    assert got.shape == (3,), f"{where}: return the pose (x, y, theta), got shape {got.shape}"
    shown = f"got {np.round(got, 6).tolist()}, expected {np.round(want, 6).tolist()}"
    assert np.allclose(got[:2], want[:2], rtol=0, atol=atol), f"{where}: {shown}: x or y is off. Linear in time?"
    assert abs(labkit.wrap_angle(got[2] - want[2])) < 1e-9, (
        f"{where}: {shown}: theta is off. theta0 + u * (theta1 - theta0 wrapped): the short way round?")
    assert -np.pi - 1e-12 <= got[2] <= np.pi + 1e-12, f"{where}: theta {got[2]:.6f} is outside (-pi, pi]: wrap it"


def assert_raises(call, what):
    try:
        call()
    except ValueError:
        return  # graded: the type (ValueError); naming the argument is good practice
    raise AssertionError(f"{what} must raise ValueError")


# ---------------------------------------------------------------------------- random inputs
def random_pose(rng, reach=20.0):
    return np.array([*rng.uniform(-reach, reach, 2), rng.uniform(-np.pi, np.pi)])


def random_track(rng, n):
    """n poses at increasing integer stamps (ns, gaps of 1 ms to 0.2 s, an offset up to 1e12 ns); headings
    anywhere on the circle, so many pairs cross +-pi, and none exactly opposite (no short way round)."""
    stamps = int(rng.integers(0, 10**12)) + np.cumsum(rng.integers(10**6, 2 * 10**8, n))
    while True:
        poses = np.column_stack([np.cumsum(rng.normal(0.0, 0.5, (n, 2)), axis=0) + rng.uniform(-20, 20, 2),
                                 rng.uniform(-np.pi, np.pi, n)])
        if n < 2 or np.all(np.abs(np.abs(labkit.wrap_angle(np.diff(poses[:, 2]))) - np.pi) > 1e-3):
            return stamps.astype(np.int64), poses


def random_stamp(rng, stamps):
    if rng.random() < 0.2:
        return int(rng.choice(stamps))
    return int(rng.integers(stamps[0], stamps[-1] + 1))


# ---------------------------------------------------------------------------- the graded cells
def test_visible(to_map, interpolate_pose, rng):
    """The visible examples again with the map frame moved (turned, scaled, shifted) and the clock
    shifted and slowed: every pose and point moves with the map, the answers move alike. Earned by
    functions, not by a table of the visible answers."""
    moved = Moved(rng)
    s = moved.scale
    where = f"turned by {moved.angle:.3f} rad, scaled by {s}, shifted by {np.round(moved.shift, 3).tolist()}"

    def move_pose(pose):
        return np.array([*moved.points(pose[:2])[0], float(moved.bearing(pose[2]))])

    examples = [  # points (sensor frame), pose, points in the map
        ([[1.0, 0.0]], (1.0, 0.0, np.pi / 2), [[1.0, 1.0]]),
        ([[0.0, 0.0], [1.0, 2.0]], (2.0, 1.0, 0.0), [[2.0, 1.0], [3.0, 3.0]]),
        ([[1.0, 0.5]], (0.0, 0.0, np.pi), [[-1.0, -0.5]]),
        ([[0.0, 1.0]], (1.0, 2.0, np.pi / 2), [[0.0, 2.0]]),
        (np.zeros((0, 2)), (1.0, 2.0, 0.3), np.zeros((0, 2))),
    ]
    for k, (points, pose, want) in enumerate(examples):
        got = to_map(s * np.asarray(points, dtype=float), move_pose(pose))
        assert_points(got, moved.points(want) if len(want) else want, f"visible to_map example {k + 1}, {where}",
                      atol=1e-9 * s)

    offset, slow = int(rng.integers(0, 10**12)), int(2 ** rng.integers(0, 8))
    a, b = (0.0, 0.0, np.radians(170)), (1.0, 2.0, np.radians(-170))
    three = ([0, 10, 30], [(0.0, 0.0, 0.0), (1.0, 0.0, 0.5), (1.0, 2.0, 1.0)])
    examples = [  # stamps, poses, t, pose at t
        ([0, 10], [(0.0, 0.0, 0.0), (1.0, 2.0, 0.5)], 5, (0.5, 1.0, 0.25)),
        ([0, 100], [a, b], 25, (0.25, 0.5, np.radians(175))),
        ([0, 100], [a, b], 75, (0.75, 1.5, np.radians(-175))),
        (*three, 10, three[1][1]),
        (*three, 20, (1.0, 1.0, 0.75)),
        (*three, 30, three[1][2]),
    ]
    for k, (stamps, poses, t, want) in enumerate(examples):
        stamps_moved = [offset + slow * st for st in stamps]
        got = interpolate_pose(stamps_moved, np.array([move_pose(p) for p in poses]), offset + slow * t)
        assert_pose(got, move_pose(np.asarray(want)), f"visible interpolate_pose example {k + 1}, {where}, "
                    f"stamps {stamps_moved}", atol=1e-9 * s)
    for t in (-1, 31):
        assert_raises(lambda t=t: interpolate_pose([offset + slow * st for st in three[0]],
                                                   np.array([move_pose(p) for p in three[1]]), offset + slow * t),
                      f"a stamp {'before the first' if t < 0 else 'after the last'} pose")


def test_hidden_random(to_map, interpolate_pose, rng):
    """40 random scans placed in the map, 60 random tracks read at random stamps (a fifth exactly at a
    stamp), against labkit and the homogeneous matrices."""
    for trial in range(40):
        n = int(rng.integers(1, 400))
        points = rng.uniform(-30.0, 30.0, (n, 2))
        pose = random_pose(rng)
        assert_points(to_map(points, pose), reference_to_map(points, pose),
                      f"random scan {trial} ({n} points, pose {np.round(pose, 4).tolist()})")
    for trial in range(60):
        stamps, poses = random_track(rng, int(rng.integers(2, 30)))
        for _ in range(3):
            t = random_stamp(rng, stamps)
            assert_pose(interpolate_pose(stamps, poses, t), reference_pose(stamps, poses, t),
                        f"random track {trial} ({len(stamps)} poses), t = {t}")


def test_hidden_edges(to_map, interpolate_pose, rng):
    """Empty and single points, lists, integers, headings of +-pi, one pose, the end stamps, turns
    across +-pi, stamps outside the track, and wrong shapes (ValueError)."""
    pose = random_pose(rng)
    assert_points(to_map(np.zeros((0, 2)), pose), np.zeros((0, 2)), "no points (an array of shape (0, 2))")
    assert_points(to_map([], pose), np.zeros((0, 2)), "no points (an empty list)")
    for k, (points, pose) in enumerate([
        ([[2.0, -1.0]], random_pose(rng)),
        ([[1, 2], [3, 4]], [1, -2, 0]),                              # integers, lists
        ([[1.5, 0.5], [0.0, -2.0]], (0.5, 0.5, np.pi)),               # heading pi
        ([[1.5, 0.5], [0.0, -2.0]], [0.5, 0.5, -np.pi]),              # heading -pi: the same
        (rng.uniform(-5, 5, (7, 2)).tolist(), random_pose(rng).tolist()),
    ]):
        assert_points(to_map(points, pose), reference_to_map(points, pose), f"to_map edge case {k}")

    stamps, poses = random_track(rng, 6)
    cases = [
        ([stamps[0]], poses[:1], int(stamps[0])),                     # one pose, read at its stamp
        (stamps, poses, int(stamps[0])),                              # the first stamp
        (stamps, poses, int(stamps[-1])),                             # the last stamp
        (stamps, poses, int(stamps[-1]) - 1),                         # just before it
        (stamps.tolist(), poses.tolist(), int(stamps[2]) + 1),        # lists
        ([0, 100], [[0.0, 0.0, 3.0], [1.0, 1.0, -3.0]], 90),           # across +-pi: wrap the result
        ([0, 100], [[0.0, 0.0, -3.0], [1.0, 1.0, 3.0]], 90),           # the other way across
        ([0, 100], [[0.0, 0.0, -0.2], [1.0, 1.0, 0.6]], 50),           # not across: no detour either
        ([0, 100, 200], [[0, 0, 0], [1, 0, 1], [2, 0, 2]], 150),       # integers
    ]
    for k, (st, ps, t) in enumerate(cases):
        assert_pose(interpolate_pose(st, ps, t), reference_pose(st, ps, t), f"interpolate_pose edge case {k}, t = {t}")

    assert_raises(lambda: interpolate_pose(stamps, poses, int(stamps[0]) - 1), "a stamp before the first pose")
    assert_raises(lambda: interpolate_pose(stamps, poses, int(stamps[-1]) + 1), "a stamp after the last pose")
    assert_raises(lambda: interpolate_pose([stamps[0]], poses[:1], int(stamps[0]) + 1), "one pose, another stamp")
    assert_raises(lambda: interpolate_pose([], np.zeros((0, 3)), 0), "no poses")
    assert_raises(lambda: interpolate_pose([0, 10, 10], poses[:3], 5), "stamps that repeat")
    assert_raises(lambda: interpolate_pose([0, 20, 10], poses[:3], 5), "stamps out of order")
    assert_raises(lambda: interpolate_pose([0, 10], poses[:3], 5), "two stamps for three poses")
    assert_raises(lambda: interpolate_pose([0, 10], poses[:2, :2], 5), "poses of shape (2, 2)")
    assert_raises(lambda: to_map(np.ones((4, 3)), pose), "points of shape (4, 3)")
    assert_raises(lambda: to_map(np.ones((4, 2)), (1.0, 2.0)), "a pose of two numbers")


def test_own_work(to_map, interpolate_pose, rng):
    """Five more scans and tracks: right answers where labkit cannot be imported."""
    for trial in range(5):
        points, pose = rng.uniform(-10.0, 10.0, (50, 2)), random_pose(rng)
        assert_points(to_map(points, pose), reference_to_map(points, pose), f"own-work scan {trial}")
        stamps, poses = random_track(rng, 8)
        t = random_stamp(rng, stamps)
        assert_pose(interpolate_pose(stamps, poses, t), reference_pose(stamps, poses, t), f"own-work track {trial}")


# ---------------------------------------------------------------------------- proof (tests/test_exercises.py)
#: A submission that gets the right answers by calling labkit: it must score 0.
DELEGATE = {
    "to_map": '''
import labkit.geometry


def to_map(points, pose):
    return labkit.geometry.transform_points(np.asarray(points, dtype=float).reshape(-1, 2), pose)
''',
    "interpolate_pose": '''
import labkit.poses


def interpolate_pose(stamps, poses, t):
    pose = labkit.poses.PoseTrack.from_samples(stamps, poses).at(t, tolerance_ns=0, max_gap_ns=2**62)
    if pose is None:
        raise ValueError("no pose at that stamp")
    return np.array(pose)
''',
}

#: Plausible wrong answers, as (text in the solution, replacement): a hidden test must catch each.
MISTAKES = {
    "translation before rotation": ("points @ rotation.T + pose[:2]", "(points + pose[:2]) @ rotation.T"),
    "turned the wrong way (R transposed)": ("points @ rotation.T + pose[:2]", "points @ rotation + pose[:2]"),
    "theta interpolated linearly, the long way round": (
        "turn = (theta1 - theta0 + np.pi) % (2 * np.pi) - np.pi", "turn = theta1 - theta0"),
    "theta not wrapped at the end": ("theta = np.pi - (np.pi - theta) % (2 * np.pi)", "pass"),
    "extrapolating instead of raising": ("if t < stamps[0] or t > stamps[-1]:", "if False:"),
    "the last stamp refused": ("if t < stamps[0] or t > stamps[-1]:", "if t < stamps[0] or t >= stamps[-1]:"),
}
