"""rerun recordings: read the .rrd back and check entities, timelines and scan counts."""

from __future__ import annotations

import os
from collections import defaultdict

import numpy as np
import pytest

from labkit import geometry, sim, write_bag
from labkit.app.data import write_simulation
from labkit.app.record import record
from labkit.viz import rr as lkrr


def rrd_rows(path):
    """{entity path: (rows on the scan timeline, timelines)} from an .rrd file."""
    from rerun.chunk import RrdReader

    rows, timelines = defaultdict(int), {}
    for chunk in RrdReader(path).store().stream():
        timelines.setdefault(chunk.entity_path, set())
        if chunk.is_static:
            rows[chunk.entity_path] += 0
            continue
        rows[chunk.entity_path] += chunk.num_rows
        timelines[chunk.entity_path] |= set(chunk.timeline_names)
    return rows, timelines


def test_importing_sets_the_offline_asset_mode():
    assert os.environ["RERUN_NOTEBOOK_ASSET"] == "serve-local"


def test_record_a_simulated_bag_with_truth(tmp_path):
    bag, _, n = write_simulation("hall", tmp_path / "hall.bag", n_scans=30)
    summary = record(bag, tmp_path / "hall.rrd")
    assert (summary.n_scans, summary.n_truth, summary.error) == (30, 30, None)
    rows, timelines = rrd_rows(tmp_path / "hall.rrd")
    for entity in ["/world/scan/points", "/world/scan/invalid", "/world/segments", "/metrics/valid_beams",
                   "/metrics/count/segments", "/world/truth/walls", "/world/truth/circles", "/world/truth/legs",
                   "/world/lines", "/world/corners", "/world/circles", "/world/arcs", "/world/legs", "/world/people",
                   "/metrics/count/lines", "/metrics/count/legs", "/metrics/time_ms/lines", "/metrics/time_ms/total"]:
        assert rows[entity] == 30, entity
        assert {"ros_time", "scan"} <= timelines[entity]
    assert summary.counts["lines"] > 30 and summary.counts["legs"] > 0
    assert summary.stage_seconds["total"] >= summary.stage_seconds["lines"] > 0
    assert "log_time" not in timelines["/world/scan/points"]
    for static in ["/world", "/world/sensor", "/description"]:
        assert static in rows and timelines[static] == set()


def test_points_in_the_rrd_are_the_valid_beams(tmp_path):
    from rerun.chunk import RrdReader

    scans = [s for s, _ in sim.simulate("office", seed=0, n_scans=12)]  # NaN dropouts
    write_bag(scans, tmp_path / "o.bag")
    record(tmp_path / "o.bag", tmp_path / "o.rrd", features=False, segment_threshold_m=None)
    got = {}
    for chunk in RrdReader(tmp_path / "o.rrd").store().stream():
        if chunk.entity_path == "/world/scan/points":
            batch = chunk.to_record_batch()
            seq = batch.column("scan").to_pylist()
            pos = batch.column("Points2D:positions").to_pylist()
            for k, p in zip(seq, pos, strict=True):
                got[k] = np.array(p, dtype=np.float64).reshape(-1, 2)
    assert sorted(got) == list(range(12))
    for k, s in enumerate(scans):
        np.testing.assert_allclose(got[k], s.xy, rtol=1e-6, atol=1e-6)  # float32 in rerun


def test_a_damaged_bag_still_gives_an_rrd_with_every_readable_scan(tmp_path):
    scans = [s for s, _ in sim.simulate("hall", seed=0, n_scans=40)]
    bag = tmp_path / "cut.bag"
    write_bag(scans, bag)
    bag.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    summary = record(bag, tmp_path / "cut.rrd")
    assert summary.error is not None and "cut.bag" in str(summary.error)
    rows, _ = rrd_rows(tmp_path / "cut.rrd")
    assert rows["/world/scan/points"] == summary.n_scans == summary.error.n_read
    assert 10 < summary.n_scans < 40


