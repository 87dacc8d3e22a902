"""Parameter records: the one place where each parameter's default and limits live.

A record is a frozen dataclass in the units a user edits, as in a TOML config: lengths in
**metres** (names end in ``_m``), angles in **degrees** (names end in ``_deg``; a pair of
angles too), counts and flags as they are. Every field carries a one-line doc (written into
TOML files as a comment) and its limits, checked when a record is built, so a bad value raises
``ValueError`` naming it, whether it comes from a config file or a keyword argument. The model
is scikit-learn's ``_parameter_constraints`` with ``validate_params``.

A detector's public function has its real signature: one keyword per field of its record, of
the same name and unit, whose default *is* the record's (``min_points: int =
SplitMergeParams.min_points``), so an IDE and :func:`inspect.signature` show what it takes.
:func:`labkit.params.checked_by` checks, at that boundary and once, the values a caller passes, against the
record's limits; the function's body trusts them. The pipeline, whose configuration is made of
these records (already checked), calls the function's ``unchecked`` twin with
:meth:`Params.kwargs`.

Keywords of an older release still work for one release, with a ``DeprecationWarning`` naming
the new one: an angle in radians under the name without ``_deg`` (``merge_dalpha=0.17`` is
``merge_dalpha_deg=9.74``), the names a record lists in :meth:`Params.renamed`, and a record
passed as the second argument (``fn(scan, record)``: use ``fn(scan, **record.kwargs())``).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import re
import types
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar, cast

import numpy as np

__all__ = ["AUTO", "Params", "param", "checked_by"]

#: The value of a threshold that follows each scan's range noise (see :mod:`labkit.noise`).
AUTO = "auto"


def param(default, doc: str, *, lo: float | None = None, strict: bool = False, hi: float | None = None,
          finite: bool = True, choices=None, optional: bool = False, kind: type | None = None,
          auto: bool = False):
    """A record field: its default, a one-line doc, and the checks applied when a record is built.

    Parameters
    ----------
    default : object
        The default value (a :class:`Params` record for a nested one).
    doc : str
        The one-line doc (shown by ``labkit config`` and the docs).
    lo : float or None
        The lower bound.
    strict : bool
        ``> lo`` instead of ``>= lo``.
    hi : float or None
        The upper bound.
    finite : bool
        Numbers must be finite; False allows infinity where it means something, such as "never"
        or "unlimited".
    choices : tuple of str, or callable, or None
        The strings allowed (a tuple, or a callable giving one).
    optional : bool
        Allow None.
    kind : type or None
        The field's type, when the default is None or ``"auto"``.
    auto : bool
        Allow the value ``"auto"``: a number the function works out from each scan (see
        :mod:`labkit.noise`).

    Returns
    -------
    dataclasses.Field
        The field, its checks in its metadata.
    """
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
            low, high = (f"{v:g}" if v is not None else edge for v, edge in ((lo, "-inf"), (hi, "inf")))
            raise ValueError(f"{name} must lie within [{low}, {high}], got {list(pair)}")
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

    _name: ClassVar[str] = ""
    _not_passed: ClassVar[tuple[str, ...]] = ()  # (ClassVar: a class attribute, not a field)

    def __init_subclass__(cls, **kwargs) -> None:
        """Give every record's docstring a numpydoc Parameters section written from its fields'
        ``param`` docs and defaults, so that the reference documents each field once, where it is
        defined (the subclass's dataclass decorator has not run yet: its fields are read from the
        class body and from the records it inherits from)."""
        super().__init_subclass__(**kwargs)
        cls.__doc__ = _with_parameters(cls)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _check_value(self._name, f, getattr(self, f.name)))
        self.check_relations({f.name: getattr(self, f.name) for f in dataclasses.fields(self)})

    @classmethod
    def check_relations(cls, values) -> None:
        """Limits between fields (``min_chord_m < max_chord_m``): ``values`` maps every field to
        its value, each already checked on its own. Raises ``ValueError`` naming a field (see
        ``_where``). Checked when a record is built and, by :func:`labkit.params.checked_by`, on the keywords
        a caller passes; a record with such limits overrides this (there are none here)."""

    @classmethod
    def _where(cls, name: str) -> str:
        """A field's name as an error message gives it (``circles.max_chord_m`` in a config section)."""
        return f"{cls._name}.{name}" if cls._name else name

    @classmethod
    def defaults(cls) -> Params:
        """The record with its defaults: one shared instance per record class (records are frozen)."""
        return _defaults(cls)

    # ------------------------------------------------------------------ the function's arguments
    def kwargs(self) -> dict:
        """The function's keyword arguments: every field but the nested records and the fields
        the function does not take (``_not_passed``), under the field's own name.

        A record is frozen, so they are gathered once and a copy is handed out after that
        (a pipeline calls every detector with the same records, scan after scan)."""
        cached = self.__dict__.get("_kwargs")
        if cached is None:
            cached = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                      if f.name not in self._not_passed and f.metadata.get("record") is None}
            object.__setattr__(self, "_kwargs", cached)
        return dict(cached)

    @classmethod
    def renamed(cls) -> dict:
        """Keyword names of an older release -> the field that replaced them (deprecated; a
        name without ``_deg`` of a ``_deg`` field, an angle in radians, needs no entry)."""
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


