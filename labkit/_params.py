"""Parameter records: one frozen record per extractor and detector, each default held once.

A record is a frozen dataclass in the units a user edits, as in a TOML config: lengths in
**metres** (names end in ``_m``), angles in **degrees** (names end in ``_deg``; a pair of
angles too), counts and flags as they are. Every field carries a one-line doc (written into
TOML files as a comment) and the range checks applied when a record is built, so a bad value
raises ``ValueError`` naming it, whether it comes from a config file or a keyword argument.

:meth:`Params.kwargs` gives the algorithm's keyword arguments: ``x_deg`` becomes ``x`` in
radians, other renames are listed by :meth:`Params.renamed`, and a record may convert a value
meaning "off" (``inf``) to the None its function takes.

:func:`takes_params` gives a function the one call shape of labkit's detectors,
``fn(scan, params=None, *, segments=None, trace=False, **overrides)``:

* ``params`` the record (default: the record's defaults), which the pipeline's config section
  is too (:class:`labkit.Config` is composed of these records), so a detector alone and its
  pipeline stage run with the same parameters;
* ``overrides`` the record's field names (``split_threshold_m=0.03``, ``merge_dalpha_deg=5``),
  checked like a config value; the function's own keyword names still work and are passed
  as given (``merge_dalpha=math.radians(5)`` in radians, ``rng=``, ``return_trace=``);
* ``segments`` labels or RangeSegments; a detector that works on range segments and is given
  none segments the scan with :class:`labkit.segmentation.SegmentationParams` ' defaults,
  as the pipeline does;
* ``trace`` the function's own trace (``trace``, ``return_trace`` or ``return_steps``): the
  result becomes ``(result, trace)``. A function that records no trace yet returns
  ``(result, [])``.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ._cache import remembered

__all__ = ["AUTO", "Params", "param", "takes_params"]

#: The value of a threshold that follows each scan's range noise (see :mod:`labkit.noise`).
AUTO = "auto"


def param(default, doc: str, *, lo: float | None = None, strict: bool = False, hi: float | None = None,
          finite: bool = False, choices=None, optional: bool = False, kind: type | None = None,
          auto: bool = False):
    """A record field: its default, a one-line doc, and the checks applied when a record is
    built (``lo``/``hi`` bounds, ``strict`` for ``> lo``, ``finite`` to refuse infinity,
    ``choices`` for strings (a tuple or a callable giving one), ``optional`` to allow None,
    ``kind`` when the default is None or ``"auto"``, ``auto`` to allow the value ``"auto"``:
    a number the function works out from each scan, see :mod:`labkit.noise`)."""
    if kind is None:
        kind = float if default == AUTO else type(default)
    meta = {"doc": doc, "lo": lo, "strict": strict, "hi": hi, "finite": finite, "choices": choices,
            "optional": optional, "kind": kind, "auto": auto}
    if isinstance(default, Params):
        return field(default_factory=type(default), metadata={**meta, "record": type(default)})
    return field(default=default, metadata=meta)


def _check_value(section: str, f: dataclasses.Field, value):
    """Type and range of one field; returns the value in its canonical Python type."""
    name = f"{section}.{f.name}" if section else f.name
    meta = f.metadata
    if not meta:  # a field without checks (a subclass's own)
        return value
    if meta.get("record") is not None:
        cls = meta["record"]
        if isinstance(value, dict):
            value = cls().updated(value, prefix=name)
        if not isinstance(value, cls):
            raise ValueError(f"{name} must be a {cls.__name__} or a table of its keys, got {type(value).__name__}")
        return value
    if value is None and meta["optional"]:
        return None
    if isinstance(value, str) and value == "none" and meta["optional"] and meta["kind"] is not str:  # (no null in TOML)
        return None
    if meta.get("auto") and isinstance(value, str):
        if value != AUTO:
            raise ValueError(f'{name} must be a number or "auto", got {value!r}')
        return AUTO
    kind = meta["kind"]
    if kind is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"{name} must be true or false, got {value!r}")
        return bool(value)
    if kind is str:
        choices = meta["choices"]() if callable(meta["choices"]) else meta["choices"]
        if not isinstance(value, str) or (choices and value not in choices):
            raise ValueError(f"{name} must be one of {choices}, got {value!r}")
        return value
    if kind is tuple:
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
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        either = ' or "auto"' if meta.get("auto") else ""
        raise ValueError(f"{name} must be a number{either}, got {value!r}")
    if kind is int:
        if not isinstance(value, (int, np.integer)):
            raise ValueError(f"{name} must be a whole number (an int), got {value!r}")
        value = int(value)
    else:
        value = float(value)
        if math.isnan(value):
            raise ValueError(f"{name} must be a number, got nan")
        if meta.get("finite") and math.isinf(value):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
    lo, hi, strict = meta["lo"], meta["hi"], meta["strict"]
    if lo is not None and (value <= lo if strict else value < lo):
        raise ValueError(f"{name} must be {'>' if strict else '>='} {lo:g}, got {value!r}")
    if hi is not None and value > hi:
        raise ValueError(f"{name} must be <= {hi:g}, got {value!r}")
    return value


@dataclass(frozen=True)
class Params:
    """Base of every parameter record (see the module docstring).

    Class attributes of a record: ``_name`` names it in error messages (a config section's
    name); ``_not_passed`` are fields its function does not take (a pipeline switch such as
    ``enabled``, or a value another function of the stage reads).
    """

    _name = ""
    _not_passed = ()  # (a class attribute, not a field)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _check_value(self._name, f, getattr(self, f.name)))

    # ------------------------------------------------------------------ the function's arguments
    def kwargs(self) -> dict:
        """The function's keyword arguments (radians for the ``_deg`` fields, see :meth:`renamed`).

        A record is frozen, so they are worked out once and a copy is handed out after that
        (a pipeline calls every detector with the same records, scan after scan)."""
        cached = self.__dict__.get("_kwargs")
        if cached is None:
            cached = self._kwargs_now()
            object.__setattr__(self, "_kwargs", cached)
        return dict(cached)

    def _kwargs_now(self) -> dict:
        rename = type(self).renamed()
        out = {}
        for f in dataclasses.fields(self):
            if f.name in self._not_passed or f.metadata.get("record") is not None:
                continue
            value = getattr(self, f.name)
            name = rename.get(f.name, f.name)
            if f.name.endswith("_deg") and f.name not in rename:
                name = f.name[:-4]
                value = tuple(math.radians(v) for v in value) if isinstance(value, tuple) else math.radians(value)
            out[name] = value
        return out

    @classmethod
    def renamed(cls) -> dict:
        """Record field -> the function's keyword, where they differ beyond the ``_deg`` rule
        (a field listed here keeps its value as it is)."""
        return {}

    @classmethod
    def ordered_fields(cls) -> list:
        """The fields in the order of a TOML table: those a subclass adds (a config section's
        ``enabled``) first, then the record's, nested records last."""
        fields = dataclasses.fields(cls)
        inherited = {f.name for base in cls.__mro__[1:] if dataclasses.is_dataclass(base) and base is not Params
                     for f in dataclasses.fields(base)}
        plain = [f for f in fields if not f.metadata.get("record")]
        return ([f for f in plain if f.name not in inherited] + [f for f in plain if f.name in inherited]
                + [f for f in fields if f.metadata.get("record")])

    def _finish(self, kw: dict, raw: dict) -> dict:
        """Last adjustments of the keyword arguments, given the ones passed as given (a hook)."""
        return kw

    # ------------------------------------------------------------------ changing a record
    def replace(self, **overrides) -> Params:
        """A copy with ``overrides`` (field names of the record), checked; unknown names raise
        ``ValueError``."""
        names = [f.name for f in self.ordered_fields()]
        unknown = [k for k in overrides if k not in names]
        if unknown:
            where = self._name or type(self).__name__
            raise ValueError(f"unknown key {where}.{unknown[0]}; {where} has: {', '.join(names)}")
        return dataclasses.replace(self, **overrides) if overrides else self

    def updated(self, changes: dict, *, prefix: str | None = None) -> Params:
        """A copy with ``changes``: ``{key: value}``, a nested record's keys as a table
        (``{"angular": {"min_points": 6}}``) or dotted (``{"angular.min_points": 6}``)."""
        where = prefix or self._name or type(self).__name__
        plain: dict = {}
        nested: dict[str, dict] = {}
        fields = {f.name: f for f in self.ordered_fields()}
        for key, value in changes.items():
            if not isinstance(key, str):
                raise ValueError(f"config keys must be strings, got {key!r}")
            head, dot, rest = key.partition(".")
            f = fields.get(head)
            if f is not None and f.metadata.get("record") is not None and (dot or isinstance(value, dict)):
                nested.setdefault(head, {}).update({rest: value} if dot else value)
            elif dot:
                raise ValueError(f"unknown key {where}.{key}; {where} has: {', '.join(fields)}")
            else:
                plain[key] = value
        for head, values in nested.items():
            plain[head] = getattr(self, head).updated(values, prefix=f"{where}.{head}")
        unknown = [k for k in plain if k not in fields]
        if unknown:
            raise ValueError(f"unknown key {where}.{unknown[0]}; {where} has: {', '.join(fields)}")
        try:
            return dataclasses.replace(self, **plain) if plain else self
        except ValueError as exc:  # a record's own message names the key alone: say where it is
            if prefix and not self._name and not str(exc).startswith(prefix):
                raise ValueError(f"{prefix}.{exc}") from None
            raise

    def to_dict(self) -> dict:
        """``{key: value}`` with plain Python values (pairs as lists, nested records as dicts)."""
        out = {}
        for f in self.ordered_fields():
            v = getattr(self, f.name)
            out[f.name] = v.to_dict() if isinstance(v, Params) else list(v) if isinstance(v, tuple) else v
        return out


