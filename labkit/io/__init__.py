"""Reading and writing scans: ROS1/ROS2/MCAP bags, CARMEN logs, JSON.

One entry point reads them all::

    for scan in labkit.read_scans("data/hall.bag"):
        ...

The format is told from the path (see :func:`detect_format`). A damaged file yields every
scan that could be read -- a record that does not decode is skipped and counted, and reading
goes on -- and then raises :class:`CorruptFileError` naming the file, how many records were
skipped and where the first was (``strict=True``: reading stops at the first bad record).

Writers never lose data (:mod:`labkit._safe`): they write under a temporary name and
rename when complete, replace an existing output only when asked and only when it is their
own kind of file, and never write over their input.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

from .._safe import OutputKind, check_output
from ..errors import RefusedError
from ..scan import Scan
from . import bags
from .bags import StampsChangedWarning, plan_stamps, write_bag
from .carmen import LASER_MESSAGES, carmen_message_types, default_message, read_carmen
from .errors import CorruptFileError, EmptyRecordingError
from .features import read_features, write_features
from .jsonscan import JSON_LINES, JSON_SCAN, read_json_lines, read_json_scan, write_json_lines, write_json_scan
from .poses import PosePlan, plan_poses, read_bag_poses

__all__ = [
    "FORMATS",
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
    "write_features",
    "read_features",
]

#: What each format name means.
FORMATS = {
    "ros1": "ROS1 bag (.bag)",
    "ros2": "ROS2 bag folder with sqlite3 storage (metadata.yaml + .db3)",
    "mcap": "MCAP file (.mcap) or ROS2 bag folder with MCAP storage",
    "carmen": "CARMEN log (.log, .clf, optionally .gz)",
    "json": "one scan as JSON {ranges, bearings} (.json)",
    "jsonl": "scans as JSON lines, one per line (.jsonl)",
}


# File name endings of each file format (ROS2 bags are folders).
_SUFFIXES = {
    "ros1": (".bag",),
    "mcap": (".mcap",),
    "carmen": (".log", ".log.gz", ".clf", ".clf.gz"),
    "jsonl": (".jsonl",),
    "json": (".json",),
}


def _format_from_suffix(name: str) -> str | None:
    return next((fmt for fmt, ends in _SUFFIXES.items() if name.lower().endswith(ends)), None)


def _supported() -> str:
    return "; ".join(f"{k}: {v}" for k, v in FORMATS.items())


def detect_format(path: str | Path) -> str:
    """Tell a file's format from its name (and, for folders, their contents).

    Returns one of the keys of :data:`FORMATS`; raises ``ValueError`` listing the
    supported formats for anything else, and ``FileNotFoundError`` for a missing path.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p} does not exist")
    name = p.name.lower()
    if p.is_dir():
        meta = p / "metadata.yaml"
        if meta.exists():
            return "mcap" if "storage_identifier: mcap" in meta.read_text(errors="replace") else "ros2"
        if any(p.glob("*.mcap")):
            return "mcap"
        if any(p.glob("*.db3")):
            return "ros2"
        raise ValueError(f"{p} is a folder but not a ROS2 bag (no metadata.yaml, .db3 or .mcap); "
                         f"supported formats: {_supported()}")
    fmt = _format_from_suffix(name)
    if fmt is not None:
        return fmt
    if name.endswith(".db3"):
        raise ValueError(f"{p} is an sqlite3 bag file: pass its folder ({p.parent}) instead")
    raise ValueError(f"cannot tell the format of {p}; supported formats: {_supported()}")


