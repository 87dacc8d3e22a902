"""Remembering parameter checks: the one caching helper every detector uses."""

from __future__ import annotations

import functools

__all__ = ["remembered"]


def remembered(check):
    """``check``, a pure function that validates parameters (and returns them converted),
    remembered for each distinct set of arguments: the detectors run by a pipeline get the
    same parameters with every scan, and checking them anew costs tens of microseconds a
    scan. Unhashable arguments (lists, arrays) are checked every time; ``typed`` keeps
    ``1``, ``1.0`` and ``True`` apart, as the checks do. A failed check is never remembered."""
    remembered = functools.lru_cache(maxsize=32, typed=True)(check)

    @functools.wraps(check)
    def checked(*args, **kwargs):
        try:
            return remembered(*args, **kwargs)
        except TypeError:  # an unhashable argument
            return check(*args, **kwargs)

    return checked
