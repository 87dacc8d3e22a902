"""The line extractors: one module per method, and the one registry of them.

* :mod:`~labkit.lines.split_merge` split-and-merge and IEPF
* :mod:`~labkit.lines.angular` angular segmentation (Meglicki 2021)
* :mod:`~labkit.lines.incremental`, :mod:`~labkit.lines.regression`,
  :mod:`~labkit.lines.ransac`, :mod:`~labkit.lines.hough` the other extractors Nguyen et al. compared
* :mod:`~labkit.lines.iav` lines by inscribed angle variance (Xavier et al. 2005)

:data:`LINE_EXTRACTORS` maps one name per method to a :class:`LineExtractor` (function,
parameter record, one-line description, display label). The pipeline's ``lines.method``,
``labkit extract --method``, ``labkit evaluate --method``, :mod:`labkit.experiments` and the
contract tests all read it: adding an extractor is one :func:`register` line below.

>>> sorted(LINE_EXTRACTORS)[:3]
['angular', 'hough', 'iav']
>>> LINE_EXTRACTORS["iepf"].label
'split-and-merge (IEPF)'
"""

from __future__ import annotations

import functools
from collections.abc import Callable

from ..scan import Scan
from ._params import LineExtractor, Params, takes_params
from .angular import AngularParams, AngularSteps, angular_arrays, angular_lines, angular_segmentation, local_directions
from .hough import HoughParams, hough_lines
from .iav import IAVLineParams, detect_lines_iav
from .incremental import IncrementalParams, incremental_lines
from .ransac import RansacParams, ransac_lines
from .regression import RegressionParams, regression_lines
from .split_merge import SplitMergeParams, lines_similar, split_and_merge

__all__ = ["split_and_merge", "lines_similar", "angular_segmentation", "angular_arrays", "AngularSteps",
           "local_directions",
           "incremental_lines", "regression_lines", "ransac_lines", "hough_lines", "detect_lines_iav",
           "LINE_EXTRACTORS", "LineExtractor", "Params", "register", "unregister", "SplitMergeParams",
           "AngularParams", "IncrementalParams", "RegressionParams", "RansacParams", "HoughParams", "IAVLineParams"]

#: name -> :class:`LineExtractor`, in the order of the comparison tables
LINE_EXTRACTORS: dict[str, LineExtractor] = {}


def register(name: str, fn: Callable, params_cls: type, description: str, *, label: str | None = None,
             fixed: dict | None = None) -> LineExtractor:
    """Add a line extractor under ``name`` (lower case, no spaces: it is a config value and a
    CLI argument). ``fn`` returns a list of :class:`~labkit.LineSegment`; it either has the
    call shape ``fn(scan, params=None, *, segments=None, trace=False, **overrides)`` (made by
    :func:`labkit._params.takes_params`) or is a plain ``fn(scan, *, segments=None,
    **params_cls().kwargs())``, which is given that shape here. ``params_cls`` is a frozen
    :class:`Params` record holding its defaults; ``label`` (default: ``name``) names it in tables."""
    if not isinstance(name, str) or not name or name != name.strip().lower() or " " in name or name == "none":
        raise ValueError(f"an extractor name must be a lower-case word other than 'none', got {name!r}")
    if name in LINE_EXTRACTORS:
        raise ValueError(f"a line extractor {name!r} is already registered")
    if not (isinstance(params_cls, type) and issubclass(params_cls, Params)):
        raise ValueError(f"params_cls must be a labkit.lines.Params record, got {params_cls!r}")
    if getattr(fn, "params_cls", None) is not params_cls:
        fn = takes_params(params_cls)(_scan_checked(fn))
    entry = LineExtractor(name, fn, params_cls, description, label or name, tuple((fixed or {}).items()))
    LINE_EXTRACTORS[name] = entry
    return entry


def _scan_checked(fn: Callable) -> Callable:
    """``fn``, refusing anything but a :class:`~labkit.Scan` with a clear error, as labkit's own extractors do."""

    @functools.wraps(fn)
    def checked(scan, *args, **kwargs):
        if not isinstance(scan, Scan):
            raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
        return fn(scan, *args, **kwargs)

    return checked


def unregister(name: str) -> None:
    """Remove a registered extractor (for tests that register a toy one)."""
    LINE_EXTRACTORS.pop(name)


register("iepf", split_and_merge, SplitMergeParams, "iterative end-point fit: split at the point farthest from the "
         "chord, then merge similar neighbours", label="split-and-merge (IEPF)", fixed={"method": "endpoints"})
register("split_and_merge", split_and_merge, SplitMergeParams, "split-and-merge: split at the point farthest from "
         "the fitted line, then merge", label="split-and-merge (fit)", fixed={"method": "fit"})
register("incremental", incremental_lines, IncrementalParams, "grow a line point by point while the next point "
         "fits", label="incremental")
register("regression", regression_lines, RegressionParams, "line regression: fit sliding windows, merge the "
         "faithful ones", label="line regression")
register("ransac", ransac_lines, RansacParams, "RANSAC: the line with most inliers, repeatedly", label="RANSAC")
register("hough", hough_lines, HoughParams, "Hough transform: vote in (r, alpha), take the peaks", label="Hough")
register("angular", angular_lines, AngularParams, "angular segmentation: DBSCAN1D on local directions, then on "
         "offsets", label="angular segmentation")
register("iav", detect_lines_iav, IAVLineParams, "whole range segments whose inscribed angles are all near 180 deg",
         label="IAV lines")
