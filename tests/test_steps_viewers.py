"""The step viewers replay any algorithm's steps: the widget (headless) and the rerun step timeline."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from labkit import Scan, Step  # noqa: E402
from labkit.viz.step_plots import draw_step, step_beams, step_viewer  # noqa: E402


@pytest.fixture
def wall():
    """A wall at x = 2 m, beams -40..40 deg every 0.5 deg (161 beams)."""
    theta = np.radians(np.arange(-40.0, 40.5, 0.5))
    yield Scan(ranges=2.0 / np.cos(theta), angles=theta)
    plt.close("all")


def _steps():
    return [
        Step("iepf", "segment", 0, 160, reason="range segment of 161 points"),
        Step("iepf", "fit", 0, 160, r=2.0, alpha=0.0, at=80, value=0.0, threshold=0.05, reason="worst 0.000 m"),
        Step("iepf", "accept", 0, 80, r=2.0, alpha=0.0, reason="accepted"),
        Step("iav_circles", "reject", 100, 120, value=0.3, threshold=0.15, test="iav std", reason="iav std 0.3"),
        Step("iav_circles", "accept", 130, 140, center=(2.3, 1.2), radius=0.3, reason="circle"),
        Step("angular", "direction", 10, 150, beams=(10, 20, 150), reason="cluster"),
    ]


def test_step_beams_range_wrap_and_explicit(wall):
    assert step_beams(wall, Step("x", "fit", 3, 6)).tolist() == [3, 4, 5, 6]
    assert step_beams(wall, Step("x", "fit", 159, 1)).tolist() == [159, 160, 0, 1]
    assert step_beams(wall, Step("x", "direction", 0, 100, beams=(5, 50))).tolist() == [5, 50]
    assert step_beams(wall, Step("x", "fit")).size == 0


def test_draw_step_titles_and_artists(wall):
    fig, axes = plt.subplots(1, 2)
    steps = _steps()
    draw_step(wall, steps, 1, axes)
    assert axes[0].get_title() == "step 2 of 6: iepf FIT, beams 0..160"
    assert axes[1].get_title() == "worst 0.000 m"
    dashed = [ln for ln in axes[1].lines if ln.get_linestyle() == "--"]
    (line,) = dashed  # the line measured against, from the projection of beam 0 to that of beam 160
    np.testing.assert_allclose(line.get_xdata(), [2.0, 2.0], atol=1e-12)
    np.testing.assert_allclose(sorted(line.get_ydata()), [-2 * math.tan(math.radians(40))] + [
        2 * math.tan(math.radians(40))], atol=1e-9)
    fig, axes = plt.subplots(1, 2)
    draw_step(wall, steps, 4, axes)  # a circle step, after one accepted line (drawn solid)
    (circle,) = [ln for ln in axes[1].lines if ln.get_linestyle() == "--"]
    xs, ys = circle.get_xdata(), circle.get_ydata()
    np.testing.assert_allclose(np.hypot(xs - 2.3, ys - 1.2), 0.3)
    accepted = [ln for ln in axes[0].lines if ln.get_linestyle() == "-" and len(ln.get_xdata()) == 2]
    assert len(accepted) == 1
    with pytest.raises(ValueError, match="k must be"):
        draw_step(wall, steps, 6, axes)


def test_step_viewer_slider_redraws(wall):
    box = step_viewer(wall, _steps())
    assert box.choice is None and box.slider.max == 5
    titles = [box.figure.axes[0].get_title()]
    for k in (3, 5):
        box.slider.value = k
        titles.append(box.figure.axes[0].get_title())
    assert titles == ["step 1 of 6: iepf SEGMENT, beams 0..160", "step 4 of 6: iav_circles REJECT, beams 100..120",
                      "step 6 of 6: angular DIRECTION, beams 10..150"]
    assert box.figure.axes[1].get_title() == "cluster"
    # the highlighted beams of the angular step are its three beams, not the range 10..150
    highlighted = [c for c in box.figure.axes[1].collections if c.get_label() == "beams of this step"]
    assert len(highlighted) == 1 and len(highlighted[0].get_offsets()) == 3


def test_step_viewer_switches_between_traces(wall):
    a, b = _steps()[:3], _steps()
    box = step_viewer(wall, {"endpoints": a, "fit": b})
    assert box.slider.max == 2
    box.slider.value = 2
    box.choice.value = "fit"
    assert (box.slider.value, box.slider.max) == (0, 5)
    assert box.figure.axes[0].get_title().startswith("step 1 of 6")


def test_step_viewer_bad_input(wall):
    with pytest.raises(ValueError, match="no steps"):
        step_viewer(wall, [])
    with pytest.raises(ValueError, match="Step records"):
        step_viewer(wall, [("fit", 0, 1)])
    with pytest.raises(ValueError, match="scan must be"):
        step_viewer(np.zeros(3), _steps())


def _rrd(path):
    """{entity: (rows on the step timeline, timelines, static?)}, and the record batches by entity."""
    from rerun.chunk import RrdReader

    out, batches = {}, {}
    for chunk in RrdReader(path).store().stream():
        rows, names, static = out.get(chunk.entity_path, (0, set(), chunk.is_static))
        out[chunk.entity_path] = (rows + (0 if chunk.is_static else chunk.num_rows),
                                  names | set(chunk.timeline_names), static)
        batches.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    return out, batches


def test_log_steps_puts_every_step_on_the_step_timeline(wall, tmp_path):
    from labkit.viz import rr as lkrr

    steps = _steps()
    assert lkrr.record_steps(wall, steps, tmp_path / "s.rrd") == len(steps)
    rows, batches = _rrd(tmp_path / "s.rrd")
    for entity in ("/world/steps/beams", "/world/steps/line", "/world/steps/circle", "/world/steps/at",
                   "/world/steps/accepted", "/world/steps/accepted_circles", "/steps/compared/value",
                   "/steps/compared/threshold", "/steps/log"):
        n, timelines, _ = rows[entity]
        assert n == len(steps), entity
        assert timelines == {"step"}, entity
    assert rows["/world/scan/points"][2] and rows["/world/scan/points"][0] == 0  # static
    # every row holds its archetype's required component (else the viewer shows an error badge)
    required = {"/world/steps/beams": "Points2D:positions", "/world/steps/at": "Points2D:positions",
                "/world/steps/line": "LineStrips2D:strips", "/world/steps/accepted": "LineStrips2D:strips",
                "/world/steps/circle": "Ellipses2D:half_sizes",
                "/world/steps/accepted_circles": "Ellipses2D:half_sizes",
                "/steps/log": "TextLog:text", "/steps/compared/value": "Scalars:scalars"}
    for entity, column in required.items():
        values = [v for b in batches[entity] for v in b.column(column).to_pylist()]
        assert len(values) == len(steps) and all(v is not None for v in values), entity
    text = [v for b in batches["/steps/log"] for v in b.column("TextLog:text").to_pylist()]
    assert text[3] == ["3: iav_circles reject beams 100..120: iav std 0.3"]
    # the accepted line shows from the step after its accept on; the circle likewise
    strips = [v for b in batches["/world/steps/accepted"] for v in b.column("LineStrips2D:strips").to_pylist()]
    assert [len(s) for s in strips] == [0, 0, 0, 1, 1, 1]
    circles = [v for b in batches["/world/steps/accepted_circles"]
               for v in b.column("Ellipses2D:half_sizes").to_pylist()]
    assert [len(c) for c in circles] == [0, 0, 0, 0, 0, 1]
    beams = [v for b in batches["/world/steps/beams"] for v in b.column("Points2D:positions").to_pylist()]
    assert [len(p) for p in beams] == [161, 161, 81, 21, 11, 3]


def _room():
    """A noiseless 4 m square room seen over 270 deg, and its walls' beams (ground truth)."""
    from labkit import sim

    c = [(2.0, -2.0), (2.0, 2.0), (-2.0, 2.0), (-2.0, -2.0)]
    world = sim.World("square", walls=tuple(sim.Wall(c[k], c[(k + 1) % 4]) for k in range(4)))
    lidar = sim.Lidar.from_fov("t", 270.0, 0.5, range_max=20.0, noise_std_m=0.0)
    return sim.scan_at(world, lidar, (0.0, 0.0, 0.3))


