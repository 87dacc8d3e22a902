"""One configuration and one call for every feature of a scan.

:class:`Config` holds every parameter of every extractor, grouped by stage, with the
sources' defaults; it is validated when built and reads and writes TOML.
:func:`extract_features` runs the stages on one scan and returns :class:`Features`;
:func:`extract_all` does so for a stream of scans.

The stages share one range segmentation (the adaptive breakpoint detector with Xavier et
al.'s 80 mm as its floor) and run in this order:

1. **segmentation** -- per-beam segment labels;
2. **legs** -- segments with a leg's chord and arc (:func:`labkit.detect_legs`), paired
   into people (:func:`labkit.pair_legs`);
3. **circles** -- IAV circles (:func:`labkit.detect_circles`) among the other segments;
4. **lines** -- iterative end-point fit (``"iepf"``, the default), split-and-merge on the
   fitted line (``"split_and_merge"``) or angular segmentation (``"angular"``); by default
   no line is fitted to a segment already taken as a leg or a circle (split-and-merge
   would otherwise put short lines on every column and leg);
5. **corners** -- where consecutive lines meet (:func:`labkit.find_corners`);
6. **arcs** -- arcs embedded in walls, such as rounded corners (:func:`labkit.detect_arcs`).
   Off by default: the arc test needs walls extracted with a tight split threshold and
   long lines (:data:`labkit.circles.iav_circles.ARC_LINE_PARAMS`), a second line pass that doubles the
   cost of a scan.

Over time, :func:`track_scans` also follows the people and circles from scan to scan
(:mod:`labkit.tracking`, the ``[tracking]`` section).

The sections of a :class:`Config` are the detectors' parameter records (one default per
parameter, held in the detector's module; see :mod:`labkit.params`), plus the pipeline's
switches (``enabled``, ``lines.method``, ``lines.skip_round``): each stage calls its detector
with its section, so a detector alone with its defaults gives what its stage gives.
Angles in a :class:`Config` are in degrees (names end in ``_deg``) so that a TOML file
reads naturally; lengths in metres (``_m``). ``inf`` is a valid TOML float and means "no
limit".

>>> from labkit import sim
>>> scan, truth = sim.scan_at(sim.make_world("hall"), sim.LIDARS["lms200"], (0.0, 0.0, 0.0))
>>> f = extract_features(scan)
>>> f.counts()["lines"] > 0 and set(f.timings) >= {"segmentation", "lines", "total"}
True
>>> extract_features(scan, Config.from_dict({"lines": {"method": "angular"}})).counts()["lines"] > 0
True
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from time import perf_counter
from typing import Any, cast

import numpy as np

from ._jit import ENABLED as _JIT
from ._safe import OutputKind, safe_output
from .circles.iav_circles import ArcParams, CircleParams, detect_arcs, detect_circles
from .circles.legs import LegsParams, detect_legs, pair_legs
from .features import CornerParams, Features, find_corners
from .lines import (
    LINE_EXTRACTORS,
    AngularParams,
    HoughParams,
    IAVLineParams,
    IncrementalParams,
    RansacParams,
    RegressionParams,
    SplitMergeParams,
)
from .params import Params, param
from .scan import Scan
from .segmentation import SegmentationParams, segment_labels
from .tracking import Tracker, TrackingParams, TrackTable

__all__ = [
    "Config",
    "SegmentationConfig",
    "LinesConfig",
    "CornersConfig",
    "CirclesConfig",
    "ArcsConfig",
    "LegsConfig",
    "TrackingConfig",
    "LINE_METHODS",
    "line_methods",
    "extract_features",
    "extract_all",
    "track_scans",
]



def line_methods() -> tuple[str, ...]:
    """The values of ``lines.method``.

    Returns
    -------
    tuple of str
        Every registered line extractor (:data:`labkit.lines.LINE_EXTRACTORS`), then ``"none"``.
    """
    return (*LINE_EXTRACTORS, "none")


#: The line methods registered when labkit was imported (see :func:`line_methods` for the live list).
LINE_METHODS = line_methods()


# The sections of a Config are the detectors' parameter records (each default once, in the
# records' modules), plus the pipeline's own switches (``enabled``, the line method).
@dataclass(frozen=True)
class SegmentationConfig(SegmentationParams):
    """Range segmentation shared by every detector (:func:`labkit.segment_labels`)."""

    _name = "segmentation"


@dataclass(frozen=True)
class LegsConfig(LegsParams):
    """Legs and people (:func:`labkit.detect_legs`, :func:`labkit.pair_legs`)."""

    _name = "legs"

    enabled: bool = param(True, "detect legs and pair them into people")


@dataclass(frozen=True)
class CirclesConfig(CircleParams):
    """IAV circles (:func:`labkit.detect_circles`; Xavier et al. Table II)."""

    _name = "circles"

    enabled: bool = param(True, "detect circles")


@dataclass(frozen=True)
class LinesConfig(SplitMergeParams):
    """Line extraction: the method, split-and-merge's keys (iepf, split_and_merge), one table per other method.

    The other methods' tables are ``[lines.angular]``, ``[lines.ransac]``, ..."""

    _name = "lines"
    method: str = param("iepf", "a registered line extractor (labkit.lines.LINE_EXTRACTORS: iepf splits on the "
                                "chord, split_and_merge on the fitted line, angular, incremental, regression, ransac, "
                                "hough, iav) or none; iepf and split_and_merge read the keys of this table, the "
                                "others their own table below", choices=line_methods)
    skip_round: bool = param(True, "fit no line to a segment taken as a leg or a circle")
    angular: AngularParams = param(AngularParams(), "angular segmentation (labkit.angular_segmentation)")
    incremental: IncrementalParams = param(IncrementalParams(), "incremental (labkit.incremental_lines)")
    regression: RegressionParams = param(RegressionParams(), "line regression (labkit.regression_lines)")
    ransac: RansacParams = param(RansacParams(), "RANSAC (labkit.ransac_lines; seeded)")
    hough: HoughParams = param(HoughParams(), "Hough transform (labkit.hough_lines)")
    iav: IAVLineParams = param(IAVLineParams(), "IAV lines (labkit.detect_lines_iav)")

    _not_passed = ("method", "skip_round")

    def params_of(self, method: str):
        """The parameter record of a registered line method: this table for iepf and
        split_and_merge, its own table for the others (a method registered later runs with
        its record's defaults)."""
        entry = LINE_EXTRACTORS[method]
        if isinstance(self, entry.params_cls):
            return self
        record = getattr(self, method, None)
        return record if isinstance(record, entry.params_cls) else entry.params_cls()