class ScanStream:
    """The scans of one file, ready to iterate (see :func:`read_scans`).

    Attributes
    ----------
    path : Path
    format : str
        One of :data:`FORMATS`.
    topic : str or None
        The LaserScan topic being read (bags) or the CARMEN message type.
    count : int or None
        How many scans the file says it holds (for progress bars), when known up front.
    readable : bool
        False when the file is damaged and is being read sequentially.
    strict : bool
        Stop at the first bad record instead of skipping it.
    poses : str or None
        Where the scans' poses come from (``"odometry /odom"``, ``"tf /tf, /tf_static, else
        odometry /odom"``, ``"the log's corrected laser poses"``, ...); None when they get none.
    pose_plan : PosePlan or None
        For bags: the pose topics read (:mod:`labkit.io.poses`).
    pose_sources : dict
        After reading a bag: for each scan frame, how its pose was found.
    """

    def __init__(self, path: Path, fmt: str, topic: str | None, count: int | None, readable: bool,
                 strict: bool = False, poses: str | None = None, pose_plan: PosePlan | None = None) -> None:
        self.path, self.format, self.topic, self.count, self.readable = path, fmt, topic, count, readable
        self.strict = strict
        self.poses = poses
        self.pose_plan = pose_plan
        self.pose_sources: dict[str, str] = {}

    def __iter__(self) -> Iterator[Scan]:
        if self.format in bags.BAG_FORMATS:
            return self._bag_scans()
        if self.format == "carmen":
            scans = read_carmen(self.path, self.topic, strict=self.strict)
        elif self.format == "json":
            scans = iter([read_json_scan(self.path)])
        else:
            scans = read_json_lines(self.path, strict=self.strict)
        return scans if self.poses is not None else _without_poses(scans)

    def _bag_scans(self) -> Iterator[Scan]:
        poses = None
        if self.pose_plan is not None:
            poses = read_bag_poses(self.path, self.format, self.pose_plan, self.readable, self.strict)
            self.pose_sources = poses.sources  # filled in as scan frames are met
        yield from bags.iter_bag(self.path, self.format, self.topic, self.readable, self.strict, poses=poses)

    def __len__(self) -> int:
        if self.count is None:
            raise TypeError("this file does not say how many scans it holds")
        return self.count

    def __repr__(self) -> str:
        return (f"ScanStream({str(self.path)!r}, format={self.format!r}, topic={self.topic!r}, "
                f"count={self.count}, poses={self.poses!r})")


def _without_poses(scans: Iterable[Scan]) -> Iterator[Scan]:
    for scan in scans:
        yield scan if scan.pose is None else scan.replace(pose=None)


