"""Recordings of every format through one table: telling a file's format, reading its scans
(:func:`read_scans`, a :class:`ScanStream` with its count, topic, poses and a scan range), writing and
converting them, and the built-in rows of :data:`labkit.io.formats.FORMATS` (bags, CARMEN logs, JSON).
:mod:`labkit.io` re-exports the public names."""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from .._safe import OutputKind, check_output
from ..errors import RefusedError
from ..scan import Scan
from . import bags
from .bags import StampsChangedWarning, plan_stamps, write_bag
from .carmen import LASER_MESSAGES, carmen_message_types, default_message, read_carmen
from .faults import WATCHED, CorruptFileError, EmptyRecordingError, Faults
from .formats import (
    FORMATS,
    FileFormat,
    folder_format,
    format_from_suffix,
    register_format,
    writable_formats,
)
from .jsonscan import JSON_LINES, JSON_SCAN, read_json_lines, read_json_scan, write_json_lines, write_json_scan
from .pose_topics import PosePlan, plan_poses, read_bag_poses

# The file formats are the rows of labkit.io.formats.FORMATS; the built-in ones are registered at
# the end of this module.


def _format_from_suffix(name: str) -> str | None:
    return format_from_suffix(name)


def _supported() -> str:
    return "; ".join(f"{k}: {v.description}" for k, v in FORMATS.items())


def detect_format(path: str | Path) -> str:
    """Tell a file's format from its name (and, for folders, their contents).

    Raises ``ValueError`` listing the supported formats for anything else, and
    ``FileNotFoundError`` for a missing path.

    Parameters
    ----------
    path : str or Path
        The file or folder.

    Returns
    -------
    str
        One of the keys of :data:`labkit.io.FORMATS`.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{p} does not exist")
    name = p.name.lower()
    if p.is_dir():
        fmt = next((k for k, f in FORMATS.items() if f.detect is not None and f.detect(p)), None)
        if fmt is not None:
            return fmt
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

    Parameters
    ----------
    path : Path
        The file.
    fmt : str
        Its format, one of :data:`labkit.io.FORMATS` (the attribute ``format``).
    topic : str or None
        The LaserScan topic being read (bags) or the CARMEN message type.
    count : int or None
        How many scans the file says it holds (for progress bars), when known up front.
    readable : bool
        Whether rosbags could open the file's index (bags); False for a bag whose index or
        database is damaged (labkit reads it all the same, record by record or row by row).
    strict : bool
        Stop at the first bad record instead of skipping it.
    poses : str or None
        Where the scans' poses come from (``"odometry /odom"``, ``"tf /tf, /tf_static, else
        odometry /odom"``, ``"the log's corrected laser poses"``, ...); None when they get none.
    pose_plan : PosePlan or None
        For bags: the pose topics read (:mod:`labkit.io.pose_topics`).

    Attributes
    ----------
    format : str
        The file's format.
    pose_sources : dict
        After reading a bag: for each scan frame, how its pose was found.
    first, stop : int, int or None
        The scan range read (``read_scans(..., scans=...)``): the scans ``first`` up to, not
        including, ``stop`` (None: to the end), counted from 0 in reading order. ``count`` is
        then the number in the range, when known, and ``held`` the number in the file.
    """

    def __init__(self, path: Path, fmt: str, topic: str | None, count: int | None, readable: bool,
                 strict: bool = False, poses: str | None = None, pose_plan: PosePlan | None = None) -> None:
        self.path, self.format, self.topic, self.count, self.readable = path, fmt, topic, count, readable
        self.strict = strict
        self.poses = poses
        self.pose_plan = pose_plan
        self.pose_sources: dict[str, str] = {}
        self.pose_count: int | None = None  # pose messages the bag's index lists
        self.held = count  # the scans the file says it holds (``count`` is the range's)
        self.first: int = 0
        self.stop: int | None = None

    def __iter__(self) -> Iterator[Scan]:
        scans = FORMATS[self.format].read(self)
        if self.poses is None:
            scans = _without_poses(scans)
        if self.first or self.stop is not None:
            scans = _in_range(scans, self.path, self.strict, self.first, self.stop)
        return scans

    def _select(self, scans: slice) -> None:
        """Read only ``scans`` (see :func:`read_scans`)."""
        if not isinstance(scans, slice) or scans.step not in (None, 1):
            raise ValueError(f"scans must be a slice of scan indices without a step, got {scans!r}")
        for end in (scans.start, scans.stop):
            if end is not None and (isinstance(end, bool) or not isinstance(end, (int, np.integer))):
                raise ValueError(f"scans must be a slice of whole numbers, got {scans!r}")
        negative = any(end is not None and end < 0 for end in (scans.start, scans.stop))
        if negative and self.count is None:
            raise RefusedError(f"{self.path} does not say how many scans it holds, so a range counted from its end "
                               f"({_slice_text(scans)}) cannot be placed: give the range from the start")
        if self.count is not None:
            first, stop, _ = scans.indices(self.count)
            self.count = max(stop - first, 0)
            self.first, self.stop = first, max(stop, first)
        else:
            self.first, self.stop = scans.start or 0, scans.stop
            if self.stop is not None:
                self.stop = max(self.stop, self.first)

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


