"""The line extractors: one module per method.

* :mod:`~labkit.lines.split_merge` split-and-merge and IEPF
* :mod:`~labkit.lines.angular` angular segmentation (Meglicki 2021)
* :mod:`~labkit.lines.incremental`, :mod:`~labkit.lines.regression`,
  :mod:`~labkit.lines.ransac`, :mod:`~labkit.lines.hough` the other extractors Nguyen et al. compared
* :mod:`~labkit.lines.iav` lines by inscribed angle variance (Xavier et al. 2005)
"""

from .angular import AngularSteps, angular_arrays, angular_segmentation, local_directions
from .hough import hough_lines
from .iav import detect_lines_iav
from .incremental import incremental_lines
from .ransac import ransac_lines
from .regression import regression_lines
from .split_merge import lines_similar, split_and_merge

__all__ = ["split_and_merge", "lines_similar", "angular_segmentation", "angular_arrays", "AngularSteps",
           "local_directions", "incremental_lines", "regression_lines", "ransac_lines", "hough_lines",
           "detect_lines_iav"]
