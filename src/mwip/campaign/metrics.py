"""Per-sample metrics of a batch run (one value per plant of a :class:`SimResult`).

With records every sample period ``Ts`` at ``t_k = k Ts`` (NaN after a plant stopped):

- ``status``: the engine's ``ok``, ``fell`` (|theta| reached pi/2) or ``diverged``;
- ``fall_time``: ``t_end`` of a plant that stopped (NaN when ``ok``);
- ``settling_time``: :func:`mwip.metrics.settling_time` of theta (2 % of its peak, >= 1 mrad);
- ``rms_theta``: ``sqrt(mean theta_k^2)`` over the records (6.3) (before the fall, if any);
- ``rms_speed_error``: the same of ``v - v_ref``, ``v = r psi'`` the true forward speed and
  ``v_ref`` the controller's speed target (``v_d``, or ``r_design psi_dot_d``; else 0);
- ``peak_torque``: ``max |u_i|`` of the torque applied to the wheels (N m);
- ``control_tv``: total variation per second of the commanded torques,
  ``sum_k sum_i |u_i(t_k+1) - u_i(t_k)| / T`` (N m/s, the chattering index);
- ``energy``: mechanical work of the drives, ``sum_k sum_i |u_i omega_i| Ts`` (J), with the
  wheel speeds relative to the body ``omega_r,l = psi' +- (b/r) alpha' - theta'`` (2.32);
- ``success``: ``ok`` and ``|theta| < success_theta`` throughout the last second of the run
  (the whole run if it is shorter): balanced, not just still standing at the end.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

from mwip.metrics import settling_time
from mwip.sim.result import SimResult

__all__ = ["METRICS", "sample_metrics"]

#: The metric columns, in table order.
METRICS: tuple[str, ...] = (
    "status",
    "success",
    "fall_time",
    "settling_time",
    "rms_theta",
    "rms_speed_error",
    "peak_torque",
    "control_tv",
    "energy",
)


def sample_metrics(
    res: SimResult,
    b: NDArray[np.float64],
    v_ref: float,
    success_theta: float,
) -> dict[str, NDArray]:
    """The metrics of every plant of the batch ``res`` (``b``: each plant's half axle)."""
    t = res.t
    st = res.states
    valid = res.valid()
    ok = res.status == "ok"
    theta = st[..., 1]
    v = res.r[:, None] * st[..., 3]
    applied = res.logs.get("u_applied", res.inputs)
    Ts = float(t[1] - t[0]) if t.size > 1 else float(res.settings.get("Ts", 0.005))
    b_over_r = (b / res.r)[:, None]
    omega = np.stack(
        [
            st[..., 3] + b_over_r * st[..., 5] - st[..., 4],
            st[..., 3] - b_over_r * st[..., 5] - st[..., 4],
        ],
        axis=-1,
    )
    with np.errstate(invalid="ignore"):
        power = np.where(valid[..., None], np.abs(applied * omega), 0.0)
        energy = power[:, :-1].sum(axis=(1, 2)) * Ts
        du = np.abs(np.diff(res.inputs, axis=1))
        tv = np.where(np.isfinite(du), du, 0.0).sum(axis=(1, 2)) / (t[-1] - t[0])
        peak = np.nanmax(np.where(valid[..., None], np.abs(applied), np.nan), axis=(1, 2))
        rms_th = np.sqrt(np.nanmean(np.where(valid, theta, np.nan) ** 2, axis=1))
        rms_v = np.sqrt(np.nanmean(np.where(valid, v - v_ref, np.nan) ** 2, axis=1))
    settle = np.array([settling_time(t, theta[i]) if ok[i] else np.nan for i in range(len(ok))])
    last = t >= t[-1] - 1.0 - 1e-9
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: plants that fell
        theta_end = np.nanmax(np.abs(theta[:, last]), axis=1)
    return {
        "status": res.status.astype(str).astype(object),
        "success": ok & (theta_end < success_theta),
        "fall_time": np.where(ok, np.nan, res.t_end),
        "settling_time": settle,
        "rms_theta": rms_th,
        "rms_speed_error": rms_v,
        "peak_torque": peak,
        "control_tv": tv,
        "energy": energy,
    }
