"""The simulator against closed-form geometry, and the consistency of its ground truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from labkit import sim
from labkit.geometry import signed_distance_to_line, transform_points
from labkit.sim.lidar import _frame


def _world(**kw) -> sim.World:
    return sim.World("test", **kw)


def _lidar(**kw) -> sim.Lidar:
    base = dict(name="t", angle_min=-np.pi / 2, angle_increment=np.pi / 180, n_beams=181, range_max=50.0,
                noise_std_m=0.0)
    base.update(kw)
    return sim.Lidar(**base)


def test_facing_a_wall_reads_d_over_cos():
    d = 3.0
    world = _world(walls=(sim.Wall((d, -100.0), (d, 100.0)),))
    lidar = _lidar()
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0))
    expected = d / np.cos(scan.angles)
    front = np.abs(scan.angles) < np.radians(80)
    np.testing.assert_allclose(scan.ranges[front], expected[front], rtol=1e-6)  # float32 storage
    (wall,) = truth.walls
    assert np.isclose(wall.r, d) and np.isclose(wall.alpha, 0.0)
    hit = np.flatnonzero((np.cos(scan.angles) > 0) & (d / np.cos(scan.angles) < lidar.range_max))
    assert (wall.first, wall.last, wall.n_beams) == (hit[0], hit[-1], hit.size)


def test_noise_has_the_stated_spread():
    d, sigma = 3.0, 0.01
    world = _world(walls=(sim.Wall((d, -100.0), (d, 100.0)),))
    lidar = _lidar(noise_std_m=sigma, n_beams=121, angle_min=-np.pi / 3)
    rng = np.random.default_rng(1)
    errs = []
    for _ in range(50):
        scan, _ = sim.scan_at(world, lidar, (0.0, 0.0, 0.0), rng=rng)
        errs.append(scan.ranges - d / np.cos(scan.angles))
    errs = np.concatenate(errs)
    assert abs(errs.mean()) < 3 * sigma / np.sqrt(errs.size)
    assert np.isclose(errs.std(), sigma, rtol=0.05)


def test_circle_tangent_beams():
    # a circle of radius R at distance D: beams hit it while |theta| < asin(R / D)
    R, D = 0.5, 4.0
    world = _world(circles=(sim.Column((D, 0.0), R),))
    lidar = _lidar(angle_min=-0.3, angle_increment=0.001, n_beams=601)
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0))
    half = np.arcsin(R / D)
    inside = np.abs(scan.angles) < half - 1e-4
    outside = np.abs(scan.angles) > half + 1e-4
    assert scan.valid[inside].all() and not scan.valid[outside].any()
    # the near intersection: D cos t - sqrt(R^2 - D^2 sin^2 t)
    t = scan.angles[inside]
    np.testing.assert_allclose(scan.ranges[inside], D * np.cos(t) - np.sqrt(R**2 - (D * np.sin(t)) ** 2),
                               rtol=1e-6)
    (c,) = truth.circles
    np.testing.assert_allclose(c.center, (D, 0.0))
    assert c.radius == R


def test_arc_is_seen_from_inside():
    # a quarter arc of radius 2 around the origin, seen from its centre: every beam reads 2
    world = _world(arcs=(sim.Arc((0.0, 0.0), 2.0, 0.0, np.pi / 2),))
    lidar = _lidar(angle_min=0.05, angle_increment=0.01, n_beams=140)
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0))
    np.testing.assert_allclose(scan.ranges, 2.0, rtol=1e-6)
    assert len(truth.arcs) == 1


def test_max_range_and_dropouts():
    world = _world(walls=(sim.Wall((3.0, -1.0), (3.0, 1.0)),))
    lidar = _lidar(range_max=10.0, dropout_prob=0.3)
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0), rng=np.random.default_rng(0))
    missed = truth.hits < 0
    assert np.all(scan.ranges[missed & np.isfinite(scan.ranges)] == 10.0)  # "no return" = range_max
    assert not scan.valid[missed].any()
    dropped = np.isnan(scan.ranges)
    assert 0.2 < dropped.mean() < 0.4


def test_pose_moves_the_view():
    world = _world(walls=(sim.Wall((5.0, -10.0), (5.0, 10.0)),))
    lidar = _lidar()
    # standing at x = 2 facing +x, the wall is 3 m ahead; turned by 90 deg it is to the right
    _, t0 = sim.scan_at(world, lidar, (2.0, 0.0, 0.0))
    _, t1 = sim.scan_at(world, lidar, (2.0, 0.0, np.pi / 2))
    assert np.isclose(t0.walls[0].r, 3.0) and np.isclose(t0.walls[0].alpha, 0.0)
    assert np.isclose(t1.walls[0].r, 3.0) and np.isclose(t1.walls[0].alpha, -np.pi / 2)


@pytest.mark.parametrize("name", ["hall", "corridor", "office", "random_polygons_3"])
def test_truth_is_consistent_with_the_scan(name):
    sc = sim.scenario(name)
    for k, (scan, truth) in enumerate(sim.simulate(sc, seed=0)):
        if k % 20:
            continue
        xy = scan.points
        for w in truth.walls:
            idx = np.arange(w.first, w.last + 1) if w.last >= w.first else \
                np.r_[w.first:scan.n_beams, 0:w.last + 1]
            assert np.all(truth.hits[idx] == w.wall_id)
            ok = scan.valid[idx]
            # noisy points lie on the true line within a few sigma
            d = signed_distance_to_line(xy[idx][ok], w.r, w.alpha)
            assert np.all(np.abs(d) < 6 * sc.lidar.noise_std_m / np.cos(1.45) + 1e-6)
            # the stated endpoints are on the line too
            assert abs(signed_distance_to_line(np.array([w.start, w.end]), w.r, w.alpha)).max() < 1e-5
        for c in truth.circles + truth.legs:
            radius = getattr(c, "radius", None) or c.diameter / 2
            idx = np.flatnonzero(truth.hits == c.object_id)
            ok = scan.valid[idx]
            dist = np.hypot(*(xy[idx][ok] - np.array(c.center)).T)
            assert np.all(np.abs(dist - radius) < 8 * sc.lidar.noise_std_m + 1e-6)


def test_people_walk_with_alternating_legs():
    p = sim.Walker(sim.PathSpec(((0.0, 0.0), (100.0, 0.0)), "bounce"), speed_mps=1.0, step_length_m=0.4)
    t = np.arange(0, 4, 0.01)
    left = np.array([p.legs_at(ti)[0] for ti in t])
    right = np.array([p.legs_at(ti)[1] for ti in t])
    vl = np.abs(np.diff(left[:, 0])) > 1e-9
    vr = np.abs(np.diff(right[:, 0])) > 1e-9
    assert not np.any(vl & vr)  # one leg is planted at any time
    assert vl.any() and vr.any()  # and both take turns
    assert np.all(np.abs(left[:, 1] - right[:, 1]) == pytest.approx(p.leg_separation_m))
    centre = np.array([p.center_at(ti) for ti in t])
    assert np.all(np.abs(0.5 * (left[:, 0] + right[:, 0]) - centre[:, 0]) <= p.step_length_m)
    with pytest.raises(ValueError, match="leg_diameter_m"):
        sim.Walker(sim.PathSpec(((0, 0), (1, 0))), leg_diameter_m=0.3)


@pytest.mark.parametrize("name", ["hall", "corridor", "office"])
def test_scenarios_have_no_collisions(name):
    """The sensor never stands inside an object and moving objects never overlap."""
    sc = sim.scenario(name)
    w = sc.world
    for t in np.arange(0.0, sc.duration_s, 0.05):
        frame = _frame(w, t)
        pose = sc.trajectory.pose_at(t)
        c, r = frame.circ_center, frame.circ_radius
        if len(c):
            assert np.all(np.hypot(*(c - pose[:2]).T) > r + 0.2), f"sensor inside a circle at t={t}"
            gaps = np.hypot(*(c[:, None] - c[None]).transpose(2, 0, 1)) - (r[:, None] + r[None])
            np.fill_diagonal(gaps, np.inf)
            assert gaps.min() > 0.0, f"objects overlap at t={t}"
        for wall in w.walls:
            a, b = np.array(wall.start), np.array(wall.end)
            for centre, radius in zip(c, r, strict=True):
                u = np.clip(np.dot(centre - a, b - a) / np.dot(b - a, b - a), 0, 1)
                assert np.hypot(*(a + u * (b - a) - centre)) > radius, f"{wall.name} cuts an object at t={t}"
            u = np.clip(np.dot(np.array(pose[:2]) - a, b - a) / np.dot(b - a, b - a), 0, 1)
            assert np.hypot(*(a + u * (b - a) - pose[:2])) > 0.2, f"sensor at a wall at t={t}"


def test_same_seed_same_scans_and_different_seed_differs():
    a = [s.ranges for s, _ in sim.simulate("office", seed=3, n_scans=5)]
    b = [s.ranges for s, _ in sim.simulate("office", seed=3, n_scans=5)]
    c = [s.ranges for s, _ in sim.simulate("office", seed=4, n_scans=5)]
    assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, c, strict=True))


def test_full_circle_truth_wraps_across_the_seam():
    # a wall behind an XV-11: the beams at -180 and +179 deg hit the same wall
    world = _world(walls=(sim.Wall((-2.0, -3.0), (-2.0, 3.0)),))
    lidar = sim.LIDARS["xv11"]
    scan, truth = sim.scan_at(world, lidar, (0.0, 0.0, 0.0))
    (wall,) = truth.walls
    assert wall.first > wall.last  # the run crosses the seam
    assert wall.n_beams == int((truth.hits == 0).sum())


def test_truth_round_trips_through_json(tmp_path):
    sc = sim.scenario("hall")
    pairs = list(sim.simulate(sc, seed=0, n_scans=3))
    path = tmp_path / "x.truth.jsonl"
    assert sim.write_truth(path, sc, [t for _, t in pairs], seed=0) == 3
    gt = sim.read_truth(path)
    assert len(gt) == 3 and gt.header["seed"] == 0 and gt.objects[0]["kind"] == "wall"
    for scan, truth in pairs:
        back = gt[scan.stamp_ns]
        assert np.array_equal(back.hits, truth.hits)
        assert len(back.walls) == len(truth.walls)
        for a, b in zip(back.walls, truth.walls, strict=True):
            assert a.first == b.first and np.isclose(a.r, b.r, atol=1e-6)
    path.write_text("{}\n")
    with pytest.raises(ValueError, match="not a labkit ground-truth header"):
        sim.read_truth(path)
    path.write_text(json.dumps({"labkit_truth": 1, "lidar": {"n_beams": 3}}) + "\n{bad\n")
    with pytest.raises(ValueError, match="line 2"):
        sim.read_truth(path)


def test_random_polygons_are_deterministic_and_separate():
    a, b = sim.random_polygons(7), sim.random_polygons(7)
    assert a == b and len(a.walls) > 4
    assert sim.random_polygons(8) != a
    with pytest.raises(ValueError, match="n_obstacles"):
        sim.random_polygons(0, n_obstacles=-1)


def test_unknown_names_list_the_choices():
    with pytest.raises(ValueError, match="hall"):
        sim.make_world("atrium")
    with pytest.raises(ValueError, match="hall"):
        sim.scenario("atrium")


def test_scan_pose_places_points_on_world_walls():
    sc = sim.scenario("corridor")
    for scan, _truth in sim.simulate(sc, seed=0, n_scans=40):
        world_pts = transform_points(scan.xy, scan.pose)
        assert np.all(world_pts[:, 0] > -0.1) and np.all(world_pts[:, 0] < 30.1)
