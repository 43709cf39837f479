"""Does `mwip twin fit` cover the truth on a robot whose structure differs from its twin's?
(issue 37, item 3: measured rates; no method of widening is claimed here.)

Stand logs (wheels off the ground, the body held, static hold, duty steps and a chirp of
`mwip twin excite`) from a **second simulator written apart from the twin's code** (this file
imports nothing of ``mwip.hardware``; it reads only the robot file's numbers), per wheel:

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

For each seed the seven drive parameters are drawn inside their prior ranges, the log is
fitted with the default robot file (``fit(..., twin=default twin, body=default body)``) and
each fitted parameter's 2-standard-error interval is checked against the truth.

    PYTHONPATH=src python benchmarks/coverage_structure.py --seeds 20 --structure off
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--structure", choices=["off", "near", "twin"], default="off",
                    help="twin: logs of the twin's own structure (mwip.identify.synth)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--static", type=float, default=0.5)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--chirp", type=float, default=1.0)
    args = ap.parse_args()

    from mwip.identify import excite, synth
    from mwip.identify.fit import fit
    from mwip.identify.logs import read_log
    from mwip.robot import default_robot

    robot = default_robot()
    tw = robot.twin
    m, d = tw.motor, tw.drive
    consts = {"R": m.resistance, "L": m.inductance, "kt": m.k_t, "Jr": m.rotor_inertia,
              "V0": d.supply_voltage, "Ts": tw.Ts, "eta": d.gear_efficiency,
              "Iwa": float(robot.body.Iwa), "Db": float(robot.body.Db)}  # fmt: skip
    _, duty, mode = excite.schedule(tw.Ts, args.static, args.step, args.chirp)
    hits = {n: 0 for n in DRIVE}
    wide = {n: 0 for n in DRIVE}
    shown = {n: 0 for n in DRIVE}  # the reported interval: widened where rejected
    rejected = 0
    tried = {n: 0 for n in DRIVE}
    devs: dict[str, list[float]] = {n: [] for n in DRIVE}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            rng = np.random.default_rng(1000 + seed)
            truth = {n: float(rng.uniform(*RANGES[n])) for n in DRIVE}
            if args.structure == "twin":
                truth = synth.draw_truth(seed)
                cols = synth.stand_log(truth, duty, mode, seed=seed)
            else:
                cols = simulate(truth, duty, mode, consts, args.structure, seed)
            path = Path(tmp) / f"log{seed}.csv"
            path.write_text(synth.csv_text(cols))
            res = fit([read_log(str(path))], tw, body=robot.body)
            chk = res.structure
            rej = chk is not None and chk.rejected
            rejected += rej
            for n in DRIVE:
                se = res.stderr.get(n)
                if res.status[n] != "fitted" or se is None or not se > 0:
                    continue
                z = (res.estimates[n] - truth[n]) / se
                tried[n] += 1
                hits[n] += abs(z) <= 2.0
                sw = se if chk is None else chk.widened.get(n, se)
                zw = abs(res.estimates[n] - truth[n]) / sw
                wide[n] += zw <= 2.0
                shown[n] += (zw if rej else abs(z)) <= 2.0
                devs[n].append(z)
            if chk is not None:
                print(f"  structure ratio {chk.ratio:.3g} (rms {chk.rms:.3g}, floor "
                      f"{chk.floor:.3g}), rejected {rej}", flush=True)
            print(f"seed {seed}: " + ", ".join(
                f"{n.split('.')[-1]} {devs[n][-1]:+.1f}" for n in DRIVE if devs[n]
                and len(devs[n]) == tried[n]), flush=True)  # fmt: skip
    print(f"\nstructure {args.structure}, {args.seeds} seeds, {time.perf_counter() - t0:.0f} s")
    print(f"structure rejected on {rejected} of {args.seeds} logs")
    print("| parameter | covered by +-2 s.e. | by +-2 widened s.e. | by the reported interval "
          "| median abs(z) | max abs(z) |")
    print("|---|---|---|---|---|---|")
    for n in DRIVE:
        z = np.abs(devs[n]) if devs[n] else np.array([np.nan])
        print(f"| {n} | {hits[n]} of {tried[n]} | {wide[n]} | {shown[n]} | "
              f"{np.median(z):.1f} | {np.max(z):.1f} |")
    total_t = max(sum(tried.values()), 1)
    print("| all | " + " | ".join(f"{sum(d.values())} of {total_t} "
                                  f"({100 * sum(d.values()) / total_t:.0f} %)"
                                  for d in (hits, wide, shown)) + " | | |")


if __name__ == "__main__":
    main()
