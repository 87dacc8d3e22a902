"""One step trace for every algorithm that takes steps.

Every detector that a notebook steps through takes ``trace=True`` and then returns
``(result, steps)``, ``steps`` a list of :class:`Step` records in the order the algorithm
took them. The records are plain data, the same for every algorithm, so one viewer
(:func:`labkit.viz.step_plots.step_viewer`, ipywidgets) and one rerun logger
(:func:`labkit.viz.rr.log_steps`, a ``step`` timeline) replay any of them.

Kinds shared by all algorithms: ``"accept"`` (a feature the algorithm keeps: its line
``r, alpha`` or circle ``center, radius`` on the beams ``first..last``) and ``"reject"``
(a candidate dropped; ``test`` names the check it failed). The accepted steps replay to
the result: in every algorithm, the ``accept`` steps that are not undone later (see each
function's documentation) are exactly the returned features.

Examples
--------
>>> s = Step("split_and_merge", "split", 10, 40, r=2.0, alpha=0.0, at=25, value=0.12, threshold=0.05,
...          test="split_threshold_m", reason="0.120 m > split_threshold_m")
>>> s.kind, s.beam_range
('split', (10, 40))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Step", "ALGORITHMS"]

#: The algorithms that return steps, by the ``algorithm`` name their steps carry.
ALGORITHMS = ("split_and_merge", "iepf", "angular", "iav_circles", "iav_lines", "iav_arcs", "legs", "incremental",
              "ransac", "regression", "hough", "tracking")


@dataclass(frozen=True)
class Step:
    """One step of an algorithm, for replay.

    Parameters
    ----------
    algorithm : str
        Which algorithm took it (one of :data:`ALGORITHMS`): ``"split_and_merge"``
        (``method="fit"``) or ``"iepf"`` (``method="endpoints"``), ``"angular"``,
        ``"iav_circles"``, ``"iav_lines"``, ``"iav_arcs"``, ``"legs"``, the reference
        line extractors ``"incremental"``, ``"ransac"``, ``"regression"``, ``"hough"``, and
        ``"tracking"`` (:mod:`labkit.tracking`, over time: ``track`` and ``detection`` say which).
    kind : str
        The action; each algorithm documents its kinds. ``"accept"`` and ``"reject"`` mean
        the same everywhere.
    first, last : int
        First and last beam of the run concerned (-1 if none). On a full-circle scan a run may
        cross the seam (``first > last``).
    r, alpha : float
        The line concerned, normal form ``x cos alpha + y sin alpha = r``; NaN if none.
    at : int
        A beam of interest (the worst point, the beam before a gap, ...); -1 if none.
    value : float
        The number the decision looked at (a distance, a statistic, a count, a standard
        deviation of angles, ...); NaN if none.
    threshold : float
        What ``value`` was compared with; NaN if none.
    center, radius : (float, float) or None, float
        The circle concerned (IAV circles, arcs, legs); ``None`` and NaN if none.
    reason : str
        Why, in words, for people.
    test : str
        The name of the check that decided (a parameter name such as ``"split_threshold_m"``,
        or an IAV verdict such as ``"iav std"``), for code that filters steps: ``reason`` is
        prose and may change wording, ``test`` does not. Empty when no check decided.
    beams : tuple of int
        The beams concerned when they are not the run ``first..last`` (angular clusters are
        spread over the scan, RANSAC's and Hough's consensus sets have holes); may also be
        given when they are (a line's own beams); empty otherwise.
    track : int
        The track concerned (:mod:`labkit.tracking`), -1 if none.
    detection : int
        The detection concerned, its index among the scan's detections, -1 if none.
    """

    algorithm: str
    kind: str
    first: int = -1
    last: int = -1
    r: float = math.nan
    alpha: float = math.nan
    at: int = -1
    value: float = math.nan
    threshold: float = math.nan
    center: tuple[float, float] | None = None
    radius: float = math.nan
    reason: str = ""
    test: str = ""
    beams: tuple[int, ...] = ()
    track: int = -1
    detection: int = -1

    @property
    def beam_range(self) -> tuple[int, int]:
        """``(first, last)``."""
        return self.first, self.last

    @property
    def has_line(self) -> bool:
        """Whether the step carries a line ``(r, alpha)``."""
        return not (math.isnan(self.r) or math.isnan(self.alpha))

    @property
    def has_circle(self) -> bool:
        """Whether the step carries a circle ``(center, radius)``."""
        return self.center is not None and not math.isnan(self.radius)
