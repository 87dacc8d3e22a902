"""The errors labkit raises on purpose, so that callers (and the command line) can tell them apart.

Two kinds matter to a user:

- :class:`CorruptFileError`: a file is damaged. Readers raise it *after* yielding every record
  they could read (bad records are skipped and counted, reading goes on to the end), so the
  output of a command is complete with every good record when it is raised.
- :class:`RefusedError` and its subclasses: labkit refused a request before doing anything (an
  output that exists, is not labkit's kind of file, is one of the inputs, has the wrong suffix).
  Each carries the message in the library's words (``str(error)``) and in the command line's
  words (:attr:`RefusedError.cli`), so that ``labkit`` speaks of ``-f`` where the API speaks of
  ``overwrite=True``.

Both are ``ValueError`` subclasses, as bad input has always been in labkit. This module uses the
standard library only: every layer may import it.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["CorruptFileError", "RefusedError", "OutputExistsError", "EmptyRecordingError"]


class RefusedError(ValueError):
    """A request labkit refuses before it does anything.

    Parameters
    ----------
    message : str
        The reason, in the words of the Python API.
    cli : str, optional
        The same reason in the words of the command line (its flags); default ``message``.
    """

    def __init__(self, message: str, cli: str | None = None) -> None:
        super().__init__(message)
        self.cli = cli or message


class OutputExistsError(RefusedError):
    """The output exists and replacing it was not asked for (``overwrite=True``, ``-f``).

    Parameters
    ----------
    path : str or Path
        The output.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        super().__init__(f"{self.path} exists; pass overwrite=True to replace it",
                         f"{self.path} exists; pass -f to replace it")


class EmptyRecordingError(RefusedError):
    """A recording holds no scans at all (an empty bag, an empty log).

    Parameters
    ----------
    message : str
        The reason, in the words of the Python API.
    cli : str, optional
        The same reason in the words of the command line; default ``message``.
    """


class CorruptFileError(ValueError):
    """A file is damaged (truncated, garbled, malformed records, missing its index).

    Raised by a reader *after* it has yielded every scan it could read: a record that cannot
    be decoded is skipped and counted, and reading goes on; a file cut short ends reading
    where it breaks. Nothing readable is lost and nothing is lost silently. With
    ``strict=True`` readers raise it at the first bad record instead.

    The message names the file, where the first damage is, the scans kept and the scans lost:
    exactly when the file says how many it held (a bag's intact index), else as "at least N"
    (a file cut short: what came after the cut is unknown).

    Parameters
    ----------
    path : str or Path
        The damaged file.
    where : str
        Where the first fault is.
    n_read : int
        How many scans were read.
    reason : str, default ""
        What is wrong at ``where``.
    n_skipped : int, default 0
        Scans lost (``n_lost``).
    lost_exact : bool, default True
        Whether the count of lost scans is exact.
    n_other : int, default 0
        Records of other topics lost.
    places : int, default 1
        How many damaged places were found.
    stopped : bool, default False
        Reading stopped at the first fault.
    n_unread : int, optional
        With ``stopped``: the scans after the fault that were not read, when known.

    Attributes
    ----------
    path : Path
        The damaged file.
    where : str
        Where the (first) fault is: a byte offset, a line number, a message count.
    n_read : int
        How many scans were read (yielded).
    reason : str
        What is wrong at ``where``.
    n_lost : int
        Scans lost: exactly (``lost_exact``) or at least this many.
    lost_exact : bool
        Whether ``n_lost`` is the exact count (the file's index said how many scans it held, or
        every damaged record was one scan) rather than a lower bound.
    n_other : int
        Records of other topics read along with the scans (poses) that were lost.
    places : int
        How many damaged places were found.
    stopped : bool
        Reading stopped at the first fault (``strict``); the scans after it were not read.
    n_skipped : int
        ``n_lost + n_other``: every record known lost.
    """

    #: the output of a command that read this file is complete: keep it (see labkit._safe)
    keeps_output = True

    def __init__(self, path: str | Path, where: str, n_read: int, reason: str = "", n_skipped: int = 0, *,
                 lost_exact: bool = True, n_other: int = 0, places: int = 1, stopped: bool = False,
                 n_unread: int | None = None) -> None:
        self.path = Path(path)
        self.where = where
        self.n_read = n_read
        self.reason = reason
        self.n_lost = n_skipped
        self.lost_exact = lost_exact
        self.n_other = n_other
        self.places = places
        self.stopped = stopped
        self.n_skipped = n_skipped + n_other
        detail = f": {reason}" if reason else ""
        head = (f"{self.path} is damaged in {places} places, the first {where}{detail}" if places > 1
                else f"{self.path} is damaged {where}{detail}")
        if stopped:
            unread = f", {n_unread} not read" if n_unread else ""
            counts = f"reading stopped there (strict): {n_read} scans kept{unread}"
        else:
            counts = f"{n_read} scans kept, {self.lost_text}"
        other = f"; also {n_other} record{'s' if n_other > 1 else ''} of other topics lost" if n_other else ""
        super().__init__(f"{head}; {counts}{other}")

    @property
    def lost_text(self) -> str:
        """``"3 lost"``, ``"none lost"``, ``"at least 2 lost"`` or ``"an unknown number lost"``."""
        if self.lost_exact:
            return f"{self.n_lost or 'none'} lost"
        return f"at least {self.n_lost} lost" if self.n_lost else "an unknown number lost"
