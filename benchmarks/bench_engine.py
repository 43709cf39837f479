"""Engine speed against the straightforward SciPy loop, measured in one process.

Reference: the same plant (real parameters) and the same discrete LQR (5 ms zero-order hold,
designed for Ts = 5 ms on the nominal parameters), written the obvious way: a Python loop
over control periods, ``scipy.integrate.solve_ivp`` restarted every 5 ms on the NumPy
right-hand side :func:`mwip.models.reduced.accelerations`. The fastest of RK45, LSODA and
Radau on this stiff plant is chosen first (on a 2 s run) and then timed on the full run.

Usage::

    python benchmarks/bench_engine.py            # full: 25 s single run, batch of 1000
    python benchmarks/bench_engine.py --quick    # smaller, for a smoke test

Prints a Markdown table for BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import platform
import time
from dataclasses import replace

import numpy as np
from scipy.integrate import solve_ivp

from mwip.control.lqr import LQR, design_lqr
from mwip.linearize import state_from_q
from mwip.models import reduced
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate

THETA0 = 0.1745
TS = 0.005


def reference_run(method: str, duration: float, K: np.ndarray, r_nom: float) -> np.ndarray:
    """solve_ivp restarted every control period; returns the state at the sample instants."""
    p = REAL

    def rhs(t: float, s: np.ndarray, u: np.ndarray) -> np.ndarray:
        a = reduced.accelerations(p, s[:3], s[3:6], u)
        return np.r_[s[3:6], a, p.r * s[3] * np.cos(s[2]), p.r * s[3] * np.sin(s[2])]

    s = np.zeros(8)
    s[1] = THETA0
    n = int(round(duration / TS))
    out = np.empty((n + 1, 8))
    out[0] = s
    for k in range(n):
        x = state_from_q(s[:3], s[3:6], r_nom)
        u = -K @ x
        sol = solve_ivp(rhs, (k * TS, (k + 1) * TS), s, method=method, args=(u,),
                        rtol=1e-6, atol=1e-9)  # fmt: skip
        s = sol.y[:, -1]
        out[k + 1] = s
    return out


def timed(fn, *args, repeat: int = 1, **kwargs):  # noqa: ANN001, ANN201
    best, res = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = fn(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return best, res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    args = ap.parse_args()
    duration = 5.0 if args.quick else 25.0
    n_batch = 100 if args.quick else 1000
    design = design_lqr(NOMINAL, Ts=TS)
    ctrl = LQR(design)

    # warm up the compiled kernels (compilation is cached on disk after the first run)
    simulate(ctrl, REAL, q0=(0, THETA0, 0), duration=0.1)

    probe = 1.0 if args.quick else 2.0
    times = {}
    for method in ("RK45", "LSODA", "Radau"):
        times[method], _ = timed(reference_run, method, probe, design.K, NOMINAL.r)
    best = min(times, key=times.get)
    t_ref, ref_states = timed(reference_run, best, duration, design.K, NOMINAL.r)

    t_single, res = timed(simulate, ctrl, REAL, q0=(0, THETA0, 0), duration=duration, repeat=5)
    dev = np.abs(res.state[:, :6] - ref_states[:, :6]).max()

    rng = np.random.default_rng(0)
    plants = replace(
        REAL,
        mb=REAL.mb * (1 + 0.1 * rng.standard_normal(n_batch)),
        l=REAL.l * (1 + 0.1 * rng.standard_normal(n_batch)),
    )
    q0 = np.zeros((n_batch, 3))
    q0[:, 1] = rng.uniform(-0.2, 0.2, n_batch)
    simulate(ctrl, plants, q0=q0, duration=0.1)  # warm the threaded kernel
    t_batch, bres = timed(simulate, ctrl, plants, q0=q0, duration=duration, record_every=2)
    ok = float(np.mean(bres.status == "ok"))

    ref_rate = duration / t_ref
    print(f"machine: {platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, duration {duration:g} s, Ts = 5 ms, dt = "
          f"{res.settings['dt'] * 1e3:g} ms")  # fmt: skip
    print()
    print("| run | wall time (s) | real-time factor / plant-s per s | vs reference |")
    print("|---|---|---|---|")
    for m, tm in times.items():
        print(f"| reference solve_ivp {m}, {probe:g} s | {tm:.3f} | {probe / tm:.1f}x | |")
    print(f"| reference solve_ivp {best}, single {duration:g} s | {t_ref:.3f} | "
          f"{ref_rate:.1f}x | 1 |")  # fmt: skip
    print(f"| mwip single {duration:g} s | {t_single:.4f} | {duration / t_single:.0f}x | "
          f"{t_ref / t_single:.0f}x faster |")  # fmt: skip
    print(f"| mwip batch {n_batch} x {duration:g} s | {t_batch:.3f} | "
          f"{n_batch * duration / t_batch:.0f} plant-s/s | "
          f"{n_batch * duration / t_batch / ref_rate:.0f}x faster |")  # fmt: skip
    print()
    print(f"max |state difference| mwip vs reference (single run): {dev:.2e}; "
          f"batch plants balanced: {ok:.1%}")  # fmt: skip


if __name__ == "__main__":
    main()
