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
   long lines (:data:`labkit.circles.iav.ARC_LINE_PARAMS`), a second line pass that doubles the
   cost of a scan.

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

import numpy as np

from ._safe import OutputKind, safe_output
from .circles.iav import detect_arcs, detect_circles
from .circles.legs import detect_legs, pair_legs
from .features import Features, find_corners
from .lines import LINE_EXTRACTORS
from .lines.angular import angular_segmentation
from .lines.split_merge import split_and_merge
from .scan import Scan
from .segmentation import segment_labels

__all__ = [
    "Config",
    "SegmentationConfig",
    "LinesConfig",
    "CornersConfig",
    "CirclesConfig",
    "ArcsConfig",
    "LegsConfig",
    "LINE_METHODS",
    "line_methods",
    "extract_features",
    "extract_all",
]



def line_methods() -> tuple[str, ...]:
    """The values of ``lines.method``: every registered line extractor
    (:data:`labkit.lines.LINE_EXTRACTORS`), then ``"none"``."""
    return (*LINE_EXTRACTORS, "none")


#: The line methods registered when labkit was imported (see :func:`line_methods` for the live list).
LINE_METHODS = line_methods()


def _p(default, doc: str, *, lo: float | None = None, strict: bool = False, hi: float | None = None,
       choices: tuple | None = None):
    """A config field: its default, a one-line doc (written into TOML files as a comment),
    and the checks applied when a config is built."""
    return field(default=default, metadata={"doc": doc, "lo": lo, "strict": strict, "hi": hi, "choices": choices})


def _check_value(section: str, f: dataclasses.Field, value):
    """Type and range of one field; returns the value in its canonical Python type."""
    name = f"{section}.{f.name}"
    meta = f.metadata
    default = f.default
    if isinstance(default, bool):
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name} must be true or false, got {value!r}")
        return bool(value)
    if isinstance(default, str):
        choices = meta["choices"]() if callable(meta["choices"]) else meta["choices"]
        if not isinstance(value, str) or (choices and value not in choices):
            raise ValueError(f"{name} must be one of {choices}, got {value!r}")
        return value
    if isinstance(default, tuple):
        try:
            pair = tuple(float(v) for v in value)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a pair [low, high], got {value!r}") from None
        if len(pair) != 2 or not (pair[0] < pair[1]) or any(math.isnan(v) for v in pair):
            raise ValueError(f"{name} must be a pair [low, high] with low < high, got {value!r}")
        lo, hi = meta["lo"], meta["hi"]
        if (lo is not None and pair[0] < lo) or (hi is not None and pair[1] > hi):
            raise ValueError(f"{name} must lie within [{lo:g}, {hi:g}], got {list(pair)}")
        return pair
    is_int = isinstance(default, int)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    if is_int:
        if float(value) != int(value):
            raise ValueError(f"{name} must be a whole number, got {value!r}")
        value = int(value)
    else:
        value = float(value)
        if math.isnan(value):
            raise ValueError(f"{name} must be a number, got nan")
    lo, hi, strict = meta["lo"], meta["hi"], meta["strict"]
    if lo is not None and (value <= lo if strict else value < lo):
        raise ValueError(f"{name} must be {'>' if strict else '>='} {lo:g}, got {value!r}")
    if hi is not None and value > hi:
        raise ValueError(f"{name} must be <= {hi:g}, got {value!r}")
    return value


class _Section:
    """Validation and conversion shared by the config sections."""

    _name = ""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _check_value(self._name, f, getattr(self, f.name)))

    def to_dict(self) -> dict:
        return {f.name: list(v) if isinstance(v := getattr(self, f.name), tuple) else v
                for f in dataclasses.fields(self)}


