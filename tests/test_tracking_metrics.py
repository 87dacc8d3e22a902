"""labkit.tracking_metrics: CLEAR MOT and IDF1 against the motmetrics package (an independent
implementation of the same definitions) on hand-built and random sequences; the unseen-object
rule on hand-built frames; the simulated truth frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit import sim
from labkit.tracking import Tracker
from labkit.tracking_metrics import MOTFrame, clear_mot, sim_frames

mm = pytest.importorskip("motmetrics", reason="motmetrics (the dev extra) is the oracle of these tests")

MAX_D = 0.5


def _oracle(frames: list[MOTFrame]) -> dict:
    """motmetrics on the same frames: Euclidean distances, NaN beyond MAX_D (do not pair)."""
    acc = mm.MOTAccumulator(auto_id=True)
    number: dict = {}  # motmetrics (with pandas 3) wants numbers for ids: names become 1, 2, ...
    for f in frames:
        d = np.hypot(f.truth_xy[:, None, 0] - f.hyp_xy[None, :, 0], f.truth_xy[:, None, 1] - f.hyp_xy[None, :, 1])
        d = np.where(d <= MAX_D, d, np.nan)
        acc.update([number.setdefault(o, len(number) + 1) for o in f.truth_ids], list(f.hyp_ids), d)
    names = ["num_objects", "num_predictions", "num_detections", "num_misses", "num_false_positives", "num_switches",
             "num_fragmentations", "mota", "motp", "idtp", "idf1", "idp", "idr"]
    summary = mm.metrics.create().compute(acc, metrics=names, name="x")
    return {k: summary[k].iloc[0] for k in names}


def _compare(frames: list[MOTFrame]) -> None:
    ours = clear_mot(frames, max_distance_m=MAX_D)
    ref = _oracle(frames)
    assert ours.objects == ref["num_objects"]
    assert ours.hypotheses == ref["num_predictions"]
    assert ours.matches == ref["num_detections"]  # every matched pair, switches included (c_t)
    assert ours.misses == ref["num_misses"]
    assert ours.false_positives == ref["num_false_positives"]
    assert ours.id_switches == ref["num_switches"]
    assert ours.fragmentations == ref["num_fragmentations"]
    assert ours.idtp == ref["idtp"]
    for ours_v, ref_v in ((ours.mota, ref["mota"]), (ours.motp, ref["motp"]), (ours.idf1, ref["idf1"]),
                          (ours.idp, ref["idp"]), (ours.idr, ref["idr"])):
        if math.isnan(ref_v):
            assert math.isnan(ours_v)
        else:
            assert ours_v == pytest.approx(ref_v, abs=1e-12)


def _f(truth: dict, hyps: dict) -> MOTFrame:
    return MOTFrame(tuple(truth), list(truth.values()) or None, tuple(hyps), list(hyps.values()) or None)


HAND_BUILT = {
    "perfect": [_f({"a": (0, 0), "b": (2, 0)}, {1: (0.1, 0), 2: (2, 0.1)})] * 4,
    # b's track is lost for a frame and found again under a new id: a switch and a fragmentation
    "lost and renamed": [_f({"a": (0, 0), "b": (2, 0)}, {1: (0, 0), 2: (2, 0)}),
                         _f({"a": (0, 0), "b": (2, 0)}, {1: (0, 0)}),
                         _f({"a": (0, 0), "b": (2, 0)}, {1: (0, 0), 3: (2.2, 0)}),
                         _f({"a": (0, 0), "b": (2, 0)}, {1: (0, 0), 3: (2.2, 0)})],
    # two objects meet and their tracks swap
    "swap at a crossing": [_f({"a": (0, 0), "b": (1, 0)}, {1: (0, 0), 2: (1, 0)}),
                           _f({"a": (0.4, 0), "b": (0.6, 0)}, {1: (0.45, 0), 2: (0.55, 0)}),
                           _f({"a": (1, 0), "b": (0, 0)}, {1: (0, 0), 2: (1, 0)}),
                           _f({"a": (1.5, 0), "b": (-0.5, 0)}, {1: (-0.5, 0), 2: (1.5, 0)})],
    # the last correspondence is kept while within the distance, even when another track is nearer
    "keep the last partner": [_f({"a": (0, 0)}, {1: (0.3, 0)}),
                              _f({"a": (0, 0)}, {1: (0.4, 0), 2: (0.0, 0)}),
                              _f({"a": (0, 0)}, {1: (0.6, 0), 2: (0.0, 0)})],
    # false positives, an object absent for frames (not a fragmentation), empty frames
    "gaps and clutter": [_f({"a": (0, 0)}, {1: (0, 0), 9: (5, 5)}),
                         _f({}, {1: (0, 0)}),
                         _f({}, {}),
                         _f({"a": (0, 0)}, {1: (0, 0)}),
                         _f({"a": (0, 0)}, {}),
                         _f({"a": (0, 0)}, {}),
                         _f({"a": (0, 0)}, {1: (0.1, 0)})],
    # one track standing between two objects, then taken over by the other
    "transfer": [_f({"a": (0, 0), "b": (0.8, 0)}, {1: (0.3, 0)}),
                 _f({"a": (0, 0), "b": (0.8, 0)}, {1: (0.6, 0)}),
                 _f({"a": (0, 0), "b": (0.8, 0)}, {1: (0.1, 0), 2: (0.8, 0)})],
    "nothing tracked": [_f({"a": (0, 0)}, {})] * 3,
    "nothing there": [_f({}, {1: (0, 0)})] * 2,
}


@pytest.mark.parametrize("name", sorted(HAND_BUILT))
def test_hand_built_sequences_score_as_motmetrics(name):
    _compare(HAND_BUILT[name])


def test_hand_built_counts_are_the_ones_worked_out_by_hand():
    s = clear_mot(HAND_BUILT["lost and renamed"])
    assert (s.matches, s.misses, s.false_positives, s.id_switches, s.fragmentations) == (7, 1, 0, 1, 1)
    assert s.mota == pytest.approx(1 - 2 / 8) and s.motp == pytest.approx(0.4 / 7)
    assert s.idtp == 6 and s.idf1 == pytest.approx(12 / 15)  # (a, 1) 4 frames + (b, 3) 2 (not (b, 2): 1), 8 + 7
    s = clear_mot(HAND_BUILT["keep the last partner"])
    assert (s.matches, s.false_positives, s.id_switches) == (3, 2, 1)  # kept 1 at 0.4 m, then 2 when 1 left
    s = clear_mot(HAND_BUILT["gaps and clutter"])
    assert (s.objects, s.misses, s.false_positives, s.fragmentations) == (5, 2, 2, 1)


@pytest.mark.parametrize("seed", range(8))
def test_random_sequences_score_as_motmetrics(seed):
    """Objects random-walking, appearing and leaving; hypotheses that follow them with noise,
    drop out, swap, split and appear from nowhere."""
    rng = np.random.default_rng(seed)
    n_obj, n_frames = int(rng.integers(1, 6)), 60
    pos = rng.uniform(0, 3, size=(n_obj, 2))
    alive = rng.random(n_obj) < 0.8
    hyp_of = {o: o + 100 for o in range(n_obj)}
    next_hyp = 1000
    frames = []
    for _ in range(n_frames):
        pos += rng.normal(scale=0.15, size=pos.shape)
        alive ^= rng.random(n_obj) < 0.05
        truth = {f"o{o}": tuple(pos[o]) for o in range(n_obj) if alive[o]}
        hyps = {}
        for o in range(n_obj):
            if rng.random() < 0.08:  # the track changes its id
                hyp_of[o], next_hyp = next_hyp, next_hyp + 1
            if alive[o] and rng.random() < 0.85 and hyp_of[o] not in hyps:
                hyps[hyp_of[o]] = tuple(pos[o] + rng.normal(scale=0.2, size=2))
        if n_obj > 1 and rng.random() < 0.1:  # two tracks swap
            a, b = rng.choice(n_obj, 2, replace=False)
            hyp_of[a], hyp_of[b] = hyp_of[b], hyp_of[a]
        for _ in range(rng.poisson(0.5)):  # clutter
            hyps[next_hyp] = tuple(rng.uniform(0, 3, 2))
            next_hyp += 1
        frames.append(_f(truth, hyps))
    _compare(frames)


# ---------------------------------------------------------------------------- unseen objects
def test_a_track_on_an_unseen_object_is_neither_a_false_positive_nor_a_match():
    """Frame 2: the object is hidden (ignored); its coasting track is dropped, not a false
    positive; a track far from it still is one; the track stays the object's (no switch)."""
    frames = [MOTFrame(("a",), [[0, 0]], (1,), [[0.05, 0]]),
              MOTFrame((), None, (1, 2), [[0.3, 0], [3.0, 0]], ignored_xy=[[0.2, 0]]),
              MOTFrame(("a",), [[0.4, 0]], (1,), [[0.45, 0]])]
    s = clear_mot(frames)
    assert (s.objects, s.hypotheses, s.matches, s.false_positives, s.ignored, s.id_switches) == (2, 3, 2, 1, 1, 0)
    assert s.mota == pytest.approx(0.5)


