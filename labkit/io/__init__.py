"""Reading and writing scans: ROS1/ROS2/MCAP bags, CARMEN logs, JSON.

One entry point reads them all::

    for scan in labkit.read_scans("data/hall.bag"):
        ...

The format is told from the path (see :func:`detect_format`). A damaged file yields every
scan that could be read -- a record that does not decode is skipped and counted, ROS1 bags and
MCAP files are read record by record and pick up again after a garbled stretch
(:mod:`labkit.io.salvage`) -- and then raises :class:`CorruptFileError` naming the file, where
the first damage is, and the scans kept and lost (exactly when the file's index says how many it
held; ``strict=True``: reading stops at the first damage).

Writers never lose data (``labkit._safe``): they write under a temporary name and
rename when complete, replace an existing output only when asked and only when it is their
own kind of file, and never write over their input.
"""

from __future__ import annotations

from .bags import StampsChangedWarning, write_bag
from .carmen import read_carmen
from .faults import CorruptFileError, EmptyRecordingError
from .feature_files import read_features, write_features
from .formats import FORMATS, FileFormat, register_format, unregister_format, writable_formats
from .jsonscan import read_json_lines, read_json_scan, write_json_lines, write_json_scan
from .recordings import (
    Conversion,
    ScanStream,
    convert,
    convert_recording,
    detect_format,
    output_format,
    output_kind,
    read_scans,
    write_scans,
)

__all__ = [
    "FORMATS",
    "FileFormat",
    "register_format",
    "unregister_format",
    "CorruptFileError",
    "EmptyRecordingError",
    "StampsChangedWarning",
    "ScanStream",
    "detect_format",
    "read_scans",
    "write_scans",
    "write_bag",
    "read_carmen",
    "read_json_scan",
    "read_json_lines",
    "write_json_scan",
    "write_json_lines",
    "convert",
    "convert_recording",
    "Conversion",
    "output_format",
    "output_kind",
    "writable_formats",
    "write_features",
    "read_features",
]


def __getattr__(name: str):
    if name == "WRITABLE":  # formats labkit writes, as registered now
        return writable_formats()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
