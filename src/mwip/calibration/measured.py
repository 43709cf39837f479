"""What a robot's board records in a run, as numbers a user can state as evidence
(``mwip twin calibrate FACTS --robot FILE``, :mod:`mwip.calibration.facts_file`).

Every metric is computed from the twin's **measured** signals ``y_meas`` (the board's fused
pitch estimate ``theta_m``, the encoders' wheel angle ``psi_m`` and speed ``psi'_m``), as a
robot's log would give it, over a window ``[t0, t1]`` of the run (default: all of it), one
value per twin of the batch (``nan`` where the twin fell: a number is evidence about a
standing run):

=================  =======  ===========================================================
metric             unit     value over the window
=================  =======  ===========================================================
``rms_theta``      rad      ``sqrt(mean(theta_m^2))`` (the book's (6.3))
``max_abs_theta``  rad      ``max |theta_m|``
``osc_amp``        rad      ``max theta_m - min theta_m`` (peak to peak)
``final_abs_theta`` rad     ``|theta_m|`` at the window's last sample
``rms_speed``      rad/s    ``sqrt(mean((psi'_m - reference)^2))`` (the book's (6.3))
``mean_speed``     rad/s    ``mean(psi'_m)`` (signed)
``travel``         m        ``r (psi_m(t1) - psi_m(t0))`` with the design model's ``r``
=================  =======  ===========================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["Metric", "METRICS", "measure"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Metric:
    """One metric: its ``unit``, what it is, and whether its value may be negative."""

    unit: str
    what: str
    signed: bool = False


METRICS: dict[str, Metric] = {
    "rms_theta": Metric("rad", "RMS of the board's pitch estimate (6.3)"),
    "max_abs_theta": Metric("rad", "largest |pitch estimate|"),
    "osc_amp": Metric("rad", "peak-to-peak pitch estimate"),
    "final_abs_theta": Metric("rad", "|pitch estimate| at the window's end"),
    "rms_speed": Metric("rad/s", "RMS of the encoder wheel speed minus `reference` (6.3)"),
    "mean_speed": Metric("rad/s", "mean encoder wheel speed", signed=True),
    "travel": Metric("m", "wheel travel r (psi(t1) - psi(t0)) by the encoders", signed=True),
}


def measure(metric: str, t: F64, y_meas: F64, ok: NDArray[np.bool_], *,
            window: tuple[float, float] | None = None, reference: float = 0.0,
            radius: float = 1.0) -> F64:  # fmt: skip
    """``metric`` (module docstring) per row of the batch ``y_meas`` (N, K, 8: ``psi``,
    ``theta``, ``alpha``, ``psi'``, ``theta'``, ``alpha'``, ``x``, ``y``) at times ``t`` (K,);
    ``nan`` where ``ok`` is false (the twin fell). ``ValueError`` for an unknown metric."""
    if metric not in METRICS:
        raise ValueError(f"metric {metric!r} unknown; allowed: {', '.join(METRICS)}")
    lo, hi = (float(t[0]), float(t[-1])) if window is None else window
    m = (t >= lo - 1e-12) & (t <= hi + 1e-12)
    if not m.any():
        raise ValueError(f"window [{lo}, {hi}] s holds no sample of the run "
                         f"(0-{float(t[-1]):g} s)")  # fmt: skip
    th = np.nan_to_num(y_meas[:, m, 1])
    psi = np.nan_to_num(y_meas[:, m, 0])
    sp = np.nan_to_num(y_meas[:, m, 3])
    if metric == "rms_theta":
        v = np.sqrt(np.mean(th**2, axis=1))
    elif metric == "max_abs_theta":
        v = np.max(np.abs(th), axis=1)
    elif metric == "osc_amp":
        v = np.ptp(th, axis=1)
    elif metric == "final_abs_theta":
        v = np.abs(th[:, -1])
    elif metric == "rms_speed":
        v = np.sqrt(np.mean((sp - reference) ** 2, axis=1))
    elif metric == "mean_speed":
        v = np.mean(sp, axis=1)
    else:  # travel
        v = radius * (psi[:, -1] - psi[:, 0])
    return np.where(ok, v, np.nan)