def _trace_keyword(parameters) -> str | None:
    for name in ("trace", "return_trace", "return_steps"):
        if name in parameters:
            return name
    return None


@functools.cache
def _default(record: type) -> Params:
    """The record with its defaults: one shared instance per record (records are frozen)."""
    return record()


@functools.cache
def _segmentation() -> tuple:
    from .scan import Scan  # noqa: PLC0415 - lazily: segmentation imports this module
    from .segmentation import segment_labels  # noqa: PLC0415

    return Scan, segment_labels


def _default_segments(data, range_sigma_m=None):
    """The default range segmentation of a scan (None for anything else: the function says what
    is wrong). Its adaptive breakpoints follow the detector's own range noise when it has one,
    ``"auto"`` (the scan's estimate) or a positive number of metres, as the detector's thresholds
    do; 0 (a detector's fixed tests, the papers') the fixed settings' noise
    (:data:`labkit.noise.RANGE_SIGMA_M`); none: the segmentation's default."""
    scan_type, segment_labels = _segmentation()
    if not isinstance(data, scan_type):
        return None
    # (the record has checked it: "auto", None or a number >= 0)
    if range_sigma_m is None:
        return segment_labels(data)
    if range_sigma_m == 0:
        from .noise import RANGE_SIGMA_M  # noqa: PLC0415 - lazily: noise imports this module

        range_sigma_m = RANGE_SIGMA_M
    return segment_labels(data, range_sigma_m=range_sigma_m)


