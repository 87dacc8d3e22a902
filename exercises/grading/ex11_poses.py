"""Hidden tests of exercise 11, ``to_map(points, pose)`` and ``interpolate_pose(stamps, poses, t)``.

Trusted: the grader runs this file in its own process, never where the student's code runs, and
nbgrader never copies it into the release. Each ``test_<cell>`` (or ``test_<cell>__<function>``)
function holds hidden tests of the graded cell with that grade id for one of the student's
functions: it gets that function (calls into the sandboxed worker) and ``rng``, a generator seeded
per submission and test, fresh for every change of the submitted code. Its messages name what is
wrong, never the inputs or the expected values. See exercises/README.md.

Two references for every answer: labkit (``labkit.geometry.transform_points``,
``labkit.poses.interpolate_poses`` with no tolerance beyond the stamps and no gap limit) and the
closed form with homogeneous 3 x 3 matrices built here (a point is ``H(pose) @ (x, y, 1)``; the
turn between two headings is the angle of the rotation block of ``H(p0)^-1 H(p1)``, which is the
short way round by construction). The two must agree before a student's answer is compared.
"""

import numpy as np

import labkit

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
    assert got.shape == want.shape, f"{where}: one row (x, y) per point, got shape {got.shape}"
    if len(want):
        wrong = np.flatnonzero(~np.all(np.isclose(got, want, rtol=0, atol=atol), axis=1))
        assert wrong.size == 0, (
            f"{where}: {wrong.size} of {len(want)} points differ from the reference (the first: point {wrong[0]}). "
            "R(theta) @ p + (x, y): rotate first, then translate, counter-clockwise by theta?")


def assert_pose(got, want, where, atol=1e-9):
    try:
        got = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        raise AssertionError(f"{where}: return (x, y, theta), got {type(got).__name__}") from None
    assert got.shape == (3,), f"{where}: return the pose (x, y, theta), got shape {got.shape}"
    assert np.allclose(got[:2], want[:2], rtol=0, atol=atol), f"{where}: x or y is off. Linear in time?"
    assert abs(labkit.wrap_angle(got[2] - want[2])) < 1e-9, (
        f"{where}: theta is off. theta0 + u * (theta1 - theta0 wrapped): the short way round?")
    assert -np.pi - 1e-12 <= got[2] <= np.pi + 1e-12, f"{where}: theta is outside (-pi, pi]: wrap it"


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


# ---------------------------------------------------------------------------- to_map
def test_hidden_random__to_map(to_map, rng):
    """40 random scans placed in the map, against labkit and the homogeneous matrices."""
    for trial in range(40):
        n = int(rng.integers(1, 400))
        points = rng.uniform(-30.0, 30.0, (n, 2))
        pose = random_pose(rng)
        assert_points(to_map(points, pose), reference_to_map(points, pose), f"random scan {trial} ({n} points)")


def test_hidden_edges__to_map(to_map, rng):
    """No points (an empty array, an empty list), lists, integers, headings of +-pi; wrong shapes (ValueError)."""
    pose = random_pose(rng)
    assert_points(to_map(np.zeros((0, 2)), pose), np.zeros((0, 2)), "no points (an array of shape (0, 2))")
    assert_points(to_map([], pose), np.zeros((0, 2)), "no points (an empty list)")
    x, y = (float(v) for v in rng.uniform(-5.0, 5.0, 2))
    two = rng.uniform(-5.0, 5.0, (2, 2)).tolist()
    for k, (points, pose) in enumerate([
        (rng.uniform(-5.0, 5.0, (1, 2)).tolist(), random_pose(rng)),
        (rng.integers(-9, 10, (2, 2)).tolist(), rng.integers(-9, 10, 3).tolist()),  # integers, lists
        (two, (x, y, np.pi)),                                                     # heading pi
        (two, [x, y, -np.pi]),                                                    # heading -pi: the same
        (rng.uniform(-5, 5, (7, 2)).tolist(), random_pose(rng).tolist()),
    ]):
        assert_points(to_map(points, pose), reference_to_map(points, pose), f"to_map edge case {k}")
    assert_raises(lambda: to_map(np.ones((int(rng.integers(1, 6)), 3)), pose), "points of three columns")
    assert_raises(lambda: to_map(np.ones((4, 2)), tuple(rng.uniform(-5, 5, 2))), "a pose of two numbers")


def test_own_work__to_map(to_map, rng):
    """Five more scans: right answers where labkit cannot be imported."""
    for trial in range(5):
        points, pose = rng.uniform(-10.0, 10.0, (50, 2)), random_pose(rng)
        assert_points(to_map(points, pose), reference_to_map(points, pose), f"own-work scan {trial}")


