"""The simulator's moving truth (World.movers_at) and the crossing worlds: what their docstrings
promise, measured from the walkers' and the cylinder's own positions."""

from __future__ import annotations

import numpy as np
import pytest

from labkit import sim

TIMES = np.arange(0.0, 64.0, 0.005)  # two full periods of the crossing worlds (32 s)


def _crossing_centres(t: np.ndarray) -> tuple[list[str], np.ndarray]:
    """The movers of crossing_6 at times ``t`` (T,), written out here from the world's definition
    (straight lines walked back and forth, the cylinder round the 7 m x 3 m loop): (T, 7, 2)."""
    out, names = [], ["cylinder"]
    corners = np.array([(2.5, 3.5), (9.5, 3.5), (9.5, 6.5), (2.5, 6.5), (2.5, 3.5)])
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(corners, axis=0), axis=1))])  # 0 .. 20 m
    s = (0.963 * 20.0 + 20.0 / 32.0 * t) % 20.0
    k = np.clip(np.searchsorted(along, s, side="right") - 1, 0, 3)
    out.append(corners[k] + ((s - along[k]) / np.diff(along)[k])[:, None] * (corners[k + 1] - corners[k]))
    for name, (a, b), trip, start in sim.CROSSING_WALKERS:
        a, b = np.array(a), np.array(b)
        length = np.linalg.norm(b - a)
        s = (start * 2 * length + 2 * length / trip * t) % (2 * length)
        s = np.where(s > length, 2 * length - s, s)
        out.append(a + (s / length)[:, None] * (b - a))
        names.append(name)
    return names, np.stack(out, axis=1)


def test_the_movers_are_where_the_world_says():
    world = sim.make_world("crossing_6")
    t = np.array([0.0, 1.3, 7.77, 15.9, 16.0, 29.41, 40.0])
    names, c = _crossing_centres(t)
    for k, tk in enumerate(t):
        movers = world.movers_at(float(tk))
        assert [m.name for m in movers] == names
        np.testing.assert_allclose([m.center for m in movers], c[k], atol=1e-9)


@pytest.mark.parametrize("name", ["hall", "office", "crossing_6"])
def test_velocities_are_the_derivative_of_the_positions(name):
    world = sim.make_world(name)
    h = 1e-4
    for t in (0.7, 3.3, 11.9, 25.05):
        for a, b in zip(world.movers_at(t), world.movers_at(t + h), strict=True):
            assert a.name == b.name
            np.testing.assert_allclose((np.array(b.center) - a.center) / h, a.velocity, atol=1e-6)


@pytest.mark.parametrize("name", ["hall", "crossing_6"])
def test_object_ids_are_the_ids_of_the_truth(name):
    world = sim.make_world(name)
    table = world.objects()
    for m in world.movers_at(1.0):
        kinds = {table[i]["kind"] for i in m.object_ids}
        assert kinds == ({"leg"} if m.kind == "person" else {"cylinder"})
        assert all(table[i]["name"].split("/")[0] == m.name for i in m.object_ids)


def test_a_walkers_centre_is_the_midpoint_of_its_legs_on_a_straight_path():
    world = sim.make_world("crossing_6")
    for p in world.people:
        for t in np.arange(0.3, 7.0, 0.37):
            s = (p.start_offset_m + p.speed_mps * t) % (2 * p.path.length)
            if min(s, abs(s - p.path.length), 2 * p.path.length - s) < p.step_length_m:
                continue  # near a turn: the legs are on both legs of the path
            left, right = p.legs_at(t)
            np.testing.assert_allclose((left + right) / 2, p.center_at(t), atol=1e-9)


def test_the_crossing_worlds_keep_their_promises():
    """Nobody walks into anybody (0.59 m at least between walkers, 0.72 m from the cylinder's
    centre, 0.67 m from a column's), anna and ben cross within 0.6 m, carl and dora pass within
    0.6 m, everybody stays within 6 m of the lidar, and the meetings repeat every 32 s."""
    world = sim.make_world("crossing_6")
    names, c = _crossing_centres(TIMES)
    d = np.linalg.norm(c[:, :, None] - c[:, None], axis=3).min(axis=0)
    np.fill_diagonal(d, np.inf)
    cyl = names.index("cylinder")
    people = [i for i in range(len(names)) if i != cyl]
    assert d[np.ix_(people, people)].min() >= 0.59
    assert d[cyl, people].min() >= 0.72
    assert d[names.index("anna"), names.index("ben")] <= 0.6
    assert d[names.index("carl"), names.index("dora")] <= 0.61
    columns = np.array([k.center for k in world.circles])
    assert np.linalg.norm(c[:, people, None] - columns[None, None], axis=3).min() >= 0.665
    lidar = np.array(sim.scenario("crossing").trajectory.pose_at(0.0)[:2])
    assert np.linalg.norm(c[:, people] - lidar, axis=2).max() <= 6.0
    half = len(TIMES) // 2
    np.testing.assert_allclose(c[:half], c[half:], atol=1e-9)


def test_crossing_worlds_by_name_and_their_limits():
    assert [len(sim.make_world(f"crossing_{n}").people) for n in range(1, 7)] == [1, 2, 3, 4, 5, 6]
    assert sim.make_world("crossing").name == "crossing" and len(sim.make_world("crossing").people) == 4
    assert sim.scenario("crossing_2").world.name == "crossing_2"
    for bad in (0, 7, 2.0, True):
        with pytest.raises(ValueError, match="n_walkers"):
            sim.crossing(bad)
    with pytest.raises(ValueError, match="crossing_<n>"):
        sim.make_world("crossings")
