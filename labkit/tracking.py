"""Tracking over time: people and moving round objects keep an identity from scan to scan.

The detectors find people (leg pairs, :class:`labkit.Person`), single legs and circles in each
scan; this module connects one scan's detections to the next. Each target is a *track*: a
constant-velocity Kalman filter over ``(x, y, vx, vy)`` with an identity and a life cycle.
:meth:`Tracker.step` takes one scan's detections through the steps of the classic tracker
(Bar-Shalom and Li; Blackman and Popoli, ch. 6-7), each a function of its own below:

1. **predict** every track to the scan's time with the constant-velocity model
   (:func:`cv_predict`; :func:`cv_model` gives ``F`` and ``Q``);
2. **gate**: the squared Mahalanobis distance ``d2 = nu' S^-1 nu`` of every detection to every
   track of its kind (:func:`innovation`), kept when under the chi-square quantile of 2 degrees
   of freedom at ``gate_probability`` (:func:`gate_threshold`);
3. **assign**: global nearest neighbour (:func:`assign`, with
   ``scipy.optimize.linear_sum_assignment``): as many (track, detection) pairs inside the gates
   as possible, and among those the least total cost ``d2 + ln det S`` (the negative
   log-likelihood of the pair, less a constant);
4. **update** each assigned track with its detection (:func:`kalman_update`, Joseph form);
   a *static* circle track (below) not detected at this scan is put at rest: its velocity is set
   to zero, so that a column hidden for a few scans stays where it stands instead of coasting away
   on the velocity that one off-centre detection (a partly hidden column's fit) gave it. (Coasting
   away, it left its column's next detections to a passing moving circle's track, which was then
   confirmed as a moving target on the column: issue 36, a robot driving past the columns.) A
   moving track coasts on its velocity, and so does a person's static track: a walker is "static"
   in its first scans, until it has gone ``min_travel_m`` (putting walkers at rest too lost them
   more often: MOTA 0.950 instead of 0.955 in the benchmark's hall with 6 walkers);
5. **birth**: a *tentative* track for every person (leg pair) or circle detection that lies
   outside every gate of its kind (a single leg never starts a track: a leg alone is too weak a
   cue for a person, and a detection inside a gate belongs to a target already followed);
6. **confirm** a tentative track detected in ``confirm_hits`` (M) of its first
   ``confirm_scans`` (N) scans, the birth scan included. It is confirmed as ``"static"`` until it
   has moved: until M updates in a row have put its estimate further than ``min_travel_m`` from
   where it was first seen (the mean of its first M detections). Then it becomes ``"confirmed"``
   (a moving target), and stays so when the target stops. A single wrong detection cannot make a
   track move, and a static track only takes detections within about ``min_travel_m`` of it (its
   gate does not grow past that while it is hidden, and it rests where it is: step 4). A column,
   a bench foot or a bin is thus recognised as static and never confirmed as a moving track;
7. **delete** a tentative track as soon as M detections in its first N scans can no longer be
   reached (more than N - M misses), and any track not detected for more than ``max_coast_s``
   seconds (scan stamps in integer nanoseconds, so "more than" is exact).

Targets and measurements. People are tracked from leg pairs (the midpoint of two legs, which
the simulator's gait puts on the body's path; ``person_sigma_m``) and updated by single legs as
weaker measurements (``leg_sigma_m``: a leg is up to half a step and half the legs' separation
from the body). Circles (:class:`labkit.Circle` of kind ``"circle"``) make a second kind of
track (``circle_sigma_m``); a detection only ever gates with tracks of its own kind. The
detectors give no covariance of their centres yet, so a detection's measurement covariance is
``sigma^2 I`` of its kind; :class:`Detections` built by hand (or by a detector that fits one)
carry a full covariance per detection, which the tracker uses as given.

Frames. Detections are in the sensor frame. With ``frame="map"`` (or ``"auto"`` when the first
scan carries a pose, :attr:`labkit.Scan.pose`) they are moved into the world frame by the
scan's pose before the steps above, so that the robot's own motion is not a target's: a column
then stays put and is recognised as static. In the map frame, a scan without a pose gives no
detections (its tracks coast). In the sensor frame a moving robot sees every column move.

Process noise. The model's acceleration is white noise of spectral density ``q``
(``acceleration_noise_m2_s3``, m^2/s^3), so over ``dt`` seconds ``Q = q [[dt^3/3, dt^2/2],
[dt^2/2, dt]]`` per axis (Bar-Shalom, Li and Kirubarajan 2001, Sec. 6.2.2). ``q = 0`` makes the
filter a least-squares fit of a straight line at constant speed.

``Tracker.step(..., trace=True)`` also returns the steps as :class:`labkit.Step` records
(algorithm ``"tracking"``; kinds ``predict``, ``gate``, ``assign``, ``update``, ``birth``,
``confirm``, ``delete``; ``track`` and ``detection`` say which), for notebooks and viewers.

The code below is the reference, and what ``trace=True`` runs. Without a trace the same steps run
as compiled kernels over all tracks at once (:mod:`labkit._tracking_engine`; the assignment is only
solved when some gate holds two detections or some detection lies in two gates; a scan's features
become detections in a few array calls, the same arrays as :func:`detections_from`'s): the same
tracks, identities, statuses and events, states and covariances equal to rounding.
``LABKIT_NO_JIT=1`` runs the reference always.

References
----------
Y. Bar-Shalom, X. R. Li and T. Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, Wiley 2001, Sec. 5.2 (Kalman filter), 6.2 (white-noise acceleration models).
S. Blackman and R. Popoli, *Design and Analysis of Modern Tracking Systems*, Artech House 1999,
ch. 6 (gating and global nearest neighbour), 7 (track initiation and deletion, M of N).
K. Arras, O. Martinez Mozos and W. Burgard, "Using boosted features for the detection of people
in 2D range data", ICRA 2007 (people from legs); A. Leigh et al., "Person tracking and
following with 2D laser scanners", ICRA 2015.

Examples
--------
One person walking at 1 m/s along x, seen every 0.1 s:

>>> tracker = Tracker()
>>> for k in range(10):
...     seen = Detections(k * 100_000_000, ("person",), [[1.0 + 0.1 * k, 2.0]])
...     table = tracker.step(seen)
>>> table.ids.tolist(), table.status.tolist()
([1], ['confirmed'])
>>> np.round(table.states[0], 2).tolist()  # x, y, vx, vy
[1.9, 2.0, 1.0, 0.0]
"""

from __future__ import annotations

import functools
import itertools
import math
import operator
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from time import perf_counter
from typing import Any

import numpy as np

from ._jit import ENABLED as _JIT
from .features import Features
from .params import Params, checked_by, param
from .steps import Step

__all__ = [
    "TrackingParams",
    "Detections",
    "TrackTable",
    "Tracker",
    "track",
    "detections_from",
    "cv_model",
    "cv_predict",
    "innovation",
    "mahalanobis2",
    "gate_threshold",
    "kalman_update",
    "assign",
    "TRACK_KINDS",
    "DETECTION_KINDS",
    "STATUSES",
]

#: The kinds of track: people (from leg pairs and legs) and circles (moving or static).
TRACK_KINDS = ("person", "circle")
#: The kinds of detection, and the kind of track each one measures.
DETECTION_KINDS = {"person": "person", "leg": "person", "circle": "circle"}
#: A track's status in a :class:`TrackTable` (see the module docstring for the life cycle).
STATUSES = ("tentative", "static", "confirmed", "deleted")
_TENTATIVE, _STATIC, _CONFIRMED, _DELETED = range(4)
_KIND_CODE = {"person": 0, "circle": 1}
_CIRCLE = _KIND_CODE["circle"]
_TRACK_KIND_OF = {"person": 0, "leg": 0, "circle": 1}
_STARTS_TRACKS = {"person": True, "leg": False, "circle": True}
_H = np.hstack([np.eye(2), np.zeros((2, 2))])  # a detection measures the position
_I2, _I4 = np.eye(2), np.eye(4)


