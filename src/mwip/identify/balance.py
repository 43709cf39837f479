"""Short-horizon prediction of a balancing log: how well a parameter set predicts a robot
driven by any controller (``mwip twin fit --validate LOG`` on a balancing log).

The balancing robot is open-loop unstable (it diverges within ~50 ms), so a balancing log is
cut into segments of ``H`` samples (default 10, 50 ms) and each is predicted from its own
start state, fitted per segment (nuisances, as in the stand fit): the pitch ``theta_0``, its
rate ``theta'_0`` and the two wheel speeds relative to the body ``w_{r,l}``; the wheel-angle
offsets are projected out. The logged commands (torques or duties) drive the twin's own
actuator (:meth:`mwip.hardware.twin.Twin.actuator`: delay, motor and PWM driver, Coulomb
friction, with the parameter set's values) and the twin's plant (:meth:`~mwip.hardware.twin.
Twin.plant`: the reduced model (2.32)/(2.33) with the reflected rotor inertia and the drive's
damping), integrated by RK4 with the torque held over each sample. Predicted signals: the
encoders ``enc_{r,l} = psi +- (b/r) alpha - theta`` (relative to the segment's start) and
the gyro ``theta' + imu.gyro_bias``.

The residual the start states are fitted to is ``(enc - enc_pred) / 1e-3 rad`` and
``(gyro - gyro_pred) / 1e-2 rad/s``; the prediction errors are the RMS of each signal. The
same segments and weights serve every parameter set, so the numbers compare parameter sets
(the fit against the prior's centre), whatever controller drove the log.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.logs import Log, window_starts

__all__ = ["BalanceSegments", "balance_segments", "balance_error", "balance_prediction"]

#: Residual scales: encoder (rad) and gyro (rad/s).
ENC_SCALE = 1e-3
GYRO_SCALE = 1e-2
#: RK4 steps per sample.
SUBSTEPS = 5


@dataclass
class BalanceSegments:
    """Balancing segments of one log in one batch."""

    cmd: NDArray[np.float64]  # (S, H + 1, 2): the command before, then the segment's
    enc: NDArray[np.float64]  # (S, H, 2), relative to the segment's first sample
    gyro: NDArray[np.float64]  # (S, H)
    x0: NDArray[np.float64]  # (S, 4) first guess: theta, theta', w_r, w_l
    is_duty: bool
    t: NDArray[np.float64] | None = None  # (S, H), the log's time of each sample

    @property
    def n(self) -> int:
        return int(self.cmd.shape[0])


def balance_segments(log: Log, H: int = 10, bias: float = 0.0) -> BalanceSegments | None:
    """Cut the ``balancing`` rows of ``log`` into segments of ``H`` samples."""
    from mwip.identify.fit import _start_guess

    on = log.mode == "balancing"
    cmd, enc = log.command, log.enc
    th, om = log.columns["theta"], log.columns["theta_rate"]
    cmds, encs, gyros, x0s, ts = [], [], [], [], []
    for k0 in window_starts(on, H):
        ts.append(log.columns["t"][k0:k0 + H])
        prev = cmd[k0 - 1] if k0 > 0 else np.zeros(2)
        cmds.append(np.concatenate([prev[None], cmd[k0:k0 + H]]))
        e = enc[k0:k0 + H] - enc[k0]
        encs.append(e)
        gyros.append(om[k0:k0 + H])
        w, _ = _start_guess(e, log.Ts)
        x0s.append([th[k0], om[k0] - bias, w[0], w[1]])
    if not cmds:
        return None
    return BalanceSegments(np.array(cmds), np.array(encs), np.array(gyros), np.array(x0s),
                           log.inputs == "duty", np.array(ts))  # fmt: skip


def _twin_with(base: Any, values: Mapping[str, float]) -> Any:
    from mwip.identify.model import STAND_PARAMS

    return base.with_values({n: float(values[n]) for n in STAND_PARAMS})


def rollout(twin: Any, seg: BalanceSegments, x0: NDArray[np.float64], Ts: float,
            body: Any = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # fmt: skip
    """Predicted encoders (S, H, 2) and pitch rates (S, H) from the start states ``x0``, the
    robot's ``body`` (default Table 6.1) in ``twin``."""
    from mwip.models.reduced import accelerations
    from mwip.params import REAL

    plant = twin.plant(REAL if body is None else body)
    act = twin.actuator(plant)
    S, H1, _ = seg.cmd.shape
    H = H1 - 1
    br = float(np.mean(plant.b / plant.r))
    cmd = seg.cmd
    if seg.is_duty:  # a duty command as the torque the firmware was asked for (its torque gain
        m, d = twin.motor, twin.drive  # k maps that torque to this duty: mwip.hardware.firmware)
        cmd = cmd * d.supply_voltage * twin.drive.gear_ratio * d.gear_efficiency * m.k_t \
            / m.resistance / twin.firmware.torque_gain  # fmt: skip
    act.reset(S)
    act.u_prev = cmd[:, 0].copy()
    q = np.zeros((S, 3))
    q[:, 1] = x0[:, 0]
    qd = np.zeros((S, 3))
    qd[:, 1] = x0[:, 1]
    qd[:, 0] = 0.5 * (x0[:, 2] + x0[:, 3]) + x0[:, 1]
    qd[:, 2] = (x0[:, 2] - x0[:, 3]) / (2.0 * br)
    enc = np.zeros((S, H, 2))
    rate = np.zeros((S, H))
    th0 = q[:, 1].copy()
    h = Ts / SUBSTEPS
    for k in range(H):
        enc[:, k, 0] = q[:, 0] + br * q[:, 2] - (q[:, 1] - th0)
        enc[:, k, 1] = q[:, 0] - br * q[:, 2] - (q[:, 1] - th0)
        rate[:, k] = qd[:, 1]
        if k == H - 1:
            break
        state = np.concatenate([q, qd, np.zeros((S, 2))], axis=1)
        u = act(k * Ts, cmd[:, k + 1], state)
        for _ in range(SUBSTEPS):
            a1 = accelerations(plant, q, qd, u)
            q2, v2 = q + 0.5 * h * qd, qd + 0.5 * h * a1
            a2 = accelerations(plant, q2, v2, u)
            q3, v3 = q + 0.5 * h * v2, qd + 0.5 * h * a2
            a3 = accelerations(plant, q3, v3, u)
            q4, v4 = q + h * v3, qd + h * a3
            a4 = accelerations(plant, q4, v4, u)
            q = q + h / 6.0 * (qd + 2 * v2 + 2 * v3 + v4)
            qd = qd + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
    return enc, rate