def test_a_track_on_a_seen_object_is_not_taken_by_an_unseen_one_nearby():
    """One track between a seen object (0.2 m away) and an unseen one (0.1 m away), a second
    track 0.3 m from the unseen one: the matching over all objects gives the first to the seen
    object and drops the second."""
    frames = [MOTFrame(("a",), [[0, 0]], (1, 2), [[0.2, 0], [0.6, 0]], ignored_xy=[[0.3, 0]])]
    s = clear_mot(frames)
    assert (s.matches, s.false_positives, s.ignored, s.misses) == (1, 0, 1, 0)


def test_bad_frames_are_refused():
    with pytest.raises(ValueError, match="truth_xy must be finite, of shape"):
        MOTFrame(("a", "b"), [[0, 0]], (), None)
    with pytest.raises(ValueError, match="hyp_ids must be unique"):
        MOTFrame((), None, (1, 1), [[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="MOTFrame"):
        clear_mot([("a",)])
    with pytest.raises(ValueError, match="max_distance_m"):
        clear_mot([], max_distance_m=0)


# ---------------------------------------------------------------------------- the simulator's truth
def test_sim_frames_hold_the_seen_movers_in_the_tracking_frame():
    """The truth of a simulated recording: every mover seen by 3 or more beams is a true object
    at World.movers_at (the map, or the sensor frame by the scan's pose), the others unseen;
    the hypotheses are the confirmed tracks of the matching kind."""
    sc = sim.scenario("crossing_2")
    pairs = list(sim.simulate(sc, seed=0, n_scans=3))
    tracker = Tracker(frame="sensor")
    tables = [tracker.step(_features_of(s), pose=s.pose) for s, _ in pairs]
    frames = sim_frames(sc.world, [t for _, t in pairs], tables)
    for (scan, truth), frame in zip(pairs, frames, strict=True):
        t = (truth.stamp_ns - sim.EPOCH_NS) * 1e-9
        seen = {m.name for m in sc.world.movers_at(t)
                if max(int((truth.hits == o).sum()) for o in m.object_ids) >= 3}
        assert set(frame.truth_ids) == seen
        assert len(frame.truth_ids) + len(frame.ignored_xy) == 3  # two walkers and the cylinder
        for name, xy in zip(frame.truth_ids, frame.truth_xy, strict=True):
            world_xy = next(m.center for m in sc.world.movers_at(t) if m.name == name)
            x, y, th = scan.pose  # the sensor frame: rotate back by the pose
            back = (x + math.cos(th) * xy[0] - math.sin(th) * xy[1], y + math.sin(th) * xy[0] + math.cos(th) * xy[1])
            assert back == pytest.approx(world_xy, abs=1e-9)
    people = sim_frames(sc.world, [t for _, t in pairs], tables, kind="person")
    assert all(set(f.truth_ids) <= {"anna", "ben"} for f in people)
    with pytest.raises(ValueError, match="kind"):
        sim_frames(sc.world, [], [], kind="dog")
    with pytest.raises(ValueError, match="same scans"):
        sim_frames(sc.world, [pairs[0][1]], [tables[1]])


def _features_of(scan):
    from labkit import extract_features

    return extract_features(scan)