#: Old keys of [lines] (before issue 14), read into the angular table.
_OLD_LINES_KEYS = {"eps_theta_deg": "angular.eps_theta_deg", "eps_dist_m": "angular.eps_dist_m",
                   "angular_min_points": "angular.min_points", "angular_split_gap_m": "angular.split_gap_m"}


@dataclass(frozen=True)
class CornersConfig(CornerParams):
    """Corners where consecutive lines meet (:func:`labkit.find_corners`)."""

    _name = "corners"

    enabled: bool = param(True, "find corners")


@dataclass(frozen=True)
class ArcsConfig(ArcParams):
    """Arcs embedded in walls, e.g. rounded corners (:func:`labkit.detect_arcs`)."""

    _name = "arcs"

    enabled: bool = param(False, "detect arcs in walls (a second, finer line pass: about twice the time per scan; "
                                 "needs an arc seen by many beams, and finds false arcs in 1-8 % of scans of rooms "
                                 "without any)")


@dataclass(frozen=True)
class TrackingConfig(TrackingParams):
    """Tracking over time (:class:`labkit.tracking.Tracker`), run by :func:`track_scans`."""

    _name = "tracking"


for _cls in (LegsConfig, CirclesConfig, CornersConfig, ArcsConfig):
    # (the first base of a stage's config is its detector's record: mypy types __mro__ as plain types)
    _cls._not_passed = (*cast(type[Params], _cls.__mro__[1])._not_passed, "enabled")
del _cls

_SECTIONS = {  # the order the stages run in, and the order of a TOML file
    "segmentation": SegmentationConfig,
    "legs": LegsConfig,
    "circles": CirclesConfig,
    "lines": LinesConfig,
    "corners": CornersConfig,
    "arcs": ArcsConfig,
    "tracking": TrackingConfig,
}


def _section(name: str, value):
    """``value`` as the section ``name``: a record of the section's own detector (such as a
    :class:`labkit.LegsParams`) becomes the section, its switches at their defaults."""
    cls = _SECTIONS[name]
    if isinstance(value, cls):
        return value
    record = cls.__mro__[1]
    if isinstance(value, record):
        return cls(**{f.name: getattr(value, f.name) for f in dataclasses.fields(record)})
    raise ValueError(f"Config.{name} must be a {cls.__name__} (or a {record.__name__}), got {type(value).__name__}")


def _first_line(doc: str | None) -> str:
    assert doc is not None, "@dataclass gives every record a docstring (its signature when none is written)"
    return " ".join(doc.strip().split("\n\n")[0].split())


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, float):
        return "inf" if v == math.inf else "-inf" if v == -math.inf else repr(v)
    return str(v)


