"""Batch of different twins (run_on_twin values=): plant-seconds per second.

SMC (exp_hodosmc) on Case 1, 10 s, on torque-ish twins that stand (emf_compensation = 1,
deadband 0, Coulomb 0, delay 0.2, current limit 10 A, gear ratio 3.7-8, no extra viscous
friction; the other unknowns drawn from the prior) with every element but the fusion (SMC
falls on every twin with the IMU fusion on: the calibration's question, not the benchmark's).

    PYTHONPATH=src python benchmarks/bench_twin_prior.py [N ...]     (default 256 2000)
"""

from __future__ import annotations

import sys
import time

import numpy as np

from mwip.hardware.elements import ELEMENTS
from mwip.hardware.prior import PRIOR
from mwip.hardware.twin import Twin, run_on_twin
from mwip.studies import exp_hodosmc
from mwip.studies.twin_settings import study_settings

NO_FUSION = [e for e in ELEMENTS if e not in ("fusion", "accel_motion", "imu_noise", "imu_bias")]


def values(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    v = PRIOR.as_values(PRIOR.sample(rng, n))
    v["drive.gear_ratio"] = rng.uniform(3.7, 8.0, n)
    for k, x in (("drive.emf_compensation", 1.0), ("drive.deadband", 0.0),
                 ("gearbox.coulomb", 0.0), ("gearbox.viscous", 0.0), ("delay", 0.2),
                 ("drive.current_limit", 10.0)):  # fmt: skip
        v[k] = np.full(n, x)
    return v


def main(sizes: list[int]) -> None:
    cfg = dict(study_settings("exp-hodosmc-speed")[0])
    q0 = (0.0, cfg["theta0"], 0.0)
    # warm-up (Numba kernels, imports; the first full-length run pays more: BENCHMARKS.md)
    run_on_twin(exp_hodosmc.make_controller("smc", cfg, cfg["speed"]), 1, twin=Twin(),
                values=values(4), rows=[NO_FUSION] * 4, duration=10.0, q0=q0)  # fmt: skip
    for n in sizes:
        ctrl = exp_hodosmc.make_controller("smc", cfg, cfg["speed"])
        v = values(n)
        t0 = time.perf_counter()
        res = run_on_twin(ctrl, 1, twin=Twin(), values=v, rows=[NO_FUSION] * n, duration=10.0,
                          q0=q0, seed=0)  # fmt: skip
        wall = time.perf_counter() - t0
        ok = int(np.sum(res.status == "ok"))
        plant_s = float(np.sum(res.t_end))
        rate = plant_s / wall
        print(f"N={n:5d}: {wall:7.2f} s wall, {ok}/{n} stood 10 s, {rate:8.1f} plant-s/s")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [256, 2000])