# one default record per class; a dict, as functools.cache would need mypy to take a class as
# Hashable, which it does not (python/mypy#11470)
_DEFAULTS: dict[type[Params], Params] = {}


def _with_parameters(cls: type) -> str | None:
    """``cls.__doc__`` with a Parameters section listing its record fields (unchanged when it has one)."""
    doc = cls.__doc__
    if not doc or "\nParameters\n" in doc or "\n    Parameters\n" in doc:
        return doc
    fields: dict[str, tuple[object, dataclasses.Field]] = {}
    for base in reversed(cls.__mro__[1:]):
        if dataclasses.is_dataclass(base):
            for f in dataclasses.fields(base):
                fields[f.name] = (f.type, f)
    annotations = cls.__dict__.get("__annotations__", {})
    for name, value in cls.__dict__.items():
        if isinstance(value, dataclasses.Field) and name in annotations:
            fields[name] = (annotations[name], value)
    if not fields:
        return doc
    lines = doc.expandtabs().splitlines()
    body = [len(line) - len(line.lstrip()) for line in lines[1:] if line.strip()]
    pad = " " * (min(body) if body else 0)
    out = [doc.rstrip(), "", pad + "Parameters", pad + "----------"]
    for name, (annotation, f) in fields.items():
        kind = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
        record = f.metadata.get("record")
        value = f.default
        default = (record.__name__ + "()" if record is not None
                   else f"{value:.10g}" if isinstance(value, float) else repr(value))
        text = re.sub(r"\|([^|\n]+)\|", r"``|\1|``", str(f.metadata.get("doc", "")).strip())  # |x|: not RST
        text = text[:1].upper() + text[1:] if text else "See the record's description."
        out += [f"{pad}{name} : {kind}, default {default}", f"{pad}    {text.rstrip('.')}."]
    return "\n".join(out) + "\n" + pad


def _defaults(cls: type[Params]) -> Params:
    record = _DEFAULTS.get(cls)
    if record is None:
        record = _DEFAULTS[cls] = cls()
    return record


