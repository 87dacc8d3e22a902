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
    """The bad records one reader met in one file, and the books of what they cost.

    A reader calls :meth:`skip` for every damaged place (a record it cannot decode, a garbled
    stretch, the end of a file cut short) and goes on while it returns True; when it has yielded
    every good scan it calls :meth:`check`, which raises one :class:`CorruptFileError` naming the
    file, where the first damage was, the scans kept and the scans lost. With ``strict=True``,
    :meth:`skip` returns False at the first damaged place: the reader stops there.

    The scans lost are counted exactly when the file says how many it holds (``expected``: a
    bag's intact index) -- ``expected`` minus the scans read -- and otherwise as the records known
    lost (``count`` of each :meth:`skip` and :meth:`lose`), "at least" that many when some damage
    cost an unknown number (``known=False``, or a file that ends early).

    Parameters
    ----------
    path : str or Path
        The file read, named by the error.
    strict : bool
        Stop at the first damaged place.
    expected : int or None
        How many scans the file says it holds (a bag's intact index); None: unknown.

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
    run.jsonl is damaged in 2 places, the first at line 3: not JSON; 9 scans kept, 2 lost
    """

    def __init__(self, path: str | Path, strict: bool = False, expected: int | None = None) -> None:
        self.path = Path(path)
        self.strict = strict
        self.expected = expected
        self.count = 0
        self.other = 0
        self.unknown = False  # some damage cost an unknown number of records
        self.stopped = False
        self.done: int | None = None  # records read, when the reader says (for merge)
        self.first: tuple[str, str] | None = None
        self.wheres: list[str] = []
        watched = WATCHED.get()
        if watched is not None:
            watched.append(self)

    def skip(self, where: str, reason: str, count: int = 1, *, known: bool = True, open_end: bool = False) -> bool:
        """Note a damaged place at ``where`` that cost ``count`` records (``known=False``: and
        perhaps more; ``open_end``: the file ends there). Returns whether to read on (False in
        strict mode)."""
        if self.first is None:
            self.first = (where, reason)
        if where not in self.wheres:
            self.wheres.append(where)
        self.count += count
        self.unknown = self.unknown or not known or open_end
        if self.strict:
            self.stopped = True
        return not self.strict

    def lose(self, count: int) -> None:
        """``count`` more records known lost at places already noted (a chunk's own index says so)."""
        self.count += count

    def merge(self, other: Faults) -> None:
        """Count the faults another pass over the same file met (the poses read before the
        scans): their records are other topics' records, their places are counted once."""
        if other.first is None:
            return
        if self.first is None:
            self.first = other.first
        for where in other.wheres:
            if where not in self.wheres:
                self.wheres.append(where)
        lost, _exact = other.lost(other.done)
        self.other += lost
        self.stopped = self.stopped or other.stopped

    def add(self, other: Faults) -> None:
        """Count the faults ``other`` met so far as this one's own (a reader stopped before its end,
        a scan range: the records it noted lost, no index count, which holds only at the file's end)."""
        if other.first is None:
            return
        if self.first is None:
            self.first = other.first
        for where in other.wheres:
            if where not in self.wheres:
                self.wheres.append(where)
        self.count += other.count
        self.other += other.other
        self.unknown = self.unknown or other.unknown
        self.stopped = self.stopped or other.stopped

    def __bool__(self) -> bool:
        return self.first is not None

    def lost(self, n_read: int | None) -> tuple[int, bool]:
        """``(records lost, exact)`` given ``n_read`` records read."""
        if self.expected is not None and n_read is not None and n_read <= self.expected and not self.stopped:
            return self.expected - n_read, True
        if self.expected is not None and n_read is None:
            return max(self.count, 0), not self.unknown
        return self.count, not self.unknown

    def check(self, n_read: int) -> None:
        """Raise the :class:`CorruptFileError` that sums up the faults, if there were any (or if
        fewer records were read than the file's index lists)."""
        lost, exact = self.lost(n_read)
        if self.first is None and lost > 0 and exact:
            self.skip("in its messages", f"{lost} of the {self.expected} scans its index lists were not found", 0)
        if self.first is not None:
            unread = self.expected - n_read if self.stopped and self.expected is not None else None
            raise CorruptFileError(self.path, self.first[0], n_read, self.first[1], lost, lost_exact=exact,
                                   n_other=self.other, places=len(self.wheres), stopped=self.stopped,
                                   n_unread=unread)
