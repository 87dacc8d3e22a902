"""The pipeline: one Config for every extractor, extract_features on ground truth, the
JSON lines export, and fuzzing with the scans real sensors produce."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from labkit import (
    Config,
    CorruptFileError,
    Features,
    Scan,
    extract_all,
    extract_features,
    read_features,
    sim,
    write_features,
)
from labkit.pipeline import CirclesConfig, LinesConfig
from tests.test_split_merge import score as line_score


# ---------------------------------------------------------------------------- Config
def test_defaults_are_the_sources_values():
    """Xavier et al. (2005) Table II, the course slides and Meglicki's defaults."""
    c = Config()
    assert c.segmentation.threshold_m == 0.08  # seg_threshold 80 mm
    assert (c.circles.min_points, c.circles.min_chord_m, c.circles.max_chord_m) == (4, 0.15, math.inf)
    assert c.circles.std_max_deg == pytest.approx(8.594, abs=1e-3)  # circle_std_max 0.15 rad
    assert c.circles.mean_range_deg == (90.0, 135.0) and c.circles.middle_range == (0.1, 0.7)
    assert (c.lines.min_points, c.lines.min_length_m) == (5, 0.15)  # line_min_pts, line_min_len
    assert c.legs.chord_range_m == (0.1, 0.25)
    assert c.lines.method == "iepf" and not c.arcs.enabled


def test_toml_round_trip_keeps_every_value(tmp_path):
    c = Config().updated({"lines.method": "angular", "circles": {"max_chord_m": 1.5, "mean_range_deg": [95, 130]},
                          "legs.iav_std_max_deg": 12.0, "arcs.enabled": True,
                          "tracking": {"frame": "map", "max_coast_s": 2.5, "confirm_hits": 4, "single_legs": False}})
    text = c.to_toml()
    assert "# largest gap between neighbouring points" in text and "max_chord_m = 1.5" in text
    assert '[tracking]' in text and 'frame = "map"' in text and "single_legs = false" in text
    assert (c.tracking.max_coast_s, c.tracking.confirm_hits) == (2.5, 4)
    assert Config.from_toml(text) == c
    assert Config.load(c.save(tmp_path / "c.toml")) == c
    assert Config.from_toml(Config().to_toml()) == Config()  # inf survives ("inf" is TOML)
    assert "max_chord_m = inf" in Config().to_toml()


@pytest.mark.parametrize("changes, named", [
    ({"lines": {"split_threshold": 0.1}}, "lines.split_threshold"),
    ({"line": {"method": "iepf"}}, "'line'"),
    ({"lines.method": "houghh"}, "lines.method"),  # a name no extractor is registered under
    ({"lines.split_threshold_m": -0.1}, "lines.split_threshold_m"),
    ({"lines.split_threshold_m": "5 cm"}, "lines.split_threshold_m"),
    ({"lines.split_threshold_m": float("nan")}, "lines.split_threshold_m"),
    ({"lines.min_points": 4.5}, "lines.min_points"),
    ({"lines.min_points": True}, "lines.min_points"),
    ({"circles.enabled": 1}, "circles.enabled"),
    ({"circles.mean_range_deg": [135, 90]}, "circles.mean_range_deg"),
    ({"circles.mean_range_deg": [90, 200]}, "circles.mean_range_deg"),
    ({"legs.chord_range_m": [0.1]}, "legs.chord_range_m"),
    ({"segmentation": 0.08}, "'segmentation'"),
    ({"tracking.frame": "world"}, "tracking.frame"),
    ({"tracking.gate_probability": 1.0}, "tracking.gate_probability"),
    ({"tracking.confirm_hits": 9}, "tracking.confirm_hits must be <= tracking.confirm_scans"),
    ({"tracking.max_coast": 1.0}, "tracking.max_coast"),
])
def test_bad_values_are_named(changes, named):
    with pytest.raises(ValueError, match=named.replace(".", r"\.").replace("[", r"\[")):
        Config().updated(changes)


def test_bad_toml_and_missing_file_say_what_to_do(tmp_path):
    with pytest.raises(ValueError, match="not valid TOML"):
        Config.from_toml("[lines\nmethod = 1")
    with pytest.raises(ValueError, match="labkit config -o"):
        Config.load(tmp_path / "missing.toml")
    (tmp_path / "bad.toml").write_text("[circles]\nmin_points = 2\n")
    with pytest.raises(ValueError, match=r"bad\.toml: circles\.min_points must be >= 3"):
        Config.load(tmp_path / "bad.toml")


