"""Simulation: the engine, its compiled plant kernel, sensors, disturbances, results.

The names below are imported on first use (:mod:`mwip.lazy`): reading a result
(:mod:`mwip.sim.result`) does not load the compiler.
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = [
    "simulate", "SimResult", "Measurement", "IdealSensor", "Sinusoid", "Pulse",
    "BOOK_SINUSOIDS", "DEFAULT_TS", "DEFAULT_DT",
]  # fmt: skip

__getattr__, __dir__ = exports(
    __name__,
    {**dict.fromkeys(("BOOK_SINUSOIDS", "Pulse", "Sinusoid"), "mwip.sim.disturbance"),
     **dict.fromkeys(("DEFAULT_DT", "DEFAULT_TS", "simulate"), "mwip.sim.engine"),
     "SimResult": "mwip.sim.result",
     **dict.fromkeys(("IdealSensor", "Measurement"), "mwip.sim.sensors")},
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.sim.disturbance import BOOK_SINUSOIDS, Pulse, Sinusoid
    from mwip.sim.engine import DEFAULT_DT, DEFAULT_TS, simulate
    from mwip.sim.result import SimResult
    from mwip.sim.sensors import IdealSensor, Measurement
