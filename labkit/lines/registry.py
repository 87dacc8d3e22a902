"""The registry of line extractors: one entry per method, read by the pipeline, the command
line, the evaluation and the tests (see :mod:`labkit.lines`)."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, cast

from ..params import Params, checked_by
from ..scan import Scan

__all__ = ["LINE_EXTRACTORS", "LineExtractor", "register", "unregister"]


class _Checked(Protocol):
    """A function :func:`~labkit.params.checked_by` its record: callable, with its undecorated twin."""

    unchecked: Callable[..., Any]

    def __call__(self, *args: Any, **kwargs: Any) -> Any: ...


@dataclass(frozen=True)
class LineExtractor:
    """One registered line extractor.

    Parameters
    ----------
    name : str
        Its one name (config, CLI, experiments).
    fn : callable
        The public function (:func:`labkit.params.checked_by` its record).
    params_cls : type of Params
        Its parameter record class.
    description : str
        A one-line description.
    label : str
        The display label of tables.
    fixed : tuple
        Keyword arguments always passed, as ``(name, value)`` pairs (e.g. split-and-merge's ``method``).
    segmented : bool
        The extractor works on range segments (the pipeline then gives it its segmentation;
        otherwise only the beams other detectors took are masked).
    """

    name: str
    fn: Callable
    params_cls: type[Params]
    description: str
    label: str
    fixed: tuple = ()
    segmented: bool = True

    def run(self, scan, params: Params | None = None, *, segments=None, trace: bool = False, **overrides) -> list:
        """The extractor on ``scan`` with ``params`` (default: the record's defaults) changed by
        ``overrides`` (field names of the record, checked; the function's other keywords, such
        as ``rng``, passed as given), on ``segments`` (labels or RangeSegments) if given."""
        if params is None:
            params = self.params_cls.defaults()
        elif not isinstance(params, self.params_cls):
            raise ValueError(f"params of {self.name!r} must be a {self.params_cls.__name__}, "
                             f"got {type(params).__name__}")
        fields = params.kwargs()
        changes = {k: v for k, v in overrides.items() if k in fields}
        if changes:
            params = params.replace(**changes)
        kw = {**params.kwargs(), **dict(self.fixed), **{k: v for k, v in overrides.items() if k not in fields}}
        if trace:
            kw["trace"] = True
        # register() made every fn checked_by its record, which sets fn.unchecked (a plain Callable to mypy)
        return cast(_Checked, self.fn).unchecked(scan, segments=segments, **kw)

    __call__ = run


#: name -> :class:`LineExtractor`, in the order of the comparison tables
LINE_EXTRACTORS: dict[str, LineExtractor] = {}


def register(name: str, fn: Callable, params_cls: type, description: str, *, label: str | None = None,
             fixed: dict | None = None, segmented: bool = True) -> LineExtractor:
    """Add a line extractor under ``name``.

    ``fn(scan, *, segments=None, trace=False, <keywords>)`` returns a list of
    :class:`~labkit.LineSegment` (and its steps with ``trace=True``), its keywords named after
    the fields of ``params_cls``; a function not yet :func:`~labkit.params.checked_by` the record
    is decorated here.

    Parameters
    ----------
    name : str
        Lower case, no spaces: it is a config value and a CLI argument.
    fn : callable
        The extractor.
    params_cls : type
        A frozen :class:`~labkit.params.Params` record holding its keywords' defaults.
    description : str
        A one-line description.
    label : str or None
        Its name in tables; None: ``name``.
    fixed : dict or None
        Keyword arguments always passed.
    segmented : bool
        The extractor works on range segments (see :class:`LineExtractor`).

    Returns
    -------
    LineExtractor
        The registry's entry.
    """
    if not isinstance(name, str) or not name or name != name.strip().lower() or " " in name or name == "none":
        raise ValueError(f"an extractor name must be a lower-case word other than 'none', got {name!r}")
    if name in LINE_EXTRACTORS:
        raise ValueError(f"a line extractor {name!r} is already registered")
    if not (isinstance(params_cls, type) and issubclass(params_cls, Params)):
        raise ValueError(f"params_cls must be a labkit.params.Params record, got {params_cls!r}")
    if getattr(fn, "params_cls", None) is not params_cls:
        fn = checked_by(params_cls)(_scan_checked(fn))  # (a function without trace: (lines, []) with trace=True)
    entry = LineExtractor(name, fn, params_cls, description, label or name, tuple((fixed or {}).items()),
                          segmented)
    LINE_EXTRACTORS[name] = entry
    return entry


def _scan_checked(fn: Callable) -> Callable:
    """``fn``, refusing anything but a :class:`~labkit.Scan` with a clear error, as labkit's own
    extractors do; one that records no steps returns ``(lines, [])`` with ``trace=True``."""
    traces = "trace" in inspect.signature(fn).parameters

    @functools.wraps(fn)
    def checked(scan, *args, trace: bool = False, **kwargs):
        if not isinstance(scan, Scan):
            raise ValueError(f"scan must be a labkit.Scan, got {type(scan).__name__}")
        if traces:
            return fn(scan, *args, trace=trace, **kwargs)
        lines = fn(scan, *args, **kwargs)
        return (lines, []) if trace else lines

    return checked


def unregister(name: str) -> None:
    """Remove a registered extractor (for tests that register a toy one).

    Parameters
    ----------
    name : str
        Its name.
    """
    LINE_EXTRACTORS.pop(name)