def balance_error(log: Log, values: Mapping[str, float], base: Any = None,
                  H: int = 10, body: Any = None) -> dict[str, float]:  # fmt: skip
    """Prediction error of ``values`` on the balancing rows of ``log``: the RMS of the
    encoder (rad) and gyro (rad/s) residuals with each segment's start state fitted; ``{}``
    when the log has no balancing segment (``body``: the robot's, default Table 6.1)."""
    return balance_prediction(log, values, base, H, body)[0]


def balance_prediction(log: Log, values: Mapping[str, float], base: Any = None, H: int = 10,
                       body: Any = None,
                       ) -> tuple[dict[str, float], dict[str, NDArray[np.float64]]]:  # fmt: skip
    """:func:`balance_error` and the traces behind it: ``(errors, trace)``, ``trace`` (empty
    without a balancing segment) with the segments' times ``t`` (S, H), the measured
    encoders ``enc`` (S, H, 2, relative to each segment's first sample) and gyro ``gyro``
    (S, H), and their predictions ``enc_pred`` (with the segment's offset projected out, as
    in the residual) and ``gyro_pred`` (``theta' + imu.gyro_bias``) from the fitted start
    states: ``enc - enc_pred`` and ``gyro - gyro_pred`` are the residuals whose RMS the
    errors are."""
    from scipy.optimize import least_squares
    from scipy.sparse import lil_matrix

    from mwip.hardware.twin import Twin

    bias = float(values["imu.gyro_bias"])
    seg = balance_segments(log, H, bias)
    if seg is None:
        return {}, {}
    twin = _twin_with(Twin() if base is None else base, values)
    S = seg.n
    scale = np.array([0.1, 1.0, 10.0, 10.0])  # theta rad, rates rad/s

    def resid(z: NDArray[np.float64]) -> NDArray[np.float64]:
        enc, rate = rollout(twin, seg, z.reshape(S, 4) * scale, log.Ts, body)
        re = seg.enc - enc
        re = re - re.mean(axis=1, keepdims=True)
        rg = seg.gyro - bias - rate
        return np.concatenate([re.reshape(S, -1) / ENC_SCALE, rg / GYRO_SCALE], axis=1).ravel()

    A = lil_matrix((S * 3 * H, 4 * S), dtype=int)
    for s in range(S):
        A[s * 3 * H:(s + 1) * 3 * H, 4 * s:4 * s + 4] = 1
    with np.errstate(all="ignore"):
        res = least_squares(resid, (seg.x0 / scale).ravel(), jac_sparsity=A.tocsr(),
                            method="trf", tr_solver="lsmr", max_nfev=200)  # fmt: skip
    r = res.fun.reshape(S, 3 * H)
    re = r[:, :2 * H] * ENC_SCALE
    rg = r[:, 2 * H:] * GYRO_SCALE
    errors = {"balance_enc_rms": float(np.sqrt(np.mean(re**2))),
              "balance_gyro_rms": float(np.sqrt(np.mean(rg**2))),
              "balance_segments": float(S)}  # fmt: skip
    assert seg.t is not None
    trace = {"t": seg.t, "enc": seg.enc, "enc_pred": seg.enc - re.reshape(S, H, 2),
             "gyro": seg.gyro, "gyro_pred": seg.gyro - rg}  # fmt: skip
    return errors, trace
