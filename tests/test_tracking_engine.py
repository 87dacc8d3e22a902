"""labkit._tracking_engine: the tracker's default (compiled) path gives the reference's tracks.

The reference is labkit/tracking.py's readable code, which ``trace=True`` runs; the default path
runs the same steps as numba kernels. Both trackers are fed the same scans side by side and every
table compared: identities, kinds, statuses, hits, stamps, which detection updated which track and
the events exactly; states and covariances to 1e-12 (the kernels take the same formulas in another
order of floating-point operations)."""

from __future__ import annotations

import dataclasses
import math
import types

import numpy as np
import pytest

from labkit import Config, extract_all, sim, tracking
from labkit import _tracking_engine as engine
from labkit.tracking import Detections, Tracker

ATOL = 1e-12


def _same(fast, ref, where) -> None:
    assert not fast.late and not ref.late or fast.late == ref.late, where
    assert fast.ids.tolist() == ref.ids.tolist(), where
    assert fast.kinds.tolist() == ref.kinds.tolist(), where
    assert fast.status.tolist() == ref.status.tolist(), where
    assert fast.events == ref.events, where
    assert fast.detection.tolist() == ref.detection.tolist(), where
    assert fast.hits.tolist() == ref.hits.tolist(), where
    assert fast.born_ns.tolist() == ref.born_ns.tolist(), where
    assert fast.last_seen_ns.tolist() == ref.last_seen_ns.tolist(), where
    np.testing.assert_allclose(fast.states, ref.states, rtol=0, atol=ATOL, err_msg=str(where))
    np.testing.assert_allclose(fast.covariances, ref.covariances, rtol=0, atol=ATOL, err_msg=str(where))


def _side_by_side(stream, params=None) -> dict:
    """Feed ``(detections or features, pose)`` to a default and a tracing tracker; compare every
    table; counts of what was seen (to check that the cases are not trivial)."""
    fast, ref = Tracker(**(params or {})), Tracker(**(params or {}))
    seen = {"scans": 0, "events": 0, "confirmed": 0, "static": 0, "updates": 0}
    for k, (observed, pose) in enumerate(stream):
        a = fast.step(observed, pose=pose)
        b, steps = ref.step(observed, pose=pose, trace=True)
        _same(a, b, k)
        seen["scans"] += 1
        seen["events"] += len(b.events)
        seen["confirmed"] += int(b.confirmed().sum())
        seen["static"] += int((b.status == "static").sum())
        seen["updates"] += sum(s.kind == "update" for s in steps)
    return seen


class _Counting:
    """The engine, its kernels wrapped to count their calls (and those of the assignment solver)."""

    KERNELS = ("in_frame", "predict_and_gate", "update", "manage", "update_and_manage", "scan_step")

    def __init__(self, monkeypatch):
        self.calls = dict.fromkeys((*self.KERNELS, "assign", "into the map"), 0)
        proxy = types.SimpleNamespace(**{name: self._counted(name, getattr(engine, name)) for name in self.KERNELS})
        monkeypatch.setattr(tracking, "_ENGINE", proxy)
        monkeypatch.setattr(tracking, "assign", self._counted("assign", tracking.assign))

    def _counted(self, name, fn):
        def wrapper(*args, **kwargs):
            self.calls[name] += 1
            if name == "scan_step" and args[9]:  # its in_map: the detections moved by the pose
                self.calls["into the map"] += 1
            return fn(*args, **kwargs)
        return wrapper


def test_the_engine_runs_here_and_shares_the_status_codes():
    kernels = tracking._engine()
    assert kernels is not None, "the kernels must run on this machine (else nothing is compared)"
    assert all(getattr(kernels, name) is getattr(engine, name) for name in _Counting.KERNELS)
    assert (engine.TENTATIVE, engine.STATIC, engine.CONFIRMED, engine.DELETED, engine.CIRCLE) == (
        tracking._TENTATIVE, tracking._STATIC, tracking._CONFIRMED, tracking._DELETED, tracking._CIRCLE)


