"""Candidates in one batch against one run per candidate, in one process (issue 24 item 1).

A tuner evaluates K candidate settings of one law on the same M robots. Reference: K engine
calls, one per candidate (each a batch of the M robots). Against it: one engine call of the
K x M robots with one packed parameter vector per robot (:func:`mwip.laws.batch.batch`), in
the compiled loop. Both give the same numbers (tests/test_packing.py); the ratio is the time
a tuner saves per population. Wall time of the calls after a warm-up (Numba caches warm).

Usage::

    python benchmarks/bench_packed.py [--law hodosmc] [--K 8] [--M 32] [--duration 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mwip.laws.batch import batch
from mwip.laws.registry import build
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", default="hodosmc")
    ap.add_argument("--K", type=int, default=8)
    ap.add_argument("--M", type=int, default=32)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--twin", action="store_true",
                    help="on the default (identified) twin: its sensors and drive, Python loop")
    a = ap.parse_args()
    plant = REAL
    if a.twin:
        from mwip.hardware.identified import default_twin

        twin = default_twin()
        plant = twin.plant(REAL)

        def kw_for() -> dict:
            return {"sensor": twin.sensor(REAL), "actuator": twin.actuator(REAL),
                    "Ts": twin.Ts, "dt": twin.dt, "seed": 1}
    else:
        def kw_for() -> dict:
            return {}
    rng = np.random.default_rng(0)
    base = np.array((6.3, 4.0))  # Table 6.3's HODOSMC gains (the SMC family's K)
    cands = [{"K": tuple(base * rng.uniform(0.7, 1.3, 2))} for _ in range(a.K)]
    q0 = np.column_stack([np.zeros(a.M), rng.uniform(-0.15, 0.15, a.M), np.zeros(a.M)])

    def separate() -> float:
        t0 = time.perf_counter()
        for c in cands:
            simulate(build(a.law, NOMINAL, c, Ts=0.005), plant, q0=q0, duration=a.duration,
                     **kw_for())
        return time.perf_counter() - t0

    def together() -> float:
        t0 = time.perf_counter()
        simulate(batch(a.law, cands, NOMINAL, Ts=0.005, repeat=a.M), plant,
                 q0=np.tile(q0, (a.K, 1)), duration=a.duration, **kw_for())
        return time.perf_counter() - t0

    separate(), together()  # warm-up (compile, caches)
    ts = sorted(separate() for _ in range(a.repeat))
    tt = sorted(together() for _ in range(a.repeat))
    plant_s = a.K * a.M * a.duration
    ms, mt = ts[len(ts) // 2], tt[len(tt) // 2]
    where = "twin" if a.twin else "plain plant, compiled loop"
    print(f"| {where}: {a.law}, K = {a.K} candidates x M = {a.M} robots x {a.duration:g} s | "
          f"{ms:.3f} s ({plant_s / ms:,.0f} plant-s/s) | {mt:.3f} s ({plant_s / mt:,.0f} "
          f"plant-s/s) | **{ms / mt:.2f}x** |")


if __name__ == "__main__":
    main()
