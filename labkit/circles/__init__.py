"""Round things: IAV circles and arcs (:mod:`~labkit.circles.iav_circles`), legs and people
(:mod:`~labkit.circles.legs`). The inscribed-angle geometry they share is :mod:`labkit.iav`."""

import warnings

from . import iav_circles, legs
from .iav_circles import ARC_LINE_PARAMS, ArcParams, CircleParams, detect_arcs, detect_circles
from .legs import LegsParams, detect_legs, is_occluded, pair_legs

__all__ = ["iav_circles", "legs", "ArcParams", "CircleParams", "LegsParams", "ARC_LINE_PARAMS", "detect_arcs",
           "detect_circles", "detect_legs", "is_occluded", "pair_legs"]

#: the geometry this package re-exported before it moved to labkit.iav (for one release, with a warning)
_MOVED_TO_IAV = ("IAVStats", "circle_from_iav", "iav_stats", "inscribed_angles", "middle_point_offset")


def __getattr__(name: str):
    if name in _MOVED_TO_IAV:
        from .. import iav

        warnings.warn(f"labkit.circles.{name} is deprecated: use labkit.iav.{name} (or labkit.{name})",
                      DeprecationWarning, stacklevel=2)
        return getattr(iav, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
