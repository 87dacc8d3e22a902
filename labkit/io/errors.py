"""Errors raised by labkit's readers, and the one way every reader skips and counts bad records."""

from __future__ import annotations

from contextvars import ContextVar
from pathlib import Path

from ..errors import CorruptFileError, EmptyRecordingError

__all__ = ["CorruptFileError", "EmptyRecordingError", "Faults"]

#: While set (to a list), every :class:`Faults` made is appended to it: a reader stopped before
#: its end (a scan range, :func:`labkit.read_scans`) can still say what it skipped on the way.
WATCHED: ContextVar[list | None] = ContextVar("labkit_watched_faults", default=None)


class Faults:
    """The bad records one reader met in one file.

    A reader calls :meth:`skip` for every record it cannot decode and goes on while it
    returns True; when it has yielded every good scan it calls :meth:`check`, which raises
    one :class:`CorruptFileError` naming the file, how many records were skipped and where
    the first was. With ``strict=True``, :meth:`skip` returns False at the first bad record:
    the reader stops there, yields what it has and calls :meth:`check`.

    Examples
    --------
    >>> faults = Faults("run.jsonl", strict=False)
    >>> faults.skip("at line 3", "not JSON")
    True
    >>> faults.skip("at line 7", "not JSON")
    True
    >>> try:
    ...     faults.check(n_read=9)
    ... except CorruptFileError as error:
    ...     print(error)
    run.jsonl is damaged: 2 records were skipped, the first at line 3: not JSON; 9 scan(s) were read
    """

    def __init__(self, path: str | Path, strict: bool = False) -> None:
        self.path = Path(path)
        self.strict = strict
        self.count = 0
        self.first: tuple[str, str] | None = None
        self.wheres: set[str] = set()
        watched = WATCHED.get()
        if watched is not None:
            watched.append(self)

    def skip(self, where: str, reason: str, count: int = 1) -> bool:
        """Note ``count`` unreadable records at ``where`` (``count=0``: the file is damaged
        there, e.g. its index is missing, but no record was lost). Returns whether to read on
        (False in strict mode)."""
        if self.first is None:
            self.first = (where, reason)
        self.wheres.add(where)
        self.count += count
        return not self.strict

    def merge(self, other: Faults) -> None:
        """Count the faults another pass over the same file met (the poses read before the
        scans), unless this one already noted the place of its first: the same damage, seen twice."""
        if other.first is not None and other.first[0] not in self.wheres:
            self.skip(*other.first, count=other.count)

    def __bool__(self) -> bool:
        return self.first is not None

    def check(self, n_read: int) -> None:
        """Raise the :class:`CorruptFileError` that sums up the faults, if there were any."""
        if self.first is not None:
            raise CorruptFileError(self.path, self.first[0], n_read, self.first[1], n_skipped=self.count)
