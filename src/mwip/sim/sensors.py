"""The plant's interfaces: what a controller sees (sensors) and what it drives (actuators).

The engine calls a sensor ``sensor(t, state) -> Measurement`` at every sample instant; the
controller gets only that :class:`Measurement`, never the plant or its parameters. The default
:class:`IdealSensor` returns the true state; the digital twin (IMU fusion, encoders) plugs in
through the same protocol.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["Measurement", "Sensor", "IdealSensor", "Actuator"]


@dataclass(frozen=True)
class Measurement:
    """Measured quantities of a batch of N robots at time ``t``.

    ``y`` (N, 8) = ``[psi, theta, alpha, psi', theta', alpha', x, y]`` as measured; the views
    ``q`` (N, 3), ``qdot`` (N, 3) and ``pos`` (N, 2) (odometry or ground truth) name its parts.
    """

    t: float
    y: NDArray[np.float64]

    @property
    def q(self) -> NDArray[np.float64]:
        """``[psi, theta, alpha]`` (N, 3)."""
        return self.y[:, 0:3]

    @property
    def qdot(self) -> NDArray[np.float64]:
        """``[psi', theta', alpha']`` (N, 3)."""
        return self.y[:, 3:6]

    @property
    def pos(self) -> NDArray[np.float64]:
        """``[x, y]`` (N, 2)."""
        return self.y[:, 6:8]


class Sensor(Protocol):
    """A measurement model: ``reset(n)`` before a run, then ``__call__`` at each sample."""

    def reset(self, n: int, seed: int | None = None) -> None: ...

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement: ...


class IdealSensor:
    """Exact measurements: the true ``q, q', [x, y]`` (copies, so controllers cannot alias)."""

    def reset(self, n: int, seed: int | None = None) -> None:
        """Nothing to reset."""

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        return Measurement(t=t, y=state.copy())


class Actuator(Protocol):
    """A drive model: ``reset(n, seed)`` before a run, then at each sample
    ``__call__(t, u_cmd, state) -> u_applied`` (N, 2), the wheel torques held over the sample.

    It belongs to the plant, so it may use the true ``state`` (N, 8), e.g. the wheel speeds
    for a motor's back-EMF; controllers never see it.
    """

    def reset(self, n: int, seed: int | None = None) -> None: ...

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]: ...
