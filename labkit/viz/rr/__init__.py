"""rerun recordings of scans and features: the only labkit package that knows rerun.

Its modules: :mod:`~labkit.viz.rr.blueprint` the layouts and timelines, :mod:`~labkit.viz.rr.entities`
scans, features and truth as entities, :mod:`~labkit.viz.rr.worldmap` the world frame and the
accumulated map, :mod:`~labkit.viz.rr.recording` a whole recording to an ``.rrd`` file,
:mod:`~labkit.viz.rr.replay` an algorithm's steps on the ``step`` timeline, :mod:`~labkit.viz.rr.tracks`
tracks over time (``labkit view --tracks``). A recording file read,
run through the pipeline and written in one call is the application's :func:`labkit.app.record.record`.

Layout of a labkit recording
----------------------------
Timelines
    ``ros_time`` (the scan's time stamp) and ``scan`` (its sequence number).
Entities
    ``world/scan/points`` valid beams, ``world/scan/invalid`` short grey rays where a beam
    returned nothing usable, ``world/sensor`` the sensor, ``world/segments`` the points
    coloured by range segment, ``world/{lines,corners,circles,arcs,legs,people}`` the
    features :func:`labkit.extract_features` found (hover one for its parameters),
    ``world/truth/{walls,circles,arcs,legs}`` simulator ground truth,
    ``metrics/count/*`` per-scan counts and ``metrics/time_ms/*`` per-stage times as time
    series, ``log`` a text log, and ``description`` a Markdown note. Features of a second
    configuration logged with ``name="B"`` go to ``world/B/...`` and ``metrics/B/...``.
    ``world`` is the sensor frame, drawn with x to the right and y up, as in labkit's
    matplotlib figures (rerun's 2D views point y down, so ``world`` carries a static
    mirror transform).
Map (when the scans carry poses: :attr:`labkit.Scan.pose`)
    ``map`` is the world frame (y up too): ``map/path`` the sensor's path, ``map/sensor`` the
    sensor's pose at each scan as a rerun transform, under it ``map/sensor/points`` and the
    current scan's features (``map/sensor/lines`` ...) -- the scan placed in the world --, and
    ``map/accumulated/{points,lines,corners,circles,legs}`` what the scans saw so far, in world
    coordinates: every ``map_every``-th scan with a pose (a keyframe; default 10) adds its points
    that fall in grid cells of ``map_cell_m`` (default 5 cm) no earlier keyframe filled, and its
    features. The map view shows the accumulated entities from the start of the recording up to
    the time cursor, so the map grows as you scrub; thinning keeps it to one point per cell, so
    even a 5000-scan log draws smoothly (a few tens of thousands of points for a building).
    ``map/truth/walls``: the simulator's walls, when its ground truth lies beside the recording.
    The map view sits beside the sensor view, on the same timelines; without poses there is
    no ``map`` and the layout is as before.
Tracks (``labkit view --tracks``, :mod:`labkit.viz.rr.tracks`)
    ``world/tracks/{points,trails,velocity}`` and ``map/tracks/...``: each track in a colour of
    its own with its id, its trail over the last seconds and its velocity; ``tracks/events`` the
    births, confirmations and deletions; ``metrics/count/tracks`` moving tracks per scan.

Importing this module sets ``RERUN_NOTEBOOK_ASSET=serve-local`` (unless already set) before
it imports rerun, so the viewer embedded in a notebook loads its assets from the installed
``rerun-notebook`` package instead of the internet. :func:`show_inline` serves them from the kernel as
they are on disk (rerun-notebook's own serve-local compresses the 67 MB viewer first: 4 s per kernel).
"""

from __future__ import annotations

import os
import sys

# rerun-notebook reads the variable when it is first imported (by rerun.notebook)
if "rerun_notebook" in sys.modules and "RERUN_NOTEBOOK_ASSET" not in os.environ:  # pragma: no cover
    import warnings

    warnings.warn(
        "rerun's notebook support was loaded before labkit.viz.rr: set RERUN_NOTEBOOK_ASSET=serve-local "
        "before importing rerun.notebook, or the inline viewer will load its assets from the internet",
        stacklevel=2,
    )
os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")

from .blueprint import APP_ID, SEQUENCE, STEP, TIME, blueprint, map_view, show_inline, steps_blueprint  # noqa: E402
from .entities import log_features, log_scans, log_static, log_text, log_truth, new_recording  # noqa: E402
from .recording import RRD_FILE, RecordSummary, StampsCollapsedWarning, describe, record_scans  # noqa: E402
from .replay import log_steps, record_steps  # noqa: E402
from .tracks import TrackLogger, log_tracks, track_color  # noqa: E402
from .worldmap import MAP_CELL_M, MAP_EVERY, log_map  # noqa: E402

__all__ = [
    "APP_ID",
    "TIME",
    "SEQUENCE",
    "STEP",
    "MAP_EVERY",
    "MAP_CELL_M",
    "RRD_FILE",
    "blueprint",
    "map_view",
    "steps_blueprint",
    "show_inline",
    "new_recording",
    "log_static",
    "log_scans",
    "log_features",
    "log_truth",
    "log_map",
    "log_text",
    "record_scans",
    "RecordSummary",
    "StampsCollapsedWarning",
    "describe",
    "log_steps",
    "record_steps",
    "TrackLogger",
    "log_tracks",
    "track_color",
]
