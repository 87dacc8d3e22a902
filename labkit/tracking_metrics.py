"""Scores of a tracker against ground truth: CLEAR MOT and the identity measures (IDF1).

A tracking result is compared with the truth scan by scan (a *frame*): which true objects are
there, where, and which hypotheses (tracks) the tracker reports, where. A hypothesis can
stand for a true object when they are at most ``max_distance_m`` apart (0.5 m by default, a
person's width).

**CLEAR MOT** (Bernardin and Stiefelhagen 2008). Frame by frame:

1. a true object keeps the hypothesis it was last matched to (in any earlier frame) if that
   hypothesis is there and close enough;
2. the other objects and hypotheses are matched one to one, as many pairs within
   ``max_distance_m`` as possible, then the least total distance (Hungarian algorithm); a new
   match of an object that was last matched to another hypothesis is an **identity switch**;
3. objects left unmatched are **misses**, hypotheses left unmatched **false positives**.

Then MOTA = 1 - (misses + false positives + switches) / objects (summed over the frames; it
can be negative; with no object at all it is NaN, or -inf if anything was reported), MOTP =
the mean distance of the matches (metres; lower is better), and a **fragmentation** is counted
each time a true object's track is interrupted: between its first and last matched frame, a
frame where it is missed right after one where it was matched (frames where the object is
absent do not count).

**IDF1** (Ristani et al. 2016): each true trajectory is paired with at most one hypothesis
trajectory, once for the whole sequence, so as to maximise the frames in which the two are
present and within ``max_distance_m`` (IDTP); then IDF1 = 2 IDTP / (objects + hypotheses),
counted in frames, with IDP = IDTP / hypotheses and IDR = IDTP / objects.

These are the definitions of the ``motmetrics`` package (py-motmetrics 1.4), which
``tests/test_tracking_metrics.py`` uses as an oracle on hand-built and random sequences.

**Objects that cannot be seen.** A frame may also list the positions of true objects that are
present but not visible (:attr:`MOTFrame.ignored_xy`: a walker hidden behind another, or seen by
too few beams). As in the MOTChallenge evaluation, the hypotheses are first matched one to one
(within ``max_distance_m``, Hungarian) against all true objects, seen or not; those matched to
an unseen object are dropped from the frame (a track that coasts through an occlusion is
neither a false positive nor a match), then the frame is scored as above.

:func:`sim_frames` builds the frames of a simulated recording: the truth is
:meth:`labkit.sim.World.movers_at` (walkers' bodies and rolling cylinders) in the tracking frame,
an object being visible when at least ``min_beams`` beams hit it, and the hypotheses are the
tracks of status ``"confirmed"``.

References
----------
K. Bernardin and R. Stiefelhagen, "Evaluating multiple object tracking performance: the CLEAR
MOT metrics", EURASIP J. Image and Video Processing, 2008. E. Ristani et al., "Performance
measures and a data set for multi-target, multi-camera tracking", ECCV Workshops 2016.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ._validate import check_int, check_positive
from .geometry import inverse_transform_points
from .sim.lidar import EPOCH_NS

__all__ = ["MOTFrame", "MOTScores", "clear_mot", "sim_frames"]


@dataclass(frozen=True, eq=False)
class MOTFrame:
    """One frame of a tracking result against its truth.

    Parameters
    ----------
    truth_ids : sequence of hashable, length n
        The true objects present and visible (names or numbers, unique in the frame).
    truth_xy : ndarray (n, 2), metres
        Their positions.
    hyp_ids : sequence of hashable, length m
        The hypotheses (track ids, unique in the frame).
    hyp_xy : ndarray (m, 2), metres
        Their positions.
    ignored_xy : ndarray (k, 2), metres
        True objects present but not visible (see the module docstring); none by default.
    """

    truth_ids: tuple
    truth_xy: np.ndarray
    hyp_ids: tuple
    hyp_xy: np.ndarray
    ignored_xy: np.ndarray | None = None

    def __post_init__(self) -> None:
        for ids, xy in (("truth_ids", "truth_xy"), ("hyp_ids", "hyp_xy"), (None, "ignored_xy")):
            value = getattr(self, xy)
            n = len(getattr(self, ids)) if ids else None
            a = np.zeros((0, 2)) if value is None else np.array(value, dtype=np.float64).reshape(-1, 2)
            if (n is not None and a.shape != (n, 2)) or not np.isfinite(a).all():
                raise ValueError(f"{xy} must be finite, of shape ({n if n is not None else 'k'}, 2), got "
                                 f"{np.shape(value)}")
            object.__setattr__(self, xy, a)
            if ids:
                names = tuple(getattr(self, ids))
                if len(set(names)) != len(names):
                    raise ValueError(f"{ids} must be unique in a frame, got {list(names)}")
                object.__setattr__(self, ids, names)


@dataclass(frozen=True)
class MOTScores:
    """CLEAR MOT and identity scores over a sequence (see the module docstring).

    Parameters
    ----------
    frames : int
        Frames scored.
    objects : int
        True objects, visible ones, frame by frame, counted over all frames.
    hypotheses : int
        Hypotheses over all frames, after dropping those on unseen objects.
    matches : int
        The matched pairs, those with an identity switch included (Bernardin's ``c_t``).
    misses : int
        True objects not matched.
    false_positives : int
        Hypotheses not matched.
    id_switches : int
        Identity switches.
    fragmentations : int
        Fragmentations of a true object's track.
    mota : float
        Multiple object tracking accuracy.
    motp : float
        Multiple object tracking precision, metres.
    idtp : int
        Identity true positives.
    idf1 : float
        Identity F1 score.
    idp : float
        Identity precision.
    idr : float
        Identity recall.
    ignored : int
        The hypotheses dropped on unseen objects.
    """

    frames: int
    objects: int
    hypotheses: int
    matches: int
    misses: int
    false_positives: int
    id_switches: int
    fragmentations: int
    mota: float
    motp: float
    idtp: int
    idf1: float
    idp: float
    idr: float
    ignored: int

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _match(cost: np.ndarray, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """As many pairs as possible among the ``allowed`` ones, then the least total cost."""
    if not allowed.any():
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    c = float(np.abs(cost[allowed]).max()) + 1.0
    from scipy.optimize import linear_sum_assignment  # here, not at import: scipy adds 22 MB to every process
    rows, cols = linear_sum_assignment(np.where(allowed, cost, 2.0 * min(cost.shape) * c + 1.0))
    keep = allowed[rows, cols]
    return rows[keep], cols[keep]


def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])


def _drop_on_unseen(frame: MOTFrame, max_distance_m: float) -> tuple[tuple, np.ndarray, int]:
    """The frame's hypotheses less those matched to a true object that is not visible."""
    ignored = frame.ignored_xy  # (0, 2) when none were given (MOTFrame.__post_init__)
    if ignored is None or not len(ignored) or not len(frame.hyp_ids):
        return frame.hyp_ids, frame.hyp_xy, 0
    every = np.vstack([frame.truth_xy, ignored])
    d = _distances(every, frame.hyp_xy)
    rows, cols = _match(d, d <= max_distance_m)
    drop = np.zeros(len(frame.hyp_ids), dtype=bool)
    drop[cols[rows >= len(frame.truth_ids)]] = True
    keep = np.flatnonzero(~drop)
    return tuple(frame.hyp_ids[k] for k in keep), frame.hyp_xy[keep], int(drop.sum())


def clear_mot(frames: Iterable[MOTFrame], *, max_distance_m: float = 0.5) -> MOTScores:
    """CLEAR MOT (MOTA, MOTP, identity switches, fragmentations) and IDF1 of a sequence of frames.

    CLEAR MOT (MOTA, MOTP, identity switches, fragmentations) and IDF1 of a sequence of
    :class:`MOTFrame` (see the module docstring for the rules).

    Parameters
    ----------
    frames : iterable of MOTFrame
        In time order.
    max_distance_m : float, metres
        The largest distance at which a hypothesis stands for a true object. Default 0.5 m.

    Returns
    -------
    MOTScores
        MOTA, MOTP, IDF1 and the counts they come from (matches, misses, false positives, identity
        switches, fragmentations).

    Examples
    --------
    One person, tracked for two frames, lost, then found again under a new identity:

    >>> xy = [[1.0, 0.0]]
    >>> frames = [MOTFrame(("ann",), xy, (1,), xy), MOTFrame(("ann",), xy, (1,), [[1.1, 0.0]]),
    ...           MOTFrame(("ann",), xy, (), None), MOTFrame(("ann",), xy, (2,), xy)]
    >>> s = clear_mot(frames)
    >>> s.matches, s.misses, s.id_switches, s.fragmentations, round(s.mota, 3), round(s.motp, 3)
    (3, 1, 1, 1, 0.5, 0.033)
    """
    max_distance_m = check_positive("max_distance_m", max_distance_m)
    last_hyp: dict = {}  # true object -> the hypothesis it was last matched to
    tracked: dict = {}  # true object -> [matched?] in the frames where it is present
    pair_frames: dict = {}  # (object, hypothesis) -> frames both present within max_distance_m
    object_frames: dict = {}
    hyp_frames: dict = {}
    n_frames = objects = hypotheses = matches = misses = false_pos = switches = ignored = 0
    distance_sum = 0.0
    for frame in frames:
        if not isinstance(frame, MOTFrame):
            raise ValueError(f"frames must be MOTFrame records, got {type(frame).__name__}")
        n_frames += 1
        hyp_ids, hyp_xy, dropped = _drop_on_unseen(frame, max_distance_m)
        ignored += dropped
        oids = frame.truth_ids
        d = _distances(frame.truth_xy, hyp_xy)
        close = d <= max_distance_m
        objects += len(oids)
        hypotheses += len(hyp_ids)
        for o in oids:
            object_frames[o] = object_frames.get(o, 0) + 1
        for h in hyp_ids:
            hyp_frames[h] = hyp_frames.get(h, 0) + 1
        for i, j in zip(*np.nonzero(close), strict=True):
            key = (oids[i], hyp_ids[j])
            pair_frames[key] = pair_frames.get(key, 0) + 1
        # 1. keep last correspondences
        o_done = np.zeros(len(oids), dtype=bool)
        h_done = np.zeros(len(hyp_ids), dtype=bool)
        column = {h: j for j, h in enumerate(hyp_ids)}
        pairs = []
        for i, o in enumerate(oids):
            j = column.get(last_hyp.get(o, _NONE))
            if j is not None and close[i, j] and not h_done[j]:
                o_done[i] = h_done[j] = True
                pairs.append((i, j))
        # 2. match the rest; a new partner of an object matched before is a switch
        free = close & ~o_done[:, None] & ~h_done[None, :]
        rows, cols = _match(d, free)
        for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
            o, h = oids[i], hyp_ids[j]
            if o in last_hyp and last_hyp[o] != h:
                switches += 1
            o_done[i] = h_done[j] = True
            pairs.append((i, j))
        for i, j in pairs:
            last_hyp[oids[i]] = hyp_ids[j]
            distance_sum += float(d[i, j])
        # 3. misses and false positives
        matches += len(pairs)
        misses += int((~o_done).sum())
        false_pos += int((~h_done).sum())
        for i, o in enumerate(oids):
            tracked.setdefault(o, []).append(bool(o_done[i]))
    fragmentations = sum(_interruptions(flags) for flags in tracked.values())
    idtp = _id_true_positives(pair_frames)
    return MOTScores(
        frames=n_frames, objects=objects, hypotheses=hypotheses, matches=matches, misses=misses,
        false_positives=false_pos, id_switches=switches, fragmentations=fragmentations,
        mota=_mota(misses + false_pos + switches, objects),
        motp=distance_sum / matches if matches else float("nan"),
        idtp=idtp, idf1=2.0 * idtp / (objects + hypotheses) if objects + hypotheses else float("nan"),
        idp=idtp / hypotheses if hypotheses else float("nan"), idr=idtp / objects if objects else float("nan"),
        ignored=ignored)


_NONE = object()


def _mota(errors: int, objects: int) -> float:
    """1 - errors / objects; with no object: NaN without errors, -inf with some (as motmetrics)."""
    if objects:
        return 1.0 - errors / objects
    return -math.inf if errors else math.nan


def _interruptions(flags: list[bool]) -> int:
    """How often a run of matched frames is followed by a missed one, between the first and
    the last matched frame."""
    f = np.array(flags, dtype=bool)
    hit = np.flatnonzero(f)
    if len(hit) == 0:
        return 0
    span = f[hit[0]:hit[-1] + 1]
    return int((span[:-1] & ~span[1:]).sum())


def _id_true_positives(pair_frames: dict) -> int:
    """The most frames of co-presence within the distance that a one-to-one pairing of true
    and hypothesis trajectories can collect (a maximum-weight bipartite matching)."""
    if not pair_frames:
        return 0
    objs = sorted({o for o, _ in pair_frames}, key=repr)
    hyps = sorted({h for _, h in pair_frames}, key=repr)
    oi = {o: i for i, o in enumerate(objs)}
    hi = {h: j for j, h in enumerate(hyps)}
    w = np.zeros((len(objs), len(hyps)))
    for (o, h), n in pair_frames.items():
        w[oi[o], hi[h]] = n
    from scipy.optimize import linear_sum_assignment  # here, not at import: scipy adds 22 MB to every process
    rows, cols = linear_sum_assignment(w, maximize=True)
    return int(w[rows, cols].sum())


# ============================================================================ simulated truth
def sim_frames(world, truths: Iterable, tables: Iterable, *, kind: str | None = None, min_beams: int = 3
               ) -> list[MOTFrame]:
    """The frames of a simulated recording: its moving truth against the confirmed tracks.

    Parameters
    ----------
    world : labkit.sim.World
        The simulated world (:meth:`~labkit.sim.World.movers_at` gives the truth).
    truths : iterable of labkit.sim.ScanTruth
        The recording's truth, one per scan, in time order (its ``stamp_ns`` gives the time
        ``t = (stamp_ns - EPOCH_NS) / 1e9`` the simulator placed the movers at, its ``pose``
        the sensor, its ``hits`` which beams saw them).
    tables : iterable of labkit.tracking.TrackTable
        The tracker's output, one per scan, the same scans in the same order.
    kind : {"person", "cylinder"} or None
        Score walkers against person tracks only, or rolling cylinders against circle tracks
        only; None (default): every mover against every confirmed track.
    min_beams : int
        A mover is visible when at least this many beams hit one of its parts (a leg, the
        cylinder); otherwise it is an unseen object (:attr:`MOTFrame.ignored_xy`).

    Returns
    -------
    list of MOTFrame
        One frame per scan, in order.
    """
    min_beams = check_int("min_beams", min_beams, 1)
    if kind not in (None, "person", "cylinder"):
        raise ValueError(f"kind must be 'person', 'cylinder' or None, got {kind!r}")
    track_kind = {None: None, "person": "person", "cylinder": "circle"}[kind]
    out = []
    for truth, table in zip(truths, tables, strict=True):
        if int(truth.stamp_ns) != int(table.stamp_ns):
            raise ValueError(f"truths and tables must be the same scans: stamps {truth.stamp_ns} and {table.stamp_ns}")
        movers = [m for m in world.movers_at((int(truth.stamp_ns) - EPOCH_NS) * 1e-9) if kind in (None, m.kind)]
        centers = np.array([m.center for m in movers], dtype=np.float64).reshape(-1, 2)
        if table.frame == "sensor":
            centers = inverse_transform_points(centers, truth.pose).reshape(-1, 2)
        seen = np.array([max((int(np.count_nonzero(truth.hits == oid)) for oid in m.object_ids), default=0)
                         >= min_beams for m in movers], dtype=bool)
        rows = table.confirmed()
        if track_kind is not None:
            rows &= table.kinds == track_kind
        out.append(MOTFrame(tuple(m.name for m, s in zip(movers, seen, strict=True) if s), centers[seen],
                            tuple(table.ids[rows].tolist()), table.states[rows, :2], centers[~seen]))
    return out
