"""Batch throughput of the compiled closed loop, and how far it is from the arithmetic bound.

Set-up (issue 18): N = 10,000 robots x 10 s, every parameter of Table 3.1 (the units-reading
real plant) scaled by its own uniform factor in [0.8, 1.2] per robot, theta0 uniform in
+-0.2 rad, 5 ms sampling, the registered ``lqr`` and ``hodosmc`` designed on the nominal
parameters. Records: the first and last sample only (``record_every`` = the whole run), so
memory is O(N), not O(N x steps); the metrics a study needs come from the final states.

Reported: plant-seconds per wall-second with 1 and 2 threads, on the machine as it is and with
two busy-loop processes started by this script keeping both cores busy; the flops of one
plant step (RK4, counted in the optimised LLVM IR of the compiled step) and of the laws
(counted by hand from the kernels), a measured peak of one core (independent multiply-adds,
scalar and vectorised), and the resulting bound.

    python benchmarks/bench_batch.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from dataclasses import fields, replace

import numba
import numpy as np

from mwip.laws import registry
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate
from mwip.sim.kernel import RK4, step_one


def batch_plant(n: int, rng: np.random.Generator):  # noqa: ANN201
    """REAL with every parameter (not g) scaled by its own factor in [0.8, 1.2] per robot."""
    changes = {f.name: getattr(REAL, f.name) * rng.uniform(0.8, 1.2, n)
               for f in fields(REAL) if f.name != "g"}  # fmt: skip
    return replace(REAL, **changes)


def run(ctrl, plant, q0, duration: float) -> tuple[float, float]:  # noqa: ANN001
    """(wall time, fraction still upright) of one batch run, records at both ends only.

    ``ctrl`` is built beforehand, not just before the run: a design's NumPy linear algebra
    leaves OpenBLAS's worker threads spinning for a while, and a threaded batch started in
    that time shares the cores with them (~0.5 s lost by the LQR's 2-thread run of 1.5 s on
    this machine; ``OPENBLAS_NUM_THREADS=1`` removes it). That is the design's cost, not the
    loop's; it is measured separately by ``--design-spin``."""
    n_samples = int(round(duration / 0.005))
    t0 = time.perf_counter()
    res = simulate(ctrl, plant, q0=q0, duration=duration, record_every=n_samples)
    return time.perf_counter() - t0, float(np.mean(res.status == "ok"))


@numba.njit  # not cached: the IR of cached code cannot be inspected
def _one_rk4_step(y, c, tau):  # noqa: ANN001, ANN202
    step_one(y, 0.1, -0.1, tau, 0, 0, c, 0.005, RK4)


def flops_per_rk4_step() -> tuple[int, int]:
    """(floating-point add/sub/mul/div/neg, calls to sin/cos) in the optimised IR of one step."""
    from mwip.models.reduced import coefficients

    y, c, tau = np.zeros(8), np.ascontiguousarray(coefficients(REAL)), np.zeros((3, 1, 3))
    _one_rk4_step(y, c, tau)
    ir = "\n".join(_one_rk4_step.inspect_llvm().values())
    body = ir[ir.index("define") :]
    arith = len(re.findall(r"= (?:fadd|fsub|fmul|fdiv|fneg)\b", body))
    trig = len(re.findall(r"call[^\n]*@(?:llvm\.)?(?:sin|cos)(?:\.f64)?\(", body))
    return arith, trig


@numba.njit(cache=True)
def _peak_scalar(n):  # noqa: ANN001, ANN202
    a0, a1, a2, a3, a4, a5, a6, a7 = 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7
    m, c = 0.9999999, 1e-7
    for _ in range(n):
        a0 = a0 * m + c
        a1 = a1 * m + c
        a2 = a2 * m + c
        a3 = a3 * m + c
        a4 = a4 * m + c
        a5 = a5 * m + c
        a6 = a6 * m + c
        a7 = a7 * m + c
    return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7


@numba.njit(cache=True, fastmath=True)
def _peak_vector(a, n):  # noqa: ANN001, ANN202
    m, c = 0.9999999, 1e-7
    for _ in range(n):
        for i in range(a.size):
            a[i] = a[i] * m + c
    return a[0]


def peak_flops() -> tuple[float, float]:
    """Measured multiply-add rate of one core (flop/s): 8 scalar chains; a vectorised loop."""
    _peak_scalar(10)
    n = 20_000_000
    best_s = min(_timeit(lambda: _peak_scalar(n)) for _ in range(3))
    a = np.ones(512)
    _peak_vector(a, 1)
    m = 100_000
    best_v = min(_timeit(lambda: _peak_vector(a, m)) for _ in range(3))
    return 16 * n / best_s, 2 * a.size * m / best_v