@dataclass(frozen=True)
class SegmentationConfig(_Section):
    """Range segmentation shared by every detector (:func:`labkit.segment_labels`)."""

    _name = "segmentation"
    threshold_m: float = _p(0.08, "largest gap between neighbouring points of a segment, metres (Xavier et al. "
                                  "seg_threshold); the floor of the adaptive threshold", lo=0, strict=True)
    adaptive: bool = _p(True, "grow the threshold with range and angular step (Borges & Aldon)")
    incidence_deg: float = _p(10.0, "grazing angle lambda of the adaptive threshold, degrees",
                              lo=0, strict=True, hi=89.9)
    range_sigma_m: float = _p(0.01, "range noise of the sensor, metres (adaptive threshold, line covariances)",
                              lo=0, strict=True)
    min_points: int = _p(2, "smallest segment kept; isolated points are dropped", lo=1)


@dataclass(frozen=True)
class LinesConfig(_Section):
    """Line extraction (:func:`labkit.split_and_merge`, :func:`labkit.angular_segmentation`)."""

    _name = "lines"
    method: str = _p("iepf", "a registered line extractor (labkit.lines.LINE_EXTRACTORS: iepf splits on the chord, "
                             "split_and_merge on the fitted line, angular, incremental, regression, ransac, hough, "
                             "iav) or none; only iepf, split_and_merge and angular read the keys below, the others "
                             "run with their own defaults", choices=line_methods)
    split_threshold_m: float = _p(0.05, "split when the worst point is farther than this from the line, metres",
                                  lo=0, strict=True)
    min_points: int = _p(5, "fewest points of a line (Xavier et al. line_min_pts)", lo=2)
    min_length_m: float = _p(0.15, "shortest line kept, metres (Xavier et al. line_min_len)", lo=0)
    max_gap_m: float = _p(0.3, "split a run at a gap wider than this between neighbouring points, metres",
                          lo=0, strict=True)
    merge: str = _p("thresholds", "merge test of neighbouring lines: thresholds, chi2 or none",
                    choices=("thresholds", "chi2", "none"))
    merge_dr_m: float = _p(0.2, "merge when |dr| is under this, metres", lo=0, strict=True)
    merge_dalpha_deg: float = _p(10.0, "and |dalpha| under this, degrees", lo=0, strict=True)
    merge_chi2: float = _p(9.21, "chi-square merge threshold (2 dof, 99 %)", lo=0, strict=True)
    weights: str = _p("inverse_range", "point weights of the fits: inverse_range (1/rho, the slides) or uniform",
                      choices=("inverse_range", "uniform"))
    skip_round: bool = _p(True, "fit no line to a segment taken as a leg or a circle")
    eps_theta_deg: float = _p(3.0, "angular segmentation: DBSCAN1D radius in line direction, degrees",
                              lo=0, strict=True)
    eps_dist_m: float = _p(0.03, "angular segmentation: DBSCAN1D radius in line offset, metres", lo=0, strict=True)
    angular_min_points: int = _p(8, "angular segmentation: DBSCAN1D min_pts", lo=1)
    angular_split_gap_m: float = _p(0.3, "angular segmentation: split collinear clusters at gaps wider than "
                                         "this, metres (inf: never)", lo=0, strict=True)


@dataclass(frozen=True)
class CornersConfig(_Section):
    """Corners where consecutive lines meet (:func:`labkit.find_corners`)."""

    _name = "corners"
    enabled: bool = _p(True, "find corners")
    min_angle_deg: float = _p(30.0, "smallest angle between the two lines, degrees", lo=0, strict=True, hi=90)
    max_gap_m: float = _p(0.3, "largest gap between the lines' facing ends, metres", lo=0)
    max_extension_m: float = _p(0.1, "how far a line may be extended to reach the corner, metres", lo=0)