@dataclass(frozen=True)
class Config:
    """Every parameter of every extractor, by stage.

    Build one with keyword sections, from a dict (:meth:`from_dict`), a TOML text
    (:meth:`from_toml`) or file (:meth:`load`); change one with :meth:`updated`. Unknown
    sections or keys and bad values raise ``ValueError`` naming them.

    Each section is its detector's parameter record (``Config().circles`` is a
    :class:`labkit.CircleParams`, with ``enabled``), so ``labkit.detect_circles(scan,
    **cfg.circles.kwargs())`` is the pipeline's call. [lines] holds split-and-merge's keys (iepf and
    split_and_merge) and one table per other line method.

    Parameters
    ----------
    segmentation : SegmentationConfig
        The range segmentation every detector shares (:class:`labkit.SegmentationParams`).
    legs : LegsConfig
        Legs and people (:class:`labkit.LegsParams`, with ``enabled``).
    circles : CirclesConfig
        IAV circles (:class:`labkit.CircleParams`, with ``enabled``).
    lines : LinesConfig
        The line method and split-and-merge's keys (:class:`labkit.SplitMergeParams`), with one table
        per other method.
    corners : CornersConfig
        Corners between lines (:class:`labkit.CornerParams`, with ``enabled``).
    arcs : ArcsConfig
        Arcs embedded in walls (:class:`labkit.ArcParams`, with ``enabled``).
    tracking : TrackingConfig
        Tracking over time (:class:`labkit.TrackingParams`).

    Examples
    --------
    >>> c = Config().updated({"lines.method": "angular", "legs": {"enabled": False}})
    >>> c.lines.method, c.legs.enabled, c.circles.min_points
    ('angular', False, 4)
    >>> Config.from_toml(c.to_toml()) == c
    True
    >>> Config.from_dict({"lines": {"split_threshold": 0.1}})
    Traceback (most recent call last):
    ...
    ValueError: unknown key lines.split_threshold; lines has: method, skip_round, split_threshold_m, ...
    >>> Config().updated({"lines.ransac.threshold_m": 0.02}).lines.ransac.threshold_m
    0.02
    >>> Config.from_dict({"lines": {"angular_min_points": 6}}).lines.angular.min_points  # an old key
    6
    """

    # in the order the stages run
    segmentation: SegmentationConfig = field(default_factory=SegmentationConfig)
    legs: LegsConfig = field(default_factory=LegsConfig)
    circles: CirclesConfig = field(default_factory=CirclesConfig)
    lines: LinesConfig = field(default_factory=LinesConfig)
    corners: CornersConfig = field(default_factory=CornersConfig)
    arcs: ArcsConfig = field(default_factory=ArcsConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)

    def __post_init__(self) -> None:
        for name in _SECTIONS:
            object.__setattr__(self, name, _section(name, getattr(self, name)))

    # ------------------------------------------------------------------ dicts
    def to_dict(self) -> dict:
        """``{section: {key: value}}`` with plain Python values (pairs as lists, the line
        methods' tables as nested dicts)."""
        return {name: getattr(self, name).to_dict() for name in _SECTIONS}

    @classmethod
    def from_dict(cls, data: dict) -> Config:
        """A config from ``{section: {key: value}}``; missing keys keep their defaults."""
        return cls().updated(data)

    def updated(self, changes: dict) -> Config:
        """A copy with ``changes`` applied: ``{section: {key: value}}`` or dotted keys
        ``{"section.key": value}``, ``{"lines.ransac.threshold_m": value}`` (or both). The
        keys of [lines] before the per-method tables (``eps_theta_deg``, ``eps_dist_m``,
        ``angular_min_points``, ``angular_split_gap_m``) are read into [lines.angular]."""
        if not isinstance(changes, dict):
            raise ValueError(f"changes must be a dict of sections, got {type(changes).__name__}")
        per_section: dict[str, dict] = {}
        for key, value in changes.items():
            if not isinstance(key, str):
                raise ValueError(f"config keys must be strings, got {key!r}")
            if "." in key:
                section, _, sub = key.partition(".")
                per_section.setdefault(section, {})[sub] = value
            elif isinstance(value, dict):
                per_section.setdefault(key, {}).update(value)
            else:
                raise ValueError(f"{key!r}: give a section as a table ({{key: value}}) or use 'section.key'; "
                                 f"sections: {', '.join(_SECTIONS)}")
        new = {}
        for section, values in per_section.items():
            if section not in _SECTIONS:
                raise ValueError(f"unknown config section {section!r}; sections: {', '.join(_SECTIONS)}")
            if section == "lines":
                values = {_OLD_LINES_KEYS.get(k, k): v for k, v in values.items()}
            new[section] = getattr(self, section).updated(values, prefix=section)
        return dataclasses.replace(self, **new)

    # ------------------------------------------------------------------ TOML
    def to_toml(self) -> str:
        """The config as TOML, every key with its doc as a comment."""
        out = ["# labkit feature extraction config (labkit.Config); angles in degrees, lengths in metres", ""]
        tables = [(name, getattr(self, name), _first_line(type(getattr(self, name)).__doc__)) for name in _SECTIONS]
        while tables:
            name, section, doc = tables.pop(0)
            out.append(f"[{name}]  # {doc}")
            nested = []
            for f in section.ordered_fields():
                value = getattr(section, f.name)
                if f.metadata.get("record"):
                    nested.append((f"{name}.{f.name}", value, f.metadata["doc"]))
                elif value is None and f.default is None:  # TOML has no null: left out, the default is read back
                    out.append(f"# {f.name} =  (none)  # {f.metadata['doc']}")
                elif value is None:  # (a default that is not None: the word, which the record reads as None)
                    out.append(f'{f.name} = "none"  # {f.metadata["doc"]}')
                else:
                    out.append(f"{f.name} = {_toml_value(value)}  # {f.metadata['doc']}")
            out.append("")
            tables[:0] = nested
        return "\n".join(out)

    @classmethod
    def from_toml(cls, text: str) -> Config:
        """A config from TOML text (see :meth:`to_toml` for the layout)."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"config is not valid TOML: {exc}") from None
        return cls.from_dict(data)

    @classmethod
    def load(cls, path: str | Path) -> Config:
        """Read a TOML file."""
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"config file {path} does not exist (write one with `labkit config -o {path}`)")
        try:
            return cls.from_toml(path.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None

    def save(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write the config to a TOML file (under a temporary name, then renamed); returns the
        path. ``overwrite`` replaces only a labkit config file."""
        path = Path(path)
        with safe_output(path, CONFIG_FILE, overwrite=overwrite) as tmp:
            tmp.write_text(self.to_toml(), encoding="utf-8")
        return path