def _blueprint(path, *columns):
    """The first value of each of ``columns`` in every blueprint row that has them all."""
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    (store,) = reader.blueprints()
    rows = []
    for chunk in reader.store(store=store).stream():
        batch = chunk.to_record_batch()
        if all(c in batch.schema.names for c in columns):
            rows.append(tuple((batch.column(c).to_pylist()[0] or [None])[0] for c in columns))
    return rows


def _views(path):
    """(kind, origin) of every view in the file's blueprint."""
    return {(kind, origin.strip("/")) for kind, origin in _blueprint(
        path, "ViewBlueprint:class_identifier", "ViewBlueprint:space_origin")}


def test_the_rrd_carries_the_default_layout(tmp_path):
    """The saved file opens with a 2D scan view, counts and stage times, a log and the notes."""
    bag, _, _ = write_simulation("office", tmp_path / "o.bag", n_scans=3)
    record(bag, tmp_path / "o.rrd")
    assert _views(tmp_path / "o.rrd") == {("2D", ""), ("TimeSeries", "metrics/count"),
                                          ("TimeSeries", "metrics/time_ms"), ("TextLog", "log"),
                                          ("TextDocument", "description")}


def _batches(path, entity):
    """{scan index: record batch row as dict} for one entity of an .rrd."""
    from rerun.chunk import RrdReader

    out = {}
    for chunk in RrdReader(path).store().stream():
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch()
            cols = {name: batch.column(name).to_pylist() for name in batch.schema.names}
            for i, k in enumerate(cols["scan"]):
                out[k] = {name: v[i] for name, v in cols.items()}
    return out


def test_the_features_in_the_rrd_are_those_of_the_pipeline(tmp_path):
    """Read the layers back and compare with extract_features run here on the same scans."""
    from labkit import Config, extract_features, read_scans

    bag, _, _ = write_simulation("hall", tmp_path / "h.bag", n_scans=12)
    config = Config().updated({"lines.method": "angular"})
    record(bag, tmp_path / "h.rrd", config=config)
    lines = _batches(tmp_path / "h.rrd", "/world/lines")
    legs = _batches(tmp_path / "h.rrd", "/world/legs")
    counts = _batches(tmp_path / "h.rrd", "/metrics/count/corners")
    assert sorted(lines) == list(range(12))
    for k, scan in enumerate(read_scans(bag)):
        f = extract_features(scan, config)
        got = np.array(lines[k]["LineStrips2D:strips"] or [], dtype=float).reshape(-1, 2, 2)
        want = np.array([[ln.start, ln.end] for ln in f.lines]).reshape(-1, 2, 2)
        np.testing.assert_allclose(got, want, atol=1e-5)
        got_legs = np.array(legs[k]["Ellipses2D:centers"] or [], dtype=float).reshape(-1, 2)
        np.testing.assert_allclose(got_legs, np.array([g.center for g in f.legs]).reshape(-1, 2), atol=1e-5)
        assert counts[k]["Scalars:scalars"] == [len(f.corners)]


def test_two_configurations_side_by_side(tmp_path):
    """log_features with a name puts a second configuration beside the first, and the
    compare blueprint gives each its own scan view."""
    from labkit import Config, extract_all

    scans = [s for s, _ in sim.simulate("hall", seed=0, n_scans=5)]
    rec = lkrr.new_recording("cmp")
    rec.save(tmp_path / "c.rrd", default_blueprint=lkrr.blueprint(compare=["iepf", "angular"]))
    lkrr.log_scans(rec, scans)
    for method in ("iepf", "angular"):
        assert lkrr.log_features(rec, extract_all(scans, Config().updated({"lines.method": method})),
                                 name=method) == 5
    rec.flush()
    rec.disconnect()
    rows, _ = rrd_rows(tmp_path / "c.rrd")
    for method in ("iepf", "angular"):
        assert rows[f"/world/{method}/lines"] == 5 and rows[f"/metrics/{method}/time_ms/total"] == 5
    views = _views(tmp_path / "c.rrd")
    assert {v for v in views if v[0] == "2D"} == {("2D", "")} and len(views) >= 5


