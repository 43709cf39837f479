"""Synthetic logs from the twin's own elements (the generator of the identification tests).

Wheels-off-ground and static logs: the body held level (``theta = 0``, at rest: the
accelerometer feels no motion), each wheel driven by the twin's drive chain
(:class:`mwip.hardware.twin.TwinActuator`: delay, the firmware's torque-to-duty map with its
back-EMF compensation, RE25 + PWM driver with quantisation, dead-band, sag and current limit,
Coulomb stick-slip friction) and integrated exactly (``J w' = T - D w``, ``J = I_wa + N^2
J_r``, ``D`` the twin plant's ``Db`` with the back-EMF damping and the gearbox viscous
friction), read by the twin's sensor chain (:class:`mwip.hardware.twin.TwinSensor`: the IMU
with its noise, bias and drift, the firmware's fusion, the encoders). Backlash is switched off
(it is not identified).

Balancing logs: :func:`mwip.hardware.twin.run_on_twin` with a controller of
:mod:`mwip.laws.registry` on the same twin.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.bounds import BOUNDS

__all__ = ["draw_truth", "twin_for", "stand_log", "stand_log_on", "balancing_log",
           "balancing_log_on", "csv_text", "write_csv"]


def draw_truth(seed: int, inner: float = 0.1) -> dict[str, float]:
    """Hidden parameters drawn uniformly from the central ``1 - 2 inner`` of the bounds."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, (lo, hi) in BOUNDS.items():
        w = hi - lo
        out[name] = float(rng.uniform(lo + inner * w, hi - inner * w))
    return out


def twin_for(truth: Mapping[str, float], base: object | None = None) -> Any:
    """The twin with ``truth``'s values (backlash off)."""
    from mwip.hardware.elements import ELEMENTS
    from mwip.hardware.twin import Twin

    tw: Twin = Twin() if base is None else base  # type: ignore[assignment]
    n = truth["drive.gear_ratio"]
    fw = tw.firmware
    return replace(
        tw,
        drive=replace(tw.drive, gear_ratio=n, deadband=truth["drive.deadband"],
                      current_limit=truth["drive.current_limit"]),
        gearbox=replace(tw.gearbox, coulomb=truth["gearbox.coulomb"],
                        viscous=truth["gearbox.viscous"]),
        imu=replace(tw.imu, gyro_bias=truth["imu.gyro_bias"], accel_bias=truth["imu.accel_bias"],
                    height=truth["imu.height"]),
        firmware=replace(fw, emf_compensation=truth["firmware.emf_compensation"],
                         delay=truth["firmware.delay"],
                         fusion=replace(fw.fusion, tau=truth["firmware.fusion.tau"])),
        elements=frozenset(e for e in ELEMENTS if e != "backlash"),
    )  # fmt: skip


def stand_log(
    truth: Mapping[str, float],
    duty: NDArray[np.float64],
    mode: NDArray[np.str_] | None = None,
    *,
    seed: int = 0,
    torque: bool = False,
    base: object | None = None,
    body: object | None = None,
) -> dict[str, NDArray]:
    """A wheels-off-ground / static log for the schedule ``duty`` (n, 2) on the twin with
    ``truth``'s values (:func:`twin_for`): :func:`stand_log_on`; ``body`` the robot's
    (:class:`mwip.params.Params`, default Table 6.1)."""
    from mwip.params import REAL

    return stand_log_on(twin_for(truth, base), REAL if body is None else body, duty, mode,
                        seed=seed, inputs="torque" if torque else "duty")  # fmt: skip


def stand_log_on(
    tw: Any,
    body: Any,
    duty: NDArray[np.float64],
    mode: NDArray[np.str_] | None = None,
    *,
    seed: int = 0,
    inputs: str = "duty",
) -> dict[str, NDArray]:
    """A wheels-off-ground / static log of the twin ``tw`` (a :class:`mwip.hardware.twin.Twin`,
    its elements as they are) and ``body`` for the schedule ``duty`` (n, 2) of the duties the
    firmware writes before its back-EMF compensation (module docstring): columns of the log
    schema, the command as ``inputs`` says: ``"duty"``, ``"torque"`` (``u_r, u_l``: the
    torques the firmware was asked for, which its torque gain ``k`` maps to those duties) or
    ``"both"``."""
    if inputs not in ("duty", "torque", "both"):
        raise ValueError(f"inputs must be 'duty', 'torque' or 'both', got {inputs!r}")
    from mwip.hardware.twin import TwinActuator, TwinSensor

    bd = body
    m, d, Ts = tw.motor, tw.drive, tw.Ts
    N = d.gear_ratio
    gain = N * d.gear_efficiency * m.k_t
    J = float(bd.Iwa) + N * N * m.rotor_inertia
    D = d.emf_damping(m) + tw.gearbox.viscous + float(bd.Db)
    a = np.exp(-D * Ts / J)
    br = float(bd.b / bd.r)
    # the body at rest on the stand: the accelerometer feels no motion
    still = replace(tw, elements=tw.elements - {"accel_motion"})
    sensor = TwinSensor(bd, still)
    sensor.reset(1, seed)
    act = TwinActuator(bd, tw, mobility=1.0 / J)
    act.reset(1)
    n = duty.shape[0]
    rng = np.random.default_rng(seed + 10_000)
    phi = rng.uniform(-1.0, 1.0, 2)
    w = np.zeros(2)
    cols: dict[str, list[float]] = {k: [] for k in (
        "t", "theta", "theta_rate", "enc_r", "enc_l", "accel_x", "accel_y")}  # fmt: skip
    cmd_out = np.zeros((n, 2))
    k_fw = float(tw.firmware.torque_gain)
    for k in range(n):
        psi, alpha = 0.5 * (phi[0] + phi[1]), (phi[0] - phi[1]) / (2.0 * br)
        state = np.array([[psi, 0.0, alpha, 0.5 * (w[0] + w[1]), 0.0,
                           (w[0] - w[1]) / (2.0 * br), 0.0, 0.0]])  # fmt: skip
        ym = sensor(k * Ts, state).y[0]
        lg = sensor.last
        enc = lg["encoder_angles"][0]
        acc = lg["imu_accel"][0]
        for key, val in (("t", k * Ts), ("theta", ym[1]), ("theta_rate", lg["imu_gyro"][0, 0]),
                         ("enc_r", enc[0]), ("enc_l", enc[1]), ("accel_x", acc[0]),
                         ("accel_y", acc[1])):  # fmt: skip
            cols[key].append(float(val))
        u = duty[k] * d.supply_voltage * gain / m.resistance / k_fw
        cmd_out[k] = u
        T = act(k * Ts, u[None, :], state)[0]
        wss = T / D
        phi = phi + wss * Ts + (w - wss) * (J / D) * (1.0 - a)
        w = wss + (w - wss) * a
    out: dict[str, NDArray] = {key: np.asarray(v) for key, v in cols.items()}
    if inputs in ("torque", "both"):
        out["u_r"], out["u_l"] = cmd_out[:, 0], cmd_out[:, 1]
    if inputs in ("duty", "both"):
        out["duty_r"], out["duty_l"] = duty[:, 0].copy(), duty[:, 1].copy()
    out["mode"] = np.asarray(mode if mode is not None else np.full(n, "wheels-off-ground"))
    return out


