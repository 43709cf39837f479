"""Chapter 6, Case 3: crossing a small stick (Fig. 6.3, Table 6.6) as a documented disturbance.

The plant model is planar on flat ground, so the stick is modelled by the generalised force it
exerts on the wheel coordinate ``psi`` (SPEC.md section 5 allows "a short, documented
disturbance"). Rolling over a stick of height ``h`` the wheel (radius ``r``) pivots on it
through ``dpsi = arccos(1 - h / r)`` while the axle rises by ``h``: lifting the whole robot
(mass ``m``) takes the work ``m g h``, which a resisting torque ``T = m g h / dpsi`` on ``psi``
does over the climb; coming down, the same torque assists. Both wheels cross together (no
yaw). The pulses are timed for the set speed ``|psi'_d|`` (a time-based disturbance cannot
follow the actual position): climb ``[start, start + dpsi/|psi'_d|)`` with ``+sign T`` against
the motion, descent of the same length with the opposite sign. The force acts on the axle
only, so nothing is applied directly to ``theta``: the body is disturbed through the coupling
(2.32), as on the robot. The collision impulse at first contact is neglected.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.unknown import Unknown

__all__ = ["StickObstacle", "StickSpec", "StickRows", "UNKNOWNS"]


@dataclass(frozen=True)
class StickSpec:
    """The Case 3 stick of the twin: ``height`` (m), "a small stick" (Sec. 6.2.3), below the
    wheel radius."""

    height: float = 0.01

    def __post_init__(self) -> None:
        if not (np.isfinite(self.height) and 0 < self.height < 0.04):
            raise ValueError(
                f"'height' must be finite and in (0, 0.04) (below r), got {self.height!r}"
            )


@dataclass(frozen=True)
class StickObstacle:
    """A stick of ``height`` (m) met at ``start`` (s) while moving at ``speed`` (rad/s,
    signed wheel speed; the book's -7) by a robot of total ``mass`` (kg) on wheels of
    radius ``r`` (m). Callable as a disturbance ``tau_ext(t) -> (K, 3)``."""

    height: float = 0.01
    start: float = 6.0
    speed: float = -7.0
    mass: float = 3.36
    r: float = 0.04
    g: float = 9.81

    def __post_init__(self) -> None:
        if not (np.isfinite(self.r) and self.r > 0):
            raise ValueError(f"'r' must be finite and in (0, inf), got {self.r!r}")
        if not (np.isfinite(self.height) and 0 < self.height < self.r):
            raise ValueError(
                f"'height' must be finite and in (0, r={self.r:g}), got {self.height!r}"
            )
        if not (np.isfinite(self.speed) and self.speed != 0):
            raise ValueError(f"'speed' must be finite and non-zero, got {self.speed!r}")
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"'mass' must be finite and in (0, inf), got {self.mass!r}")
        if not np.isfinite(self.start):
            raise ValueError(f"'start' must be finite, got {self.start!r}")

    @property
    def climb_angle(self) -> float:
        """Wheel rotation while pivoting on the stick, ``arccos(1 - h / r)`` (rad)."""
        return float(np.arccos(1.0 - self.height / self.r))

    @property
    def duration(self) -> float:
        """Length of the climb (and of the descent) at the set speed (s)."""
        return self.climb_angle / abs(self.speed)

    @property
    def torque(self) -> float:
        """Resisting torque on ``psi`` during the climb, ``m g h / dpsi`` (N m)."""
        return self.mass * self.g * self.height / self.climb_angle

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float)
        d = self.duration
        against = -np.sign(self.speed) * self.torque
        climb = (tt >= self.start) & (tt < self.start + d)
        down = (tt >= self.start + d) & (tt < self.start + 2 * d)
        out = np.zeros((*tt.shape, 3))
        out[..., 0] = against * climb - against * down
        return out


class StickRows:
    """One :class:`StickObstacle` per row of a batch, as a disturbance ``(K, N, 3)``: the
    pulses of all rows evaluated at once (the same arithmetic as each stick's own call)."""

    def __init__(self, sticks: Sequence[StickObstacle]) -> None:
        self.sticks = list(sticks)
        self.start = np.array([s.start for s in self.sticks])
        self.duration = np.array([s.duration for s in self.sticks])
        self.against = np.array([-np.sign(s.speed) * s.torque for s in self.sticks])

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float)[..., None]
        d, start, against = self.duration, self.start, self.against
        climb = (tt >= start) & (tt < start + d)
        down = (tt >= start + d) & (tt < start + 2 * d)
        out = np.zeros((*tt.shape[:-1], len(self.sticks), 3))
        out[..., 0] = against * climb - against * down
        return out


#: The stick's unknown (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("stick.height", 0.005, 0.02, "m", 'Case 3 stick, "a small stick", below r = 4 cm',
            "case 3", 0.01),
)  # fmt: skip
