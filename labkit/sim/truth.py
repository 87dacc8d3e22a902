"""Ground truth: what each simulated scan should contain, and the ``.truth.jsonl`` files."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from .._safe import OutputKind, first_json_line_with, safe_output

__all__ = ["VisibleWall", "VisibleCircle", "VisibleArc", "VisibleLeg", "ScanTruth", "GroundTruth",
           "TRUTH_FILE", "write_truth", "read_truth", "TruthStream", "truth_path_for"]

_ROUND = 6  # decimals kept in ground-truth files (micrometres, micro-radians)


# ============================================================================ ground truth
@dataclass(frozen=True)
class VisibleWall:
    """The visible part of a wall in one scan, in the sensor frame.

    On a full-circle scan a run of beams may cross the seam: then ``first > last``.

    Parameters
    ----------
    wall_id : int
        Its object id (as in ``hits``).
    name : str
        Its name in the world.
    r : float
        The wall's line in normal form: distance from the sensor, metres.
    alpha : float
        The wall's line in normal form: the normal's angle, radians.
    start : tuple of (float, float)
        The true (noise-free) hit point of the first beam of the run that hits it.
    end : tuple of (float, float)
        The true hit point of the last beam of that run.
    first : int
        The first beam of the run of consecutive beams that hit it.
    last : int
        The last beam of that run.
    n_beams : int
        How many beams hit it.
    """

    wall_id: int
    name: str
    r: float
    alpha: float
    start: tuple[float, float]
    end: tuple[float, float]
    first: int
    last: int
    n_beams: int

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))


@dataclass(frozen=True)
class VisibleCircle:
    """A circle (column, bench foot, rolling cylinder) seen in one scan, sensor frame.

    Parameters
    ----------
    object_id : int
        Its object id (as in ``hits``).
    name : str
        Its name in the world.
    kind : str
        ``"column"``, ``"bench"``, ``"cylinder"``, ...
    center : tuple of (float, float)
        Its centre, metres.
    radius : float
        Its radius, metres.
    first : int
        The first beam that hits it.
    last : int
        The last beam that hits it.
    n_beams : int
        How many beams hit it.
    """

    object_id: int
    name: str
    kind: str
    center: tuple[float, float]
    radius: float
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class VisibleArc:
    """An arc (rounded corner) seen in one scan, in the sensor frame.

    Parameters
    ----------
    object_id : int
        Its object id (as in ``hits``).
    name : str
        Its name in the world.
    center : tuple of (float, float)
        The arc's centre, metres.
    radius : float
        Its radius, metres.
    start : tuple of (float, float)
        The true hit point of its first beam.
    end : tuple of (float, float)
        The true hit point of its last beam.
    first : int
        The first beam that hits it.
    last : int
        The last beam that hits it.
    n_beams : int
        How many beams hit it.
    """

    object_id: int
    name: str
    center: tuple[float, float]
    radius: float
    start: tuple[float, float]
    end: tuple[float, float]
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class VisibleLeg:
    """One leg of a person seen in one scan (sensor frame).

    Parameters
    ----------
    object_id : int
        Its object id (as in ``hits``).
    person : str
        The person's name.
    center : tuple of (float, float)
        The leg's centre, metres.
    diameter : float
        Its diameter, metres.
    first : int
        The first beam that hits it.
    last : int
        The last beam that hits it.
    n_beams : int
        How many beams hit it.
    """

    object_id: int
    person: str
    center: tuple[float, float]
    diameter: float
    first: int
    last: int
    n_beams: int


@dataclass(frozen=True)
class ScanTruth:
    """What one simulated scan contains.

    Parameters
    ----------
    stamp_ns : int
        The scan's time stamp, nanoseconds.
    pose : tuple of (float, float, float)
        The sensor pose in the world, ``(x, y, theta)``.
    hits : ndarray of shape (N,), int
        The object id each beam hit (see :meth:`labkit.sim.World.objects`), -1 where the beam hit
        nothing within range.
    walls : tuple of VisibleWall
        The walls seen.
    circles : tuple of VisibleCircle
        The circles seen (columns, bench feet, rolling cylinders).
    arcs : tuple of VisibleArc
        The arcs seen.
    legs : tuple of VisibleLeg
        The legs seen.
    """

    stamp_ns: int
    pose: tuple[float, float, float]
    hits: np.ndarray = field(repr=False)
    walls: tuple[VisibleWall, ...] = ()
    circles: tuple[VisibleCircle, ...] = ()
    arcs: tuple[VisibleArc, ...] = ()
    legs: tuple[VisibleLeg, ...] = ()

    def to_json(self) -> dict:
        runs = _runs(self.hits, wrap=False)
        return {
            "stamp_ns": int(self.stamp_ns),
            "pose": [round(v, _ROUND) for v in self.pose],
            "hits": [[int(a), int(b), int(o)] for a, b, o in runs],
            "walls": [_rounded(asdict(w)) for w in self.walls],
            "circles": [_rounded(asdict(c)) for c in self.circles],
            "arcs": [_rounded(asdict(a)) for a in self.arcs],
            "legs": [_rounded(asdict(g)) for g in self.legs],
        }

    @classmethod
    def from_json(cls, d: dict, n_beams: int) -> ScanTruth:
        hits = np.full(n_beams, -1, dtype=np.int64)
        for a, b, o in d["hits"]:
            hits[a:b + 1] = o

        def tup(items, kind):
            out = []
            for it in items:
                it = dict(it)
                for k in ("start", "end", "center"):
                    if k in it:
                        it[k] = tuple(it[k])
                out.append(kind(**it))
            return tuple(out)

        return cls(
            stamp_ns=int(d["stamp_ns"]),
            pose=tuple(d["pose"]),
            hits=hits,
            walls=tup(d["walls"], VisibleWall),
            circles=tup(d["circles"], VisibleCircle),
            arcs=tup(d["arcs"], VisibleArc),
            legs=tup(d["legs"], VisibleLeg),
        )


def _rounded(d):
    if isinstance(d, float):
        return round(d, _ROUND)
    if isinstance(d, dict):
        return {k: _rounded(v) for k, v in d.items()}
    if isinstance(d, list | tuple):
        return [_rounded(v) for v in d]
    if isinstance(d, np.generic):
        return _rounded(d.item())
    return d


def _runs(labels: np.ndarray, wrap: bool) -> list[tuple[int, int, int]]:
    """Runs ``(first, last, label)`` of equal consecutive labels, -1 labels skipped.

    With ``wrap`` a run touching both ends of the array is joined across the seam and
    reported with ``first > last``.
    """
    n = len(labels)
    if n == 0:
        return []
    change = np.flatnonzero(np.diff(labels) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change - 1, [n - 1]])
    runs = [(int(a), int(b), int(labels[a])) for a, b in zip(starts, ends, strict=True)]
    if wrap and len(runs) > 1 and runs[0][2] == runs[-1][2]:
        first, last = runs[0], runs[-1]
        runs = runs[1:-1] + [(last[0], first[1], first[2])]
    return [r for r in runs if r[2] >= 0]


def _run_len(first: int, last: int, n: int) -> int:
    return last - first + 1 if last >= first else n - first + last + 1



# ============================================================================ truth files
def truth_path_for(bag_path: str | Path) -> Path:
    """Where the ground truth of a recording lives: ``<name>.truth.jsonl`` beside it.

    Parameters
    ----------
    bag_path : str or Path
        The recording.

    Returns
    -------
    Path
        Its ground-truth file (whether or not it exists).
    """
    p = Path(bag_path)
    stem = p.name[: -len(p.suffix)] if p.suffix in (".bag", ".mcap", ".db3") else p.name
    return p.with_name(f"{stem}.truth.jsonl")


@dataclass(frozen=True)
class GroundTruth:
    """The ground truth of a whole recording: a header and one :class:`ScanTruth` per scan.

    A scan's truth is looked up by stamp (``truth[stamp_ns]``).

    Parameters
    ----------
    header : dict
        The file's header: format version, world, lidar, object table, seed.
    scans : dict of int to ScanTruth
        Each scan's truth by its ``stamp_ns``.
    """

    header: dict
    scans: dict[int, ScanTruth]

    def __getitem__(self, stamp_ns: int) -> ScanTruth:
        return self.scans[int(stamp_ns)]

    def __contains__(self, stamp_ns: object) -> bool:
        return stamp_ns in self.scans

    def __len__(self) -> int:
        return len(self.scans)

    def __iter__(self):
        return iter(self.scans.values())

    @property
    def objects(self) -> list[dict]:
        return self.header["objects"]


#: What :func:`write_truth` writes (see labkit._safe): how an existing one is recognised.
TRUTH_FILE = OutputKind("a labkit ground-truth file (.truth.jsonl)", (".truth.jsonl",),
                        first_json_line_with("labkit_truth"))


class Recorded(Protocol):
    """What a ground-truth file's header describes: a world and a lidar (each with ``to_dict()``),
    the topic and the frame of the scans (a :class:`labkit.sim.Scenario`)."""

    @property
    def world(self) -> Any: ...
    @property
    def lidar(self) -> Any: ...
    @property
    def topic(self) -> str: ...
    @property
    def frame_id(self) -> str: ...


def write_truth(path: str | Path, sc: Recorded, truths, *, seed: int, overwrite: bool = False) -> int:
    """Write the truth of every scan as JSON lines.

    Line 1 is a header (format version, world, lidar, object table, seed); every further
    line is one scan's truth keyed by ``stamp_ns``. Written under a temporary name and
    renamed when complete.

    Parameters
    ----------
    path : str or Path
        The file to write.
    sc : labkit.sim.Scenario
        What the header describes: the world, the lidar, the topic and the frame of the scans.
    truths : iterable of ScanTruth
        The scans' truths, in time order.
    seed : int
        The simulation's seed, kept in the header.
    overwrite : bool
        Replace an existing ground-truth file (never any other kind of file).

    Returns
    -------
    int
        How many scans' truths were written.
    """
    header = {
        "labkit_truth": 1,
        "world": _rounded(sc.world.to_dict()),
        "lidar": _rounded(sc.lidar.to_dict()),
        "objects": sc.world.objects(),
        "seed": int(seed),
        "topic": sc.topic,
        "frame_id": sc.frame_id,
    }
    count = 0
    with safe_output(path, TRUTH_FILE, overwrite=overwrite) as tmp, \
            open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(json.dumps(header, separators=(",", ":")) + "\n")
        for tr in truths:
            fh.write(json.dumps(tr.to_json(), separators=(",", ":")) + "\n")
            count += 1
    return count


def read_truth(path: str | Path) -> GroundTruth:
    """Read a ground-truth JSON-lines file written by :func:`write_truth`, all of it, into memory.

    :class:`TruthStream` reads one scan at a time.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    GroundTruth
        The header and every scan's truth.
    """
    stream = TruthStream(path)
    return GroundTruth(stream.header, {tr.stamp_ns: tr for tr in stream})


class TruthStream:
    """A ground-truth file read one scan at a time, so that memory stays flat however long the recording.

    ``header`` (line 1) is read at once; iterating gives each scan's :class:`ScanTruth` in file
    order (the simulator writes them in time order).

    Parameters
    ----------
    path : str or Path
        The file (:func:`write_truth`'s). A first line that is not a labkit ground-truth header
        raises ``ValueError``.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        with open(self.path, encoding="utf-8") as fh:
            try:
                header = json.loads(fh.readline())
            except json.JSONDecodeError as exc:
                raise ValueError(f"{self.path}: line 1 is not a labkit ground-truth header: {exc}") from None
        if not isinstance(header, dict) or header.get("labkit_truth") != 1:
            raise ValueError(f"{self.path}: line 1 is not a labkit ground-truth header")
        self.header = header

    def __iter__(self) -> Iterator[ScanTruth]:
        n = int(self.header["lidar"]["n_beams"])
        with open(self.path, encoding="utf-8") as fh:
            fh.readline()
            for lineno, line in enumerate(fh, start=2):
                if not line.strip():
                    continue
                try:
                    tr = ScanTruth.from_json(json.loads(line), n)
                except (json.JSONDecodeError, KeyError, TypeError) as exc:
                    raise ValueError(f"{self.path}: line {lineno} is not a scan record: {exc}") from None
                yield tr