def balancing_log(
    truth: Mapping[str, float], controller: str = "lqr", duration: float = 5.0, seed: int = 0,
    base: object | None = None,
    body: object | None = None,
) -> dict[str, NDArray]:
    """A balancing log: ``controller`` (registry name, designed on the book's nominal
    parameters) on the twin with ``truth`` and the robot's ``body`` (default Table 6.1):
    :func:`balancing_log_on`."""
    from mwip.laws.registry import build

    tw = twin_for(truth, base)
    return balancing_log_on(tw, body, build(controller, Ts=tw.Ts), duration, seed)


def balancing_log_on(
    tw: Any, body: Any, ctrl: Any, duration: float = 5.0, seed: int = 0,
    q0: tuple[float, float, float] = (0.0, 0.05, 0.0), inputs: str = "torque",
) -> dict[str, NDArray]:
    """A balancing log of the controller ``ctrl`` on the twin ``tw`` and ``body`` (``None``:
    Table 6.1) from the lean ``q0``: what the board records each sample (its pitch estimate,
    the gyro, the encoders relative to the body, and as ``inputs`` says the commanded torques
    ``"torque"``, the duties its firmware computes from them before the back-EMF compensation,
    ``k R u / (N eta k_t V_0)``, ``"duty"``, or ``"both"``)."""
    if inputs not in ("duty", "torque", "both"):
        raise ValueError(f"inputs must be 'duty', 'torque' or 'both', got {inputs!r}")
    from mwip.hardware.twin import run_on_twin

    res = run_on_twin(ctrl, twin=tw, q0=q0, duration=duration,
                      record_every=1, seed=seed, plant=body)  # fmt: skip
    y = np.asarray(res.logs["y_meas"])[0]
    gyro = np.asarray(res.logs["imu_gyro"])[0]
    u = np.asarray(res.u)
    u = u[0] if u.ndim == 3 else u
    from mwip.params import REAL

    plant = tw.plant(REAL if body is None else body)
    br = float(np.mean(plant.b / plant.r))
    rel = y[:, 0] - y[:, 1] - (y[0, 0] - y[0, 1])
    half = br * (y[:, 2] - y[0, 2])
    n = min(len(y), len(u))
    out = {
        "t": np.arange(n) * tw.Ts,
        "theta": y[:n, 1], "theta_rate": gyro[:n],
        "enc_r": (rel + half)[:n], "enc_l": (rel - half)[:n],
    }  # fmt: skip
    if inputs in ("torque", "both"):
        out["u_r"], out["u_l"] = u[:n, 0], u[:n, 1]
    if inputs in ("duty", "both"):
        m, d = tw.motor, tw.drive
        duty = tw.firmware.torque_gain * m.resistance * u[:n] / (
            d.gear_ratio * d.gear_efficiency * m.k_t * d.supply_voltage)
        out["duty_r"], out["duty_l"] = duty[:, 0], duty[:, 1]
    out["mode"] = np.full(n, "balancing")
    return out


def csv_text(cols: Mapping[str, NDArray]) -> str:
    """Log columns as CSV text (floats with ``repr`` precision)."""
    names = list(cols)
    n = len(next(iter(cols.values())))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\r\n")
    w.writerow(names)
    for i in range(n):
        w.writerow([cols[k][i] if isinstance(cols[k][i], str) else repr(float(cols[k][i]))
                    for k in names])  # fmt: skip
    return buf.getvalue()


def write_csv(path: str | Path, cols: Mapping[str, NDArray]) -> Path:
    """Write log columns as CSV (:func:`csv_text`)."""
    with open(path, "w", newline="") as fh:
        fh.write(csv_text(cols))
    return Path(path)