def test_the_default_path_runs_the_kernels_and_not_the_reference(monkeypatch):
    """Would fail if the default path fell back to the reference silently: the reference's steps
    raise, and every kernel must have run."""
    assert tracking._engine() is not None, "the kernels are switched off (LABKIT_NO_JIT) or failed to import"
    counting = _Counting(monkeypatch)
    for name in ("_predict", "_gate_all", "_update", "_birth", "_confirm", "_to_delete"):
        monkeypatch.setattr(Tracker, name, lambda *a, _n=name, **k: pytest.fail(f"the reference's {_n} ran"))
    tracker = Tracker()
    for k in range(12):
        seen = Detections(k * 100_000_000, ("person", "person", "circle"),
                          [[0.1 * k, 0.0], [5.0, 0.1 * k], [3.0, 3.0]])
        table = tracker.step(seen)
    assert table.status.tolist() == ["confirmed", "confirmed", "static"]
    assert all(counting.calls[n] for n in ("scan_step", "update", "manage")), counting.calls  # (births: update, manage)
    assert counting.calls["assign"] == 0, "no conflict in any gate: the assignment problem is not solved"


def _scans(name, n_scans, trajectory=None, noise=0.02, seed=4):
    sc = sim.scenario(name)
    sc = dataclasses.replace(sc, lidar=dataclasses.replace(sc.lidar, noise_std_m=noise))
    if trajectory is not None:
        sc = dataclasses.replace(sc, trajectory=trajectory)
    scans = [s for s, _ in sim.simulate(sc, seed=seed, n_scans=n_scans)]
    return scans, extract_all(scans, Config())


ROBOT = sim.Trajectory(((0.0, 4.0, 0.4, math.pi / 2), (8.0, 8.0, 0.6, math.pi / 2 + 0.4),
                        (16.0, 4.0, 0.4, math.pi / 2 - 0.3)))


@pytest.mark.parametrize("name, trajectory, frame", [
    ("crossing_4", None, "auto"),
    ("crossing_6", ROBOT, "map"),
    ("crossing_2", ROBOT, "sensor"),
])
def test_the_engine_gives_the_references_tracks_on_the_simulated_worlds(monkeypatch, name, trajectory, frame):
    counting = _Counting(monkeypatch)
    scans, features = _scans(name, 160, trajectory)
    seen = _side_by_side(((f, s.pose) for s, f in zip(scans, features, strict=True)), {"frame": frame})
    assert seen["confirmed"] > 100 and seen["updates"] > 300 and seen["events"] > 5, seen
    assert counting.calls["scan_step"] > 100, counting.calls
    assert (counting.calls["into the map"] > 100) == (frame != "sensor"), counting.calls


def _random_case(rng):
    """Targets moving and standing, a clutter of false detections, targets that vanish, close
    passes (gates that hold two detections), full covariances, gaps in time and poses."""
    n_targets = int(rng.integers(1, 7))
    start = rng.uniform(-5, 5, (n_targets, 2))
    speed = rng.uniform(-1.5, 1.5, (n_targets, 2)) * (rng.random((n_targets, 1)) < 0.7)
    kind = rng.choice(["person", "circle"], n_targets)
    with_pose = rng.random() < 0.5
    stamp = 0
    for _ in range(int(rng.integers(20, 60))):
        stamp += int(rng.choice([50_000_000, 100_000_000, 100_000_000, 400_000_000, 2_000_000_000],
                                p=[0.2, 0.5, 0.2, 0.08, 0.02]))
        kinds, xy = [], []
        for i in range(n_targets):
            if rng.random() < 0.15:
                continue
            p = start[i] + speed[i] * stamp * 1e-9 + rng.normal(0, 0.03, 2)
            if kind[i] == "person" and rng.random() < 0.3:  # seen as one leg, or two
                for _ in range(int(rng.integers(1, 3))):
                    kinds.append("leg")
                    xy.append(p + rng.normal(0, 0.1, 2))
            else:
                kinds.append(str(kind[i]))
                xy.append(p)
        for _ in range(int(rng.poisson(1.0))):  # clutter
            kinds.append(str(rng.choice(["person", "leg", "circle"])))
            xy.append(rng.uniform(-6, 6, 2))
        order = rng.permutation(len(kinds))
        kinds = tuple(kinds[i] for i in order)
        xy = np.array(xy, dtype=float).reshape(-1, 2)[order]
        cov = None
        if rng.random() < 0.5 and len(kinds):
            L = rng.normal(0, 0.05, (len(kinds), 2, 2))
            cov = L @ np.swapaxes(L, 1, 2) + 1e-3 * np.eye(2)
        pose = tuple(rng.uniform([-1, -1, -math.pi], [1, 1, math.pi])) if with_pose else None
        if pose is not None:  # the targets are in the map: give the detections in the sensor frame
            c, s = math.cos(pose[2]), math.sin(pose[2])
            xy = (xy - np.array(pose[:2])) @ np.array([[c, -s], [s, c]])
        yield Detections(stamp, kinds, xy, cov), pose