def read_scans(path: str | Path, topic: str | None = None, *, strict: bool = False,
               poses: str | bool | None = None) -> ScanStream:
    """Open any supported file and return its scans as an iterable :class:`ScanStream`.

    Parameters
    ----------
    path : str or Path
        A ROS1 ``.bag``, a ROS2 bag folder (sqlite3 or MCAP storage), an ``.mcap`` file,
        a CARMEN log, a ``.json`` scan or a ``.jsonl`` file of scans.
    topic : str, optional
        For bags, the ``sensor_msgs/LaserScan`` topic; by default the only one. For
        CARMEN logs, the laser message type (``"FLASER"``, ``"ROBOTLASER1"``...).
    strict : bool
        Stop reading at the first record that cannot be decoded (default: skip it, count
        it and read on).
    poses : str, bool or None
        Where each scan's :attr:`~labkit.Scan.pose` (the sensor's pose in a world frame) comes
        from. None (default): wherever the recording has poses -- a CARMEN log's corrected
        poses, a JSON scan's ``pose``, a bag's ``/tf`` or its one ``nav_msgs/Odometry`` topic,
        interpolated to each scan's stamp (:mod:`labkit.io.poses` gives the rules). A bag topic
        name: that odometry or tf topic. False: no poses.

    Raises
    ------
    ValueError
        Unknown format (the message lists the supported ones); no LaserScan topic (it
        lists the bag's topics); several LaserScan topics and no ``topic`` (it lists them);
        ``poses`` names no pose topic, or a bag has several odometry topics and no tf.
        :class:`EmptyRecordingError` (a ValueError) for a bag without any topic.
    CorruptFileError
        While iterating, after the last scan that could be read from a damaged file: every
        record that could not be decoded was skipped and counted.

    Examples
    --------
    >>> from labkit import read_scans, bundled_data
    >>> scans = read_scans(bundled_data("hall.bag"))
    >>> scans.count, next(iter(scans)).n_beams
    (600, 361)
    """
    p = Path(path)
    fmt = detect_format(p)
    if poses is not None and not isinstance(poses, (bool, str)):
        raise ValueError(f"poses must be None, True, False or a topic name, got {poses!r}")
    if fmt in bags.BAG_FORMATS:
        topics, readable = bags.list_topics(p, fmt)
        chosen = bags.resolve_topic(p, topics, topic)
        count = next((c for name, _t, c in topics if name == chosen), None) if readable else None
        plan = plan_poses(p, topics, None if poses is True else poses)
        return ScanStream(p, fmt, chosen, count, readable, strict, plan.describe() if plan else None, plan)
    if isinstance(poses, str):
        raise RefusedError(f"poses names a bag topic; {FORMATS[fmt]} files carry their poses in the scans "
                           "(poses=False: none)",
                           f"--poses names a bag topic; {FORMATS[fmt]} files carry their poses in the scans "
                           "(--poses none: none)")
    inline = None if poses is False else ("the log's laser poses" if fmt == "carmen" else "the scans' 'pose' fields")
    if fmt == "carmen":
        if topic is not None and topic not in LASER_MESSAGES:
            raise RefusedError(f"for a CARMEN log, topic is a laser message type {LASER_MESSAGES}, got {topic!r}",
                               f"for a CARMEN log, --topic is a laser message type {LASER_MESSAGES}, got {topic!r}")
        counts = carmen_message_types(p)
        if topic is None:
            topic = default_message(counts)
        if topic is None:
            raise EmptyRecordingError(f"{p} has no laser messages ({', '.join(LASER_MESSAGES)})")
        if topic not in counts:
            found = ", ".join(f"{k} ({v})" for k, v in sorted(counts.items()))
            raise ValueError(f"{p} has no {topic} messages; laser messages found: {found}")
        return ScanStream(p, fmt, topic, counts[topic], True, strict, inline if topic in _POSED else None)
    if topic is not None:
        raise RefusedError(f"topic does not apply to {FORMATS[fmt]} files",
                           f"--topic does not apply to {FORMATS[fmt]} files")
    if fmt == "json":
        return ScanStream(p, fmt, None, 1, True, strict, inline)
    return ScanStream(p, fmt, None, None, True, strict, inline)


_POSED = ("FLASER", "RLASER", "ROBOTLASER1", "ROBOTLASER2")  # CARMEN laser messages that carry a pose


def write_scans(
    scans: Iterable[Scan], path: str | Path, format: str | None = None, *, topic: str = "/scan",
    overwrite: bool = False, inputs: Iterable[str | Path] = (),
) -> int:
    """Write scans to any writable format (bags, ``.jsonl``, a single-scan ``.json``).

    Returns the number written. Bags: see :func:`write_bag`. CARMEN logs are read-only.
    ``overwrite`` replaces only an output of the same kind; ``inputs`` are the files the
    scans come from, which the output may not be (see :mod:`labkit._safe`).
    """
    p = Path(path)
    fmt = output_format(p, format)
    if fmt in bags.BAG_FORMATS:
        return write_bag(scans, p, fmt, topic=topic, overwrite=overwrite, inputs=inputs)
    if fmt == "jsonl":
        return write_json_lines(scans, p, overwrite=overwrite, inputs=inputs)
    items = list(scans)
    if len(items) != 1:
        raise ValueError(f"a .json file holds exactly one scan, got {len(items)}; use .jsonl")
    write_json_scan(items[0], p, overwrite=overwrite, inputs=inputs)
    return 1


