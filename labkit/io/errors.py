"""Errors raised by labkit's readers."""

from __future__ import annotations

from pathlib import Path

__all__ = ["CorruptFileError"]


class CorruptFileError(ValueError):
    """A file is damaged (truncated, garbled, missing its index).

    Raised by a reader *after* it has yielded every scan that could be read before the
    fault, so nothing readable is lost and nothing is lost silently.

    Attributes
    ----------
    path : Path
        The damaged file.
    where : str
        Where it broke (a byte offset, a line number, a message count).
    n_read : int
        How many scans were yielded before the fault.
    """

    def __init__(self, path: str | Path, where: str, n_read: int, reason: str = "") -> None:
        self.path = Path(path)
        self.where = where
        self.n_read = n_read
        self.reason = reason
        detail = f": {reason}" if reason else ""
        super().__init__(
            f"{self.path} is damaged {where}{detail}; the {n_read} scan(s) before the fault were read"
        )