def test_sections_are_validated_when_built_directly():
    with pytest.raises(ValueError, match="lines.max_gap_m"):
        LinesConfig(max_gap_m=0.0)
    with pytest.raises(ValueError, match="Config.circles"):
        Config(circles=LinesConfig())
    assert CirclesConfig(min_points=5).min_points == 5


# ---------------------------------------------------------------------------- ground truth
@pytest.fixture(scope="module")
def hall():
    return list(sim.simulate("hall", 0, n_scans=200))


def _round_scores(data, features):
    """(precision, recall) of circles and of legs against the simulator's objects: a
    detection is true within 5 cm (circles) or 10 cm (legs) of a true centre; recall counts
    the objects within 6 m seen by 4 beams (circles) and legs seen by 3 beams that the
    detector could see whole (not cut by the scan's ends)."""
    out = {}
    for key, tol, min_beams in (("circles", 0.05, 4), ("legs", 0.10, 3)):
        tp = fp = seen = found = 0
        for (scan, truth), f in zip(data, features, strict=True):
            true = getattr(truth, key)
            centers = np.array([c.center for c in true]).reshape(-1, 2)
            matched = set()
            for det in getattr(f, key):
                d = np.hypot(*(centers - det.center).T)
                if d.size and d.min() < tol:
                    tp += 1
                    matched.add(int(d.argmin()))
                else:
                    fp += 1
            for k, c in enumerate(true):
                if c.n_beams >= min_beams and np.hypot(*c.center) < 6.0 and 0 < c.first and c.last < scan.n_beams - 1:
                    seen += 1
                    found += k in matched
        out[key] = (tp / max(tp + fp, 1), found / max(seen, 1))
    return out


def test_the_hall_through_the_whole_pipeline(hall):
    """One shared segmentation for every detector: the walls, columns and the student's legs
    of the hall are still found as the detectors find them alone (tests/test_iav.py,
    tests/test_legs.py, tests/test_split_merge.py). Measured over 200 scans: circles
    precision 1.0, recall 0.96; legs 0.99, 0.93; every eligible wall found, 5 % false lines.
    Asserted with margin."""
    feats = [extract_features(scan) for scan, _ in hall]
    scores = _round_scores(hall, feats)
    assert scores["circles"][0] >= 0.97 and scores["circles"][1] >= 0.9
    assert scores["legs"][0] >= 0.95 and scores["legs"][1] >= 0.85
    n_walls = len(sim.scenario("hall").world.walls)
    tp = eligible = fp = on_walls = 0
    for (_, truth), f in zip(hall, feats, strict=True):
        a, b, c, d = line_score(f.lines, truth, n_walls)
        tp, eligible, fp, on_walls = tp + a, eligible + b, fp + c, on_walls + d
    assert tp / eligible >= 0.95 and fp / on_walls <= 0.15
    assert sum(len(f.people) for f in feats) > 50


def test_no_line_is_fitted_to_a_column_or_a_leg(hall):
    """With skip_round (the default) the beams of detected circles and legs carry no line;
    without it split-and-merge puts short lines on them."""
    loose = Config().updated({"lines.skip_round": False})
    on_round = {True: 0, False: 0}
    for scan, _ in hall[:60]:
        for skip, cfg in ((True, None), (False, loose)):
            f = extract_features(scan, cfg)
            taken = np.zeros(scan.n_beams, bool)
            for obj in (*f.circles, *f.legs):
                taken[f.labels == f.labels[obj.first]] = True
            on_round[skip] += sum(bool(taken[ln.indices].any()) for ln in f.lines)
    assert on_round[True] == 0 and on_round[False] > 20


def test_stages_switch_off():
    scan, _ = next(iter(sim.simulate("hall", 0, n_scans=1)))
    off = Config().updated({"legs.enabled": False, "circles.enabled": False, "lines.method": "none",
                            "corners.enabled": False})
    f = extract_features(scan, off)
    assert f.counts() == {"segments": f.n_segments, "lines": 0, "corners": 0, "circles": 0, "arcs": 0, "legs": 0,
                          "people": 0}
    assert f.n_segments > 5 and set(f.timings) == {"segmentation", "legs", "circles", "lines", "corners", "arcs",
                                                  "total"}


@pytest.mark.parametrize("method", ["iepf", "split_and_merge", "angular"])
def test_every_line_method_finds_the_office_walls(method):
    """Office world (XV-11, 360 deg, 15 mm noise, dropouts): most eligible walls found by each
    method (fit-split and angular segmentation lose short walls, see their own tests)."""
    cfg = Config().updated({"lines.method": method})
    n_walls = len(sim.scenario("office").world.walls)
    tp = eligible = 0
    for scan, truth in sim.simulate("office", 0, n_scans=20):
        a, b, _, _ = line_score(extract_features(scan, cfg).lines, truth, n_walls)
        tp, eligible = tp + a, eligible + b
    assert tp / eligible >= {"iepf": 0.95, "split_and_merge": 0.8, "angular": 0.6}[method]