# ---------------------------------------------------------------------------- interpolate_pose
def test_hidden_random__interpolate_pose(interpolate_pose, rng):
    """60 random tracks read at random stamps (a fifth exactly at a stamp), against labkit and the matrices."""
    for trial in range(60):
        stamps, poses = random_track(rng, int(rng.integers(2, 30)))
        for _ in range(3):
            t = random_stamp(rng, stamps)
            assert_pose(interpolate_pose(stamps, poses, t), reference_pose(stamps, poses, t),
                        f"random track {trial} ({len(stamps)} poses)")


def _across(rng, sign):
    """Two headings either side of +-pi (a turn across it, ``sign`` the way round) and a stamp where the heading
    has crossed it (so it must be wrapped back into (-pi, pi])."""
    a, b = rng.uniform(0.05, 0.5, 2)  # the first heading a short of pi (of -pi), the second b past it
    first, second = (np.pi - a, -np.pi + b) if sign > 0 else (-np.pi + a, np.pi - b)
    span = int(rng.integers(1000, 10**6))
    crossed = a / (a + b)  # the fraction of the way at which the heading crosses +-pi
    t = int(np.ceil(span * (crossed + rng.uniform(0.1, 0.9) * (1 - crossed))))
    return [0, span], [[0.0, 0.0, first], rng.uniform(-2.0, 2.0, 2).tolist() + [second]], min(t, span - 1)


def test_hidden_edges__interpolate_pose(interpolate_pose, rng):
    """One pose, the end stamps, lists, integers, turns across +-pi (both ways) and not across; stamps outside the
    track, repeated or out of order, mismatched shapes (ValueError)."""
    stamps, poses = random_track(rng, 6)
    calm = [[0.0, 0.0, -0.2], [1.0, 1.0, 0.6]]
    span = int(rng.integers(10, 1000))
    cases = [
        ("one pose, read at its stamp", [stamps[0]], poses[:1], int(stamps[0])),
        ("the first stamp", stamps, poses, int(stamps[0])),
        ("the last stamp", stamps, poses, int(stamps[-1])),
        ("just before the last stamp", stamps, poses, int(stamps[-1]) - 1),
        ("lists", stamps.tolist(), poses.tolist(), int(stamps[2]) + 1),
        ("a turn across +-pi", *_across(rng, 1)),
        ("a turn across +-pi the other way", *_across(rng, -1)),
        ("a turn not across +-pi", [0, span], calm, int(rng.integers(1, span))),
        ("integers", [0, 100, 200], rng.integers(-3, 4, (3, 3)).tolist(), int(rng.integers(101, 200))),
    ]
    for what, st, ps, t in cases:
        assert_pose(interpolate_pose(st, ps, t), reference_pose(st, ps, t), f"interpolate_pose: {what}")
    assert_raises(lambda: interpolate_pose(stamps, poses, int(stamps[0]) - int(rng.integers(1, 10**6))),
                  "a stamp before the first pose")
    assert_raises(lambda: interpolate_pose(stamps, poses, int(stamps[-1]) + int(rng.integers(1, 10**6))),
                  "a stamp after the last pose")
    assert_raises(lambda: interpolate_pose([stamps[0]], poses[:1], int(stamps[0]) + 1), "one pose, another stamp")
    assert_raises(lambda: interpolate_pose([], np.zeros((0, 3)), 0), "no poses")
    assert_raises(lambda: interpolate_pose([0, 10, 10], poses[:3], 5), "stamps that repeat")
    assert_raises(lambda: interpolate_pose([0, 20, 10], poses[:3], 5), "stamps out of order")
    assert_raises(lambda: interpolate_pose([0, 10], poses[:3], 5), "two stamps for three poses")
    assert_raises(lambda: interpolate_pose([0, 10], poses[:2, :2], 5), "poses of two numbers")


def test_own_work__interpolate_pose(interpolate_pose, rng):
    """Five more tracks: right answers where labkit cannot be imported."""
    for trial in range(5):
        stamps, poses = random_track(rng, 8)
        t = int(stamps[-1]) if trial == 0 else random_stamp(rng, stamps)  # the last stamp is in the track
        assert_pose(interpolate_pose(stamps, poses, t), reference_pose(stamps, poses, t), f"own-work track {trial}")
    for sign in (1, -1):
        stamps, poses, t = _across(rng, sign)
        assert_pose(interpolate_pose(stamps, poses, t), reference_pose(stamps, poses, t), "own-work turn across +-pi")


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
