"""The registry entry of a line extractor (private; the records' base is :mod:`labkit._params`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .._params import AUTO, Params, param, takes_params

__all__ = ["AUTO", "LineExtractor", "Params", "param", "takes_params"]


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