def test_arcs_stage_finds_a_rounded_room_corner():
    """A room corner rounded with a radius of 0.8 m seen from 2 m inside the room (the
    hall's rounded corner is 9 m away and seen by 9 beams, too few for any method)."""
    corner = sim.Arc((2.2, 2.2), 0.8, 0.0, math.pi / 2)
    walls = (sim.Wall((3.0, -2.0), (3.0, 2.2)), sim.Wall((2.2, 3.0), (-2.0, 3.0)))
    world = sim.World("rounded", walls=walls, arcs=(corner,))
    cfg = Config().updated({"arcs.enabled": True})
    rng = np.random.default_rng(5)
    for _ in range(10):
        scan, _ = sim.scan_at(world, sim.LIDARS["lms200"], (0.0, 0.0, 0.0), rng=rng)
        (arc,) = extract_features(scan, cfg).arcs
        assert np.hypot(*(arc.center - corner.center)) < 0.08 and arc.radius == pytest.approx(0.8, rel=0.1)
        assert extract_features(scan).arcs == ()  # off by default


def test_corners_wrap_on_full_circle_scans():
    """A 4 x 3 m room seen by the 360 deg XV-11 from inside: all four corners, at the room's
    corners, including the one between the last line and the first."""
    xs, ys = (-1.5, 2.5), (-1.2, 1.8)
    room = [(xs[0], ys[0]), (xs[1], ys[0]), (xs[1], ys[1]), (xs[0], ys[1])]
    walls = tuple(sim.Wall(room[k], room[(k + 1) % 4]) for k in range(4))
    world = sim.World("room", walls=walls)
    rng = np.random.default_rng(2)
    for heading in (0.0, 0.6, math.pi - 0.01):
        scan, _ = sim.scan_at(world, sim.LIDARS["xv11"], (0.0, 0.0, heading), rng=rng)
        f = extract_features(scan)
        assert len(f.lines) == 4 and len(f.corners) == 4
        c, s = math.cos(heading), math.sin(heading)
        true = np.array([[c * x + s * y, -s * x + c * y] for x, y in room])  # sensor frame
        for corner in f.corners:
            assert np.hypot(*(true - corner.point).T).min() < 0.05


# ---------------------------------------------------------------------------- records
def test_records_hold_every_feature_and_round_trip_through_json_lines(tmp_path, hall):
    feats = list(extract_all([s for s, _ in hall[:20]]))
    assert write_features(feats, tmp_path / "f.jsonl") == 20
    back = list(read_features(tmp_path / "f.jsonl"))
    for f, rec in zip(feats, back, strict=True):
        types = [item["type"] for item in rec["features"]]
        assert rec["counts"] == f.counts()
        assert types.count("line") == len(f.lines) and types.count("leg") == len(f.legs)
        assert types.count("circle") == len(f.circles) and types.count("person") == len(f.people)
        lines = [item for item in rec["features"] if item["type"] == "line"]
        for item, ln in zip(lines, f.lines, strict=True):
            assert (item["first"], item["last"], item["n_points"]) == (ln.first, ln.last, ln.n_points)
            np.testing.assert_array_equal(item["start"], ln.start)
        assert rec["timings_ms"]["total"] == pytest.approx(f.timings["total"] * 1e3, abs=1e-3)
    with pytest.raises(ValueError, match="exists"):
        write_features(feats, tmp_path / "f.jsonl")


def test_a_json_line_is_the_strict_copy_of_its_record():
    """Written as they are or through json_safe (a record with NaN, infinity or a numpy scalar), a line is
    the record with its non-finite floats as null, every other value as json_safe gives it."""
    from labkit.io.feature_files import _json_line

    plain = {"scan": 3, "r": 0.1 + 0.2, "xs": (1.5, -2.0), "n": 7, "ok": True, "name": "line"}
    odd = {"scan": 4, "a": float("nan"), "b": [float("inf"), -float("inf"), 2.5], "c": np.float64(0.3),
           "d": np.int64(-5), "e": np.bool_(True), "f": {"g": (np.float32(1.25), float("nan"))}}
    assert json.loads(_json_line(plain)) == {**plain, "xs": [1.5, -2.0]}
    assert _json_line(plain) == json.dumps(plain, separators=(",", ":"))
    assert json.loads(_json_line(odd)) == {"scan": 4, "a": None, "b": [None, None, 2.5], "c": 0.3, "d": -5,
                                           "e": True, "f": {"g": [1.25, None]}}