def _is_config_file(path: Path) -> bool:
    """A TOML file whose tables are all sections of :class:`Config` (written by labkit or by hand)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    sections = {f.name for f in dataclasses.fields(Config)}
    return bool(data) and set(data) <= sections and all(isinstance(v, dict) for v in data.values())


#: What :meth:`Config.save` writes (see labkit._safe): how an existing config is recognised.
CONFIG_FILE = OutputKind("a labkit config (.toml)", (".toml",), _is_config_file)


# ---------------------------------------------------------------------------- the pipeline
_DEFAULT = Config()  # frozen: built and validated once


def _mask_segments(labels: np.ndarray, taken: list) -> np.ndarray:
    """``labels`` with the segments holding the first beam of each feature set to -1."""
    if not taken:
        return labels
    # A look-up table by label (its last entry, for -1, stays False): one gather instead of np.isin's sort.
    drop = np.zeros(int(labels.max()) + 2, dtype=bool)
    drop[labels[[f.first for f in taken]]] = True
    drop[-1] = False
    return np.where(drop[labels], -1, labels)


def extract_features(scan: Scan, config: Config | None = None) -> Features:
    """Run every stage of ``config`` (default: :class:`Config` ()) on one scan.

    See the module docstring for the stages and their order. Invalid beams are masked,
    never raised; a scan with no valid beam gives empty features.

    Parameters
    ----------
    scan : Scan
        The laser scan.
    config : Config, optional
        Every stage's parameters; default ``Config()``.

    Returns
    -------
    Features
        Lines, corners, circles, arcs, legs and people of the scan, the range segment of every beam
        (``labels``) and the seconds each stage took (``timings``).
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    cfg = _DEFAULT if config is None else config
    if not isinstance(cfg, Config):
        raise ValueError(f"config must be a labkit.Config, got {type(cfg).__name__}")
    # the same stages with the scan's quantities worked out once (labkit._pipeline_engine): the same features
    if (engine := _engine()) is not None and (plan := engine[0](cfg)) is not None:
        return engine[1](scan, plan)
    return _stages(scan, cfg)


_ENGINE: Any = False  # (False: not imported yet)


def _engine():
    """``(plan_for, extract)`` of labkit._pipeline_engine, or None where the compiled engines do not
    run (``LABKIT_NO_JIT=1``); imported on the first scan (it imports numba)."""
    global _ENGINE
    if _ENGINE is False:
        _ENGINE = None
        if _JIT:
            from ._pipeline_engine import READY, extract, plan_for

            _ENGINE = (plan_for, extract) if READY else None
    return _ENGINE


