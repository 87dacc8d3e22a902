"""Round things: IAV circles and arcs (:mod:`~labkit.circles.iav`), legs and people
(:mod:`~labkit.circles.legs`)."""

from . import iav, legs
from .iav import (
    ArcParams,
    CircleParams,
    IAVStats,
    circle_from_iav,
    detect_arcs,
    detect_circles,
    iav_stats,
    inscribed_angles,
    middle_point_offset,
)
from .legs import LegsParams, detect_legs, pair_legs

__all__ = ["iav", "legs", "ArcParams", "CircleParams", "LegsParams",
           "IAVStats", "circle_from_iav", "detect_arcs", "detect_circles", "iav_stats",
           "inscribed_angles", "middle_point_offset", "detect_legs", "pair_legs"]