# ---------------------------------------------------------------------------- the public boundary
def checked_by(record: type[Params], *, positional: tuple[str, ...] = (), renamed: dict | None = None) -> Callable:
    """Check the keyword arguments of a detector against its parameter record, once, where the user calls in.

    The signature stays the function's own. The decorated ``fn(first, *, <keywords>)`` names each
    keyword it takes from the record after the field. A value passed under such a name is checked
    as a config value is (and converted: ``"auto"``, whole numbers, pairs); its other keywords
    (``segments``, ``trace``, ``method``...) pass through. ``fn.unchecked`` is the undecorated
    function, for callers that hold a checked record (``fn.unchecked(scan, **record.kwargs())``),
    and ``fn.params_cls`` the record.

    Deprecated, for one release, each with a ``DeprecationWarning`` naming the new form: an angle
    in radians under its old name without ``_deg``; the old names of ``renamed`` and of the
    record's :meth:`Params.renamed` (``{old: new}``; a value passed as it is); a record as the
    second positional argument; and the old positional shape, values after ``first`` in the
    order of ``positional``.

    Parameters
    ----------
    record : type of Params
        The parameter record whose fields the keywords are.
    positional : tuple of str
        The fields the old positional shape passed after ``first``, in order (deprecated).
    renamed : dict or None
        Old keyword -> new field name (deprecated names).

    Returns
    -------
    callable
        The decorator.
    """

    def decorate(fn: Callable) -> Callable:
        fields = {f.name: f for f in dataclasses.fields(record) if f.metadata.get("record") is None}
        signature = inspect.signature(fn).parameters
        takes = [name for name in signature if name in fields]
        # limits between fields, checked on the values a call passes and the defaults of the others
        # (a classmethod read from its class is a bound method: mypy types it as the plain callable)
        own = cast(types.MethodType, record.check_relations).__func__
        related = own is not cast(types.MethodType, Params.check_relations).__func__
        defaults = {name: signature[name].default for name in takes}
        old = {name[:-4]: name for name in takes if name.endswith("_deg")}
        old.update({k: v for k, v in {**record.renamed(), **(renamed or {})}.items() if v in takes or k == v})
        name = fn.__name__
        section = record._name

        def _old(kwargs: dict, key: str) -> None:
            new = old[key]
            value = kwargs.pop(key)
            if new.endswith("_deg") and new[:-4] == key:  # an angle (or a pair) in radians
                unit = " (in degrees)"
                if value is not None and not isinstance(value, str):
                    value = (tuple(math.degrees(v) for v in value) if isinstance(value, (tuple, list))
                             else math.degrees(value))
            else:
                unit = ""
            warnings.warn(f"{name}({key}=...) is deprecated: use {new}=...{unit}", DeprecationWarning,
                          stacklevel=3)
            if new in kwargs:
                raise TypeError(f"{name}() got both {key!r} and {new!r}")
            kwargs[new] = value

        def _positional(args: tuple, kwargs: dict) -> None:
            if len(args) == 1 and isinstance(args[0], Params):
                given = args[0]
                if not isinstance(given, record):
                    raise ValueError(f"a record passed to {name} must be a {record.__name__}, got "
                                     f"{type(given).__name__}")
                warnings.warn(f"{name}(scan, {record.__name__}(...)) is deprecated: pass its values as keywords, "
                              f"{name}(scan, **params.kwargs())", DeprecationWarning, stacklevel=3)
                for key, value in given.kwargs().items():
                    if key in takes:
                        kwargs.setdefault(key, value)
                return
            if len(args) > len(positional):
                raise TypeError(f"{name}() takes one positional argument and keywords ({', '.join(takes)})")
            warnings.warn(f"{name}() with {', '.join(positional[:len(args)])} by position is deprecated: pass "
                          "them as keywords", DeprecationWarning, stacklevel=3)
            for key, value in zip(positional, args, strict=False):
                if key in kwargs:
                    raise TypeError(f"{name}() got {key!r} twice")
                kwargs[key] = value

        @functools.wraps(fn)
        def wrapper(first, *args, **kwargs):
            if args:
                _positional(args, kwargs)
            if kwargs:  # (a loop over scans mostly passes none: that path stays short)
                for key in list(kwargs):
                    if key in old and key not in fields:
                        _old(kwargs, key)
                checked = False
                for key, value in kwargs.items():
                    f = fields.get(key)
                    if f is not None:
                        kwargs[key] = _check_value(section, f, value)
                        checked = True
                if related and checked:
                    record.check_relations({**defaults, **kwargs})
            return fn(first, **kwargs)

        wrapper.unchecked = fn  # type: ignore[attr-defined]
        wrapper.params_cls = record  # type: ignore[attr-defined]
        return wrapper

    return decorate
