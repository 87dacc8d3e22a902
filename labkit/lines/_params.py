"""The registry entry of a line extractor (private; the records' base is :mod:`labkit._params`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .._params import AUTO, Params, param, takes_params

__all__ = ["AUTO", "LineExtractor", "Params", "PlacingParams", "param", "takes_params"]


@dataclass(frozen=True)
class PlacingParams(Params):
    """The placing fields RANSAC, the Hough transform and incremental extraction share (the
    meaning of split-and-merge's): the range noise of the lines' covariances and what a user
    trusts; a line is reported only if it is likely within ``place_dr_m`` and
    ``place_dalpha_deg`` of the true line."""

    range_sigma_m: float = param(AUTO, "range noise of the lines' covariances (placing), metres; none: each "
                                       "line's own residuals; auto: estimated from each scan (labkit.noise)",
                                 lo=0, strict=True, optional=True, kind=float, auto=True)
    place_dr_m: float = param(0.05, "report a line only if it is likely within this of the true r, metres",
                              lo=0, strict=True)
    place_dalpha_deg: float = param(3.0, "and within this of the true alpha, degrees", lo=0, strict=True)
    place_confidence: float = param(0.8, "with at least this probability by its covariance (0: report every "
                                         "line, the papers)", lo=0, hi=1)


@dataclass(frozen=True)
class LineExtractor:
    """One registered line extractor: its one ``name`` (config, CLI, experiments), the
    function (``fn(scan, params=None, *, segments=None, trace=False, **overrides)``), its
    parameter record class, a one-line description and the display ``label`` of tables.
    ``fixed`` are keyword arguments always passed (e.g. split-and-merge's ``method``)."""

    name: str
    fn: Callable
    params_cls: type
    description: str
    label: str
    fixed: tuple = ()

    @property
    def segmented(self) -> bool:
        """Whether the extractor works on range segments (the pipeline then gives it its
        segmentation; otherwise only the beams other detectors took are masked)."""
        return bool(getattr(self.fn, "segmented", True))

    def run(self, scan, params: Params | None = None, *, segments=None, trace: bool = False, **overrides) -> list:
        """The extractor on ``scan`` with ``params`` (default: the record's defaults) changed by
        ``overrides`` (field names of the record), on ``segments`` (labels or RangeSegments) if given."""
        if params is not None and not isinstance(params, self.params_cls):
            raise ValueError(f"params of {self.name!r} must be a {self.params_cls.__name__}, "
                             f"got {type(params).__name__}")
        kw = {**dict(self.fixed), **overrides}
        if trace:
            kw["trace"] = True
        return self.fn(scan, params, segments=segments, **kw)

    __call__ = run
