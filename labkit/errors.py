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
    """The output exists and replacing it was not asked for (``overwrite=True``, ``-f``)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        super().__init__(f"{self.path} exists; pass overwrite=True to replace it",
                         f"{self.path} exists; pass -f to replace it")


class EmptyRecordingError(RefusedError):
    """A recording holds no scans at all (an empty bag, an empty log)."""


class CorruptFileError(ValueError):
    """A file is damaged (truncated, garbled, malformed records, missing its index).

    Raised by a reader *after* it has yielded every scan it could read: a record that cannot
    be decoded is skipped and counted, and reading goes on; a file cut short ends reading
    where it breaks. Nothing readable is lost and nothing is lost silently. With
    ``strict=True`` readers raise it at the first bad record instead.

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
    n_skipped : int
        How many records could not be read (0 when the only fault is a missing index or footer).
    """

    #: the output of a command that read this file is complete: keep it (see labkit._safe)
    keeps_output = True

    def __init__(self, path: str | Path, where: str, n_read: int, reason: str = "", n_skipped: int = 0) -> None:
        self.path = Path(path)
        self.where = where
        self.n_read = n_read
        self.reason = reason
        self.n_skipped = n_skipped
        detail = f": {reason}" if reason else ""
        if n_skipped > 1:
            text = (f"{self.path} is damaged: {n_skipped} records were skipped, the first {where}{detail}; "
                    f"{n_read} scan(s) were read")
        elif n_skipped == 1:
            text = f"{self.path} is damaged {where}{detail}; {n_read} scan(s) were read, 1 record was lost"
        else:
            text = f"{self.path} is damaged {where}{detail}; {n_read} scan(s) were read"
        super().__init__(text)
