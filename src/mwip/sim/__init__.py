"""Simulation: the engine, its compiled plant kernel, sensors, disturbances, results."""

from mwip.sim.disturbance import BOOK_SINUSOIDS, Pulse, Sinusoid
from mwip.sim.engine import DEFAULT_DT, DEFAULT_TS, simulate
from mwip.sim.result import SimResult
from mwip.sim.sensors import IdealSensor, Measurement

__all__ = [
    "simulate", "SimResult", "Measurement", "IdealSensor", "Sinusoid", "Pulse",
    "BOOK_SINUSOIDS", "DEFAULT_TS", "DEFAULT_DT",
]  # fmt: skip
