"""The plant's interfaces: what a controller sees (sensors) and what it drives (actuators).

The engine calls a sensor ``sensor(t, state) -> Measurement`` at every sample instant; the
controller gets only that :class:`Measurement`, never the plant or its parameters. The default
:class:`IdealSensor` returns the true state; the digital twin (IMU fusion, encoders) plugs in
through the same protocol. The types themselves live in :mod:`mwip.core` (re-exported here).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mwip.core import Actuator, Measurement, Sensor

__all__ = ["Measurement", "Sensor", "IdealSensor", "Actuator"]


class IdealSensor:
    """Exact measurements: the true ``q, q', [x, y]`` (copies, so controllers cannot alias)."""

    def reset(self, n: int, seed: int | None = None) -> None:
        """Nothing to reset."""

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        return Measurement(t=t, y=state.copy())
