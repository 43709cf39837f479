"""The excitation a user runs for ``mwip twin fit`` (``mwip twin excite``).

The schedule (one row per control sample, a ``mode`` column):

1. ``static``: the robot held level and still (motors off) for ``static`` seconds: the gyro's
   zero-rate offset (``imu.gyro_bias``) and, with a level body, the accelerometer offset
   (``imu.accel_bias``);
2. ``wheels-off-ground`` (robot on a stand, wheels free): duty steps of both signs and
   sizes (small ones near the dead-band, large ones into the current limit), then a chirp:
   ``drive.gear_ratio`` (the wheel's inertia ``N^2 J`` and gain), ``firmware.emf_compensation``
   (the speed damping), ``drive.deadband``, ``drive.current_limit``, ``gearbox.coulomb``,
   ``gearbox.viscous`` and ``delay`` (the chirp's phase). The wheels get different
   schedules (the right one's steps are the left one's delayed), so the battery sag is seen.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["schedule", "STEP_LEVELS"]

#: Duty levels of the steps (each held ``step`` seconds, then back to 0).
STEP_LEVELS = (0.03, -0.05, 0.08, -0.12, 0.2, -0.3, 0.5, -0.7, 0.9, -0.9, 0.015, -0.025)


def schedule(
    Ts: float = 0.005, static: float = 2.0, step: float = 0.25, chirp: float = 4.0,
    amplitude: float = 0.35, f0: float = 0.5, f1: float = 15.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.str_]]:  # fmt: skip
    """``(t, duty (n, 2), mode (n,))`` of the excitation."""
    if not (0 < Ts <= 0.1):
        raise ValueError(f"'Ts' must be in (0, 0.1] s, got {Ts!r}")
    for name, v in (("static", static), ("step", step), ("chirp", chirp)):
        if not (np.isfinite(v) and 0 <= v <= 600):
            raise ValueError(f"{name!r} must be in [0, 600] s, got {v!r}")
    ns = int(round(static / Ts))
    parts: list[NDArray[np.float64]] = [np.zeros(ns)]
    nstep = max(int(round(step / Ts)), 1)
    for lvl in STEP_LEVELS:
        parts += [np.full(nstep, lvl), np.zeros(nstep)]
    nc = int(round(chirp / Ts))
    tc = np.arange(nc) * Ts
    k = (f1 - f0) / max(chirp, Ts)
    parts.append(amplitude * np.sin(2 * np.pi * (f0 * tc + 0.5 * k * tc * tc)))
    left = np.concatenate(parts)
    shift = nstep // 2
    right = np.concatenate([left[:ns], np.roll(left[ns:], shift)])
    mode = np.array(["static"] * ns + ["wheels-off-ground"] * (len(left) - ns))
    t = np.arange(len(left), dtype=float) * Ts
    duty = np.column_stack([right, left]).astype(float)
    return t, duty, mode.astype(np.str_)
