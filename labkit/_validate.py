"""Argument checks shared by the algorithm modules: one wording for every ``ValueError``,
each naming the argument (the message starts with its name)."""

from __future__ import annotations

import math
import numbers


def check_positive(name: str, value, *, allow_inf: bool = False) -> float:
    """``value`` as a float > 0 (finite unless ``allow_inf``), else ``ValueError``.

    >>> check_positive("eps", 0.5)
    0.5
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    v = float(value)
    if not (v > 0 and (allow_inf or math.isfinite(v))):
        raise ValueError(f"{name} must be a positive{'' if allow_inf else ' finite'} number, got {value!r}")
    return v


def check_nonneg(name: str, value, *, allow_inf: bool = False) -> float:
    """``value`` as a float >= 0 (finite unless ``allow_inf``), else ``ValueError``.

    >>> check_nonneg("min_length_m", 0)
    0.0
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number >= 0, got {value!r}")
    v = float(value)
    if not (v >= 0 and (allow_inf or math.isfinite(v))):
        raise ValueError(f"{name} must be a{'' if allow_inf else ' finite'} number >= 0, got {value!r}")
    return v


def check_int(name: str, value, minimum: int) -> int:
    """``value`` as an int >= ``minimum`` (an integer type, not a bool), else ``ValueError``.

    >>> check_int("min_pts", 3, 1)
    3
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)
