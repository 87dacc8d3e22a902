"""The table of file formats: one row per format, with its suffixes, reader, counter and writer.

Everything that reads or writes recordings asks this table: :func:`labkit.read_scans`,
:func:`labkit.write_scans`, :func:`labkit.convert`, :func:`labkit.io.detect_format`, the
recordings :mod:`labkit.app.parallel` picks up in a folder, and the command line (``labkit convert
--format`` choices, help texts, ``labkit info``). Adding a format is one module and one call::

    from labkit.io import FileFormat, register_format

    def read_xyz(stream):                 # stream.path, stream.topic, stream.strict
        ...                               # yield labkit.Scan objects

    register_format(FileFormat("xyz", (".xyz",), "XYZ scans, one per line (.xyz)", read=read_xyz,
                               count=count_xyz, write=write_xyz, output_kind=XYZ_FILE))

The built-in rows (ROS1, ROS2, MCAP, CARMEN, JSON, JSON lines) are registered by
:mod:`labkit.io` itself. This module depends on nothing else in labkit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["FileFormat", "FORMATS", "register_format", "unregister_format", "writable_formats",
           "format_from_suffix", "folder_format", "recording_suffixes"]


@dataclass(frozen=True)
class FileFormat:
    """One file format.

    Parameters
    ----------
    name : str
        The format's name (``read_scans(...).format``, ``labkit convert --format``).
    suffixes : tuple of str
        Lower-case file name endings (``(".log", ".log.gz")``); empty for a folder format.
    description : str
        One line for users: ``labkit info`` prints it, errors list it.
    read : callable
        ``read(stream)`` -> iterator of :class:`~labkit.Scan`, given the
        :class:`~labkit.io.ScanStream` being read (``stream.path``, ``.topic``, ``.strict``).
        Raise :class:`~labkit.io.CorruptFileError` after the last readable scan of a damaged file.
    count : callable or None
        ``count(path)`` -> how many scans the file holds, cheaply (progress bars, ``labkit info``);
        None when it is known only by reading them all.
    write : callable or None
        ``write(scans, path, *, topic, overwrite, inputs)`` -> number written, through
        ``labkit._safe``; None for a read-only format.
    output_kind : OutputKind, callable or None
        What ``write`` writes (``labkit._safe.OutputKind``), or ``output_kind(path)`` giving it.
    noun : str
        The files in a sentence ("CARMEN logs"); default ``"<name> files"``.
    label : str
        Short name in help texts and listings (``"CARMEN .log/.gz"``); default the suffixes.
    free_stamps : bool
        Its time stamps may be anything (negative, out of order): :func:`labkit.convert` restamps
        them when writing a format that cannot hold them (bags).
    in_folders : bool
        Picked up inside a folder given to ``labkit extract``/``evaluate`` (False when labkit's own
        outputs share the suffix, as ``.jsonl`` features do).
    folder : bool
        Written as a folder: a name without suffix means this format.
    open : callable or None
        For formats with topics and poses (bags, CARMEN logs):
        ``open(path, name, topic, strict, poses)`` -> :class:`~labkit.io.ScanStream`. None: the
        plain rules (no topic, poses from the scans, ``count``).
    detect : callable or None
        ``detect(folder)`` -> whether a folder holds a recording of this format (formats that can be
        folders: a ROS2 bag, an MCAP bag folder). The first format that says yes wins.
    name_format : callable or None
        ``name_format(path, name)`` -> the format written to ``path`` when ``--format name`` is
        given (checks the name agrees); None: the name must end in the first suffix.
    list_topics : callable or None
        ``list_topics(path)`` -> ``([(topic, type, count or None), ...], readable)`` for ``labkit info``.
    """

    name: str
    suffixes: tuple[str, ...]
    description: str
    read: Callable[[Any], Any]
    count: Callable[[Path], int] | None = None
    write: Callable[..., int] | None = None
    output_kind: Any = None
    noun: str = ""
    label: str = ""
    free_stamps: bool = True
    in_folders: bool = True
    folder: bool = False
    open: Callable[..., Any] | None = None
    detect: Callable[[Path], bool] | None = None
    name_format: Callable[[Path, str], str] | None = None
    list_topics: Callable[[Path], Any] | None = None

    def __post_init__(self) -> None:
        if not self.name or not self.name.isidentifier():
            raise ValueError(f"a format name is a short identifier, got {self.name!r}")
        if any(not s.startswith(".") or s != s.lower() for s in self.suffixes):
            raise ValueError(f"suffixes are lower-case and start with a dot, got {self.suffixes!r}")
        if not self.suffixes and not self.folder:
            raise ValueError(f"format {self.name!r} needs suffixes (or folder=True)")
        if self.write is not None and self.output_kind is None:
            raise ValueError(f"format {self.name!r} writes: give its output_kind (labkit._safe.OutputKind)")
        if not self.noun:
            object.__setattr__(self, "noun", f"{self.name} files")
        if not self.label:
            object.__setattr__(self, "label", "/".join(self.suffixes))

    @property
    def writable(self) -> bool:
        return self.write is not None

    def kind(self, path: Path):
        """The ``labkit._safe.OutputKind`` written at ``path``."""
        return self.output_kind(path) if callable(self.output_kind) else self.output_kind

    def __str__(self) -> str:  # FORMATS[name] used to be the description
        return self.description


#: Every file format labkit reads, by name, in registration order.
FORMATS: dict[str, FileFormat] = {}


def register_format(fmt: FileFormat, *, replace: bool = False) -> FileFormat:
    """Add a row to :data:`FORMATS`.

    Refused (``ValueError``): a name already taken, or a suffix another format already claims.

    Parameters
    ----------
    fmt : FileFormat
        The format.
    replace : bool
        Change an existing row of the same name.

    Returns
    -------
    FileFormat
        ``fmt``.
    """
    if not isinstance(fmt, FileFormat):
        raise TypeError(f"register_format takes a FileFormat, got {type(fmt).__name__}")
    if fmt.name in FORMATS and not replace:
        raise ValueError(f"a file format named {fmt.name!r} exists; pass replace=True to change it")
    for other in FORMATS.values():
        taken = set(other.suffixes) & set(fmt.suffixes)
        if other.name != fmt.name and taken:
            raise ValueError(f"{', '.join(sorted(taken))} already belong(s) to format {other.name!r}")
    FORMATS[fmt.name] = fmt
    return fmt


def unregister_format(name: str) -> FileFormat:
    """Remove a row from :data:`FORMATS` (tests, plug-ins).

    Parameters
    ----------
    name : str
        The format's name.

    Returns
    -------
    FileFormat
        The row removed.
    """
    if name not in FORMATS:
        raise KeyError(f"no file format named {name!r}; formats: {', '.join(FORMATS)}")
    return FORMATS.pop(name)


def writable_formats() -> tuple[str, ...]:
    """The names of the formats labkit writes.

    Returns
    -------
    tuple of str
        Every format with a writer.
    """
    return tuple(k for k, f in FORMATS.items() if f.writable)


def format_from_suffix(name: str) -> str | None:
    """The format a file name's ending says (longest matching suffix), or None.

    Parameters
    ----------
    name : str
        A file name (or path).

    Returns
    -------
    str or None
        The format's name; None when no suffix matches.
    """
    name = name.lower()
    best = max(((len(s), k) for k, f in FORMATS.items() for s in f.suffixes if name.endswith(s)), default=None)
    return best[1] if best else None


def folder_format() -> str | None:
    """The writable folder format (what a name without suffix is written as).

    Returns
    -------
    str or None
        Its name; None when no registered format writes folders.
    """
    return next((k for k, f in FORMATS.items() if f.folder and f.writable), None)


def recording_suffixes(in_folders_only: bool = False) -> tuple[str, ...]:
    """Every file suffix of every format (or of those picked up in folders).

    Parameters
    ----------
    in_folders_only : bool
        Only the formats found when a folder of recordings is given (:attr:`FileFormat.in_folders`).

    Returns
    -------
    tuple of str
        The suffixes, with their dot.
    """
    return tuple(s for f in FORMATS.values() if f.in_folders or not in_folders_only for s in f.suffixes)
