"""Placing: a line is reported only if the data can place it (what the extractors with a
``place_confidence`` share).

By its covariance (from the range noise), a line must lie within ``place_dr_m`` in ``r`` and
``place_dalpha_deg`` in ``alpha`` of the true line with probability ``place_confidence``
(:func:`labkit.fitting.placement_probability`); Nguyen et al.'s tolerance of a correct line is the
default. A short piece seen from afar, whose angle the data cannot fix to a few degrees, is dropped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..features import LineSegment
from ..fitting import placement_probability
from ..params import AUTO, Params, param

__all__ = ["PlacingParams", "placed"]


@dataclass(frozen=True)
class PlacingParams(Params):
    """The placing fields RANSAC, the Hough transform and incremental extraction share.

    They mean what split-and-merge's do: the range noise of the lines' covariances and what a user
    trusts; a line is reported only if it is likely within ``place_dr_m`` and
    ``place_dalpha_deg`` of the true line."""

    range_sigma_m: float = param(AUTO, "range noise of the lines' covariances (placing), metres; none: each "
                                       "line's own residuals; auto: estimated from each scan (labkit.noise)",
                                 lo=0, strict=True, optional=True, kind=float, auto=True)
    place_dr_m: float = param(0.05, "report a line only if it is likely within this of the true r, metres",
                              lo=0, strict=True)
    place_dalpha_deg: float = param(3.0, "and within this of the true alpha, degrees", lo=0, strict=True)
    place_confidence: float = param(0.8, "with at least this probability by its covariance (0: report every "
                                         "line, the papers)", lo=0, hi=1)


def placed(lines: list[LineSegment], place_dr_m: float, place_dalpha_deg: float, place_confidence: float,
           steps=None) -> list[LineSegment]:
    """The lines the data can place, as their covariances say.

    Those whose covariance gives them at least ``place_confidence`` of lying within
    ``place_dr_m`` metres and ``place_dalpha_deg`` degrees of the true line
    (:func:`labkit.fitting.placement_probability`) are kept. Shared by every extractor with a
    ``place_confidence``. (In split-and-merge, joining such a line to its neighbour instead,
    when the joined line still passes the split test, found fewer walls and more false lines on
    the simulated sets of ``benchmarks/evaluation.py``.)

    Parameters
    ----------
    lines : list of LineSegment
        The lines, with their covariances.
    place_dr_m : float
        The tolerance in ``r``, metres.
    place_dalpha_deg : float
        The tolerance in ``alpha``, degrees.
    place_confidence : float
        The probability a line must reach; 0 keeps every line.
    steps : Steps or None
        When given, every other line is added as a ``"reject"`` step with ``test="place_confidence"``.

    Returns
    -------
    list of LineSegment
        The lines kept, in order.
    """
    if place_confidence <= 0 or not lines:
        return lines
    chance = np.asarray(placement_probability(np.array([ln.covariance for ln in lines]), place_dr_m,
                                              math.radians(place_dalpha_deg))).tolist()
    out = []
    for ln, c in zip(lines, chance, strict=True):
        if c >= place_confidence:
            out.append(ln)
        elif steps is not None:
            steps.add("reject", ln.first, ln.last, ln.r, ln.alpha, value=c, threshold=place_confidence,
                      test="place_confidence", reason=f"placed with probability {c:.2f} < place_confidence")
    return out