@dataclass(frozen=True)
class CirclesConfig(_Section):
    """IAV circles (:func:`labkit.detect_circles`; Xavier et al. Table II)."""

    _name = "circles"
    enabled: bool = _p(True, "detect circles")
    min_points: int = _p(4, "fewest points (circle_min_pts)", lo=3)
    min_chord_m: float = _p(0.15, "shortest chord, metres (circle_min_len)", lo=0)
    max_chord_m: float = _p(math.inf, "longest chord, metres (circle_max_len; inf: unlimited)", lo=0, strict=True)
    middle_range: tuple = _p((0.1, 0.7), "prerequisite band: the middle point's distance from the chord, "
                                         "as a fraction of the chord", lo=0)
    mean_range_deg: tuple = _p((90.0, 135.0), "accepted IAV mean, degrees", lo=0, hi=180)
    std_max_deg: float = _p(math.degrees(0.15), "largest IAV standard deviation, degrees (circle_std_max 0.15 rad)",
                            lo=0, strict=True)
    center_method: str = _p("iav", "centre and radius: iav (the paper's construction), algebraic or geometric",
                            choices=("iav", "algebraic", "geometric"))
    arc_like: bool = _p(False, "also keep arc-like shapes (tree trunks) with a larger spread, minus V-corners")
    arc_like_std_max_deg: float = _p(23.0, "arc-like: largest IAV standard deviation, degrees", lo=0, strict=True)
    v_corner_neighbours: int = _p(4, "arc-like: neighbours whose angles must grow for a V-corner", lo=1)


@dataclass(frozen=True)
class ArcsConfig(_Section):
    """Arcs embedded in walls, e.g. rounded corners (:func:`labkit.detect_arcs`)."""

    _name = "arcs"
    enabled: bool = _p(False, "detect arcs in walls (a second, finer line pass: about twice the time per scan; "
                              "needs an arc seen by many beams, and finds false arcs in 1-8 % of scans of rooms "
                              "without any)")
    split_threshold_m: float = _p(0.02, "split threshold of the finer line pass, metres", lo=0, strict=True)
    min_length_m: float = _p(0.5, "shortest line of the finer line pass, metres", lo=0)
    min_points: int = _p(4, "fewest points of an arc", lo=3)
    min_chord_m: float = _p(0.15, "shortest chord of an arc, metres", lo=0)
    mean_range_deg: tuple = _p((90.0, 155.0), "accepted IAV mean, degrees", lo=0, hi=180)
    std_max_deg: float = _p(math.degrees(0.15), "largest IAV standard deviation, degrees", lo=0, strict=True)
    center_method: str = _p("geometric", "centre and radius: geometric, algebraic or iav",
                            choices=("iav", "algebraic", "geometric"))


@dataclass(frozen=True)
class LegsConfig(_Section):
    """Legs and people (:func:`labkit.detect_legs`, :func:`labkit.pair_legs`)."""

    _name = "legs"
    enabled: bool = _p(True, "detect legs and pair them into people")
    min_points: int = _p(3, "fewest points of a leg", lo=3)
    chord_range_m: tuple = _p((0.1, 0.25), "accepted chord, metres (Xavier et al.)", lo=0)
    chord_padding_beams: float = _p(1.0, "widen the chord by this many beam spacings at the leg's range", lo=0)
    middle_range: tuple = _p((0.1, 0.7), "prerequisite band, as for circles", lo=0)
    iav_mean_range_deg: tuple = _p((0.0, 180.0), "accepted IAV mean, degrees ([0, 180]: not tested)", lo=0, hi=180)
    iav_std_max_deg: float = _p(math.inf, "largest IAV standard deviation, degrees (inf: not tested)",
                                lo=0, strict=True)
    reject_occluded: bool = _p(True, "drop segments partly hidden behind a nearer object")
    center_method: str = _p("ray", "centre: ray (middle point pushed back by the radius), iav, algebraic, geometric",
                            choices=("ray", "iav", "algebraic", "geometric"))
    pair_max_distance_m: float = _p(0.6, "two legs closer than this are one person, metres", lo=0, strict=True)


