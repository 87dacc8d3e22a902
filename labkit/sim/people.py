"""Moving objects of the simulated worlds: paths, a rolling cylinder and walking people.

:class:`Walker` is a simulated person (two legs with a gait); it is not
:class:`labkit.Person`, the *detected* pair of legs. :class:`Mover` is where a moving object
is at one instant and how fast it goes: the truth a tracker (:mod:`labkit.tracking`) is scored
against (:meth:`labkit.sim.World.movers_at`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PathSpec", "RollingCylinder", "Walker", "Mover"]


@dataclass(frozen=True)
class PathSpec:
    """A polyline path for moving objects, walked at constant speed.

    Parameters
    ----------
    waypoints : tuple of tuple of (float, float)
        The polyline's points, metres, world frame.
    mode : str
        ``"loop"`` closes the polyline and goes round; ``"bounce"`` walks to the end and back.
    """

    waypoints: tuple[tuple[float, float], ...]
    mode: str = "loop"

    def __post_init__(self) -> None:
        if len(self.waypoints) < 2:
            raise ValueError("waypoints must hold at least two points")
        if self.mode not in ("loop", "bounce"):
            raise ValueError(f"mode must be 'loop' or 'bounce', got {self.mode!r}")

    def _vertices(self) -> np.ndarray:
        pts = np.asarray(self.waypoints, dtype=np.float64)
        return np.vstack([pts, pts[:1]]) if self.mode == "loop" else pts

    @property
    def length(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self._vertices(), axis=0), axis=1)))

    def at(self, s: float, *, walking: bool = True) -> tuple[np.ndarray, float]:
        """Position (2,) and heading (radians) after walking ``s`` metres from the start.

        The heading is the walking direction; with ``walking=False`` it is the direction of
        the polyline itself (which does not turn round when a bounce path does).
        """
        verts = self._vertices()
        seg = np.diff(verts, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        total = lengths.sum()
        direction = 1.0
        if self.mode == "loop":
            s = s % total
        else:
            s = s % (2 * total)
            if s > total:
                s, direction = 2 * total - s, -1.0
        cum = np.concatenate([[0.0], np.cumsum(lengths)])
        k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1))
        u = (s - cum[k]) / lengths[k]
        pos = verts[k] + u * seg[k]
        if not walking:
            direction = 1.0
        heading = np.arctan2(direction * seg[k, 1], direction * seg[k, 0])
        return pos, float(heading)

    def velocity(self, s: float, speed_mps: float) -> np.ndarray:
        """Velocity (2,) of something walking at ``speed_mps`` when it is ``s`` metres along
        (the walking direction; at a corner or a bounce, that of the stretch it enters)."""
        _, heading = self.at(s)
        return speed_mps * np.array([np.cos(heading), np.sin(heading)])


@dataclass(frozen=True)
class Mover:
    """A moving object at one instant, in the world frame: the truth of a track.

    Parameters
    ----------
    name : str
        The walker's or the cylinder's name.
    kind : str
        ``"person"`` (a :class:`Walker`; its centre is the body's, on the path, which on a
        straight path is the midpoint of its two legs) or ``"cylinder"``.
    object_ids : tuple of int
        Its ids in a scan's ``hits`` (two legs, or the cylinder), see :meth:`World.objects`.
    center, velocity : (float, float)
        Metres and metres per second.
    """

    name: str
    kind: str
    object_ids: tuple[int, ...]
    center: tuple[float, float]
    velocity: tuple[float, float]


@dataclass(frozen=True)
class RollingCylinder:
    """A cylinder pulled along a path at ``speed_mps`` (Xavier et al.'s mobile cylinder).

    Parameters
    ----------
    radius : float
        The cylinder's radius, metres.
    path : PathSpec
        The path its centre follows.
    speed_mps : float
        Its speed, metres per second.
    name : str
        Its name in the ground truth.
    start_offset_m : float
        Where along the path it is at time 0, metres.
    """

    radius: float
    path: PathSpec
    speed_mps: float
    name: str = "cylinder"
    start_offset_m: float = 0.0

    def center_at(self, t: float) -> np.ndarray:
        return self.path.at(self.start_offset_m + self.speed_mps * t)[0]

    def velocity_at(self, t: float) -> np.ndarray:
        return self.path.velocity(self.start_offset_m + self.speed_mps * t, self.speed_mps)


@dataclass(frozen=True)
class Walker:
    """A person walking along a path; the laser sees two legs at knee height.

    Gait model: footfalls are ``step_length_m`` apart along the path, alternating
    between the two sides of the path at ``+-leg_separation_m / 2`` from it. While the
    body covers one step, the stance leg stays planted and the swing leg moves from its
    last footfall to the next at twice the walking speed, so the legs alternate as in real
    walking. Each leg keeps to its side of the path, also on the way back of a bounce
    path, so the legs never cross.

    Parameters
    ----------
    path : PathSpec
        The path the body follows.
    speed_mps : float
        The walking speed, metres per second.
    leg_diameter_m : float
        Each leg's diameter, metres.
    leg_separation_m : float
        The distance between the two sides the feet fall on, metres.
    step_length_m : float
        The distance between footfalls along the path, metres.
    name : str
        The person's name in the ground truth.
    start_offset_m : float
        Where along the path the person is at time 0, metres.
    """

    path: PathSpec
    speed_mps: float = 1.0
    leg_diameter_m: float = 0.14
    leg_separation_m: float = 0.25
    step_length_m: float = 0.4
    name: str = "person"
    start_offset_m: float = 0.0

    def __post_init__(self) -> None:
        if not 0.1 <= self.leg_diameter_m <= 0.25:
            raise ValueError(f"leg_diameter_m must be within 0.1-0.25 m, got {self.leg_diameter_m}")
        if self.leg_separation_m <= self.leg_diameter_m:
            raise ValueError("leg_separation_m must exceed leg_diameter_m (legs would overlap)")

    def _foot(self, s: float, side: float) -> np.ndarray:
        """A foot at ``s`` metres along the path, on the given side of it."""
        pos, heading = self.path.at(max(s, 0.0), walking=False)  # no footfalls before the start
        normal = np.array([-np.sin(heading), np.cos(heading)])
        return pos + side * 0.5 * self.leg_separation_m * normal

    def legs_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Centres (2,) of the left and right leg at time ``t`` seconds."""
        s = self.start_offset_m + self.speed_mps * t
        step = self.step_length_m
        k = int(np.floor(s / step + 0.5))  # the footfall the body is passing over
        u = s / step + 0.5 - k  # progress of the current step in [0, 1)
        stance_side = 1.0 if k % 2 == 0 else -1.0
        stance = self._foot(k * step, stance_side)
        # the swing leg travels along the path (not across a corner) from footfall k-1 to k+1
        swing = self._foot((k - 1 + 2 * u) * step, -stance_side)
        return (stance, swing) if stance_side > 0 else (swing, stance)

    def center_at(self, t: float) -> np.ndarray:
        return self.path.at(self.start_offset_m + self.speed_mps * t)[0]

    def velocity_at(self, t: float) -> np.ndarray:
        """The body's velocity (2,) at time ``t``, m/s (the legs' mean velocity over a step)."""
        return self.path.velocity(self.start_offset_m + self.speed_mps * t, self.speed_mps)