def _slice_text(scans: slice) -> str:
    return f"{'' if scans.start is None else scans.start}:{'' if scans.stop is None else scans.stop}"


def _in_range(scans: Iterable[Scan], path: Path, strict: bool, first: int, stop: int | None) -> Iterator[Scan]:
    """The scans ``first`` .. ``stop - 1`` of ``scans``; reading stops after the last one. A
    record the reader skipped on the way (before or inside the range) is still reported: the
    reader's :class:`~labkit.io.faults.Faults` are watched, and a :class:`CorruptFileError`
    follows the range's last scan (the reader raises its own when it reaches the file's end)."""
    it = iter(scans)
    watched: list[Faults] = []
    read = 0

    def pull():
        token = WATCHED.set(watched)
        try:
            return next(it, None)
        finally:
            WATCHED.reset(token)

    try:
        while stop is None or read < stop:
            scan = pull()
            if scan is None:
                return  # the file's end: the reader has raised its own error if it skipped anything
            if read >= first:
                yield scan
            read += 1
        seen = Faults(path, strict)
        for faults in watched:
            seen.add(faults)
        seen.check(read)
    finally:
        close = getattr(it, "close", None)
        if close is not None:
            close()


def read_scans(path: str | Path, topic: str | None = None, *, strict: bool = False,
               poses: str | bool | None = None, scans: slice | None = None) -> ScanStream:
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
        interpolated to each scan's stamp (:mod:`labkit.io.pose_topics` gives the rules). A bag topic
        name: that odometry or tf topic. False: no poses.
    scans : slice, optional
        Read only these scans, as Python slices them: ``slice(100, 200)`` the scans 100 to 199,
        counted from 0 in reading order (a damaged file: among the scans that could be read);
        ``slice(-50, None)`` the last 50 (only for files that say how many scans they hold). No
        step. Reading stops after the range's last scan; a record skipped on the way is still
        reported (``CorruptFileError`` after the range's scans). The stream's ``first`` is
        where the range starts, ``count`` how many scans it holds (when known).

    Returns
    -------
    ScanStream
        An iterable of :class:`labkit.Scan` (read as it is iterated), with ``count`` and ``first``.

    Raises
    ------
    ValueError
        Unknown format (the message lists the supported ones); no LaserScan topic (it
        lists the bag's topics); several LaserScan topics and no ``topic`` (it lists them);
        ``poses`` names no pose topic, or a bag has several odometry topics and no tf.
        :class:`EmptyRecordingError` (a ValueError) for an input that holds no scans at all: a
        file of 0 bytes, a bag without any topic, a log without laser messages, a ``.jsonl``
        without a line (the command line's exit status 2).
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
    if fmt in _BUILT_IN and p.is_file() and p.stat().st_size == 0:
        raise EmptyRecordingError(f"{p} is empty (0 bytes): there is nothing to read")
    if poses is not None and not isinstance(poses, (bool, str)):
        raise ValueError(f"poses must be None, True, False or a topic name, got {poses!r}")
    row = FORMATS[fmt]
    if row.open is not None:
        stream = row.open(p, fmt, topic, strict, poses)
    else:
        _refuse_pose_topic(fmt, poses)
        if topic is not None:
            raise RefusedError(f"topic does not apply to {row.description} files",
                               f"--topic does not apply to {row.description} files")
        inline = None if poses is False else "the scans' 'pose' fields"
        stream = ScanStream(p, fmt, None, row.count(p) if row.count is not None else None, True, strict, inline)
    if scans is not None:
        stream._select(scans)
    return stream


def _refuse_pose_topic(fmt: str, poses: str | bool | None) -> None:
    if isinstance(poses, str):
        what = FORMATS[fmt].description
        raise RefusedError(f"poses names a bag topic; {what} files carry their poses in the scans "
                           "(poses=False: none)",
                           f"--poses names a bag topic; {what} files carry their poses in the scans "
                           "(--poses none: none)")


_POSED = ("FLASER", "RLASER", "ROBOTLASER1", "ROBOTLASER2")  # CARMEN laser messages that carry a pose


def write_scans(
    scans: Iterable[Scan], path: str | Path, format: str | None = None, *, topic: str = "/scan",
    overwrite: bool = False, inputs: Iterable[str | Path] = (),
) -> int:
    """Write scans to any writable format (bags, ``.jsonl``, a single-scan ``.json``).

    Returns the number written. Bags: see :func:`write_bag`. CARMEN logs are read-only.
    ``overwrite`` replaces only an output of the same kind; ``inputs`` are the files the
    scans come from, which the output may not be (see ``labkit._safe``).

    Parameters
    ----------
    scans : iterable of Scan
        The scans.
    path : str or Path
        The output; its format from its name unless ``format`` is given.
    format : str, optional
        A name of :data:`labkit.io.FORMATS` with a writer.
    topic : str, default "/scan"
        The topic of the scans in a bag.
    overwrite : bool, default False
        Replace an existing output of the same kind.
    inputs : iterable of str or Path
        The files the scans come from, which the output may not be.

    Returns
    -------
    int
        The number of scans written.
    """
    p = Path(path)
    fmt = output_format(p, format)
    write = FORMATS[fmt].write
    if write is None:  # output_format names only writable formats
        raise RefusedError(f"labkit does not write {FORMATS[fmt].noun}")
    return write(scans, p, topic=topic, overwrite=overwrite, inputs=inputs)


def output_format(p: Path, format: str | None = None) -> str:
    """The format written to a path: from its name, checked against ``format`` when one is given.

    A name without suffix is a ROS2 bag folder.

    Parameters
    ----------
    p : Path
        The output.
    format : str or None
        The format asked for; None: the name's.

    Returns
    -------
    str
        The format's name.
    """
    guess = _format_from_suffix(p.name)
    if guess is not None and not FORMATS[guess].writable:
        raise RefusedError(f"labkit reads {FORMATS[guess].noun} but does not write them")
    folder = folder_format()
    if guess is None and p.suffix not in ("", ".") and format is None:
        ends = [s for f in FORMATS.values() if f.writable for s in f.suffixes[:1]]
        raise RefusedError(f"cannot tell the output format of {p}; use {', '.join(ends)}"
                           + (f" or a folder name ({FORMATS[folder].label})" if folder else ""))
    if format is None:
        if guess is None and folder is None:
            raise RefusedError(f"cannot tell the output format of {p}; give it a suffix")
        return guess if guess is not None else str(folder)  # one of them is set (checked above)
    writable = writable_formats()
    if format not in writable:
        raise ValueError(f"cannot write {format!r}; writable formats: {', '.join(writable)}")
    row = FORMATS[format]
    if row.name_format is not None:
        return row.name_format(p, format)
    if guess != format:
        raise RefusedError(f"{p}: format={format!r} needs a name ending in {row.suffixes[0]}",
                           f"{p}: --format {format} needs a name ending in {row.suffixes[0]}")
    return format


def output_kind(p: Path, fmt: str) -> OutputKind:
    """What the writer of a format writes at a path (for ``labkit._safe.check_output``).

    Parameters
    ----------
    p : Path
        The output.
    fmt : str
        Its format.

    Returns
    -------
    labkit._safe.OutputKind
        The kind of file or folder, which an existing output must be to be replaced.
    """
    return FORMATS[fmt].kind(p)


def __getattr__(name: str):
    if name == "WRITABLE":  # formats labkit writes, as registered now
        return writable_formats()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def convert(src: str | Path, dst: str | Path, *, topic: str | None = None, format: str | None = None,
            overwrite: bool = False, progress: bool = False, strict: bool = False,
            poses: str | bool | None = None, only_scans: bool = False, scans: slice | None = None) -> int:
    """Copy the recording ``src`` into ``dst`` (formats from the names); return the scans copied.

    Between bags (ROS1 ``.bag``, ROS2 folder, MCAP) the whole recording is copied: every topic,
    under its own name, converted between ROS1 and ROS2 definitions (:mod:`labkit.io.bagcopy`;
    a topic whose type does not convert is left out with a :class:`~labkit.io.bagcopy.TopicsSkippedWarning`);
    ``topic`` and ``poses`` do not apply then. With ``only_scans=True``, and whenever either
    side is not a bag, the scans alone are copied: the LaserScan topic (``topic``) as ``/scan``,
    with their poses (``poses`` as in :func:`read_scans`) as ``nav_msgs/Odometry`` on ``/odom``
    in a bag, as ``pose`` fields in JSON lines.

    ``scans``: only this range of scans (a slice, as for :func:`read_scans`); a scans-only copy
    (between bags it needs ``only_scans=True``: a whole-recording copy has no scan range).

    A damaged ``src`` still produces a complete ``dst`` holding every readable scan, then
    the :class:`CorruptFileError` propagates. ``progress=True`` shows a tqdm bar. ``dst``
    may not be ``src`` (nor inside it), and an existing ``dst`` is replaced only with
    ``overwrite=True`` and only when it is the same kind of output.

    Time stamps that the output bag format cannot hold (CARMEN logs and JSON scans may have
    negative stamps, or garbage) are changed on purpose, as ``labkit.io.bags.plan_stamps``
    describes, and a :class:`StampsChangedWarning` says how.

    Parameters
    ----------
    src : str or Path
        The recording to copy.
    dst : str or Path
        The output; its format from its name unless ``format`` is given.
    topic : str, optional
        The LaserScan topic (for a scans-only copy), as for :func:`read_scans`.
    format : str, optional
        The output's format, a name of :data:`labkit.io.FORMATS` with a writer.
    overwrite : bool, default False
        Replace an existing ``dst`` of the same kind.
    progress : bool, default False
        Show a progress bar.
    strict : bool, default False
        Stop at the first record that cannot be decoded.
    poses : str, bool or None
        Where the scans' poses come from, as for :func:`read_scans`.
    only_scans : bool, default False
        Copy the scans alone, also between bags.
    scans : slice, optional
        Only this range of scans, as for :func:`read_scans` (a scans-only copy).

    Returns
    -------
    int
        The number of scans copied.
    """
    return convert_recording(src, dst, topic=topic, format=format, overwrite=overwrite, progress=progress,
                             strict=strict, poses=poses, only_scans=only_scans, scans=scans).scans


@dataclass(frozen=True)
class Conversion:
    """What :func:`convert_recording` wrote.

    Parameters
    ----------
    scans : int
        The scans copied.
    messages : dict
        For a whole-bag copy, the messages written per topic (empty for a scans-only copy).
    """

    scans: int
    messages: dict = field(default_factory=dict)


def convert_recording(src: str | Path, dst: str | Path, *, topic: str | None = None, format: str | None = None,
                      overwrite: bool = False, progress: bool = False, strict: bool = False,
                      poses: str | bool | None = None, only_scans: bool = False,
                      scans: slice | None = None) -> Conversion:
    """:func:`convert`, saying what it wrote (:class:`Conversion`).

    Parameters
    ----------
    src : str or Path
        The recording to copy.
    dst : str or Path
        The output; its format from its name unless ``format`` is given.
    topic : str, optional
        The LaserScan topic (for a scans-only copy), as for :func:`read_scans`.
    format : str, optional
        The output's format, a name of :data:`labkit.io.FORMATS` with a writer.
    overwrite : bool, default False
        Replace an existing ``dst`` of the same kind.
    progress : bool, default False
        Show a progress bar.
    strict : bool, default False
        Stop at the first record that cannot be decoded.
    poses : str, bool or None
        Where the scans' poses come from, as for :func:`read_scans`.
    only_scans : bool, default False
        Copy the scans alone, also between bags.
    scans : slice, optional
        Only this range of scans, as for :func:`convert`.

    Returns
    -------
    Conversion
        The scans copied and, for a whole-bag copy, the messages per topic.
    """
    src, dst = Path(src), Path(dst)
    fmt = output_format(dst, format)
    src_fmt = detect_format(src)
    if not only_scans and src_fmt in bags.BAG_FORMATS and fmt in bags.BAG_FORMATS:
        if scans is not None:
            raise RefusedError("a scan range is a scans-only copy: a bag-to-bag copy carries every topic whole "
                               "(only_scans=True for the range's scans alone)",
                               "--scans and --time choose what --only-scans copies; without it a bag-to-bag copy "
                               "carries every topic whole")
        if topic is not None or poses not in (None, True):
            raise RefusedError("topic and poses choose what a scans-only copy holds; a bag-to-bag copy carries every "
                               "topic as it is (only_scans=True for the scans alone)",
                               "--topic and --poses choose what --only-scans copies; without it a bag-to-bag copy "
                               "carries every topic as it is")
        if src.is_file() and src.stat().st_size == 0:
            raise EmptyRecordingError(f"{src} is empty (0 bytes): there is nothing to read")
        bags.list_topics(src, src_fmt)  # an empty bag, or one too damaged to declare a topic: refused here
        check_output(dst, output_kind(dst, fmt), overwrite=overwrite, inputs=[src])
        from .bagcopy import copy_bag

        n_scans, _n, per_topic = copy_bag(src, src_fmt, dst, fmt, overwrite=overwrite, strict=strict,
                                          progress=progress)
        return Conversion(n_scans, dict(per_topic))
    stream = read_scans(src, topic=topic, strict=strict, poses=poses, scans=scans)
    check_output(dst, output_kind(dst, fmt), overwrite=overwrite, inputs=[src])  # refuse before reading
    restamp = None
    if FORMATS[stream.format].free_stamps and not FORMATS[fmt].free_stamps:
        try:
            restamp, note = plan_stamps(read_scans(src, topic=topic, poses=False, scans=scans), fmt)
        except CorruptFileError:  # read what can be read; the conversion reports the damage
            restamp, note = plan_stamps(_readable(read_scans(src, topic=topic, poses=False, scans=scans)), fmt)
        if note:
            warnings.warn(f"{src}: {note}", StampsChangedWarning, stacklevel=2)
    written: Iterable[Scan] = stream
    if restamp is not None:
        written = (restamp(scan, k) for k, scan in enumerate(stream))
    if progress:
        from tqdm.auto import tqdm

        written = tqdm(written, total=stream.count, unit="scan", desc=f"convert {src.name}")
    return Conversion(write_scans(written, dst, fmt, overwrite=overwrite, inputs=[src]))


def _readable(stream: Iterable[Scan]) -> Iterator[Scan]:
    try:
        yield from stream
    except CorruptFileError:
        return


# ---------------------------------------------------------------------------- the built-in formats
def _read_bag(stream: ScanStream) -> Iterator[Scan]:
    poses = None
    if stream.pose_plan is not None:
        unwatched = WATCHED.set(None)  # a scan range reports what the scans' reader met, not the whole pose pass
        try:
            poses = read_bag_poses(stream.path, stream.format, stream.pose_plan, stream.readable, stream.strict,
                                   expected=stream.pose_count)
        finally:
            WATCHED.reset(unwatched)
        stream.pose_sources = poses.sources  # filled in as scan frames are met
    assert stream.topic is not None  # a bag's stream always names its topic (_open_bag resolves it)
    yield from bags.iter_bag(stream.path, stream.format, stream.topic, stream.readable, stream.strict, poses=poses,
                             expected=stream.held)


def _open_bag(p: Path, fmt: str, topic: str | None, strict: bool, poses: str | bool | None) -> ScanStream:
    topics, readable = bags.list_topics(p, fmt)
    chosen = bags.resolve_topic(p, topics, topic)
    count = next((c for name, _t, c in topics if name == chosen), None)  # the index's, when it can be read
    plan = plan_poses(p, topics, None if poses is True else poses)
    stream = ScanStream(p, fmt, chosen, count, readable, strict, plan.describe() if plan else None, plan)
    pose_counts = [c for name, _t, c in topics if plan is not None and name in plan.msgtypes]
    if pose_counts and all(c is not None for c in pose_counts):
        stream.pose_count = sum(c for c in pose_counts if c is not None)
    return stream


def _write_bag(fmt: str):
    def write(scans: Iterable[Scan], path: Path, *, topic: str = "/scan", overwrite: bool = False,
              inputs: Iterable[str | Path] = ()) -> int:
        return write_bag(scans, path, fmt, topic=topic, overwrite=overwrite, inputs=inputs)
    return write


def _bag_metadata(p: Path) -> str | None:
    meta = p / "metadata.yaml"
    return meta.read_text(errors="replace") if meta.exists() else None


def _is_ros2_folder(p: Path) -> bool:
    meta = _bag_metadata(p)
    if meta is not None:
        return "storage_identifier: mcap" not in meta
    return not any(p.glob("*.mcap")) and any(p.glob("*.db3"))


def _is_mcap_folder(p: Path) -> bool:
    meta = _bag_metadata(p)
    return "storage_identifier: mcap" in meta if meta is not None else any(p.glob("*.mcap"))


def _bag_row(name: str, suffixes: tuple[str, ...], description: str, **kw) -> FileFormat:
    return FileFormat(name, suffixes, description, read=_read_bag, write=_write_bag(name),
                      output_kind=partial(bags.output_kind, fmt=name), free_stamps=False, open=_open_bag,
                      name_format=bags.bag_format, list_topics=partial(bags.list_topics, fmt=name), **kw)


def _open_carmen(p: Path, fmt: str, topic: str | None, strict: bool, poses: str | bool | None) -> ScanStream:
    _refuse_pose_topic(fmt, poses)
    inline = None if poses is False else "the log's laser poses"
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


def _read_carmen(stream: ScanStream) -> Iterator[Scan]:
    return read_carmen(stream.path, stream.topic, strict=stream.strict)


def _read_json(stream: ScanStream) -> Iterator[Scan]:
    return iter([read_json_scan(stream.path)])


def _count_one(_path: Path) -> int:
    return 1


def _write_json(scans: Iterable[Scan], path: Path, *, topic: str = "/scan", overwrite: bool = False,
                inputs: Iterable[str | Path] = ()) -> int:
    items = list(scans)
    if len(items) != 1:
        raise ValueError(f"a .json file holds exactly one scan, got {len(items)}; use .jsonl")
    write_json_scan(items[0], path, overwrite=overwrite, inputs=inputs)
    return 1


def _read_jsonl(stream: ScanStream) -> Iterator[Scan]:
    return read_json_lines(stream.path, strict=stream.strict)


def _write_jsonl(scans: Iterable[Scan], path: Path, *, topic: str = "/scan", overwrite: bool = False,
                 inputs: Iterable[str | Path] = ()) -> int:
    return write_json_lines(scans, path, overwrite=overwrite, inputs=inputs)


register_format(_bag_row("ros1", (".bag",), "ROS1 bag (.bag)", noun="ROS1 bags", label=".bag"))
register_format(_bag_row("ros2", (), "ROS2 bag folder with sqlite3 storage (metadata.yaml + .db3)",
                         noun="ROS2 bags", label="ROS2 bag folder", folder=True, detect=_is_ros2_folder))
register_format(_bag_row("mcap", (".mcap",), "MCAP file (.mcap) or ROS2 bag folder with MCAP storage",
                         noun="MCAP bags", label=".mcap", detect=_is_mcap_folder))
register_format(FileFormat("carmen", (".log", ".log.gz", ".clf", ".clf.gz"), "CARMEN log (.log, .clf, optionally .gz)",
                           read=_read_carmen, noun="CARMEN logs", label="CARMEN .log/.gz", open=_open_carmen))
register_format(FileFormat("json", (".json",), "one scan as JSON {ranges, bearings} (.json)", read=_read_json,
                           count=_count_one, write=_write_json, output_kind=JSON_SCAN, in_folders=False))
register_format(FileFormat("jsonl", (".jsonl",), "scans as JSON lines, one per line (.jsonl)", read=_read_jsonl,
                           write=_write_jsonl, output_kind=JSON_LINES, in_folders=False))
_BUILT_IN = frozenset(FORMATS)  # the formats above (an empty file of a format registered later is its own affair)
