"""The ground floor: the types every layer shares (measurement, controller, observer, sensor,
actuator). It imports nothing from mwip, so the engine, the controllers, the observers and the
digital twin all import their interfaces from here and from nowhere above them.

The loop the engine runs at each sample instant ``t_k = k Ts`` (SPEC.md section 2)::

    meas = sensor(t_k, state)            # Sensor: the plant's true state -> a Measurement
    u    = controller(t_k, meas)         # Controller: measurement -> commanded [u_r, u_l]
    u_a  = actuator(t_k, u, state)       # Actuator (optional): command -> applied torque
    state <- plant integrated over [t_k, t_k + Ts] with u_a held (zero-order hold)

Controllers and observers see only measurements and nominal parameters, never the plant.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Measurement", "Controller", "Observer", "Sensor", "Actuator", "FloatArray", "HOLD_CODES",
    "HOLD_START", "HOLD_END", "HOLD_TRAPEZOID",
]  # fmt: skip

#: A float64 NumPy array (any shape).
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Measurement:
    """Measured quantities of a batch of N robots at time ``t``.

    ``y`` (N, 8) = ``[psi, theta, alpha, psi', theta', alpha', x, y]`` as measured; the views
    ``q`` (N, 3), ``qdot`` (N, 3) and ``pos`` (N, 2) (odometry or ground truth) name its parts.
    """

    t: float
    y: FloatArray

    @property
    def q(self) -> FloatArray:
        """``[psi, theta, alpha]`` (N, 3)."""
        return self.y[:, 0:3]

    @property
    def qdot(self) -> FloatArray:
        """``[psi', theta', alpha']`` (N, 3)."""
        return self.y[:, 3:6]

    @property
    def pos(self) -> FloatArray:
        """``[x, y]`` (N, 2)."""
        return self.y[:, 6:8]


@runtime_checkable
class Controller(Protocol):
    """A discrete (sampled) or static control law for a batch of N robots.

    The engine calls ``reset(meas)`` once with the first measurement, then ``__call__(t, meas)``
    at every sample instant; it returns ``u`` (N, 2) = ``[u_r, u_l]`` (N m), held constant
    until the next sample (zero-order hold). ``log()`` is called right after each call and
    returns named arrays (N, ...) to record (empty if none).

    ``Ts`` is the sample period the controller was designed for (``None``: any). A law that
    is a static function of ``(t, measurement)`` has ``static`` true; only those can run in
    the engine's ``"continuous"`` mode (the law inside the plant's right-hand side, as the
    book's MATLAB studies do). Both may be plain attributes or read-only properties.
    """

    @property
    def Ts(self) -> float | None: ...

    @property
    def static(self) -> bool: ...

    def reset(self, meas: Measurement) -> None: ...

    def __call__(self, t: float, meas: Measurement) -> FloatArray: ...

    def log(self) -> Mapping[str, FloatArray]: ...


@runtime_checkable
class Observer(Protocol):
    """A sampled disturbance observer of the lumped disturbance (2.36), e.g.
    :class:`mwip.observers.HighOrderDO`.

    ``reset(qdot0, q0=...)`` starts a run of N robots from the first measurement;
    ``update(q, qdot, u)`` advances it over one sample ``Ts`` with the measurement at the end
    of the sample and the torque ``u`` (N, 2) held over it; ``tau_hat`` (N, 3) is the current
    estimate of ``tau_d`` in the generalised coordinates ``[psi, theta, alpha]``.
    """

    @property
    def Ts(self) -> float: ...

    def reset(
        self, qdot0: ArrayLike, estimates0: ArrayLike | None = None, q0: ArrayLike | None = None
    ) -> None: ...

    def update(self, q: ArrayLike, qdot: ArrayLike, u: ArrayLike) -> FloatArray: ...

    @property
    def tau_hat(self) -> FloatArray: ...


class Sensor(Protocol):
    """A measurement model: ``reset(n, seed)`` before a run of n robots, then
    ``sensor(t, state) -> Measurement`` at each sample, ``state`` (n, 8) the true state."""

    def reset(self, n: int, seed: int | None = None) -> None: ...

    def __call__(self, t: float, state: FloatArray) -> Measurement: ...


class Actuator(Protocol):
    """A drive model: ``reset(n, seed)`` before a run, then at each sample
    ``actuator(t, u_cmd, state) -> u_applied`` (N, 2), the wheel torques held over the sample.

    It belongs to the plant, so it may use the true ``state`` (N, 8), e.g. the wheel speeds
    for a motor's back-EMF; controllers never see it.
    """

    def reset(self, n: int, seed: int | None = None) -> None: ...

    def __call__(self, t: float, u_cmd: FloatArray, state: FloatArray) -> FloatArray: ...


#: Observer ``hold`` codes (the ``hold`` field of :mod:`mwip.laws.smc.packing`): where the
#: model terms ``F, G`` of (2.36) are evaluated over a sample (:mod:`mwip.observers._hodo_kernel`).
HOLD_START, HOLD_END, HOLD_TRAPEZOID = 0, 1, 2
HOLD_CODES = {"start": HOLD_START, "end": HOLD_END, "trapezoid": HOLD_TRAPEZOID}