def _random_params(rng) -> dict:
    m = int(rng.integers(1, 4))
    return {"acceleration_noise_m2_s3": float(rng.choice([0.0, 0.5, 3.0])), "confirm_hits": m,
            "confirm_scans": m + int(rng.integers(0, 3)), "max_coast_s": float(rng.choice([0.0, 0.3, 1.5])),
            "min_travel_m": float(rng.choice([0.05, 0.3])), "gate_probability": float(rng.choice([0.9, 0.99])),
            "single_legs": bool(rng.random() < 0.8)}


def test_the_engine_gives_the_references_tracks_on_random_cases(monkeypatch):
    counting = _Counting(monkeypatch)
    rng = np.random.default_rng(36)
    total = {"scans": 0, "events": 0, "confirmed": 0, "static": 0, "updates": 0}
    for case in range(16):
        params = _random_params(rng) if case % 2 else None
        seen = _side_by_side(_random_case(rng), params)
        total = {k: total[k] + seen[k] for k in total}
    assert total["confirmed"] > 200 and total["static"] > 50 and total["updates"] > 500, total
    assert counting.calls["assign"] > 10, ("conflicts in the gates must have been solved", counting.calls)
    assert counting.calls["update_and_manage"] > 10, ("scan_step left conflicts to the caller", counting.calls)


def test_with_no_jit_the_reference_runs(monkeypatch):
    monkeypatch.setattr(tracking, "_ENGINE", None)
    monkeypatch.setattr(tracking.Tracker, "_compiled_step", lambda *a, **k: pytest.fail("the kernels ran"))
    tracker = Tracker()
    for k in range(3):
        table = tracker.step(Detections(k * 100_000_000, ("person",), [[0.5 * k, 0.0]]))
    assert table.status.tolist() == ["static"] and table.events == (("static", 1),)


# ---------------------------------------------------------------------------- the bulk conversion
def _equal(found: tuple, ref: Detections, where) -> None:
    """The bulk conversion's arrays are the reference's: same values, types and shapes."""
    stamp, kinds, positions, covariances, first, last, det_kind, starts = found
    assert stamp == ref.stamp_ns and kinds == ref.kinds, where
    for name, a in (("positions", positions), ("covariances", covariances), ("first", first), ("last", last)):
        b = getattr(ref, name)
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), (where, name)
    assert det_kind.tolist() == [int(tracking.DETECTION_KINDS[k] == "circle") for k in kinds], where
    assert starts.tolist() == [k != "leg" for k in kinds], where


@pytest.mark.parametrize("name, trajectory", [("crossing_6", None), ("crossing_2", ROBOT)])
def test_the_bulk_detections_are_detections_from_on_the_simulated_worlds(name, trajectory):
    """The compiled path's conversion of a scan's features (tracking._bulk_detections) gives the
    arrays of the readable detections_from, bit for bit, with the default sigmas and others, with
    and without single legs; the scans hold people, single legs and circles."""
    scans, features = _scans(name, 50, trajectory, noise=0.03)
    counts = {"person": 0, "leg": 0, "circle": 0, "legs in people": 0}
    for k, f in enumerate(features):
        for sigmas, single in (((0.08, 0.2, 0.05), True), ((0.1, 0.3, 0.07), False)):
            ref = tracking.detections_from(f, person_sigma_m=sigmas[0], leg_sigma_m=sigmas[1],
                                           circle_sigma_m=sigmas[2], single_legs=single)
            _equal(tracking._bulk_detections(f, *sigmas, single), ref, (k, single))
            if single:
                for kind in ref.kinds:
                    counts[kind] += 1
        counts["legs in people"] += 2 * len(f.people)
    assert min(counts["person"], counts["leg"], counts["circle"], counts["legs in people"]) > 20, counts


