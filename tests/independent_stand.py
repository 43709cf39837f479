"""A stand simulator written apart from the twin's code: the reference robot of another
structure for the fit's structure test (issue 37, item 3; tests/test_identify_structure.py,
benchmarks/coverage_structure.py). It imports nothing of ``mwip``; it reads only the robot
file's numbers it is given (``consts``).

Per wheel:

- the firmware: the duty ``d_k`` of the schedule plus the back-EMF compensation
  ``c k_e N w_meas / V_0`` of the speed it *measures* (the last two encoder readings), held
  from ``D Ts`` after the sample (the previous duty before: a true delay, not the twin's mix),
  clipped to +-1, a sharp dead-band ``sign(d) max(|d| - db, 0)``, PWM of 1000 levels;
- the driver and motor: ``V = d V_0`` (no battery sag), ``L i' = V - R i - k_e N w`` with the
  current clamped to +-``I_max`` (the twin clamps the voltage), RK4 at ``Ts / 20``;
- the wheel: ``J w' = eta N k_t i - b_v w - f_c tanh(w / 0.05) - D_b w``, with, in the
  ``off`` structure, ``eta`` = 0.70 where the robot file says 0.75, the rotor reflected
  through the gearbox as ``N^2 J_r / eta`` (the file: ``N^2 J_r``), the wheel's inertia 10 %
  above the file's, and the smooth Coulomb law; ``near`` uses the file's ``eta``, ``N^2
  J_r``, ``Iwa`` and a Coulomb law of width 1e-4 rad/s (near the twin's stick-slip), and
  still differs from the twin in the rest of this list (a true delay, the compensation of the
  measured speed, the current clamp, no battery sag);
- the sensors: encoders of 400 counts per motor turn, a still body's gyro and accelerometer
  with white noise and offsets.
"""

from __future__ import annotations

import math

import numpy as np

DRIVE = ("drive.gear_ratio", "firmware.emf_compensation", "drive.deadband",
         "drive.current_limit", "gearbox.coulomb", "gearbox.viscous", "firmware.delay")  # fmt: skip
#: the truth's ranges (inside the prior's; a robot of this class)
RANGES = {
    "drive.gear_ratio": (4.0, 20.0), "firmware.emf_compensation": (0.2, 0.95),
    "drive.deadband": (0.002, 0.03), "drive.current_limit": (1.5, 6.0),
    "gearbox.coulomb": (0.001, 0.03), "gearbox.viscous": (0.0001, 0.002),
    "firmware.delay": (0.05, 0.9),
}  # fmt: skip


def simulate(truth: dict[str, float], duty: np.ndarray, mode: np.ndarray, consts: dict,
             structure: str, seed: int) -> dict[str, np.ndarray]:  # fmt: skip
    """The stand log (module docstring) as columns of the log schema."""
    rng = np.random.default_rng(seed)
    R, L, kt, Jr, V0, Ts = (consts[k] for k in ("R", "L", "kt", "Jr", "V0", "Ts"))
    N, c = truth["drive.gear_ratio"], truth["firmware.emf_compensation"]
    db = truth["drive.deadband"]
    imax, fc = truth["drive.current_limit"], truth["gearbox.coulomb"]
    bv, D = truth["gearbox.viscous"], truth["firmware.delay"]
    off = structure == "off"
    eta = 0.70 if off else consts["eta"]
    J = consts["Iwa"] * (1.10 if off else 1.0) + N * N * Jr / (eta if off else 1.0)
    width = 0.05 if off else 1e-4
    Db = consts["Db"]
    n, sub = duty.shape[0], 20
    h = Ts / sub
    cpr = 400.0
    q = 2.0 * math.pi / (cpr * N)  # encoder step at the wheel (rad)
    w = np.zeros(2)
    i = np.zeros(2)
    phi = np.zeros(2)
    enc_prev = np.zeros(2)
    d_prev = np.zeros(2)
    enc = np.zeros((n, 2))
    for k in range(n):
        e = np.floor(phi / q) * q
        enc[k] = e
        w_meas = (e - enc_prev) / Ts if k > 0 else np.zeros(2)
        enc_prev = e
        d_new = duty[k] + c * kt * N * w_meas / V0
        d_new = np.clip(d_new, -1.0, 1.0)
        d_new = np.sign(d_new) * np.maximum(np.abs(d_new) - db, 0.0)
        d_new = np.round(d_new * 1000.0) / 1000.0
        for s in range(sub):
            d = d_prev if (s + 0.5) * h < D * Ts else d_new
            V = d * V0

            def f(wi: np.ndarray, ii: np.ndarray, V: np.ndarray = V) -> tuple:
                di = (V - R * ii - kt * N * wi) / L
                tq = eta * N * kt * ii - bv * wi - fc * np.tanh(wi / width) - Db * wi
                return tq / J, di

            a1, b1 = f(w, i)
            a2, b2 = f(w + 0.5 * h * a1, np.clip(i + 0.5 * h * b1, -imax, imax))
            a3, b3 = f(w + 0.5 * h * a2, np.clip(i + 0.5 * h * b2, -imax, imax))
            a4, b4 = f(w + h * a3, np.clip(i + h * b3, -imax, imax))
            phi = phi + h * (w + h / 6.0 * (a1 + a2 + a3))  # (position: RK4 on w)
            w = w + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
            i = np.clip(i + h / 6.0 * (b1 + 2 * b2 + 2 * b3 + b4), -imax, imax)
        d_prev = d_new
    t = np.arange(n) * Ts
    return {
        "t": t, "theta": 0.002 * rng.standard_normal(n),
        "theta_rate": 0.01 + 0.003 * rng.standard_normal(n),
        "enc_r": enc[:, 0], "enc_l": enc[:, 1],
        "accel_x": -0.02 + 0.02 * rng.standard_normal(n),
        "accel_y": 9.81 + 0.02 * rng.standard_normal(n),
        "duty_r": duty[:, 0], "duty_l": duty[:, 1], "mode": mode,
    }


def truth(seed: int) -> dict[str, float]:
    """The seven drive parameters of seed ``seed``, uniform in :data:`RANGES`."""
    rng = np.random.default_rng(1000 + seed)
    return {n: float(rng.uniform(*RANGES[n])) for n in DRIVE}


def consts_of(robot: object) -> dict[str, float]:
    """The robot file's numbers the simulator reads."""
    tw = robot.twin  # type: ignore[attr-defined]
    m, d = tw.motor, tw.drive
    body = robot.body  # type: ignore[attr-defined]
    return {"R": m.resistance, "L": m.inductance, "kt": m.k_t, "Jr": m.rotor_inertia,
            "V0": d.supply_voltage, "Ts": tw.Ts, "eta": d.gear_efficiency,
            "Iwa": float(body.Iwa), "Db": float(body.Db)}  # fmt: skip