def output_format(p: Path, format: str | None = None) -> str:
    """The format written to ``p``: from its name (a name without suffix is a ROS2 bag folder),
    checked against ``format`` when one is given."""
    guess = _format_from_suffix(p.name)
    if guess == "carmen":
        raise RefusedError("labkit reads CARMEN logs but does not write them")
    if guess is None and p.suffix not in ("", ".") and format is None:
        raise RefusedError(f"cannot tell the output format of {p}; use .bag, .mcap, .jsonl, .json or a folder name"
                           " (ROS2 bag)")
    if format is None:
        return guess or "ros2"
    if format not in WRITABLE:
        raise ValueError(f"cannot write {format!r}; writable formats: {', '.join(WRITABLE)}")
    if format in bags.BAG_FORMATS:
        return bags.bag_format(p, format)
    if guess != format:
        raise RefusedError(f"{p}: format={format!r} needs a name ending in .{format}",
                           f"{p}: --format {format} needs a name ending in .{format}")
    return format


def output_kind(p: Path, fmt: str) -> OutputKind:
    """What the writer of format ``fmt`` writes at ``p`` (for :func:`labkit._safe.check_output`)."""
    if fmt in bags.BAG_FORMATS:
        return bags.output_kind(p, fmt)
    return JSON_LINES if fmt == "jsonl" else JSON_SCAN


#: Formats labkit writes.
WRITABLE = ("ros1", "ros2", "mcap", "jsonl", "json")
_FREE_STAMPS = ("carmen", "json", "jsonl")  # formats whose stamps may be anything


def convert(src: str | Path, dst: str | Path, *, topic: str | None = None, format: str | None = None,
            overwrite: bool = False, progress: bool = False, strict: bool = False,
            poses: str | bool | None = None) -> int:
    """Copy the scans of ``src`` into ``dst`` (formats from the names); return the count.

    The scans keep their poses (``poses`` as in :func:`read_scans`): a bag written gets them as
    ``nav_msgs/Odometry`` on ``/odom``, JSON lines as ``pose`` fields.

    A damaged ``src`` still produces a complete ``dst`` holding every readable scan, then
    the :class:`CorruptFileError` propagates. ``progress=True`` shows a tqdm bar. ``dst``
    may not be ``src`` (nor inside it), and an existing ``dst`` is replaced only with
    ``overwrite=True`` and only when it is the same kind of output.

    Time stamps that the output bag format cannot hold (CARMEN logs and JSON scans may have
    negative stamps, or garbage) are changed on purpose, as :func:`labkit.io.bags.plan_stamps`
    describes, and a :class:`StampsChangedWarning` says how.
    """
    src, dst = Path(src), Path(dst)
    fmt = output_format(dst, format)
    stream = read_scans(src, topic=topic, strict=strict, poses=poses)
    check_output(dst, output_kind(dst, fmt), overwrite=overwrite, inputs=[src])  # refuse before reading
    restamp = None
    if fmt in bags.BAG_FORMATS and stream.format in _FREE_STAMPS:
        try:
            restamp, note = plan_stamps(read_scans(src, topic=topic, poses=False), fmt)
        except CorruptFileError:  # read what can be read; the conversion reports the damage
            restamp, note = plan_stamps(_readable(read_scans(src, topic=topic, poses=False)), fmt)
        if note:
            warnings.warn(f"{src}: {note}", StampsChangedWarning, stacklevel=2)
    scans: Iterable[Scan] = stream
    if restamp is not None:
        scans = (restamp(scan, k) for k, scan in enumerate(stream))
    if progress:
        from tqdm.auto import tqdm

        scans = tqdm(scans, total=stream.count, unit="scan", desc=f"convert {src.name}")
    return write_scans(scans, dst, fmt, overwrite=overwrite, inputs=[src])


def _readable(stream: Iterable[Scan]) -> Iterator[Scan]:
    try:
        yield from stream
    except CorruptFileError:
        return