_REFERENCE = ["incremental", "regression", "ransac", "hough"]


@pytest.mark.parametrize("name", _REFERENCE)
def test_step_viewer_replays_a_reference_extractor(name):
    """The widget steps through a real trace of each reference line extractor: every kind it
    takes is drawn, and after the last step the accepted lines (red) lie on the room's walls."""
    from labkit.lines import LINE_EXTRACTORS

    scan, truth = _room()
    lines, steps = LINE_EXTRACTORS[name].fn(scan, trace=True)
    box = step_viewer(scan, steps)
    assert box.slider.max == len(steps) - 1
    for kind in dict.fromkeys(s.kind for s in steps):
        k = next(i for i, s in enumerate(steps) if s.kind == kind)
        box.slider.value = k
        assert box.figure.axes[0].get_title().startswith(f"step {k + 1} of {len(steps)}: {name} {kind.upper()}")
        assert box.figure.axes[1].get_title() == steps[k].reason
    # after the last step (a step with nothing to draw appended): every accepted line drawn, as a
    # 2-point segment whose ends lie on the room's walls
    fig, axes = plt.subplots(1, 2)
    draw_step(scan, [*steps, Step(name, "end")], len(steps), axes)
    drawn = [ln for ln in axes[0].lines if len(ln.get_xdata()) == 2 and ln.get_linestyle() == "-"]
    assert len(drawn) == len(lines) == len(truth.walls)
    c, s_ = math.cos(0.3), math.sin(0.3)
    for ln in drawn:  # both ends on the square's boundary: max(|x|, |y|) = 2 in the world frame
        x, y = np.asarray(ln.get_xdata()), np.asarray(ln.get_ydata())
        np.testing.assert_allclose(np.maximum(np.abs(c * x - s_ * y), np.abs(s_ * x + c * y)), 2.0, atol=2e-3)