def test_a_corrupt_features_file_gives_what_it_can_then_an_error(tmp_path):
    feats = list(extract_all([s for s, _ in sim.simulate("hall", 0, n_scans=5)]))
    write_features(feats, tmp_path / "f.jsonl")
    lines = (tmp_path / "f.jsonl").read_text().splitlines()
    (tmp_path / "f.jsonl").write_text("\n".join(lines[:3] + [lines[3][:40]] + lines[4:]) + "\n")
    got = []
    with pytest.raises(CorruptFileError, match="at line 4") as err:  # the bad line is skipped
        for rec in read_features(tmp_path / "f.jsonl"):
            got.append(rec)
    assert [r["scan"] for r in got] == [0, 1, 2, 4] and err.value.n_read == 4 and err.value.n_skipped == 1
    got = []
    with pytest.raises(CorruptFileError, match="at line 4") as err:
        for rec in read_features(tmp_path / "f.jsonl", strict=True):
            got.append(rec)
    assert len(got) == 3 and err.value.n_read == 3


def test_bad_arguments():
    scan, _ = next(iter(sim.simulate("hall", 0, n_scans=1)))
    with pytest.raises(ValueError, match="scan must be a labkit.Scan"):
        extract_features(scan.ranges)
    with pytest.raises(ValueError, match="config must be a labkit.Config"):
        extract_features(scan, {"lines": {}})


# ---------------------------------------------------------------------------- fuzzing
_READINGS = st.one_of(
    st.floats(0.02, 40.0), st.just(float("nan")), st.just(float("inf")), st.just(0.0), st.just(30.0),
    st.floats(-5.0, 0.0), st.floats(30.0, 1e9),
)


@st.composite
def _scans(draw):
    """Scans as sensors hand them over: any length from 0 to 5000 beams (tiny and huge),
    partial or full circle, readings mixing real ranges, NaN, inf, 0, negative, exactly the
    maximum range ("no return") and beyond it, and walls (runs of smooth ranges)."""
    n = draw(st.one_of(st.integers(0, 8), st.integers(9, 400), st.sampled_from([1441, 2881, 5000])))
    full = draw(st.booleans())
    span = 2 * math.pi * (1 - 1 / max(n, 1)) if full else draw(st.floats(0.1, 4.7))
    if n and draw(st.booleans()):  # smooth runs (walls, circles) broken by odd readings
        base = draw(st.floats(0.3, 20.0))
        ranges = base + np.cumsum(np.full(n, draw(st.floats(-0.02, 0.02))))
        odd = draw(st.lists(st.tuples(st.integers(0, n - 1), _READINGS), max_size=30))
        for i, v in odd:
            ranges[i] = v
    else:
        ranges = np.array(draw(st.lists(_READINGS, min_size=n, max_size=n)), dtype=float)
        if n > 50:
            ranges = np.resize(ranges, n)
    angles = -span / 2 + span * np.arange(n) / max(n - 1, 1) if n > 1 else np.zeros(n)
    return Scan(ranges=ranges, angles=angles, range_max=30.0)


_ALL_ON = Config().updated({"arcs.enabled": True, "circles.arc_like": True})


@settings(max_examples=150)
@given(scan=_scans(), method=st.sampled_from(["iepf", "split_and_merge", "angular"]))
@example(scan=Scan(ranges=[], angles=[]), method="iepf")
@example(scan=Scan(ranges=[np.nan] * 10, angles=np.linspace(-1, 1, 10), range_max=30.0), method="angular")
@example(scan=Scan(ranges=[1.0], angles=[0.0]), method="split_and_merge")
def test_fuzz_extract_features_never_raises(scan, method):
    """Any scan gives Features whose beam indices lie in the scan and whose record is JSON."""
    f = extract_features(scan, _ALL_ON.updated({"lines.method": method}))
    assert isinstance(f, Features) and f.labels.shape == (scan.n_beams,)
    assert np.all(f.labels[~scan.valid] == -1)
    for item in (*f.lines, *f.circles, *f.arcs, *f.legs):
        assert 0 <= item.first < max(scan.n_beams, 1) and 0 <= item.last < max(scan.n_beams, 1)
        for v in (getattr(item, "center", None), getattr(item, "start", None), getattr(item, "end", None)):
            assert v is None or np.all(np.isfinite(v))
    json.dumps(f.as_record(), allow_nan=True)