@pytest.mark.parametrize("n", [1, 300])
def test_log_scans_batches_keep_the_sequence(tmp_path, n):
    rec = lkrr.new_recording("t")
    rec.save(tmp_path / "b.rrd")
    scans = [s for s, _ in sim.simulate("office", seed=0, n_scans=n)]
    assert lkrr.log_scans(rec, scans, start_index=5) == n
    rec.flush()
    rec.disconnect()
    rows, _ = rrd_rows(tmp_path / "b.rrd")
    assert rows["/world/scan/points"] == n


# ---------------------------------------------------------------------------- the map (world frame)
def _transforms(path, entity="/map/sensor"):
    """{scan index: (translation, quaternion)} of the per-scan transforms in an .rrd."""
    out = {}
    for k, row in _batches(path, entity).items():
        out[k] = (np.array(row["Transform3D:translation"]).reshape(3),
                  np.array(row["Transform3D:quaternion"]).reshape(4))
    return out


def _distance_to_walls(points, walls):
    d = np.full(len(points), np.inf)
    for w in walls:
        a, b = np.array(w.start), np.array(w.end)
        t = np.clip(((points - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        d = np.minimum(d, np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1))
    return d


def test_a_recording_with_poses_gets_the_map_view(tmp_path):
    """The simulator's bags carry its exact sensor poses: every scan's transform is that pose, the
    accumulated map is decimated and lies on the world's walls, and the map view sits beside the scan view."""
    data = list(sim.simulate("corridor", seed=0, n_scans=45))
    write_bag([s for s, _ in data], tmp_path / "c.bag")
    summary = record(tmp_path / "c.bag", tmp_path / "c.rrd")
    assert summary.n_scans == 45
    rrd = tmp_path / "c.rrd"
    transforms = _transforms(rrd)
    assert sorted(transforms) == list(range(45))
    for k, (_, truth) in enumerate(data):
        x, y, theta = truth.pose
        translation, q = transforms[k]
        np.testing.assert_allclose(translation, [x, y, 0.0], atol=1e-5)
        np.testing.assert_allclose(q, [0.0, 0.0, np.sin(theta / 2), np.cos(theta / 2)], atol=1e-6)
    rows, timelines = rrd_rows(rrd)
    assert rows["/map/sensor/points"] == rows["/map/sensor/lines"] == 45
    assert rows["/map/accumulated/points"] == rows["/map/accumulated/lines"] == 5  # scans 0, 10, ... 40
    assert {"ros_time", "scan"} <= timelines["/map/accumulated/points"]
    acc = np.concatenate([np.array(r["Points2D:positions"], dtype=float).reshape(-1, 2)
                          for r in _batches(rrd, "/map/accumulated/points").values()])
    cells = {tuple(c) for c in np.floor(acc / lkrr.MAP_CELL_M).astype(int)}
    assert len(cells) == len(acc)  # one point per 5 cm cell
    keyframes = np.concatenate([geometry.transform_points(data[k][0].xy, data[k][1].pose) for k in range(0, 45, 10)])
    assert len(acc) < len(keyframes)
    d = _distance_to_walls(acc, sim.make_world("corridor").walls)
    assert np.mean(d < 0.08) > 0.9  # walls (the rest: the walking person)
    assert "/map/path" in rows and timelines["/map/path"] == set()  # static: the whole path
    views = _views(rrd)
    assert ("2D", "") in views and len([v for v in views if v[0] == "2D"]) == 1  # both spatial views sit at the root
    names = _view_names(rrd)
    assert {"Scan (sensor frame)", "Map (world frame)"} <= names


def _view_names(path):
    return {name for (name,) in _blueprint(path, "ViewBlueprint:display_name")}


def test_without_poses_the_layout_is_as_before(tmp_path):
    write_bag([s for s, _ in sim.simulate("office", seed=0, n_scans=6)], tmp_path / "o.bag", pose_topic=None)
    record(tmp_path / "o.bag", tmp_path / "o.rrd")
    rows, _ = rrd_rows(tmp_path / "o.rrd")
    assert not any(e.startswith("/map") for e in rows)
    assert "Map (world frame)" not in _view_names(tmp_path / "o.rrd")
    # and a bag with poses read with poses=False too
    write_bag([s for s, _ in sim.simulate("office", seed=0, n_scans=6)], tmp_path / "p.bag")
    record(tmp_path / "p.bag", tmp_path / "p.rrd", poses=False)
    assert not any(e.startswith("/map") for e in rrd_rows(tmp_path / "p.rrd")[0])


def test_a_scan_without_a_pose_shows_nothing_in_the_map(tmp_path):
    scans = [s for s, _ in sim.simulate("corridor", seed=0, n_scans=12)]
    scans[5] = scans[5].replace(pose=None)
    from labkit import Config

    lkrr.record_scans(scans, tmp_path / "g.rrd", name="gap", config=Config())
    points = _batches(tmp_path / "g.rrd", "/map/sensor/points")
    assert points[5]["Points2D:positions"] in (None, []) and len(points[4]["Points2D:positions"]) > 100
    assert sorted(_transforms(tmp_path / "g.rrd")) == [k for k in range(12) if k != 5]
    lines = _batches(tmp_path / "g.rrd", "/map/sensor/lines")
    assert lines[5]["LineStrips2D:strips"] in (None, [])


# ---------------------------------------------------------------------------- what the viewer needs
#: The component without which rerun cannot draw an archetype (its error badge: "Component
#: 'Ellipses2D:half_sizes' does not exist on the entity"); None: nothing required.
REQUIRED = {"Points2D": "positions", "Ellipses2D": "half_sizes", "LineStrips2D": "strips", "Arrows2D": "vectors",
            "Scalars": "scalars", "TextLog": "text", "TextDocument": "text", "Transform3D": None,
            "RecordingInfo": None}


def _matches(entity: str, query: str, origin: str) -> bool:
    """Whether ``entity`` matches one entity-path expression of a view's contents (``+``/``-`` stripped)."""
    path = "/" + query.replace("$origin", origin).strip("/ ")
    path = path.replace("//", "/")
    if path.endswith("/**"):
        root = path[:-3].rstrip("/") or ""
        return root == "" or entity == root or entity.startswith(root + "/")
    return entity == path


def blueprint_gaps(path) -> list[str]:
    """What the viewer would not draw in an .rrd: entities that name an archetype without its
    required component, and views of its blueprint that no entity with data falls into."""
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    columns, rows = defaultdict(set), defaultdict(int)
    for chunk in reader.store().stream():
        names = [c for c in chunk.to_record_batch().schema.names if ":" in c]
        columns[chunk.entity_path] |= set(names)
        rows[chunk.entity_path] += chunk.num_rows
    gaps = []
    for entity, cols in sorted(columns.items()):
        for archetype in sorted({c.split(":")[0] for c in cols}):
            if archetype not in REQUIRED:
                gaps.append(f"{entity}: archetype {archetype} not in REQUIRED (add what it needs)")
            elif REQUIRED[archetype] and f"{archetype}:{REQUIRED[archetype]}" not in cols:
                gaps.append(f"{entity}: {archetype} without {archetype}:{REQUIRED[archetype]}")
    (store,) = reader.blueprints()
    views, queries = {}, {}
    for chunk in reader.store(store=store).stream():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            views[chunk.entity_path] = (batch.column("ViewBlueprint:display_name").to_pylist()[0][0],
                                        "/" + batch.column("ViewBlueprint:space_origin").to_pylist()[0][0].strip("/"))
        if "ViewContents:query" in batch.schema.names:
            queries[chunk.entity_path.rsplit("/", 1)[0]] = batch.column("ViewContents:query").to_pylist()[0]
    assert views, "no views in the blueprint"
    for view, (name, origin) in views.items():
        shown = set()
        for query in queries.get(view, ["$origin/**"]):
            for line in query.splitlines():
                line = line.strip()
                hits = {e for e in columns if _matches(e, line.lstrip("+- "), origin.rstrip("/"))}
                shown = shown - hits if line.startswith("-") else shown | hits
        if not any(rows[e] and columns[e] - {"RecordingInfo:name", "RecordingInfo:start_time"} for e in shown):
            gaps.append(f"view {name!r} ({origin}) has no data")
    return gaps


def test_every_entity_and_panel_of_a_recording_can_be_drawn(tmp_path):
    """A recording with features: every entity carries the component its archetype needs, and every
    panel of the default layout has data (no error badge, no empty panel)."""
    bag, _, _ = write_simulation("hall", tmp_path / "h.bag", n_scans=5)
    record(bag, tmp_path / "h.rrd")
    assert blueprint_gaps(tmp_path / "h.rrd") == []


def test_blueprint_gaps_finds_points_where_ellipses_are_expected(tmp_path):
    """The checker itself: legs logged as points under features' ellipse layer, and a layout whose
    stage-time and log panels stay empty, are both reported."""
    import rerun as rr

    scans = [s for s, _ in sim.simulate("hall", seed=0, n_scans=3)]
    rec = lkrr.new_recording("gaps")
    rec.save(tmp_path / "g.rrd", default_blueprint=lkrr.blueprint())
    lkrr.log_static(rec, "notes")
    lkrr.log_scans(rec, scans)
    rec.log("world/legs", rr.Ellipses2D.from_fields(draw_order=42.0), static=True)
    rec.set_time(lkrr.SEQUENCE, sequence=0)
    rec.log("world/legs", rr.Points2D([[1.0, 2.0]]))
    rec.flush()
    rec.disconnect()
    gaps = blueprint_gaps(tmp_path / "g.rrd")
    assert "/world/legs: Ellipses2D without Ellipses2D:half_sizes" in gaps
    assert "view 'Milliseconds per stage' (/metrics/time_ms) has no data" in gaps
    assert "view 'Log' (/log) has no data" in gaps
    assert len(gaps) == 3, gaps


def test_a_recording_without_features_has_no_empty_panel(tmp_path):
    """``record(..., features=False)``: scans and segments only, with and without poses. No stage-time
    panel without stage times, no accumulated feature layer declared without features to fill it."""
    write_bag([s for s, _ in sim.simulate("office", seed=0, n_scans=6)], tmp_path / "o.bag", pose_topic=None)
    record(tmp_path / "o.bag", tmp_path / "o.rrd", features=False)
    assert blueprint_gaps(tmp_path / "o.rrd") == []
    assert "Milliseconds per stage" not in _view_names(tmp_path / "o.rrd")
    write_bag([s for s, _ in sim.simulate("corridor", seed=0, n_scans=12)], tmp_path / "c.bag")
    record(tmp_path / "c.bag", tmp_path / "c.rrd", features=False)
    assert blueprint_gaps(tmp_path / "c.rrd") == []
    rows, _ = rrd_rows(tmp_path / "c.rrd")
    assert rows["/map/accumulated/points"] == 2  # scans 0 and 10
    assert not any(e.startswith("/map/accumulated/") and e != "/map/accumulated/points" for e in rows)
    assert {"Scan (sensor frame)", "Map (world frame)"} <= _view_names(tmp_path / "c.rrd")
    # with features, every panel stays, the map's feature layers too
    record(tmp_path / "c.bag", tmp_path / "f.rrd")
    assert blueprint_gaps(tmp_path / "f.rrd") == []
    assert "Milliseconds per stage" in _view_names(tmp_path / "f.rrd")
    assert "/map/accumulated/legs" in rrd_rows(tmp_path / "f.rrd")[0]