@pytest.mark.parametrize("name", _REFERENCE)
def test_log_steps_of_a_reference_extractor(name, tmp_path):
    """The rerun step timeline holds one row per step of a real trace, every required
    component present, and the accepted lines pile up one per accept step."""
    from labkit.lines import LINE_EXTRACTORS
    from labkit.viz import rr as lkrr

    scan, _ = _room()
    _, steps = LINE_EXTRACTORS[name].fn(scan, trace=True)
    assert lkrr.record_steps(scan, steps, tmp_path / "s.rrd") == len(steps)
    rows, batches = _rrd(tmp_path / "s.rrd")
    for entity, column in {"/world/steps/beams": "Points2D:positions", "/world/steps/line": "LineStrips2D:strips",
                           "/world/steps/accepted": "LineStrips2D:strips", "/steps/log": "TextLog:text"}.items():
        assert rows[entity][0] == len(steps), entity
        values = [v for b in batches[entity] for v in b.column(column).to_pylist()]
        assert len(values) == len(steps) and all(v is not None for v in values), entity
    strips = [v for b in batches["/world/steps/accepted"] for v in b.column("LineStrips2D:strips").to_pylist()]
    accepted_before = np.cumsum([0] + [s.kind == "accept" for s in steps])[:-1]
    assert [len(s) for s in strips] == accepted_before.tolist()
    beams = [v for b in batches["/world/steps/beams"] for v in b.column("Points2D:positions").to_pylist()]
    assert [len(p) for p in beams] == [len(step_beams(scan, s)) for s in steps]
