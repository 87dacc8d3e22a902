"""The old call shape of labkit's detectors, ``fn(scan, params=None, *, segments=None, trace=False,
**overrides)``, for the IAV family until its functions have real signatures (temporary)."""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
from collections.abc import Callable

from .._cache import remembered
from ..params import Params


def old_kwargs(record: Params) -> dict:
    """The old keyword arguments of a record: ``x_deg`` as ``x`` in radians, and the old renames."""
    rename = getattr(type(record), "old_renamed", dict)()
    out = {}
    for f in dataclasses.fields(record):
        if f.name in record._not_passed or f.metadata.get("record") is not None:
            continue
        value = getattr(record, f.name)
        name = rename.get(f.name, f.name)
        if f.name.endswith("_deg") and f.name not in rename:
            name = f.name[:-4]
            value = tuple(math.radians(v) for v in value) if isinstance(value, tuple) else math.radians(value)
        out[name] = value
    return out


def _kw(p: Params) -> dict:
    return p._old_kwargs() if hasattr(p, "_old_kwargs") else old_kwargs(p)


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
    from ..scan import Scan  # noqa: PLC0415
    from ..segmentation import segment_labels  # noqa: PLC0415

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
        from ..noise import RANGE_SIGMA_M  # noqa: PLC0415

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
                kw = _kw(_overridden(p, **by_record)) if by_record else _kw(p)
                if raw:
                    kw.update(raw)
            else:
                kw = _kw(p)
            kw = p._finish(kw, raw) if hasattr(p, "_finish") else kw
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