def _timeit(fn) -> float:  # noqa: ANN001
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--design-spin", action="store_true",
                    help="also time LQR batches started right after their design")  # fmt: skip
    args = ap.parse_args()
    n, duration = (1000, 2.0) if args.quick else (10_000, 10.0)
    rng = np.random.default_rng(0)
    plant = batch_plant(n, rng)
    q0 = np.zeros((n, 3))
    q0[:, 1] = rng.uniform(-0.2, 0.2, n)
    ctrls = {name: registry.build(name, NOMINAL) for name in ("lqr", "hodosmc")}
    for ctrl in ctrls.values():  # load the compiled loops
        run(ctrl, batch_plant(64, rng), np.zeros((64, 3)), 0.05)
    if args.design_spin:
        for threads in (1, 2):
            numba.set_num_threads(threads)
            fresh = [run(registry.build("lqr", NOMINAL), plant, q0, duration)[0]
                     for _ in range(args.repeat)]  # fmt: skip
            print(f"lqr, {threads} thread(s), designed just before each run: wall "
                  f"{np.median(fresh):.3f} s [{min(fresh):.3f}, {max(fresh):.3f}]")  # fmt: skip
        print()

    print(f"N = {n} robots x {duration:g} s, 5 ms sampling; {os.cpu_count()} cores; numba "
          f"{numba.__version__}, threading layer {numba.threading_layer()}; load average "
          f"{os.getloadavg()[0]:.2f}")  # fmt: skip
    print()
    print("| controller | machine | threads | wall (s), median [min, max] | plant-s/s | upright |")
    print("|---|---|---|---|---|---|")
    rates: dict[tuple[str, str, int], float] = {}
    for busy in (False, True):
        procs = []
        if busy:
            procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                     for _ in range(os.cpu_count() or 2)]  # fmt: skip
            time.sleep(0.5)
        try:
            for name in ("lqr", "hodosmc"):
                for threads in (1, 2):
                    numba.set_num_threads(threads)
                    ts, ok = [], 0.0
                    for _ in range(1 if args.quick else args.repeat):
                        t, ok = run(ctrls[name], plant, q0, duration)
                        ts.append(t)
                    med = float(np.median(ts))
                    rate = n * duration / med
                    what = "2 busy processes" if busy else "as is"
                    rates[(name, what, threads)] = rate
                    print(f"| {name} | {what} | {threads} | {med:.3f} [{min(ts):.3f}, "
                          f"{max(ts):.3f}] | {rate:,.0f} | {ok:.1%} |")  # fmt: skip
        finally:
            for p in procs:
                p.terminate()
                p.wait()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)

    arith, trig = flops_per_rk4_step()
    scalar, vector = peak_flops()
    # law flops per sample, counted from the kernels (see docs/engine.md)
    # HODOSMC: observer rows on uncoupled channels (12 x 9), d_k and f_k (15), F, G once (85),
    # the surface and law (41)
    law = {"lqr": 24, "hodosmc": 12 * 9 + 15 + 85 + 41}
    print()
    print(f"one RK4 plant step: {arith} add/sub/mul/div/neg and {trig} sin/cos calls "
          f"(optimised IR); peak of one core: {scalar / 1e9:.2f} Gflop/s scalar (8 chains), "
          f"{vector / 1e9:.2f} Gflop/s vectorised")  # fmt: skip
    trig_flops = 20  # a libm sin/cos costs about as much as 20 flops (~15-20 ns at ~1 GHz)
    cores = os.cpu_count() or 2
    for name in ("lqr", "hodosmc"):
        per_sample = arith + trig_flops * trig + law[name]  # one RK4 step per 5 ms sample
        bound_scalar = cores * scalar / per_sample * 0.005
        bound_vector = cores * vector / per_sample * 0.005
        best = max(v for k, v in rates.items() if k[0] == name)
        print(f"{name}: ~{per_sample} flop-equivalents per 5 ms sample; bound {cores} cores "
              f"scalar {bound_scalar:,.0f} plant-s/s (best measured {best:,.0f}: "
              f"{best / bound_scalar:.0%}), vectorised over robots "
              f"{bound_vector:,.0f}")  # fmt: skip


if __name__ == "__main__":
    main()
