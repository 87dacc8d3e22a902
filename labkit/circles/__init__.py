"""Round things: IAV circles and arcs (:mod:`~labkit.circles.iav_circles`), legs and people
(:mod:`~labkit.circles.legs`). The inscribed-angle geometry they share is :mod:`labkit.iav`."""

from . import iav_circles, legs
from .iav_circles import ARC_LINE_PARAMS, ArcParams, CircleParams, detect_arcs, detect_circles
from .legs import LegsParams, detect_legs, is_occluded, pair_legs

__all__ = ["iav_circles", "legs", "ArcParams", "CircleParams", "LegsParams", "ARC_LINE_PARAMS", "detect_arcs",
           "detect_circles", "detect_legs", "is_occluded", "pair_legs"]
