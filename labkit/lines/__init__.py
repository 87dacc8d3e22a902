"""The line extractors: one module per method, and the one registry of them.

* :mod:`~labkit.lines.split_merge` split-and-merge and IEPF (:func:`iepf`, the bare split of the slides)
* :mod:`~labkit.lines.angular` angular segmentation (Meglicki 2021)
* :mod:`~labkit.lines.incremental`, :mod:`~labkit.lines.regression`,
  :mod:`~labkit.lines.ransac`, :mod:`~labkit.lines.hough` the other extractors Nguyen et al. compared
* :mod:`~labkit.lines.iav_lines` lines by inscribed angle variance (Xavier et al. 2005)

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

from ..params import Params
from .angular import AngularParams, AngularSteps, angular_arrays, angular_lines, angular_segmentation, local_directions
from .hough import HoughParams, hough_lines
from .iav_lines import IAVLineParams, detect_lines_iav
from .incremental import IncrementalParams, incremental_lines
from .placing import PlacingParams
from .ransac import RansacParams, ransac_lines
from .registry import LINE_EXTRACTORS, LineExtractor, register, unregister
from .regression import RegressionParams, regression_lines
from .split_merge import SplitMergeParams, iepf, lines_similar, split_and_merge

__all__ = ["split_and_merge", "iepf", "lines_similar", "angular_segmentation", "angular_arrays", "AngularSteps",
           "local_directions",
           "incremental_lines", "regression_lines", "ransac_lines", "hough_lines", "detect_lines_iav",
           "LINE_EXTRACTORS", "LineExtractor", "Params", "register", "unregister", "SplitMergeParams",
           "AngularParams", "IncrementalParams", "RegressionParams", "RansacParams", "HoughParams", "IAVLineParams",
           "PlacingParams"]

register("iepf", split_and_merge, SplitMergeParams, "iterative end-point fit: split at the point farthest from the "
         "chord, then merge similar neighbours", label="split-and-merge (IEPF)", fixed={"method": "endpoints"})
register("split_and_merge", split_and_merge, SplitMergeParams, "split-and-merge: split at the point farthest from "
         "the fitted line, then merge", label="split-and-merge (fit)", fixed={"method": "fit"})
register("incremental", incremental_lines, IncrementalParams, "grow a line point by point while the next point "
         "fits", label="incremental", segmented=False)
register("regression", regression_lines, RegressionParams, "line regression: fit sliding windows, merge the "
         "faithful ones", label="line regression", segmented=False)
register("ransac", ransac_lines, RansacParams, "RANSAC: the line with most inliers, repeatedly", label="RANSAC",
         segmented=False)
register("hough", hough_lines, HoughParams, "Hough transform: vote in (r, alpha), take the peaks", label="Hough",
         segmented=False)
register("angular", angular_lines, AngularParams, "angular segmentation: DBSCAN1D on local directions, then on "
         "offsets", label="angular segmentation", segmented=False)
register("iav", detect_lines_iav, IAVLineParams, "whole range segments whose inscribed angles are all near 180 deg",
         label="IAV lines")