_NONE: dict = {}  # no keyword passed as given (never written to)


@remembered
def _overridden(p: Params, **changes) -> Params:
    """``p.replace(**changes)``, remembered (typed: ``adaptive=1`` is not ``adaptive=True``): a loop
    that calls a detector with the same keywords scan after scan checks and builds the record once."""
    return p.replace(**changes)


def takes_params(record: type, *, positional: tuple[str, ...] = (), segmented: bool = False,
                 own_segmentation: tuple[str, ...] = (), on_segments: Callable | None = None) -> Callable:
    """Decorate ``fn(first, *, <keywords>)`` into ``fn(first, params=None, *, segments=None,
    trace=False, **overrides)`` (see the module docstring).

    ``positional`` are the keyword names the old call shape took by position after ``first``
    (``segment_labels(scan, 0.08)``): a value that is not a record in ``params``' place is
    the first of them. ``segmented``: the function works on range segments, and segments
    the scan with the default segmentation when given none (unless one of
    ``own_segmentation``, the old keywords of its own segmentation, is given). ``on_segments``
    ``(scan, result, segments)`` applies ``segments`` to the result of a function that takes
    none.
    """

    def decorate(fn: Callable) -> Callable:
        parameters = inspect.signature(fn).parameters
        first = next(iter(parameters))
        own = set(parameters) - {first}
        fields = {f.name for f in dataclasses.fields(record)}
        trace_kw = _trace_keyword(own)
        takes_segments = "segments" in own

        def positional_args(params, args: tuple, overrides: dict):
            """The old call shape's positional values after ``first``, moved into ``overrides``."""
            given = ((params,) if params is not None and not isinstance(params, Params) else ()) + args
            if len(given) > len(positional):
                raise TypeError(f"{fn.__name__}() takes the scan, a {record.__name__} and keyword arguments")
            for name, value in zip(positional, given, strict=False):
                if name in overrides:
                    raise TypeError(f"{fn.__name__}() got {name!r} twice")
                overrides[name] = value
            return params if isinstance(params, Params) else None

        @functools.wraps(fn)
        def wrapper(data, params=None, *args, segments=None, trace=False, **overrides):
            if args or params is not None and not isinstance(params, Params):
                params = positional_args(params, args, overrides)
            p = _default(record) if params is None else params
            if not isinstance(p, record):
                raise ValueError(f"params of {fn.__name__} must be a {record.__name__}, got {type(p).__name__}")
            raw = _NONE
            if overrides:  # (a loop over scans mostly passes none: that path stays short)
                if trace_kw is not None and trace_kw != "trace" and trace_kw in overrides:  # trace's old name
                    trace = bool(overrides.pop(trace_kw)) or trace
                if fields.issuperset(overrides):  # the record's own names only (the usual case)
                    by_record = overrides
                else:
                    by_record = {k: v for k, v in overrides.items() if k in fields}
                    raw = {k: v for k, v in overrides.items() if k not in fields}
                    unknown = [k for k in raw if k not in own or k in ("segments", trace_kw)]
                    if unknown:
                        raise TypeError(f"{fn.__name__}() has no parameter {unknown[0]!r}; its parameters: "
                                        f"{', '.join(fields)}")
                kw = _overridden(p, **by_record).kwargs() if by_record else p.kwargs()
                if raw:
                    kw.update(raw)
            else:
                kw = p.kwargs()
            kw = p._finish(kw, raw)
            if segments is not None and not takes_segments and on_segments is None:
                raise TypeError(f"{fn.__name__}() takes no segments")
            if segmented and segments is None and not any(k in raw for k in own_segmentation):
                segments = _default_segments(data, kw.get("range_sigma_m"))
            if takes_segments:
                kw["segments"] = segments
            if trace_kw is not None:
                kw[trace_kw] = trace
            result = fn(data, **kw)
            if segments is not None and on_segments is not None:
                result = (on_segments(data, result[0], segments), result[1]) if trace else \
                    on_segments(data, result, segments)
            if trace and trace_kw is None:
                return result, []
            return result

        shape = [inspect.Parameter(first, inspect.Parameter.POSITIONAL_OR_KEYWORD),
                 inspect.Parameter("params", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None)]
        if takes_segments or on_segments is not None:
            shape.append(inspect.Parameter("segments", inspect.Parameter.KEYWORD_ONLY, default=None))
        shape += [inspect.Parameter("trace", inspect.Parameter.KEYWORD_ONLY, default=False),
                  inspect.Parameter("overrides", inspect.Parameter.VAR_KEYWORD)]
        wrapper.__signature__ = inspect.Signature(shape)
        wrapper.params_cls = record
        wrapper.segmented = segmented  # the pipeline gives it its range segments (else only a mask)
        return wrapper

    return decorate