def test_the_bulk_detections_of_features_built_by_hand():
    """Centres of another type or shape (a record built by hand) take the reference's conversion;
    a person whose legs are not in scan order still spans both; no feature gives no detection."""
    from labkit.features import Circle, Features, Leg, Person

    def leg(x, y, first, last):
        return Leg(np.array([x, y]), 0.12, np.array([x, y]), first, last, 5, 2.0, 0.1)

    a, b, c = leg(1.0, 0.0, 30, 34), leg(1.2, 0.2, 10, 14), leg(3.0, 1.0, 50, 52)
    person = Person(np.array([1.1, 0.1]), (a, b))
    circle = Circle(np.array([2, 2]), 0.1, 2.0, 0.1, 0.9, 60, 66, 7)  # integer centre
    arc = Circle(np.array([5.0, 5.0]), 0.1, 2.0, 0.1, 0.9, 70, 76, 7, kind="arc-like")
    labels = np.zeros(100, dtype=np.int64)
    for f in (Features(7, 100, labels, circles=(circle, arc), legs=(a, b, c), people=(person,)),
              Features(8, 100, labels, circles=(arc,), legs=(a, b, c), people=(person,)),
              Features(9, 100, labels), Features(10, 100, labels, circles=(arc,)),
              Features(11, 100, labels, circles=(circle, arc))):
        for single in (True, False):
            ref = tracking.detections_from(f, single_legs=single)
            _equal(tracking._bulk_detections(f, 0.08, 0.2, 0.05, single), ref, (f.stamp_ns, single))
    assert tracking._bulk_detections(Features(8, 100, labels, legs=(a, b, c), people=(person,)), 0.08, 0.2, 0.05,
                                     True)[4].tolist() == [10, 50]


@pytest.mark.parametrize("frame", ["map", "sensor"])
def test_the_tables_detections_make_their_beams_when_read_and_stay_a_record(frame):
    """The compiled path leaves a table's beams (first, last) unmade until read (the tracker never
    reads them); read, pickled, copied, replaced or printed, they are detections_from's and the
    reference's, and the record behaves as one built with its beams given."""
    import copy
    import pickle

    uses = {"read": lambda d: d, "pickle": lambda d: pickle.loads(pickle.dumps(d)), "deepcopy": copy.deepcopy,
            "copy": copy.copy, "replace": lambda d: dataclasses.replace(d, stamp_ns=d.stamp_ns + 1),
            "in_frame": lambda d: d.in_frame((1.0, 2.0, 0.3))}
    scans, features = _scans("crossing_2", 12, ROBOT, noise=0.03)
    features = list(features)
    fast = {use: Tracker(frame=frame) for use in (*uses, "repr")}  # a record of its own for each use
    ref = Tracker(frame=frame)
    lazy = 0
    for k, (scan, f) in enumerate(zip(scans, features, strict=True)):
        r = ref.step(f, pose=scan.pose, trace=True)[0].detections  # the reference's record, beams given
        truth = tracking.detections_from(f)
        assert len(truth), k
        records = {use: tracker.step(f, pose=scan.pose).detections for use, tracker in fast.items()}
        lazy += sum("_beams" in vars(d) for d in records.values())  # not made yet
        for use, made in uses.items():
            d = made(records[use])
            for name in ("first", "last"):
                a, b = getattr(d, name), getattr(truth, name)
                assert a.dtype == b.dtype == np.int64 and np.array_equal(a, b), (k, use, name)
                assert np.array_equal(a, getattr(r, name)), (k, use, name)
                assert not a.flags.writeable or use in ("pickle", "deepcopy"), (k, use, name)  # (as positions)
            assert "_beams" not in vars(d), (k, use)
            if use != "in_frame":
                np.testing.assert_allclose(d.positions, r.positions, rtol=0, atol=ATOL)
                np.testing.assert_allclose(d.covariances, r.covariances, rtol=0, atol=ATOL)
                assert d.kinds == r.kinds, (k, use)
        d = records["repr"]
        given = Detections(d.stamp_ns, d.kinds, d.positions, d.covariances, truth.first, truth.last)
        assert repr(d) == repr(given), k
        assert d == d and d != given and d != copy.copy(d), k  # (eq=False: a record equals itself alone)
    assert lazy == len(scans) * len(fast), "the compiled path made the beams before they were read"
    late = fast["read"].step(features[0], pose=scans[0].pose)  # a scan that goes back: its record too
    assert late.late and np.array_equal(late.detections.first, tracking.detections_from(features[0]).first)
    assert Detections(5, ("leg",), [[1.0, 2.0]]).first.tolist() == [-1] and Detections.first is None
