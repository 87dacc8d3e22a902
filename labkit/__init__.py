"""labkit: feature extraction from 2D laser range scans, for teaching and research.

The library's public names are re-exported here; modules:

- :mod:`labkit.scan` the :class:`Scan` model
- :mod:`labkit.geometry` angles, normal-form lines, transforms
- :mod:`labkit.segmentation` range segmentation
- :mod:`labkit.noise` the range noise estimated from the scans, and the "auto" thresholds built on it
- :mod:`labkit.fitting` line and circle fits
- :mod:`labkit.lines` the line extractors, one module each: :mod:`~labkit.lines.split_merge`
  (split-and-merge and IEPF), :mod:`~labkit.lines.angular` (angular segmentation, Meglicki 2021),
  :mod:`~labkit.lines.incremental`, :mod:`~labkit.lines.regression`, :mod:`~labkit.lines.ransac`,
  :mod:`~labkit.lines.hough` (the others Nguyen et al. compared, written to teach) and
  :mod:`~labkit.lines.iav_lines` (lines by inscribed angle variance)
- :mod:`labkit.iav` the inscribed angle variance: inscribed angles, the circle prerequisite, circles
  from the chord (Xavier et al. 2005)
- :mod:`labkit.circles` round things: :mod:`~labkit.circles.iav_circles` (IAV circles, arcs) and
  :mod:`~labkit.circles.legs` (legs, paired into people)
- :mod:`labkit.dbscan` DBSCAN on 1-D data in linear time (:func:`dbscan1d`)
- :mod:`labkit.features` feature records (lines, corners, circles, legs) and corners
- :mod:`labkit.evaluation` scores against ground truth (Nguyen's line metrics, circles, legs) and ray-axis RMSE
- :mod:`labkit.experiments` the evaluation experiments (simulated sets, comparisons, sweeps)
- :mod:`labkit.pipeline` one :class:`Config` and :func:`extract_features` for every feature
- :mod:`labkit.tracking` people and moving circles followed over time (Kalman filters, gating,
  assignment, a track life cycle); :mod:`labkit.tracking_metrics` CLEAR MOT and IDF1
- :mod:`labkit.sim` the simulator with ground truth (worlds, people, lidar, truth files)
- :mod:`labkit.poses` SE(2) poses: composition, interpolation to a scan's stamp, frame trees
- :mod:`labkit.io` bags, CARMEN logs, JSON (and the poses they carry)
- :mod:`labkit.tables` features as a pandas DataFrame / Parquet table (needs ``labkit[research]``)
- :mod:`labkit.parallel` many recordings on Dask (needs ``labkit[research]``; import explicitly)
- :mod:`labkit.data` the bundled recordings
- :mod:`labkit.viz` matplotlib, rerun and ipywidgets viewers (import explicitly)
"""


from . import circles, evaluation, geometry, iav, lines, poses, sim, tracking, tracking_metrics
from .circles import ArcParams, CircleParams, LegsParams, detect_arcs, detect_circles, detect_legs, pair_legs
from .data import bundled_data
from .dbscan import DBSCAN1D, dbscan1d, dbscan1d_reference
from .evaluation import match_circles, match_legs, match_lines, ray_errors, score_detections, score_lines
from .features import Circle, Corner, CornerParams, Features, Leg, LineSegment, Person, find_corners, line_segment
from .fitting import CircleFit, LineFit, fit_circle, fit_line_ols, fit_line_polar, fit_line_tls, placement_probability
from .geometry import angle_difference, circular_mean, line_through_points, wrap_angle
from .iav import IAVStats, circle_from_iav, iav_stats, inscribed_angles, middle_point_offset
from .io import (
    CorruptFileError,
    convert,
    read_carmen,
    read_features,
    read_json_scan,
    read_scans,
    write_bag,
    write_features,
    write_scans,
)
from .lines import (
    AngularParams,
    AngularSteps,
    HoughParams,
    IAVLineParams,
    IncrementalParams,
    RansacParams,
    RegressionParams,
    SplitMergeParams,
    angular_arrays,
    angular_segmentation,
    detect_lines_iav,
    hough_lines,
    incremental_lines,
    lines_similar,
    local_directions,
    ransac_lines,
    regression_lines,
    split_and_merge,
)
from .noise import estimate_range_noise, range_noise_residuals
from .pipeline import Config, extract_all, extract_features, track_scans
from .scan import Scan, polar_to_cartesian
from .segmentation import RangeSegment, SegmentationParams, breakpoint_thresholds, range_segments, segment_labels
from .steps import Step
from .tables import features_table, read_table
from .tracking import Tracker, TrackingParams, TrackTable, track
from .tracking_metrics import clear_mot

__version__ = "0.1.0"

__all__ = [
    # the parameter records, one per extractor and detector (degrees and metres)
    "SegmentationParams",
    "LegsParams",
    "CircleParams",
    "ArcParams",
    "CornerParams",
    "SplitMergeParams",
    "AngularParams",
    "IncrementalParams",
    "RegressionParams",
    "RansacParams",
    "HoughParams",
    "IAVLineParams",
    "Scan",
    "polar_to_cartesian",
    "geometry",
    "wrap_angle",
    "angle_difference",
    "circular_mean",
    "line_through_points",
    "RangeSegment",
    "segment_labels",
    "estimate_range_noise",
    "range_noise_residuals",
    "placement_probability",
    "range_segments",
    "breakpoint_thresholds",
    "split_and_merge",
    "incremental_lines",
    "regression_lines",
    "ransac_lines",
    "hough_lines",
    "lines_similar",
    "Step",
    "LineFit",
    "CircleFit",
    "fit_line_polar",
    "fit_line_tls",
    "fit_line_ols",
    "fit_circle",
    "LineSegment",
    "Corner",
    "Circle",
    "Leg",
    "Person",
    "line_segment",
    "find_corners",
    "Features",
    "Config",
    "extract_features",
    "extract_all",
    "dbscan1d",
    "dbscan1d_reference",
    "DBSCAN1D",
    "angular_segmentation",
    "angular_arrays",
    "AngularSteps",
    "local_directions",
    "lines",
    "circles",
    "iav",
    "inscribed_angles",
    "iav_stats",
    "IAVStats",
    "circle_from_iav",
    "middle_point_offset",
    "detect_circles",
    "detect_lines_iav",
    "detect_arcs",
    "detect_legs",
    "pair_legs",
    "sim",
    "bundled_data",
    "read_scans",
    "read_carmen",
    "read_json_scan",
    "write_bag",
    "write_scans",
    "convert",
    "write_features",
    "read_features",
    "CorruptFileError",
    "evaluation",
    "match_lines",
    "score_lines",
    "match_circles",
    "match_legs",
    "score_detections",
    "ray_errors",
    "poses",
    "features_table",
    "read_table",
    "tracking",
    "tracking_metrics",
    "TrackingParams",
    "Tracker",
    "TrackTable",
    "track",
    "track_scans",
    "clear_mot",
    "__version__",
]
