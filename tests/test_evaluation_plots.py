"""The evaluation notebooks' figures (labkit.viz.evaluation_plots) draw what they are given, where it is."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from labkit.viz import evaluation_plots as ev


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _line(start, end):
    return SimpleNamespace(start=start, end=end)


def test_line_status_follows_the_rule_by_hand():
    # lines 0 and 3 matched, line 1 scored and unmatched, line 2 not scored
    match = SimpleNamespace(pairs=[(0, 5), (3, 1)], scored=[0, 1, 3])
    assert ev.line_status(4, match) == ["matched", "false positive", "not scored", "matched"]


def test_draw_match_colours_each_line_by_its_fate(monkeypatch):
    scan = SimpleNamespace()
    lines = [_line((0.0, 0.0), (1.0, 0.0)), _line((0.0, 1.0), (1.0, 1.0)), _line((2.0, 0.0), (2.0, 1.0))]
    walls = [SimpleNamespace(start=(0.0, 0.0), end=(1.0, 0.0)), SimpleNamespace(start=(5.0, 0.0), end=(5.0, 2.0))]
    truth = SimpleNamespace(walls=walls)
    match = SimpleNamespace(pairs=[(0, 0)], scored=[0, 1], truth=[0, 1], missed=[1], dr=[0.004], dalpha=[0.01])
    fig, ax = plt.subplots()
    drawn_scans = []
    monkeypatch.setattr(ev.lkplot, "plot_scan", lambda s, a, **kw: drawn_scans.append(s))
    ev.draw_match(ax, scan, truth, lines, match)
    assert drawn_scans == [scan]
    by_label = {c.get_label(): np.array(c.get_segments()) for c in ax.collections}
    assert set(by_label) == {"matched (1)", "false positive (1)", "not scored (1)"}
    np.testing.assert_allclose(by_label["matched (1)"], [[(0.0, 0.0), (1.0, 0.0)]])
    np.testing.assert_allclose(by_label["not scored (1)"], [[(2.0, 0.0), (2.0, 1.0)]])
    walls_drawn = {ln.get_label(): ln.get_linestyle() for ln in ax.lines}
    assert walls_drawn == {"found wall": "-", "missed wall": "--"}
    assert [t.get_text() for t in ax.texts] == ["|dr| 4 mm\n|dα| 0.57°"]


def test_threshold_sweep_marks_the_rows_it_is_given():
    levels = (0.005, 0.01, 0.02)
    sweep = [{"noise_std_m": n, "split_threshold_m": t, "tp_rate": 0.9 - t - n, "fp_rate": t / 2 + n}
             for n in levels for t in (0.02, 0.05, 0.1)]
    best = {n: next(r for r in sweep if r["noise_std_m"] == n and r["split_threshold_m"] == 0.1) for n in levels}
    fig = ev.plot_threshold_sweep(sweep, 0.05, [(best, "best: {cm:g} cm", dict(marker="*"))])
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert len(shown) == 3 and len(fig.axes) == 4  # a 2 x 2 grid, the fourth panel hidden
    for ax, noise in zip(shown, levels, strict=True):
        star = next(ln for ln in ax.lines if ln.get_label() == "best: 10 cm")
        assert (star.get_xdata()[0], star.get_ydata()[0]) == (best[noise]["fp_rate"], best[noise]["tp_rate"])
        ring = next(ln for ln in ax.lines if ln.get_label() == "the papers' fixed 5 cm")
        fixed = next(r for r in sweep if r["noise_std_m"] == noise and r["split_threshold_m"] == 0.05)
        assert (ring.get_xdata()[0], ring.get_ydata()[0]) == (fixed["fp_rate"], fixed["tp_rate"])


def test_rate_bars_are_the_rows_values():
    rows = [{"noise_std_m": n, "method": m, "tp_rate": tp, "fp_rate": fp, "scans_per_s": sp}
            for n, m, tp, fp, sp in [(0.005, "a", 0.9, 0.1, 100.0), (0.005, "b", 0.8, 0.2, 1000.0),
                                     (0.02, "a", 0.7, 0.3, 90.0), (0.02, "b", 0.6, 0.4, 900.0)]]
    fig = ev.plot_rate_bars(rows, {"b": 0.25})
    widths = [sorted(p.get_width() for p in ax.patches) for ax in fig.axes]
    assert widths == [[0.6, 0.7, 0.8, 0.9], [0.1, 0.2, 0.3, 0.4], [90.0, 100.0, 900.0, 1000.0]]
    (published,) = fig.axes[1].collections
    assert published.get_offsets()[0][0] == 0.25


def test_plot_match_titles_a_new_figure_and_puts_the_legend_outside(monkeypatch):
    monkeypatch.setattr(ev.lkplot, "plot_scan", lambda s, a, **kw: a)
    lines = [_line((0.0, 0.0), (1.0, 0.0)), _line((0.0, 1.0), (1.0, 1.0))]
    truth = SimpleNamespace(walls=[SimpleNamespace(start=(0.0, 0.0), end=(1.0, 0.0))])
    match = SimpleNamespace(pairs=[(0, 0)], scored=[0, 1], truth=[0], missed=[], dr=[0.0], dalpha=[0.0])
    ax = ev.plot_match(SimpleNamespace(), truth, lines, match, title="t", figsize=(6, 4))
    assert tuple(ax.figure.get_size_inches()) == (6, 4) and ax.get_title() == "t"
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["found wall", "matched (1)", "false positive (1)"]
    # anchored at the axes' right edge, 1 % beyond it
    assert tuple(legend.get_bbox_to_anchor().transformed(ax.transAxes.inverted()).p0) == pytest.approx((1.01, 1.0))


def test_split_match_titles_its_rates_and_prints_its_counts(monkeypatch, capsys):
    # 3 lines: line 0 matched to wall 0, line 1 scored and unmatched, line 2 not scored; wall 1 missed
    lines = [_line((0.0, 0.0), (1.0, 0.0)), _line((0.0, 1.0), (1.0, 1.0)), _line((2.0, 0.0), (2.0, 1.0))]
    walls = [SimpleNamespace(start=(0.0, 0.0), end=(1.0, 0.0)), SimpleNamespace(start=(5.0, 0.0), end=(5.0, 2.0))]
    match = SimpleNamespace(pairs=[(0, 0)], scored=[0, 1], truth=[0, 1], missed=[1], dr=[0.004], dalpha=[0.01],
                            n_matched=1, false_positives=[1])
    score = SimpleNamespace(tp_rate=0.5, fp_rate=0.5)
    monkeypatch.setattr(ev.lkplot, "plot_scan", lambda s, a, **kw: None)
    titles = []
    monkeypatch.setattr(ev.plt, "show", lambda: titles.append(plt.gcf().axes[0].get_title()))
    counts = ev.plot_split_match(SimpleNamespace(), SimpleNamespace(walls=walls), lines, match, score, 0.025, 0.005)
    assert titles == ["noise 5 mm, split threshold 2.5 cm: TruePos 0.50, FalsePos 0.50"]
    assert counts == "3 lines: 1 matched, 1 false positives, 1 not scored; missed walls [1]"
    assert capsys.readouterr().out == counts + "\n"


def test_threshold_controls_call_show_with_each_setting():
    calls = []
    box = ev.threshold_controls(lambda split_threshold_m, noise: calls.append((split_threshold_m, noise)),
                                (0.005, 0.02), noise=0.005)
    slider, picker = box.children[0].children
    assert [label for label, _ in picker.options] == ["5 mm", "20 mm"]
    assert (slider.min, slider.max, slider.step, slider.continuous_update) == (0.005, 0.3, 0.005, False)
    assert calls == [(0.05, 0.005)]
    slider.value = 0.1
    picker.value = 0.02
    assert calls == [(0.05, 0.005), (0.1, 0.005), (0.1, 0.02)]
    with pytest.raises(ValueError, match="not one of"):
        ev.threshold_controls(print, (0.005, 0.02), noise=0.01)


def test_auto_against_fixed_marks_both_auto_methods_on_every_level():
    levels = (0.005, 0.02)
    sweep = [{"noise_std_m": n, "split_threshold_m": t, "tp_rate": 0.9 - t, "fp_rate": t + n}
             for n in levels for t in (0.02, 0.05)]
    auto_rows = [{"method": m, "noise_std_m": n, "tp_rate": tp + n, "fp_rate": fp} for n in levels
                 for m, tp, fp in [("auto threshold, every line", 0.8, 0.2), ("AUTO_LINES", 0.7, 0.05)]]
    fig = ev.plot_auto_against_fixed(sweep, auto_rows, 0.05, n_per_level=30)
    assert fig._suptitle.get_text().startswith("split-and-merge (IEPF) on 30 scans per level")
    for ax, noise in zip(fig.axes, levels, strict=True):
        marked = {ln.get_label(): (ln.get_xdata()[0], ln.get_ydata()[0]) for ln in ax.lines}
        assert marked["auto threshold, every line reported"] == (0.2, 0.8 + noise)
        assert marked["AUTO_LINES, the default (also drops lines it cannot place)"] == (0.05, 0.7 + noise)
