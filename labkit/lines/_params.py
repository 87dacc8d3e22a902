"""The parameter records of the line extractors and the registry entry (private base).

A record is a frozen dataclass in the units a user edits: lengths in metres (names end in
``_m``), angles in **degrees** (names end in ``_deg``), as in a TOML config. :meth:`Params.kwargs`
gives the extractor's keyword arguments: ``x_deg`` becomes ``x`` in radians, and an
infinite length that means "off" becomes None where the extractor takes None.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Params:
    """Base of every line extractor's parameter record (see the module docstring)."""

    def kwargs(self) -> dict:
        """The extractor's keyword arguments (radians for the ``_deg`` fields)."""
        rename = type(self).renamed()
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            name = rename.get(f.name, f.name)
            if f.name.endswith("_deg") and f.name not in rename:
                name, value = f.name[:-4], math.radians(value)
            out[name] = value
        return out

    @classmethod
    def renamed(cls) -> dict:
        """Record field -> the extractor's keyword, where they differ beyond the ``_deg`` rule."""
        return {}

    def replace(self, **overrides) -> Params:
        """A copy with ``overrides`` (field names of the record); unknown names raise ``ValueError``."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise ValueError(f"{type(self).__name__} has no parameter {unknown[0]!r}; "
                             f"it has: {', '.join(sorted(names))}")
        return dataclasses.replace(self, **overrides) if overrides else self


@dataclass(frozen=True)
class LineExtractor:
    """One registered line extractor: its one ``name`` (config, CLI, experiments), the
    function, its parameter record class, a one-line description and the display ``label``
    of tables. ``fixed`` are keyword arguments always passed (e.g. split-and-merge's
    ``method``)."""

    name: str
    fn: Callable
    params_cls: type
    description: str
    label: str
    fixed: tuple = ()

    def run(self, scan, params: Params | None = None, *, segments=None, **overrides) -> list:
        """The extractor on ``scan`` with ``params`` (default: the record's defaults) changed by
        ``overrides`` (field names of the record), on ``segments`` (labels or RangeSegments) if given."""
        p = (self.params_cls() if params is None else params).replace(**overrides)
        if not isinstance(p, self.params_cls):
            raise ValueError(f"params of {self.name!r} must be a {self.params_cls.__name__}, got {type(p).__name__}")
        return self.fn(scan, **p.kwargs(), **dict(self.fixed), segments=segments)

    __call__ = run
