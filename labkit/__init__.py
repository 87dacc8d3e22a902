"""labkit: feature extraction from 2D laser range scans, for teaching and research.

The library's public names are re-exported here; modules:

- :mod:`labkit.scan` the :class:`Scan` model
- :mod:`labkit.geometry` angles, normal-form lines, transforms
- :mod:`labkit.segmentation` range segmentation
- :mod:`labkit.sim` the simulator with ground truth
- :mod:`labkit.io` bags, CARMEN logs, JSON
- :mod:`labkit.data` the bundled recordings
- :mod:`labkit.viz` matplotlib, rerun and ipywidgets viewers (import explicitly)
"""

from . import geometry, sim
from .data import bundled_data
from .geometry import angle_difference, circular_mean, line_through_points, wrap_angle
from .io import CorruptFileError, convert, read_carmen, read_json_scan, read_scans, write_bag, write_scans
from .scan import Scan, polar_to_cartesian
from .segmentation import RangeSegment, range_segments, segment_labels

__version__ = "0.1.0"

__all__ = [
    "Scan",
    "polar_to_cartesian",
    "geometry",
    "wrap_angle",
    "angle_difference",
    "circular_mean",
    "line_through_points",
    "RangeSegment",
    "segment_labels",
    "range_segments",
    "sim",
    "bundled_data",
    "read_scans",
    "read_carmen",
    "read_json_scan",
    "write_bag",
    "write_scans",
    "convert",
    "CorruptFileError",
    "__version__",
]