_SECTIONS = {  # the order the stages run in, and the order of a TOML file
    "segmentation": SegmentationConfig,
    "legs": LegsConfig,
    "circles": CirclesConfig,
    "lines": LinesConfig,
    "corners": CornersConfig,
    "arcs": ArcsConfig,
}


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

    >>> c = Config().updated({"lines.method": "angular", "legs": {"enabled": False}})
    >>> c.lines.method, c.legs.enabled, c.circles.min_points
    ('angular', False, 4)
    >>> Config.from_toml(c.to_toml()) == c
    True
    >>> Config.from_dict({"lines": {"split_threshold": 0.1}})
    Traceback (most recent call last):
    ...
    ValueError: unknown key lines.split_threshold; lines has: method, split_threshold_m, ...
    """

    # in the order the stages run
    segmentation: SegmentationConfig = field(default_factory=SegmentationConfig)
    legs: LegsConfig = field(default_factory=LegsConfig)
    circles: CirclesConfig = field(default_factory=CirclesConfig)
    lines: LinesConfig = field(default_factory=LinesConfig)
    corners: CornersConfig = field(default_factory=CornersConfig)
    arcs: ArcsConfig = field(default_factory=ArcsConfig)

    def __post_init__(self) -> None:
        for name, cls in _SECTIONS.items():
            if not isinstance(getattr(self, name), cls):
                raise ValueError(f"Config.{name} must be a {cls.__name__}, got {type(getattr(self, name)).__name__}")

    # ------------------------------------------------------------------ dicts
    def to_dict(self) -> dict:
        """``{section: {key: value}}`` with plain Python values (pairs as lists)."""
        return {name: getattr(self, name).to_dict() for name in _SECTIONS}

    @classmethod
    def from_dict(cls, data: dict) -> Config:
        """A config from ``{section: {key: value}}``; missing keys keep their defaults."""
        return cls().updated(data)

    def updated(self, changes: dict) -> Config:
        """A copy with ``changes`` applied: ``{section: {key: value}}`` or dotted keys
        ``{"section.key": value}`` (or both)."""
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
            current = getattr(self, section)
            names = [f.name for f in dataclasses.fields(current)]
            for k in values:
                if k not in names:
                    raise ValueError(f"unknown key {section}.{k}; {section} has: {', '.join(names)}")
            new[section] = dataclasses.replace(current, **values)
        return dataclasses.replace(self, **new)

    # ------------------------------------------------------------------ TOML
    def to_toml(self) -> str:
        """The config as TOML, every key with its doc as a comment."""
        out = ["# labkit feature extraction config (labkit.Config); angles in degrees, lengths in metres", ""]
        for name in _SECTIONS:
            section = getattr(self, name)
            out.append(f"[{name}]  # {type(section).__doc__.strip()}")
            for f in dataclasses.fields(section):
                out.append(f"{f.name} = {_toml_value(getattr(section, f.name))}  # {f.metadata['doc']}")
            out.append("")
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


def _deg(pair) -> tuple[float, float]:
    return (math.radians(pair[0]), math.radians(pair[1]))


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
    """
    if not isinstance(scan, Scan):
        raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
    cfg = _DEFAULT if config is None else config
    if not isinstance(cfg, Config):
        raise ValueError(f"config must be a labkit.Config, got {type(cfg).__name__}")
    seg, lc, cc, lg = cfg.segmentation, cfg.lines, cfg.circles, cfg.legs
    timings: dict[str, float] = {}
    t_start = t = perf_counter()

    def lap(stage: str) -> None:
        nonlocal t
        now = perf_counter()
        timings[stage] = now - t
        t = now

    labels = segment_labels(scan, seg.threshold_m, min_points=seg.min_points, adaptive=seg.adaptive,
                            incidence_deg=seg.incidence_deg, range_sigma_m=seg.range_sigma_m)
    lap("segmentation")
    legs, people = [], []
    if lg.enabled:
        legs = detect_legs(
            scan, min_points=lg.min_points, chord_range=lg.chord_range_m, chord_padding_beams=lg.chord_padding_beams,
            middle_range=lg.middle_range,
            iav_mean_range=None if lg.iav_mean_range_deg == (0.0, 180.0) else _deg(lg.iav_mean_range_deg),
            iav_std_max=None if math.isinf(lg.iav_std_max_deg) else math.radians(lg.iav_std_max_deg),
            reject_occluded=lg.reject_occluded, center_method=lg.center_method, segments=labels)
        people = pair_legs(legs, lg.pair_max_distance_m)
    lap("legs")
    rest = _mask_segments(labels, legs)
    circles = []
    if cc.enabled:
        circles = detect_circles(
            scan, min_points=cc.min_points, min_chord_m=cc.min_chord_m, max_chord_m=cc.max_chord_m,
            middle_range=cc.middle_range, mean_range=_deg(cc.mean_range_deg), std_max=math.radians(cc.std_max_deg),
            center_method=cc.center_method, arc_like=cc.arc_like,
            arc_like_std_max=math.radians(cc.arc_like_std_max_deg), v_corner_neighbours=cc.v_corner_neighbours,
            segments=rest)
    lap("circles")
    rest = _mask_segments(rest, circles)
    lines = []
    if lc.method in ("iepf", "split_and_merge"):
        lines = split_and_merge(
            scan, method="endpoints" if lc.method == "iepf" else "fit", split_threshold_m=lc.split_threshold_m,
            min_points=lc.min_points, min_length_m=lc.min_length_m, max_gap_m=lc.max_gap_m,
            merge=None if lc.merge == "none" else lc.merge, merge_dr_m=lc.merge_dr_m,
            merge_dalpha=math.radians(lc.merge_dalpha_deg), merge_chi2=lc.merge_chi2,
            range_sigma_m=seg.range_sigma_m, weights=None if lc.weights == "inverse_range" else "uniform",
            segments=rest if lc.skip_round else labels)
    elif lc.method == "angular":
        lines = angular_segmentation(
            scan, math.radians(lc.eps_theta_deg), lc.eps_dist_m, lc.angular_min_points,
            split_gap_m=None if math.isinf(lc.angular_split_gap_m) else lc.angular_split_gap_m)
        if lc.skip_round and (legs or circles):
            round_beams = (labels >= 0) & (rest < 0)
            lines = [ln for ln in lines if not round_beams[ln.indices].mean() > 0.5]
    elif lc.method != "none":  # any other registered extractor, with its own record's defaults
        lines = LINE_EXTRACTORS[lc.method].run(scan, segments=rest if lc.skip_round else labels)
    lap("lines")
    corners = []
    if cfg.corners.enabled and len(lines) > 1:
        co = cfg.corners
        corners = find_corners(lines, min_angle=math.radians(co.min_angle_deg), max_gap_m=co.max_gap_m,
                               max_extension_m=co.max_extension_m, wrap=scan.is_full_circle)
    lap("corners")
    arcs = []
    if cfg.arcs.enabled:
        ac = cfg.arcs
        arcs = detect_arcs(
            scan, None, min_points=ac.min_points, min_chord_m=ac.min_chord_m, mean_range=_deg(ac.mean_range_deg),
            std_max=math.radians(ac.std_max_deg), center_method=ac.center_method,
            line_params={"split_threshold_m": ac.split_threshold_m, "min_length_m": ac.min_length_m}, segments=rest)
    lap("arcs")
    timings["total"] = perf_counter() - t_start
    return Features(scan.stamp_ns, scan.n_beams, labels, tuple(lines), tuple(corners), tuple(circles), tuple(arcs),
                    tuple(legs), tuple(people), timings)


def extract_all(scans: Iterable[Scan], config: Config | None = None) -> Iterator[Features]:
    """:func:`extract_features` for every scan of a stream, lazily (one scan in memory)."""
    cfg = _DEFAULT if config is None else config
    for scan in scans:
        yield extract_features(scan, cfg)