@dataclass(frozen=True)
class TrackingParams(Params):
    """Parameters of :class:`Tracker` and :func:`track`.

    The ``[tracking]`` table of :class:`labkit.Config`, each default once: lengths in metres, times in seconds."""

    frame: str = param("auto", "track in the sensor frame, the map frame (moved by each scan's pose) or auto: "
                               "the map frame when the first scan carries a pose", choices=("auto", "sensor", "map"),
                       kind=str)
    acceleration_noise_m2_s3: float = param(0.5, "process noise: spectral density of the white acceleration of "
                                                 "the constant-velocity model, m^2/s^3", lo=0)
    initial_speed_sigma_mps: float = param(1.5, "standard deviation of a new track's velocity in x and in y, m/s",
                                           lo=0, strict=True)
    person_sigma_m: float = param(0.08, "standard deviation of a person's position measured by a leg pair "
                                        "(their midpoint), metres", lo=0, strict=True)
    leg_sigma_m: float = param(0.2, "standard deviation of a person's position measured by one leg, metres",
                               lo=0, strict=True)
    circle_sigma_m: float = param(0.05, "standard deviation of a circle's centre, metres", lo=0, strict=True)
    single_legs: bool = param(True, "update people with single legs (weaker measurements) besides leg pairs")
    gate_probability: float = param(0.99, "gate: a detection is considered for a track when its Mahalanobis "
                                          "distance is within the chi-square (2 dof) quantile at this probability",
                                    lo=0, strict=True, hi=0.999999)
    confirm_hits: int = param(3, "M: a track is confirmed when detected in M of its first N scans", lo=1)
    confirm_scans: int = param(5, "N: the scans, from its birth, in which a track must be detected M times", lo=1)
    max_coast_s: float = param(1.5, "delete a track not detected for longer than this, seconds", lo=0)
    min_travel_m: float = param(0.3, "a confirmed track is static until M updates in a row put its estimate this "
                                     "far from where it was first seen (the mean of its first M detections), metres",
                                lo=0, strict=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.confirm_hits > self.confirm_scans:
            where = f"{self._name}." if self._name else ""
            raise ValueError(f"{where}confirm_hits must be <= {where}confirm_scans (M of N), got "
                             f"{self.confirm_hits} of {self.confirm_scans}")


# ============================================================================ the filter
def cv_model(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Build the constant-velocity model over ``dt`` seconds.

    The state is ``(x, y, vx, vy)``; the process noise is an acceleration white noise of spectral
    density ``q`` in each axis (Bar-Shalom et al. 2001, eq. 6.2.2-12).

    Parameters
    ----------
    dt : float
        The time step, seconds.
    q : float
        The acceleration's spectral density, m^2/s^3.

    Returns
    -------
    F : ndarray of shape (4, 4)
        The transition matrix.
    Q : ndarray of shape (4, 4)
        The process noise covariance.

    Examples
    --------

    >>> F, Q = cv_model(0.5, 2.0)
    >>> F[0].tolist(), np.round(Q[0], 4).tolist()
    ([1.0, 0.0, 0.5, 0.0], [0.0833, 0.0, 0.25, 0.0])
    """
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    a, b, c = dt**3 / 3.0, dt**2 / 2.0, dt
    Q = q * np.array([[a, 0.0, b, 0.0], [0.0, a, 0.0, b], [b, 0.0, c, 0.0], [0.0, b, 0.0, c]])
    return F, Q


def cv_predict(x, P, dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Predict states and covariances ``dt`` seconds ahead with the constant-velocity model.

    ``x' = F x`` and ``P' = F P F' + Q`` (:func:`cv_model`), on one track or a stack of them.

    Parameters
    ----------
    x : array_like of shape (..., 4)
        States ``(x, y, vx, vy)``.
    P : array_like of shape (..., 4, 4)
        Their covariances.
    dt : float
        The time step, seconds.
    q : float
        The acceleration's spectral density, m^2/s^3.

    Returns
    -------
    x : ndarray of shape (..., 4)
        The predicted states.
    P : ndarray of shape (..., 4, 4)
        Their covariances.

    Examples
    --------

    >>> x, P = cv_predict(np.array([0.0, 0.0, 1.0, 0.5]), np.eye(4), 0.1, 0.0)
    >>> x.tolist()
    [0.1, 0.05, 1.0, 0.5]
    """
    F, Q = _cv_model(float(dt), float(q))
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    return x @ F.T, F @ P @ F.T + Q


@functools.lru_cache(maxsize=64)
def _cv_model(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cv_model`, remembered (scans mostly come at one rate), read-only."""
    F, Q = cv_model(dt, q)
    F.setflags(write=False)
    Q.setflags(write=False)
    return F, Q


def innovation(x, P, z, R) -> tuple[np.ndarray, np.ndarray]:
    """Compute the innovation of a position measurement and its covariance.

    ``nu = z - H x`` and ``S = H P H' + R``, where ``H`` picks the position out of ``(x, y, vx, vy)``.
    The arrays broadcast (tracks against detections).

    Parameters
    ----------
    x : array_like of shape (..., 4)
        States.
    P : array_like of shape (..., 4, 4)
        Their covariances.
    z : array_like of shape (..., 2)
        Position measurements, metres.
    R : array_like of shape (..., 2, 2)
        Their covariances.

    Returns
    -------
    nu : ndarray of shape (..., 2)
        The innovations.
    S : ndarray of shape (..., 2, 2)
        Their covariances.
    """
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    return np.asarray(z, dtype=np.float64) - x[..., :2], P[..., :2, :2] + np.asarray(R, dtype=np.float64)


def mahalanobis2(nu, S) -> tuple[np.ndarray, np.ndarray]:
    """Compute the squared Mahalanobis distance ``nu' S^-1 nu`` and ``ln det S``.

    ``S`` is inverted in closed form (2 x 2).

    Parameters
    ----------
    nu : array_like of shape (..., 2)
        Innovations.
    S : array_like of shape (..., 2, 2)
        Their covariances.

    Returns
    -------
    d2 : ndarray of shape (...)
        The squared distances.
    logdet : ndarray of shape (...)
        ``ln det S``.

    Examples
    --------

    >>> d2, logdet = mahalanobis2(np.array([0.3, 0.0]), 0.01 * np.eye(2))
    >>> round(float(d2), 9), round(float(logdet), 4)
    (9.0, -9.2103)
    """
    nu = np.asarray(nu, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    det = a * d - b * c
    u, v = nu[..., 0], nu[..., 1]
    return (d * u * u - (b + c) * u * v + a * v * v) / det, np.log(det)


def gate_threshold(probability: float) -> float:
    """Compute the gate: the chi-square quantile of 2 degrees of freedom at ``probability``.

    With 2 degrees of freedom the chi-square law is exponential, so the quantile has the closed form
    ``-2 ln(1 - p)``. A true detection's ``d2`` exceeds it with probability ``1 - p``.

    Parameters
    ----------
    probability : float
        The share of true detections the gate keeps, in (0, 1).

    Returns
    -------
    float
        The threshold on the squared Mahalanobis distance.

    Raises
    ------
    ValueError
        When ``probability`` is not in (0, 1).

    Examples
    --------

    >>> round(gate_threshold(0.99), 4)
    9.2103
    """
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability must lie in (0, 1), got {probability!r}")
    return -2.0 * math.log1p(-probability)


def kalman_update(x, P, z, R) -> tuple[np.ndarray, np.ndarray]:
    """Update states and covariances by position measurements (the Kalman update).

    The gain is ``K = P H' S^-1``, the state ``x + K nu``, and the covariance is taken in Joseph form
    ``(I - K H) P (I - K H)' + K R K'`` (symmetric and positive definite also when rounding hurts the
    short form ``(I - K H) P``).

    Parameters
    ----------
    x : array_like of shape (..., 4)
        States.
    P : array_like of shape (..., 4, 4)
        Their covariances.
    z : array_like of shape (..., 2)
        Position measurements, metres.
    R : array_like of shape (..., 2, 2)
        Their covariances.

    Returns
    -------
    x : ndarray of shape (..., 4)
        The updated states.
    P : ndarray of shape (..., 4, 4)
        Their covariances.

    Examples
    --------

    >>> x, P = kalman_update(np.zeros(4), np.eye(4), np.array([1.0, 0.0]), np.eye(2))
    >>> x.tolist(), float(P[0, 0])
    ([0.5, 0.0, 0.0, 0.0], 0.5)
    """
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    nu, S = innovation(x, P, z, R)
    K = P[..., :, :2] @ _inverse2(S)  # P H' S^-1, (..., 4, 2)
    x = x + (K @ nu[..., None])[..., 0]
    I_KH = _I4 - K @ _H
    P = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    return x, 0.5 * (P + np.swapaxes(P, -1, -2))


def _inverse2(S: np.ndarray) -> np.ndarray:
    """The inverses of 2 x 2 matrices (..., 2, 2), in closed form."""
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    det = a * d - b * c
    return np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]


def assign(cost) -> tuple[np.ndarray, np.ndarray]:
    """Pair tracks with detections by global nearest neighbour.

    As many pairs inside the gates as possible, and among those the least total cost: the
    pairs outside the gates are given a cost larger than any assignment of pairs inside them
    can reach (``2 r c + 1`` for ``r = min(T, D)`` pairs of costs within ``[-c, c]``), the
    problem is solved by ``scipy.optimize.linear_sum_assignment`` and those pairs are dropped.

    Parameters
    ----------
    cost : array_like of shape (T, D)
        The cost of each pair of a track (row) and a detection (column); ``inf`` outside the gate.

    Returns
    -------
    rows, cols : ndarray of int
        The pairs: track ``rows[k]`` takes detection ``cols[k]``.

    Examples
    --------

    >>> rows, cols = assign(np.array([[1.0, 2.0], [1.5, np.inf]]))
    >>> list(zip(rows.tolist(), cols.tolist()))   # not (0, 0): then track 1 would go without
    [(0, 1), (1, 0)]
    """
    cost = np.asarray(cost, dtype=np.float64)
    inside = np.isfinite(cost)
    if not inside.any():
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    c = float(np.abs(cost[inside]).max()) + 1.0
    from scipy.optimize import linear_sum_assignment  # here, not at import: scipy adds 22 MB to every process
    rows, cols = linear_sum_assignment(np.where(inside, cost, 2.0 * min(cost.shape) * c + 1.0))
    keep = inside[rows, cols]
    return rows[keep], cols[keep]


# ============================================================================ detections
class _Beams:
    """A :class:`Detections`' ``first`` or ``last`` beams, made on first reading when the tracker
    built the record from a scan's features (:func:`_bulk_arrays`; the tracker itself never reads
    them); otherwise they are in the record as given."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, record, owner=None):
        if record is None:
            return None  # the field's default
        made = record.__dict__.get("_beams")
        if made is None:
            raise AttributeError(self.name)
        first, last = made()
        first.setflags(write=False)
        last.setflags(write=False)
        record.__dict__.update(first=first, last=last)
        record.__dict__.pop("_beams", None)
        return record.__dict__[self.name]


@dataclass(frozen=True, eq=False)
class Detections:
    """One scan's detections, as the tracker takes them.

    Parameters
    ----------
    stamp_ns : int
        The scan's time stamp.
    kinds : tuple of str
        ``"person"`` (a leg pair), ``"leg"`` (a leg alone) or ``"circle"``, one per detection.
    positions : ndarray of shape (K, 2), metres
        In the sensor frame (the tracker moves them into the map frame when it tracks there).
    covariances : ndarray of shape (K, 2, 2), m^2, or None
        Their measurement covariances; None: ``sigma^2 I`` with the tracker's sigma of each kind
        (``person_sigma_m``, ``leg_sigma_m``, ``circle_sigma_m``, see :meth:`with_sigmas`).
    first, last : ndarray of shape (K,), int
        The beams each detection came from (-1 when unknown), to draw it on its scan. In a
        :class:`TrackTable`'s ``detections`` they are made when first read (the tracker does not
        read them); such a record prints, pickles, copies and takes ``dataclasses.replace`` as any other.
    """

    stamp_ns: int
    kinds: tuple
    positions: np.ndarray
    covariances: np.ndarray | None = None
    first: np.ndarray | None = _Beams()  # type: ignore[assignment]  # (default None; see _Beams)
    last: np.ndarray | None = _Beams()  # type: ignore[assignment]

    def __post_init__(self) -> None:
        kinds = tuple(self.kinds)
        bad = [k for k in kinds if k not in DETECTION_KINDS]
        if bad:
            raise ValueError(f"kinds must be among {tuple(DETECTION_KINDS)}, got {bad[0]!r}")
        n = len(kinds)
        try:
            p = np.array(self.positions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"positions must be finite, of shape ({n}, 2), got {self.positions!r}") from None
        if p.size == 0:
            p = p.reshape(0, 2)
        if p.shape != (n, 2) or not np.isfinite(p).all():
            raise ValueError(f"positions must be finite, of shape ({n}, 2) (one per kind), got "
                             f"{np.shape(self.positions)}")
        if self.covariances is None:
            c = None
        else:
            c = np.array(self.covariances, dtype=np.float64)
            if c.shape != (n, 2, 2) or not np.isfinite(c).all():
                raise ValueError(f"covariances must be finite, of shape ({n}, 2, 2), got {c.shape}")
            if n and (np.abs(c - np.swapaxes(c, 1, 2)).max() > 1e-12 or
                      (np.linalg.eigvalsh(0.5 * (c + np.swapaxes(c, 1, 2))) <= 0).any()):
                raise ValueError("covariances must be symmetric and positive definite")
        beams = []
        for name in ("first", "last"):
            b = getattr(self, name)
            b = np.full(n, -1, dtype=np.int64) if b is None else np.array(b, dtype=np.int64).reshape(-1)
            if b.shape != (n,):
                raise ValueError(f"{name} must hold one beam per detection ({n}), got {b.shape}")
            beams.append(b)
        for name, value in (("kinds", kinds), ("positions", p), ("covariances", c), ("first", beams[0]),
                            ("last", beams[1])):
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "stamp_ns", int(self.stamp_ns))

    def __len__(self) -> int:
        return len(self.kinds)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__, first=self.first, last=self.last)  # (the beams made, if they were not)
        state.pop("_beams", None)
        return state

    @classmethod
    def _trusted(cls, stamp_ns: int, kinds: tuple, positions, covariances, first, last) -> Detections:
        """A record of values already checked (the tracker's own), built without the checks."""
        d = object.__new__(cls)
        d.__dict__.update(stamp_ns=stamp_ns, kinds=kinds, positions=positions, covariances=covariances,
                          first=first, last=last)
        return d

    @classmethod
    def _of(cls, stamp_ns: int, kinds: tuple, positions, covariances, beams) -> Detections:
        """:meth:`_trusted` with the beams as ``(first, last)``, or as a function that makes them
        (called on first reading, see :class:`_Beams`)."""
        d = object.__new__(cls)
        d.__dict__.update(stamp_ns=stamp_ns, kinds=kinds, positions=positions, covariances=covariances)
        if callable(beams):
            d.__dict__["_beams"] = beams
        else:
            d.__dict__["first"], d.__dict__["last"] = beams
        return d

    def _beams_as_given(self):
        """The beams as :meth:`_of` takes them, not made if they were not."""
        made = self.__dict__.get("_beams")
        return made if made is not None else (self.first, self.last)

    def with_sigmas(self, person_sigma_m: float, leg_sigma_m: float, circle_sigma_m: float) -> Detections:
        """These detections with ``sigma^2 I`` of its kind as each one's covariance, where they
        have none (``covariances`` None); as they are otherwise."""
        if self.covariances is not None:
            return self
        sigma = {"person": person_sigma_m, "leg": leg_sigma_m, "circle": circle_sigma_m}
        var = np.array([sigma[k] ** 2 for k in self.kinds], dtype=np.float64)
        return Detections._of(self.stamp_ns, self.kinds, self.positions, var[:, None, None] * _I2,
                              self._beams_as_given())

    def in_frame(self, pose) -> Detections:
        """The detections moved from the sensor frame by ``pose = (x, y, theta)`` (the sensor's
        pose in the map): ``p' = R p + t``, ``C' = R C R'``."""
        x, y, theta = pose
        c, s = math.cos(theta), math.sin(theta)
        rot = np.array([[c, -s], [s, c]])
        return Detections._of(self.stamp_ns, self.kinds, self.positions @ rot.T + np.array([x, y]),
                              rot @ self.covariances @ rot.T, self._beams_as_given())


def detections_from(
    features: Features,
    *,
    person_sigma_m: float = TrackingParams.person_sigma_m,
    leg_sigma_m: float = TrackingParams.leg_sigma_m,
    circle_sigma_m: float = TrackingParams.circle_sigma_m,
    single_legs: bool = TrackingParams.single_legs,
) -> Detections:
    """Take the detections the tracker follows out of one scan's features, in the sensor frame.

    Every person (the midpoint of its two legs), every leg in no person (with ``single_legs``) and
    every circle of kind ``"circle"`` (not ``"arc-like"``), each with ``sigma^2 I`` of its kind.

    Parameters
    ----------
    features : labkit.Features
        One scan's features.
    person_sigma_m, leg_sigma_m, circle_sigma_m : float
        The position sigma of each kind of detection, metres.
    single_legs : bool
        Whether legs that belong to no person are detections too.

    Returns
    -------
    Detections
        The scan's detections.

    Raises
    ------
    ValueError
        When ``features`` is not a :class:`labkit.Features`.
    """
    if not isinstance(features, Features):
        raise ValueError(f"features must be labkit.Features, got {type(features).__name__}")
    people = features.people
    paired = {id(leg) for person in people for leg in person.legs}
    legs = [leg for leg in features.legs if id(leg) not in paired] if single_legs else []
    circles = [circle for circle in features.circles if circle.kind == "circle"]
    found = (*people, *legs, *circles)
    counts = (len(people), len(legs), len(circles))
    kinds = ("person",) * counts[0] + ("leg",) * counts[1] + ("circle",) * counts[2]
    positions = np.concatenate([f.center for f in found], dtype=np.float64).reshape(-1, 2) if found \
        else np.zeros((0, 2))
    var = np.array([person_sigma_m**2] * counts[0] + [leg_sigma_m**2] * counts[1] + [circle_sigma_m**2] * counts[2],
                   dtype=np.float64)
    pairs = [person.legs for person in people]
    first = [min(a.first, b.first) for a, b in pairs] + [f.first for f in found[counts[0]:]]
    last = [max(a.last, b.last) for a, b in pairs] + [f.last for f in found[counts[0]:]]
    return Detections._trusted(int(features.stamp_ns), kinds, positions, var[:, None, None] * _I2,
                               np.array(first, dtype=np.int64), np.array(last, dtype=np.int64))


# ============================================================================ the track table
@dataclass(frozen=True, eq=False)
class TrackTable:
    """The tracks after one scan: one row per track, columns as arrays.

    Every live track is listed (tentative, static and confirmed), and so is a track deleted
    at this scan (status ``"deleted"``, its last prediction), once. The moving targets are the
    rows whose status is ``"confirmed"`` (:meth:`confirmed`).

    Parameters
    ----------
    stamp_ns : int
        The scan's time stamp.
    frame : str
        ``"sensor"`` or ``"map"``: the frame of the states.
    pose : (x, y, theta) or None
        The scan's pose that moved its detections into the map frame (None in the sensor frame,
        or when the scan had none).
    ids : ndarray (T,), int
        Track identities, from 1, never reused.
    kinds, status : ndarray (T,), str
        ``"person"`` or ``"circle"``; ``"tentative"``, ``"static"``, ``"confirmed"`` or ``"deleted"``.
    states : ndarray (T, 4)
        ``(x, y, vx, vy)``, metres and m/s.
    covariances : ndarray (T, 4, 4)
        Their covariances.
    hits : ndarray (T,), int
        Scans in which the track was detected.
    born_ns, last_seen_ns : ndarray (T,), int
        When it was born, and last detected.
    detection : ndarray (T,), int
        The detection (index into ``detections``) that updated it at this scan, -1 if none.
    detections : Detections
        The scan's detections, in the tracking frame.
    events : tuple of (str, int)
        ``("birth", id)``, ``("confirm", id)`` (a moving track), ``("static", id)`` (confirmed
        static), ``("delete", id)``, in the order they happened.
    seconds : float
        The time the tracker took for this scan.
    late : bool
        The scan came with a stamp older than the last one tracked and was not tracked: the
        tracks are listed as they were (a recording whose stamps go back; see
        :attr:`Tracker.late_scans`).
    """

    stamp_ns: int
    frame: str
    pose: tuple | None
    ids: np.ndarray
    kinds: np.ndarray
    status: np.ndarray
    states: np.ndarray
    covariances: np.ndarray
    hits: np.ndarray
    born_ns: np.ndarray
    last_seen_ns: np.ndarray
    detection: np.ndarray
    detections: Detections
    events: tuple = ()
    seconds: float = 0.0
    late: bool = False

    def __len__(self) -> int:
        return len(self.ids)

    def confirmed(self) -> np.ndarray:
        """The rows of the confirmed (moving) tracks, as a boolean mask."""
        return self.status == "confirmed"

    def rows(self) -> list[dict]:
        """One JSON-ready dict per track: ``stamp_ns``, ``frame``, ``id``, ``kind``, ``status``,
        ``x``, ``y``, ``vx``, ``vy``, ``covariance`` (4 x 4 as nested lists), ``hits``,
        ``born_ns``, ``last_seen_ns`` (what ``labkit track`` writes, one row per track per scan)."""
        out = []
        for i in range(len(self.ids)):
            x, y, vx, vy = self.states[i].tolist()
            out.append({"stamp_ns": self.stamp_ns, "frame": self.frame, "id": int(self.ids[i]),
                        "kind": str(self.kinds[i]), "status": str(self.status[i]), "x": x, "y": y, "vx": vx,
                        "vy": vy, "covariance": self.covariances[i].tolist(), "hits": int(self.hits[i]),
                        "born_ns": int(self.born_ns[i]), "last_seen_ns": int(self.last_seen_ns[i])})
        return out

    def __repr__(self) -> str:
        counts = {s: int((self.status == s).sum()) for s in STATUSES}
        return (f"TrackTable(stamp_ns={self.stamp_ns}, frame={self.frame!r}, "
                + ", ".join(f"{v} {k}" for k, v in counts.items()) + ")")


# ============================================================================ the tracker
class Tracker:
    """A multi-target tracker (see the module docstring for the steps and the life cycle).

    Build one with the keywords of :class:`TrackingParams` (``Tracker(**config.tracking.kwargs())``
    with a :class:`labkit.Config`), then call :meth:`step` once per scan, in time order.

    Parameters
    ----------
    frame : str, default 'auto'
        Track in the sensor frame, the map frame (moved by each scan's pose) or auto: the map frame
        when the first scan carries a pose.
    acceleration_noise_m2_s3 : float, default 0.5
        Process noise: spectral density of the white acceleration of the constant-velocity model,
        m^2/s^3.
    initial_speed_sigma_mps : float, default 1.5
        Standard deviation of a new track's velocity in x and in y, m/s.
    person_sigma_m : float, default 0.08
        Standard deviation of a person's position measured by a leg pair (their midpoint), metres.
    leg_sigma_m : float, default 0.2
        Standard deviation of a person's position measured by one leg, metres.
    circle_sigma_m : float, default 0.05
        Standard deviation of a circle's centre, metres.
    single_legs : bool, default True
        Update people with single legs (weaker measurements) besides leg pairs.
    gate_probability : float, default 0.99
        Gate: a detection is considered for a track when its Mahalanobis distance is within the
        chi-square (2 dof) quantile at this probability.
    confirm_hits : int, default 3
        M: a track is confirmed when detected in M of its first N scans.
    confirm_scans : int, default 5
        N: the scans, from its birth, in which a track must be detected M times.
    max_coast_s : float, default 1.5
        Delete a track not detected for longer than this, seconds.
    min_travel_m : float, default 0.3
        A confirmed track is static until M updates in a row put its estimate this far from where it
        was first seen (the mean of its first M detections), metres.
    """

    @checked_by(TrackingParams)
    def __init__(
        self,
        *,
        frame: str = TrackingParams.frame,
        acceleration_noise_m2_s3: float = TrackingParams.acceleration_noise_m2_s3,
        initial_speed_sigma_mps: float = TrackingParams.initial_speed_sigma_mps,
        person_sigma_m: float = TrackingParams.person_sigma_m,
        leg_sigma_m: float = TrackingParams.leg_sigma_m,
        circle_sigma_m: float = TrackingParams.circle_sigma_m,
        single_legs: bool = TrackingParams.single_legs,
        gate_probability: float = TrackingParams.gate_probability,
        confirm_hits: int = TrackingParams.confirm_hits,
        confirm_scans: int = TrackingParams.confirm_scans,
        max_coast_s: float = TrackingParams.max_coast_s,
        min_travel_m: float = TrackingParams.min_travel_m,
    ) -> None:
        self.params = TrackingParams(
            frame=frame, acceleration_noise_m2_s3=acceleration_noise_m2_s3,
            initial_speed_sigma_mps=initial_speed_sigma_mps, person_sigma_m=person_sigma_m, leg_sigma_m=leg_sigma_m,
            circle_sigma_m=circle_sigma_m, single_legs=single_legs, gate_probability=gate_probability,
            confirm_hits=confirm_hits, confirm_scans=confirm_scans, max_coast_s=max_coast_s,
            min_travel_m=min_travel_m)
        self.frame = None if frame == "auto" else frame  # decided at the first scan
        self._gate = gate_threshold(gate_probability)
        self._max_coast_ns = round(max_coast_s * 1e9)
        self._next_id = 1
        self._stamp: int | None = None
        #: scans older than the last one tracked, which were not tracked (see :meth:`step`)
        self.late_scans = 0
        # the live tracks, one row each
        self._ids = np.zeros(0, dtype=np.int64)
        self._kind = np.zeros(0, dtype=np.int64)
        self._status = np.zeros(0, dtype=np.int64)
        self._x = np.zeros((0, 4))
        self._P = np.zeros((0, 4, 4))
        self._anchor = np.zeros((0, 2))  # where it was first seen
        self._moved = np.zeros(0, dtype=bool)
        self._far = np.zeros(0, dtype=np.int64)
        self._hits = np.zeros(0, dtype=np.int64)
        self._scans = np.zeros(0, dtype=np.int64)
        self._born = np.zeros(0, dtype=np.int64)
        self._seen = np.zeros(0, dtype=np.int64)
        self._work: tuple | None = None  # the compiled path's work arrays (_work_arrays)

    def __repr__(self) -> str:
        return f"Tracker({len(self._ids)} tracks, frame={self.frame!r})"

    # ------------------------------------------------------------------ one scan
    def step(self, observed: Features | Detections, *, pose=None, trace: bool = False):
        """Take one scan's detections (its :class:`labkit.Features`, or :class:`Detections`),
        in the sensor frame, with the scan's ``pose`` in the map (or None); returns the
        :class:`TrackTable` after the scan, and with ``trace=True`` also the steps taken.

        Scans must come in time order: one stamped before the last one tracked is not tracked
        (its table has ``late=True``, the tracks as they were; :attr:`late_scans` counts them)."""
        t_start = perf_counter()
        if not trace and _engine() is not None:  # the same steps, compiled (labkit._tracking_engine)
            return self._compiled_step(observed, pose, t_start)
        steps: list[Step] | None = [] if trace else None
        detections, pose = self._detections(observed, pose)
        if self._stamp is not None and detections.stamp_ns < self._stamp:
            return self._late(detections, pose, steps, t_start)
        dt = self._advance_clock(detections.stamp_ns)
        self._predict(dt, steps)                                      # 1
        cost = self._gate_all(detections, steps)                      # 2
        tracks, dets = assign(cost)                                   # 3
        _trace_assign(steps, self._ids, tracks, dets, cost, detections)
        self._update(tracks, dets, detections, steps)                 # 4
        self._rest(detections.stamp_ns)
        events = self._birth(cost, detections, steps)                 # 5
        events += self._confirm(steps)                                # 6
        deleted = self._to_delete(detections.stamp_ns, steps)         # 7
        events += [("delete", int(i)) for i in self._ids[deleted]]
        detection = np.full(len(self._ids), -1, dtype=np.int64)
        detection[tracks] = dets
        table = self._table(detections, pose, deleted, detection, tuple(events))
        self._keep(~deleted)
        table = _with_seconds(table, perf_counter() - t_start)
        return (table, steps) if trace else table

    def _compiled_step(self, observed: Features | Detections, pose, t_start: float) -> TrackTable:
        """:meth:`step` without a trace: the detections taken in bulk (:func:`_bulk_detections`),
        steps 1-7 as :mod:`labkit._tracking_engine`'s kernels."""
        p, engine = self.params, _ENGINE
        stamp, kinds, z, R, beams, det_kind, starts, pose = self._fast_detections(observed, pose)
        if self._stamp is not None and stamp < self._stamp:
            detections = Detections._of(stamp, kinds, z, R, beams)
            return self._late(detections if pose is None else detections.in_frame(pose), pose, None, t_start)
        dt = 0.0 if self._stamp is None else (stamp - self._stamp) * 1e-9  # _advance_clock (the kernel counts the scan)
        self._stamp = stamp
        n_tracks, n_dets = len(self._ids), len(kinds)
        cost, pairs, gated, new = self._work_arrays(n_tracks, n_dets)
        if pose is None:
            zm, Rm, in_map, pose_x, pose_y, pose_theta = _NOWHERE_Z, _NOWHERE_R, False, 0.0, 0.0, 0.0
        else:
            zm, Rm, in_map, (pose_x, pose_y, pose_theta) = np.empty_like(z), np.empty_like(R), True, pose
        out = np.empty((7, n_tracks), np.int64)  # confirmed, listed (the table's status), the table's detection, ids,
        #                                          hits, born_ns, last_seen_ns
        n_pairs, conflict, n_new, n_confirmed, n_deleted, done = engine.scan_step(  # (the frame), 1, 2, (5's births)
            self._x, self._P, dt, p.acceleration_noise_m2_s3, self._scans, self._kind, self._status, z, R, in_map,
            pose_x, pose_y, pose_theta, zm, Rm, det_kind, starts, self._gate, p.min_travel_m**2 / self._gate, cost,
            pairs, gated, new, self._hits, self._seen, self._anchor, self._far, self._moved, stamp, p.confirm_hits,
            p.confirm_scans, p.min_travel_m, self._max_coast_ns, self._ids, self._born, out)  # and, done: 3, 4, 6, 7
        if not in_map:
            zm, Rm = z, R
        detections = Detections._of(stamp, kinds, zm, Rm, beams)  # (the beams made when read)
        events: list = []
        if not done:  # an assignment to solve, or births
            tracks, dets = (assign(cost[:n_tracks, :n_dets]) if conflict                      # 3
                            else (pairs[0, :n_pairs], pairs[1, :n_pairs]))
            state = (self._x, self._P, tracks, dets, zm, Rm, self._hits, self._seen, self._anchor, self._far,
                     self._moved)
            if n_new:
                engine.update(*state, stamp, p.confirm_hits, p.min_travel_m)                   # 4
                events = self._add_tracks(new[:n_new].tolist(), detections, None)              # 5
                out = np.empty((7, len(self._ids)), np.int64)
                n_confirmed, n_deleted = engine.manage(                                        # 4, 6, 7
                    self._x, self._kind, self._status, self._hits, self._scans, self._moved, self._seen, stamp,
                    p.confirm_hits, p.confirm_scans, self._max_coast_ns, out[0], out[1])
                out[2] = -1
                out[2, tracks] = dets
            else:
                n_confirmed, n_deleted = engine.update_and_manage(                             # 4, 6, 7
                    *state, self._kind, self._status, self._scans, stamp, p.confirm_hits, p.confirm_scans,
                    p.min_travel_m, self._max_coast_ns, out[0], out[1], out[2])
            out[3], out[4], out[5], out[6] = self._ids, self._hits, self._born, self._seen
        listed, detection = out[1], out[2]
        if n_confirmed:
            events += [("confirm" if c == 2 else "static", tid)
                       for tid, c in zip(self._ids.tolist(), out[0].tolist(), strict=True) if c]
        if n_deleted:
            deleted = listed == _DELETED
            events += [("delete", tid) for tid in self._ids[deleted].tolist()]
        table = object.__new__(TrackTable)  # (the values are the tracker's own: no checks to run)
        table.__dict__.update(
            stamp_ns=stamp, frame=self.frame, pose=pose, ids=out[3], kinds=_KINDS[self._kind],
            status=_STATUS_NAMES[listed], states=self._x.copy(), covariances=self._P.copy(), hits=out[4],
            born_ns=out[5], last_seen_ns=out[6], detection=detection, detections=detections, events=tuple(events),
            late=False)
        if n_deleted:
            self._keep(~deleted)
        table.__dict__["seconds"] = perf_counter() - t_start
        return table

    def _work_arrays(self, n_tracks: int, n_dets: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The gate kernel's outputs (cost, pairs, in some gate, births), kept from scan to scan and
        grown by doubling: at least ``n_tracks`` x ``n_dets``."""
        work = self._work
        if work is None or work[0].shape[0] < n_tracks or work[0].shape[1] < n_dets:
            rows, cols = (max(8, 2 * n_tracks), max(8, 2 * n_dets)) if work is None else \
                (max(work[0].shape[0], 2 * n_tracks), max(work[0].shape[1], 2 * n_dets))
            work = self._work = (np.empty((rows, cols)), np.empty((2, rows * cols), np.intp),
                                 np.empty(cols, dtype=bool), np.empty(cols, np.intp))
        return work

    def _detections(self, observed, pose) -> tuple[Detections, tuple | None]:
        """The scan's detections in the tracking frame, and the pose used (None if none)."""
        p = self.params
        if isinstance(observed, Features):
            observed = detections_from(observed, person_sigma_m=p.person_sigma_m, leg_sigma_m=p.leg_sigma_m,
                                       circle_sigma_m=p.circle_sigma_m, single_legs=p.single_legs)
        elif isinstance(observed, Detections):
            observed = observed.with_sigmas(p.person_sigma_m, p.leg_sigma_m, p.circle_sigma_m)
        else:
            raise _not_observed(observed)
        pose = self._pose(pose)
        if self.frame == "sensor":
            return observed, None
        if pose is None:  # the map frame without a pose: nothing can be placed
            return _no_detections(observed.stamp_ns), None
        return observed.in_frame(pose), pose

    def _pose(self, pose) -> tuple | None:
        """The scan's pose checked, as a tuple of floats (or None); the first scan's decides the
        frame when it is ``"auto"``."""
        if pose is not None:
            try:
                x, y, theta = pose
                pose = (float(x), float(y), float(theta))
            except (TypeError, ValueError):
                raise ValueError(f"pose must be three finite numbers (x, y, theta), got {pose!r}") from None
            if not (math.isfinite(pose[0]) and math.isfinite(pose[1]) and math.isfinite(pose[2])):
                raise ValueError(f"pose must be three finite numbers (x, y, theta), got {pose!r}")
        if self.frame is None:
            self.frame = "map" if pose is not None else "sensor"
        return pose

    def _fast_detections(self, observed, pose) -> tuple:
        """:meth:`_detections` for the compiled path, as arrays, in the sensor frame (the kernel moves
        them): a scan's features taken in bulk (:func:`_bulk_arrays`); the stamp, kinds,
        positions, covariances, beams (as :meth:`Detections._of` takes them), the kind of track each
        detection measures (0 person, 1 circle) and whether it may start one, and the pose to move
        them by (None: none)."""
        p = self.params
        if isinstance(observed, Features):
            found = _bulk_arrays(observed, p.person_sigma_m, p.leg_sigma_m, p.circle_sigma_m, p.single_legs)
        elif isinstance(observed, Detections):
            observed = observed.with_sigmas(p.person_sigma_m, p.leg_sigma_m, p.circle_sigma_m)
            found = (observed.stamp_ns, observed.kinds, observed.positions, observed.covariances,
                     observed._beams_as_given(), *_track_kinds_of(observed.kinds))
        else:
            raise _not_observed(observed)
        pose = self._pose(pose)
        if self.frame == "sensor":
            return (*found, None)
        if pose is None:  # the map frame without a pose: nothing can be placed
            none = _no_detections(found[0])
            return (none.stamp_ns, none.kinds, none.positions, none.covariances, (none.first, none.last),
                    *_track_kinds_of(()), None)
        return (*found, pose)

    def _late(self, detections: Detections, pose, steps, t_start: float):
        """A scan older than the last one tracked (a recording whose stamps go back): not tracked.
        Its table lists the tracks as they are, with ``late=True``; :attr:`late_scans` counts them."""
        self.late_scans += 1
        table = self._table(detections, pose, np.zeros(len(self._ids), dtype=bool),
                            np.full(len(self._ids), -1, dtype=np.int64), ())
        object.__setattr__(table, "late", True)
        table = _with_seconds(table, perf_counter() - t_start)
        return (table, steps) if steps is not None else table

    def _advance_clock(self, stamp_ns: int) -> float:
        dt = 0.0 if self._stamp is None else (stamp_ns - self._stamp) * 1e-9
        self._stamp = stamp_ns
        self._scans += 1
        return dt

    # ------------------------------------------------------------------ 1. predict
    def _predict(self, dt: float, steps) -> None:
        """Every track to the scan's time (:func:`cv_predict`)."""
        if len(self._ids) and dt > 0.0:
            self._x, self._P = cv_predict(self._x, self._P, dt, self.params.acceleration_noise_m2_s3)
        if steps is not None:
            for i, tid in enumerate(self._ids.tolist()):
                steps.append(Step("tracking", "predict", center=tuple(self._x[i, :2].tolist()), value=dt,
                                  radius=float(math.sqrt(max(np.linalg.eigvalsh(self._P[i, :2, :2]).max(), 0.0))),
                                  track=tid, reason=f"track {tid} predicted {dt:.3f} s ahead "
                                                    f"(radius: its largest position standard deviation)"))

    # ------------------------------------------------------------------ 2. gate
    def _gate_all(self, detections: Detections, steps) -> np.ndarray:
        """Cost ``d2 + ln det S`` of every (track, detection) pair of the same kind inside the
        gate; ``inf`` elsewhere."""
        n_tracks, n_dets = len(self._ids), len(detections)
        if n_tracks == 0 or n_dets == 0:
            return np.full((n_tracks, n_dets), np.inf)
        covariances, first, last = _measured(detections)
        nu, S = innovation(self._x[:, None, :], self._static_gate_P()[:, None, :, :], detections.positions[None],
                           covariances[None])
        d2, logdet = mahalanobis2(nu, S)
        det_kind = np.array([_TRACK_KIND_OF[k] for k in detections.kinds])
        same_kind = self._kind[:, None] == det_kind[None, :]
        inside = same_kind & (d2 <= self._gate)
        if steps is not None:
            for i, j in zip(*np.nonzero(same_kind), strict=True):
                ok = bool(inside[i, j])
                steps.append(Step("tracking", "gate", int(first[j]), int(last[j]),
                                  center=tuple(detections.positions[j].tolist()), value=float(d2[i, j]),
                                  threshold=self._gate, test="gate_probability", track=int(self._ids[i]),
                                  detection=int(j), reason=f"{detections.kinds[j]} {j} {'inside' if ok else 'outside'} "
                                  f"the gate of track {self._ids[i]}: d2 = {d2[i, j]:.2f} "
                                  f"{'<=' if ok else '>'} {self._gate:.2f}"))
        return np.where(inside, d2 + logdet, np.inf)

    def _static_gate_P(self) -> np.ndarray:
        """The covariances the gate reads: a static track's position covariance scaled down so that
        it alone spans no more than ``min_travel_m`` (its largest eigenvalue at most
        ``min_travel_m^2 / gate``): a column hidden for a while takes no detection from across the room."""
        static = self._status == _STATIC
        if not static.any():
            return self._P
        P = self._P.copy()
        a, b, d = P[static, 0, 0], P[static, 0, 1], P[static, 1, 1]
        largest = 0.5 * (a + d) + np.sqrt(0.25 * (a - d) ** 2 + b * b)
        cap = self.params.min_travel_m**2 / self._gate
        scale = np.minimum(1.0, cap / np.maximum(largest, 1e-300))
        P[static, :2, :2] *= scale[:, None, None]
        return P

    # ------------------------------------------------------------------ 4. update
    def _update(self, tracks: np.ndarray, dets: np.ndarray, detections: Detections, steps) -> None:
        """Each assigned track with its detection (:func:`kalman_update`)."""
        if len(tracks) == 0:
            return
        covariances, first, last = _measured(detections)
        x, P = kalman_update(self._x[tracks], self._P[tracks], detections.positions[dets], covariances[dets])
        self._x[tracks], self._P[tracks] = x, P
        self._hits[tracks] += 1
        self._seen[tracks] = detections.stamp_ns
        early = self._hits[tracks] <= self.params.confirm_hits  # the anchor: the mean of its first M detections
        self._anchor[tracks[early]] += (detections.positions[dets[early]] - self._anchor[tracks[early]]) \
            / self._hits[tracks[early], None]
        far = np.hypot(*(x[:, :2] - self._anchor[tracks]).T) > self.params.min_travel_m
        self._far[tracks] = np.where(far, self._far[tracks] + 1, 0)  # updates in a row beyond min_travel_m
        self._moved[tracks] |= self._far[tracks] >= self.params.confirm_hits
        if steps is not None:
            for i, j in zip(tracks.tolist(), dets.tolist(), strict=True):
                steps.append(Step("tracking", "update", int(first[j]), int(last[j]),
                                  center=tuple(self._x[i, :2].tolist()), track=int(self._ids[i]), detection=j,
                                  reason=f"track {self._ids[i]} updated by {detections.kinds[j]} {j}"))

    def _rest(self, stamp_ns: int) -> None:
        """A static circle track not detected at this scan is put at rest (its velocity set to
        zero), so that it does not coast away from where it stands on the velocity one detection
        gave it."""
        rest = (self._status == _STATIC) & (self._kind == _CIRCLE) & (self._seen != stamp_ns)
        self._x[rest, 2:] = 0.0

    # ------------------------------------------------------------------ 5. birth
    def _birth(self, cost: np.ndarray, detections: Detections, steps) -> list:
        """A tentative track for every person or circle detection outside every gate."""
        outside = ~np.isfinite(cost).any(axis=0) if cost.shape[0] else np.ones(len(detections), dtype=bool)
        new = [j for j in range(len(detections)) if outside[j] and _STARTS_TRACKS[detections.kinds[j]]]
        if not new:
            return []
        return self._add_tracks(new, detections, steps)

    def _add_tracks(self, new: list, detections: Detections, steps) -> list:
        """Tentative tracks from detections ``new`` (indices): at the detection, at rest, with the
        detection's covariance and ``initial_speed_sigma_mps`` in each velocity."""
        p = self.params
        covariances = _measured(detections, beams=False)[0]  # (the beams for the trace only)
        ids = np.arange(self._next_id, self._next_id + len(new), dtype=np.int64)
        self._next_id += len(new)
        z = detections.positions[new]
        x = np.hstack([z, np.zeros((len(new), 2))])
        P = np.zeros((len(new), 4, 4))
        P[:, :2, :2] = covariances[new]
        P[:, 2, 2] = P[:, 3, 3] = p.initial_speed_sigma_mps**2
        kinds = np.array([_TRACK_KIND_OF[detections.kinds[j]] for j in new], dtype=np.int64)
        stamp = np.full(len(new), detections.stamp_ns, dtype=np.int64)
        self._ids = np.concatenate([self._ids, ids])
        self._kind = np.concatenate([self._kind, kinds])
        self._status = np.concatenate([self._status, np.full(len(new), _TENTATIVE)])
        self._x = np.concatenate([self._x, x])
        self._P = np.concatenate([self._P, P])
        self._anchor = np.concatenate([self._anchor, z])
        self._moved = np.concatenate([self._moved, np.zeros(len(new), dtype=bool)])
        self._far = np.concatenate([self._far, np.zeros(len(new), dtype=np.int64)])
        self._hits = np.concatenate([self._hits, np.ones(len(new), dtype=np.int64)])
        self._scans = np.concatenate([self._scans, np.ones(len(new), dtype=np.int64)])
        self._born = np.concatenate([self._born, stamp])
        self._seen = np.concatenate([self._seen, stamp])
        if steps is not None:
            _, first, last = _measured(detections)
            for tid, j in zip(ids.tolist(), new, strict=True):
                steps.append(Step("tracking", "birth", int(first[j]), int(last[j]),
                                  center=tuple(detections.positions[j].tolist()), track=tid, detection=j,
                                  reason=f"track {tid} born, tentative, from {detections.kinds[j]} {j} "
                                         "(outside every gate)"))
        return [("birth", tid) for tid in ids.tolist()]

    # ------------------------------------------------------------------ 6. confirm
    def _confirm(self, steps) -> list:
        """Tentative tracks detected ``confirm_hits`` times become static or confirmed; static
        tracks that have moved (``min_travel_m``, M updates in a row) become confirmed."""
        p = self.params
        events = []
        ready = (self._status == _TENTATIVE) & (self._hits >= p.confirm_hits)
        moving = (self._status == _STATIC) & self._moved
        for i in np.flatnonzero(ready | moving).tolist():
            tid = int(self._ids[i])
            travel = float(np.hypot(*(self._x[i, :2] - self._anchor[i])))
            self._status[i] = _CONFIRMED if self._moved[i] else _STATIC
            events.append(("confirm" if self._moved[i] else "static", tid))
            if steps is not None:
                if ready[i]:
                    what = "confirmed, moving" if self._moved[i] else "confirmed static"
                    steps.append(Step("tracking", "confirm", center=tuple(self._x[i, :2].tolist()),
                                      value=float(self._hits[i]), threshold=float(p.confirm_hits), test="confirm_hits",
                                      track=tid, reason=f"track {tid} {what}: detected in {self._hits[i]} of its "
                                                        f"{self._scans[i]} scans, travelled {travel:.2f} m"))
                else:
                    steps.append(Step("tracking", "confirm", center=tuple(self._x[i, :2].tolist()), value=travel,
                                      threshold=p.min_travel_m, test="min_travel_m", track=tid,
                                      reason=f"static track {tid} moves: {travel:.2f} m from where it was first "
                                             f"seen, beyond min_travel_m at {p.confirm_hits} updates in a row"))
        return events

    # ------------------------------------------------------------------ 7. delete
    def _to_delete(self, now_ns: int, steps) -> np.ndarray:
        """Tentative tracks that can no longer be confirmed, and tracks not detected for more
        than ``max_coast_s`` at ``now_ns`` (the scan's stamp): a boolean mask of the tracks."""
        p = self.params
        hopeless = (self._status == _TENTATIVE) & (self._scans - self._hits > p.confirm_scans - p.confirm_hits)
        lost = (now_ns - self._seen) > self._max_coast_ns if len(self._ids) else np.zeros(0, dtype=bool)
        deleted = hopeless | lost
        if steps is not None:
            for i in np.flatnonzero(deleted).tolist():
                tid = int(self._ids[i])
                if hopeless[i]:
                    misses = int(self._scans[i] - self._hits[i])
                    steps.append(Step("tracking", "delete", center=tuple(self._x[i, :2].tolist()), value=float(misses),
                                      threshold=float(p.confirm_scans - p.confirm_hits), test="confirm_hits",
                                      track=tid, reason=f"tentative track {tid} deleted: {misses} misses, so fewer "
                                                        f"than {p.confirm_hits} detections in {p.confirm_scans} scans"))
                else:
                    gone = (now_ns - int(self._seen[i])) * 1e-9
                    steps.append(Step("tracking", "delete", center=tuple(self._x[i, :2].tolist()), value=gone,
                                      threshold=p.max_coast_s, test="max_coast_s", track=tid,
                                      reason=f"track {tid} deleted: not detected for {gone:.2f} s"))
        return deleted

    # ------------------------------------------------------------------ bookkeeping
    def _table(self, detections, pose, deleted, detection, events) -> TrackTable:
        if self.frame is None:
            raise RuntimeError("the tracking frame is decided by the first scan's detections (_detections)")
        status = np.where(deleted, _DELETED, self._status)
        return TrackTable(int(detections.stamp_ns), self.frame, pose, self._ids.copy(), _KINDS[self._kind],
                          _STATUS_NAMES[status], self._x.copy(), self._P.copy(), self._hits.copy(),
                          self._born.copy(), self._seen.copy(), detection, detections, events)

    def _keep(self, keep: np.ndarray) -> None:
        if keep.all():
            return
        for name in ("_ids", "_kind", "_status", "_x", "_P", "_anchor", "_moved", "_far", "_hits", "_scans", "_born",
                     "_seen"):
            setattr(self, name, getattr(self, name)[keep])


_KINDS = np.array(TRACK_KINDS)
_STATUS_NAMES = np.array(STATUSES)
_ENGINE: Any = False  # labkit._tracking_engine's kernels once imported; None where they do not run


def _engine():
    """labkit._tracking_engine, or None with ``LABKIT_NO_JIT=1``; imported at the first scan."""
    global _ENGINE
    if _ENGINE is False:
        _ENGINE = None
        if _JIT:
            from types import SimpleNamespace

            from ._tracking_engine import in_frame, manage, predict_and_gate, scan_step, update, update_and_manage

            _ENGINE = SimpleNamespace(in_frame=in_frame, predict_and_gate=predict_and_gate, update=update,
                                      manage=manage, update_and_manage=update_and_manage, scan_step=scan_step)
    return _ENGINE


def _not_observed(observed) -> ValueError:
    return ValueError(f"observed must be labkit.Features or labkit.tracking.Detections, got "
                      f"{type(observed).__name__}")


def _no_detections(stamp_ns: int) -> Detections:
    return Detections._trusted(stamp_ns, (), np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros(0, dtype=np.int64),
                               np.zeros(0, dtype=np.int64))


# ---------------------------------------------------------------- the compiled path's glue
@functools.lru_cache(maxsize=256)
def _track_kinds_of(kinds: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The kind of track (0 person, 1 circle) each detection kind measures, and whether it starts
    tracks; read-only (remembered: scans repeat a few lists of kinds)."""
    out = np.array([_TRACK_KIND_OF[k] for k in kinds], dtype=np.int64)
    starts = np.array([_STARTS_TRACKS[k] for k in kinds], dtype=bool)
    out.setflags(write=False)
    starts.setflags(write=False)
    return out, starts


@functools.lru_cache(maxsize=512)
def _layout(n_people: int, n_legs: int, n_circles: int, person_var: float, leg_var: float,
            circle_var: float) -> tuple[tuple, np.ndarray, np.ndarray, np.ndarray]:
    """What :func:`detections_from` gives a scan of so many people, single legs and circles
    besides their positions and beams: the kinds, the covariances (``sigma^2 I``, read-only), the
    kind of track each detection measures and whether it starts one (remembered: scans repeat a
    few counts)."""
    kinds = ("person",) * n_people + ("leg",) * n_legs + ("circle",) * n_circles
    var = np.array([person_var] * n_people + [leg_var] * n_legs + [circle_var] * n_circles, dtype=np.float64)
    covariances = var[:, None, None] * _I2
    covariances.setflags(write=False)
    return (kinds, covariances, *_track_kinds_of(kinds))


def _bulk_detections(features: Features, person_sigma_m: float, leg_sigma_m: float, circle_sigma_m: float,
                     single_legs: bool) -> tuple:
    """:func:`detections_from`'s arrays (the same; ``tests/test_tracking_engine.py`` checks) in a
    few calls (:func:`_bulk_arrays`, its beams made): the stamp, kinds, positions, covariances,
    first and last beams, the kind of track each detection measures and whether it starts one."""
    stamp, kinds, positions, covariances, beams, det_kind, starts = _bulk_arrays(
        features, person_sigma_m, leg_sigma_m, circle_sigma_m, single_legs)
    first, last = beams() if callable(beams) else beams
    return stamp, kinds, positions, covariances, first, last, det_kind, starts


def _bulk_arrays(features: Features, person_sigma_m: float, leg_sigma_m: float, circle_sigma_m: float,
                 single_legs: bool) -> tuple:
    """:func:`detections_from`'s arrays in a few calls: the positions in one ``concatenate``, and
    what depends only on the counts (kinds, covariances) remembered (:func:`_layout`): the stamp,
    kinds, positions, covariances, the beams (``(first, last)``, or the function that makes them in
    one ``fromiter``, :func:`_beams_of`: the tracker never reads them), the kind of track each
    detection measures and whether it starts one."""
    people = features.people
    legs: tuple | list = features.legs if single_legs else ()
    if people and legs:
        paired = {id(leg) for person in people for leg in person.legs}
        legs = [leg for leg in legs if id(leg) not in paired]
    circles = [circle for circle in features.circles if circle.kind == "circle"]
    others = (*legs, *circles)
    n = len(people) + len(others)
    layout = _layout(len(people), len(legs), len(circles), person_sigma_m**2, leg_sigma_m**2, circle_sigma_m**2)
    kinds, covariances, det_kind, starts = layout
    if not n:
        none = _no_detections(int(features.stamp_ns))
        return none.stamp_ns, kinds, none.positions, covariances, (none.first, none.last), det_kind, starts
    positions = np.concatenate([f.center for f in (*people, *others)])
    if positions.dtype != np.float64 or positions.shape != (2 * n,):  # centres built by hand: as the reference
        d = detections_from(features, person_sigma_m=person_sigma_m, leg_sigma_m=leg_sigma_m,
                            circle_sigma_m=circle_sigma_m, single_legs=single_legs)
        return d.stamp_ns, d.kinds, d.positions, d.covariances, (d.first, d.last), det_kind, starts
    return (int(features.stamp_ns), kinds, positions.reshape(n, 2), covariances,
            functools.partial(_beams_of, people, others), det_kind, starts)


def _beams_of(people: tuple, others: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The first and last beams of the people (both legs spanned), then of the other features."""
    n = len(people) + len(others)
    ends = [(min(a.first, b.first), max(a.last, b.last)) for a, b in (person.legs for person in people)]
    ends += map(_ENDS, others)
    beams = np.fromiter(_chain(ends), np.int64, 2 * n).reshape(n, 2).T
    return beams[0], beams[1]


_ENDS = operator.attrgetter("first", "last")
_NOWHERE_Z, _NOWHERE_R = np.empty((0, 2)), np.empty((0, 2, 2))  # predict_and_gate's zm, Rm in the sensor frame
_chain = itertools.chain.from_iterable


def _measured(detections: Detections, beams: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The covariances and beams (first, last) of detections the tracker took: arrays once
    :meth:`Detections.with_sigmas` gave each detection its covariance (and ``__post_init__`` its beams);
    ``beams=False``: the covariances alone, the beams not read (not made, see :class:`_Beams`) but
    given as empty arrays."""
    if not beams:
        if detections.covariances is None:
            raise RuntimeError("the tracker takes detections with covariances (Detections.with_sigmas)")
        return detections.covariances, _UNREAD, _UNREAD
    if detections.covariances is None or detections.first is None or detections.last is None:
        raise RuntimeError("the tracker takes detections with covariances and beams (Detections.with_sigmas)")
    return detections.covariances, detections.first, detections.last


_UNREAD = np.zeros(0, dtype=np.int64)


def _with_seconds(table: TrackTable, seconds: float) -> TrackTable:
    object.__setattr__(table, "seconds", seconds)
    return table


def _trace_assign(steps, ids, tracks, dets, cost, detections) -> None:
    if steps is None:
        return
    for i, j in zip(tracks.tolist(), dets.tolist(), strict=True):
        steps.append(Step("tracking", "assign", int(detections.first[j]), int(detections.last[j]),
                          center=tuple(detections.positions[j].tolist()), value=float(cost[i, j]),
                          track=int(ids[i]), detection=j,
                          reason=f"{detections.kinds[j]} {j} assigned to track {ids[i]} "
                                 f"(cost d2 + ln det S = {cost[i, j]:.2f})"))


# ============================================================================ a stream of scans
@checked_by(TrackingParams)
def track(
    stream: Iterable,
    *,
    frame: str = TrackingParams.frame,
    acceleration_noise_m2_s3: float = TrackingParams.acceleration_noise_m2_s3,
    initial_speed_sigma_mps: float = TrackingParams.initial_speed_sigma_mps,
    person_sigma_m: float = TrackingParams.person_sigma_m,
    leg_sigma_m: float = TrackingParams.leg_sigma_m,
    circle_sigma_m: float = TrackingParams.circle_sigma_m,
    single_legs: bool = TrackingParams.single_legs,
    gate_probability: float = TrackingParams.gate_probability,
    confirm_hits: int = TrackingParams.confirm_hits,
    confirm_scans: int = TrackingParams.confirm_scans,
    max_coast_s: float = TrackingParams.max_coast_s,
    min_travel_m: float = TrackingParams.min_travel_m,
    trace: bool = False,
) -> Iterator:
    """Track over a stream of scans, lazily: one :class:`TrackTable` per scan.

    Parameters
    ----------
    stream : iterable
        :class:`labkit.Features` (which carry no pose: the sensor frame; with ``frame="map"``
        nothing could be placed), or ``(scan, features)`` pairs whose
        :attr:`labkit.Scan.pose` places the scan in the map (``frame="map"``, or ``"auto"`` when
        the first scan has one); :class:`Detections` work too, alone or as ``(pose, detections)``.
        :func:`labkit.pipeline.track_scans` runs the pipeline and this together.
    frame : str, default 'auto'
        Track in the sensor frame, the map frame (moved by each scan's pose) or auto: the map frame
        when the first scan carries a pose.
    acceleration_noise_m2_s3 : float, default 0.5
        Process noise: spectral density of the white acceleration of the constant-velocity model,
        m^2/s^3.
    initial_speed_sigma_mps : float, default 1.5
        Standard deviation of a new track's velocity in x and in y, m/s.
    person_sigma_m : float, default 0.08
        Standard deviation of a person's position measured by a leg pair (their midpoint), metres.
    leg_sigma_m : float, default 0.2
        Standard deviation of a person's position measured by one leg, metres.
    circle_sigma_m : float, default 0.05
        Standard deviation of a circle's centre, metres.
    single_legs : bool, default True
        Update people with single legs (weaker measurements) besides leg pairs.
    gate_probability : float, default 0.99
        Gate: a detection is considered for a track when its Mahalanobis distance is within the
        chi-square (2 dof) quantile at this probability.
    confirm_hits : int, default 3
        M: a track is confirmed when detected in M of its first N scans.
    confirm_scans : int, default 5
        N: the scans, from its birth, in which a track must be detected M times.
    max_coast_s : float, default 1.5
        Delete a track not detected for longer than this, seconds.
    min_travel_m : float, default 0.3
        A confirmed track is static until M updates in a row put its estimate this far from where it
        was first seen (the mean of its first M detections), metres.
    trace : bool
        Yield ``(table, steps)`` per scan (see :meth:`Tracker.step`).

    Returns
    -------
    iterator of TrackTable
        The tracks after each scan (read lazily); with ``trace``, ``(table, steps)`` per scan.

    Examples
    --------
    >>> from labkit import sim, extract_all
    >>> scans = [s for s, _ in sim.simulate("crossing_2", seed=1, n_scans=40)]
    >>> tables = list(track(zip(scans, extract_all(scans))))
    >>> tables[-1].frame, int(tables[-1].confirmed().sum())
    ('map', 3)
    """
    tracker = Tracker(frame=frame, acceleration_noise_m2_s3=acceleration_noise_m2_s3,
                      initial_speed_sigma_mps=initial_speed_sigma_mps, person_sigma_m=person_sigma_m,
                      leg_sigma_m=leg_sigma_m, circle_sigma_m=circle_sigma_m, single_legs=single_legs,
                      gate_probability=gate_probability, confirm_hits=confirm_hits, confirm_scans=confirm_scans,
                      max_coast_s=max_coast_s, min_travel_m=min_travel_m)
    return _tracked(tracker, stream, trace)


def _tracked(tracker: Tracker, stream: Iterable, trace: bool) -> Iterator:
    for item in stream:
        if isinstance(item, (Features, Detections)):
            yield tracker.step(item, trace=trace)
            continue
        try:
            first, observed = item
        except (TypeError, ValueError):
            raise ValueError(f"stream items must be Features or (scan, features) pairs, got {type(item).__name__}") \
                from None
        pose = getattr(first, "pose", first)  # a Scan's pose, or a pose given as such
        yield tracker.step(observed, pose=pose, trace=trace)


def _compile_engine() -> None:
    """Compile (or load from numba's cache) the kernels of :mod:`labkit._tracking_engine`, on a few
    made-up scans; the Makefile's set-up runs it beside the other engines', so that no notebook, test
    or command pays the compilation on its first tracked scan."""
    from .features import Circle, Leg, Person

    def leg(x: float, y: float, first: int) -> Leg:
        return Leg(np.array([x, y]), 0.12, np.array([x, y]), first, first + 4, 5, 2.0, 0.1)

    kinds = ("person", "leg", "circle", "circle")
    for with_pose in (False, True):
        for given in ("positions", "covariances", "features"):  # the array types the kernels meet
            tracker = Tracker()
            for k in range(8):
                z = np.array([[1.0 + 0.05 * k, 0.5], [2.0, -1.0 + 0.02 * k], [3.0, 0.0], [3.3, 0.1 * k]])
                pose = (0.01 * k, 0.0, 0.002 * k) if with_pose else None
                if given == "features":
                    pair = (leg(z[0, 0], 0.35, 10), leg(z[0, 0], 0.65, 20))
                    circles = tuple(Circle(z[j].copy(), 0.1, 2.0, 0.1, 0.9, 10 * j, 10 * j + 5, 6) for j in (2, 3))
                    observed: Features | Detections = Features(
                        k * 100_000_000, 100, np.zeros(100, dtype=np.int64), circles=circles,
                        legs=(*pair, leg(z[1, 0], z[1, 1], 30)), people=(Person(z[0].copy(), pair),))
                else:
                    cov = np.tile(0.01 * np.eye(2), (4, 1, 1)) if given == "covariances" else None
                    observed = Detections(k * 100_000_000, kinds, z, cov)
                tracker.step(observed, pose=pose)