def _stages(scan: Scan, cfg: Config) -> Features:
    """The stages of :func:`extract_features`, each its detector called with its section."""
    seg, lc, cc, lg = cfg.segmentation, cfg.lines, cfg.circles, cfg.legs
    timings: dict[str, float] = {}
    t_start = t = perf_counter()

    def lap(stage: str) -> None:
        nonlocal t
        now = perf_counter()
        timings[stage] = now - t
        t = now

    # Each stage is its detector called with its config section (which is its parameter
    # record, checked when the Config was built): the same call as the detector alone, given the
    # segments the stages before left.
    labels = segment_labels.unchecked(scan, **seg.kwargs())
    lap("segmentation")
    legs, people = [], []
    if lg.enabled:
        legs = detect_legs.unchecked(scan, **lg.kwargs(), segments=labels)
        people = pair_legs(legs, lg.pair_max_distance_m)
    lap("legs")
    rest = _mask_segments(labels, legs)
    circles = []
    if cc.enabled:
        circles = detect_circles.unchecked(scan, **cc.kwargs(), segments=rest)
    lap("circles")
    rest = _mask_segments(rest, circles)
    lines = []
    if lc.method != "none":
        entry = LINE_EXTRACTORS[lc.method]
        if entry.segmented:  # on the range segments (minus those taken as legs and circles)
            segments = rest if lc.skip_round else labels
        elif lc.skip_round and (legs or circles):  # on the whole scan, minus the beams taken
            segments = np.where(scan.valid & ((rest >= 0) | (labels < 0)), 0, -1)
        else:
            segments = None
        lines = entry.run(scan, lc.params_of(lc.method), segments=segments)
    lap("lines")
    corners = []
    if cfg.corners.enabled and len(lines) > 1:
        corners = find_corners.unchecked(lines, **cfg.corners.kwargs(), wrap=scan.is_full_circle)
    lap("corners")
    arcs = []
    if cfg.arcs.enabled:
        arcs = detect_arcs.unchecked(scan, **cfg.arcs.kwargs(), segments=rest)
    lap("arcs")
    timings["total"] = perf_counter() - t_start
    return Features(scan.stamp_ns, scan.n_beams, labels, tuple(lines), tuple(corners), tuple(circles), tuple(arcs),
                    tuple(legs), tuple(people), timings)


def extract_all(scans: Iterable[Scan], config: Config | None = None) -> Iterator[Features]:
    """:func:`extract_features` for every scan of a stream, lazily (one scan in memory).

    Parameters
    ----------
    scans : iterable of Scan
        The scans, e.g. :func:`labkit.read_scans`'s stream.
    config : Config, optional
        Every stage's parameters; default ``Config()``.

    Yields
    ------
    Features
        The features of each scan, in the order of ``scans``.
    """
    cfg = _DEFAULT if config is None else config
    for scan in scans:
        yield extract_features(scan, cfg)


def track_scans(scans: Iterable[Scan], config: Config | None = None, *,
                trace: bool = False) -> Iterator[tuple[Features, TrackTable]]:
    """:func:`extract_features` and tracking over a stream of scans, lazily.

    :func:`extract_features` and tracking (:class:`labkit.tracking.Tracker` with the ``[tracking]``
    section) over a stream of scans, lazily: ``(features, tracks)`` per scan, ``tracks`` a
    :class:`labkit.tracking.TrackTable` (``(features, (tracks, steps))`` with ``trace``). The scans'
    poses (:attr:`Scan.pose`) place them in the map frame when ``tracking.frame`` is ``"map"``, or
    ``"auto"`` and the first scan has one.

    Parameters
    ----------
    scans : iterable of Scan
        The scans, in time order.
    config : Config, optional
        Every stage's parameters, the ``[tracking]`` section too; default ``Config()``.
    trace : bool, default False
        Also yield the tracker's steps of each scan.

    Yields
    ------
    (Features, TrackTable)
        The features of each scan and the tracks after it (``(features, (tracks, steps))`` with
        ``trace``).
    """
    cfg = _DEFAULT if config is None else config
    if not isinstance(cfg, Config):
        raise ValueError(f"config must be a labkit.Config, got {type(cfg).__name__}")
    tracker = Tracker(**cfg.tracking.kwargs())
    for scan in scans:
        features = extract_features(scan, cfg)
        yield features, tracker.step(features, pose=scan.pose, trace=trace)
