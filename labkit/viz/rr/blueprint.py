"""The viewer's layouts (rerun blueprints) and the timelines every labkit recording shares."""

from __future__ import annotations

import rerun as rr
import rerun.blueprint as rrb

from . import _assets

__all__ = ["APP_ID", "TIME", "SEQUENCE", "STEP", "map_view", "blueprint", "steps_blueprint", "show_inline"]

APP_ID = "labkit"
TIME = "ros_time"
SEQUENCE = "scan"
#: The timeline of an algorithm's steps on one scan (:func:`~labkit.viz.rr.replay.log_steps`).
STEP = "step"
_ACCUMULATED = ("points", "lines", "corners", "circles", "legs")
# rerun's 2D views have y pointing down; mirror so that y points up as in matplotlib.
_Y_UP = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
# The time-series panels are small beside the scan view, and a legend of five to seven series
# covers most of one: no legend (hovering a curve names it, the entity tree lists them all).
_NO_LEGEND = rrb.PlotLegend(visible=False)


def map_view() -> rrb.Spatial2DView:
    """The world-frame view: ``map/**``, the accumulated map shown from the start up to the cursor.

    Returns
    -------
    rerun.blueprint.Spatial2DView
        The view, for a blueprint.
    """
    grow = rrb.VisibleTimeRanges([
        rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                             end=rrb.TimeRangeBoundary.cursor_relative())
        for timeline in (SEQUENCE, TIME)])
    return rrb.Spatial2DView(origin="/", contents="map/**", name="Map (world frame)",
                             overrides={f"/map/accumulated/{layer}": grow for layer in _ACCUMULATED})


def blueprint(compare: tuple[str, ...] | list[str] = (), *, with_map: bool = False,
              with_times: bool = True, timeline: str | None = None, with_tracks: bool = False) -> rrb.Blueprint:
    """The default layout: the scan view on the left; counts, stage times, log and notes on the right.

    With ``compare=("A", "B")`` there is one scan view per named configuration (features logged
    with ``log_features(..., name="A")``), side by side, each showing the scan, the ground truth
    and that configuration's features.

    Parameters
    ----------
    compare : tuple or list of str
        The names of the configurations to show side by side; empty: one scan view.
    with_map : bool
        The map view (world frame) beside the scan view.
    with_times : bool
        The stage-time panel (a recording without features has no stage times).
    timeline : str or None
        The timeline the viewer opens on (:data:`SEQUENCE` for a recording whose stamps do not
        advance); None: the viewer's choice.
    with_tracks : bool
        A log of the tracks' births, confirmations and deletions (``tracks/events``) under the log.

    Returns
    -------
    rerun.blueprint.Blueprint
        The layout, to send with the recording.
    """
    if compare:
        others = {n: [f"- /world/{m}/**" for m in compare if m != n] for n in compare}
        views = [rrb.Spatial2DView(origin="/", contents=["+ /world/**", *others[n]], name=f"{n}")
                 for n in compare]
        plots = [rrb.Tabs(rrb.TimeSeriesView(origin=f"metrics/{n}/count", name=f"{n}: counts", plot_legend=_NO_LEGEND),
                          rrb.TimeSeriesView(origin=f"metrics/{n}/time_ms", name=f"{n}: ms per stage",
                                            plot_legend=_NO_LEGEND))
                 for n in compare]
        below = rrb.Horizontal(*plots, rrb.TextDocumentView(origin="description", name="About"))
        return rrb.Blueprint(rrb.Vertical(rrb.Horizontal(*views), below, row_shares=[3, 2]), collapse_panels=False)
    views = [rrb.Spatial2DView(origin="/", contents="world/**", name="Scan (sensor frame)")]
    if with_map:
        views.append(map_view())
    panels = [(rrb.TimeSeriesView(origin="metrics/count", name="Per-scan counts", plot_legend=_NO_LEGEND), 2),
              (rrb.TimeSeriesView(origin="metrics/time_ms", name="Milliseconds per stage", plot_legend=_NO_LEGEND), 2),
              (rrb.TextLogView(origin="log", name="Log"), 1),
              (rrb.TextDocumentView(origin="description", name="About"), 2)]
    if with_tracks:
        panels.insert(3, (rrb.TextLogView(origin="tracks/events", name="Track events"), 1))
    if not with_times:
        del panels[1]
    return rrb.Blueprint(
        rrb.Horizontal(
            *views,
            rrb.Vertical(*[view for view, _ in panels], row_shares=[share for _, share in panels]),
            column_shares=[3, 3, 2] if with_map else [3, 2],
        ),
        *([rrb.TimePanel(timeline=timeline)] if timeline else []),
        collapse_panels=False,
    )


def show_inline(rec: rr.RecordingStream, *, width: int = 950, height: int = 600, compare=(),
                with_map: bool = False, with_tracks: bool = False) -> None:
    """Show a recording in the notebook with the default blueprint, or the side-by-side one; works offline.

    Parameters
    ----------
    rec : rerun.RecordingStream
        The recording.
    width : int
        The viewer's width, pixels.
    height : int
        The viewer's height, pixels.
    compare : tuple or list of str
        The configurations to show side by side, as in :func:`blueprint`.
    with_map : bool
        Also the map view.
    with_tracks : bool
        Also the track events.

    Notes
    -----
    The viewer's code (67 MB) is sent to the browser from this process, as it is on disk, by a small
    server started at the first call (``labkit.viz.rr._assets``): rerun-notebook's own ``serve-local``
    compresses it first, 4 s of CPU per kernel.
    """
    _assets.serve()
    rec.notebook_show(width=width, height=height, blueprint=blueprint(compare, with_map=with_map,
                                                                      with_tracks=with_tracks))


def steps_blueprint() -> rrb.Blueprint:
    """The layout of :func:`~labkit.viz.rr.replay.log_steps`: the scan and its steps on the left, numbers right.

    The right side shows the step's value against its threshold over the steps, and the steps' log.

    Returns
    -------
    rerun.blueprint.Blueprint
        The layout.
    """
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="/", contents="world/**", name="Steps (sensor frame)"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="steps/compared", name="Value and threshold per step"),
                rrb.TextLogView(origin="steps/log", name="Steps"),
                row_shares=[1, 2],
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=False,
    )
