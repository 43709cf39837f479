"""Single-run speed of the engine against the loops a user would write, in one process.

The same closed loop every time: the units-reading real plant (`mwip.params.REAL`), the
registered ``lqr`` (discrete Riccati for Ts = 5 ms on the nominal parameters), zero-order
hold, theta0 = 0.1745 rad. References, timed in this process on a shorter run and compared
as rates (plant-seconds per wall-second):

- ``solve_ivp`` restarted every 5 ms on the NumPy model (LSODA and RK45, ``rtol=1e-6,
  atol=1e-9``), the loop of the README's "without mwip" example;
- a NumPy RK4 loop, one step per 5 ms sample (the same method and accuracy as mwip's default);
- python-control: ``input_output_response`` of :func:`mwip.pycontrol.plant_system` over each
  sample with the torque held.

Then mwip's compiled closed loop (25 s LQR; 25 s HODOSMC at 1 ms) and the cost of one 25 s
run of every registered controller relative to the LQR (5 s runs, scaled).

Usage::

    python benchmarks/bench_engine.py            # full
    python benchmarks/bench_engine.py --quick    # smoke test

Prints Markdown for BENCHMARKS.md; each figure is the median of the repeats, with the range.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
from scipy.integrate import solve_ivp

from mwip.laws import registry
from mwip.models import reduced
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate

THETA0 = 0.1745
TS = 0.005


def _rhs(s: np.ndarray, u: np.ndarray) -> np.ndarray:
    a = reduced.accelerations(REAL, s[:3], s[3:6], u)
    return np.r_[s[3:6], a, REAL.r * s[3] * np.cos(s[2]), REAL.r * s[3] * np.sin(s[2])]


def _law(ctrl):  # noqa: ANN001, ANN202
    gain, offset = ctrl._gain, ctrl._offset  # u = y[:6] @ gain + offset
    return lambda s: s[:6] @ gain + offset


def solve_ivp_loop(method: str, duration: float, ctrl) -> np.ndarray:  # noqa: ANN001
    """solve_ivp restarted every control period; the state at the sample instants."""
    law = _law(ctrl)
    s = np.zeros(8)
    s[1] = THETA0
    n = int(round(duration / TS))
    out = np.empty((n + 1, 8))
    out[0] = s
    for k in range(n):
        u = law(s)
        sol = solve_ivp(lambda t, x, u=u: _rhs(x, u), (k * TS, (k + 1) * TS), s, method=method,
                        rtol=1e-6, atol=1e-9)  # fmt: skip
        s = sol.y[:, -1]
        out[k + 1] = s
    return out


def numpy_rk4_loop(duration: float, ctrl) -> np.ndarray:  # noqa: ANN001
    """Classical RK4, one step per 5 ms sample, NumPy right-hand side."""
    law = _law(ctrl)
    s = np.zeros(8)
    s[1] = THETA0
    n = int(round(duration / TS))
    out = np.empty((n + 1, 8))
    out[0] = s
    h = TS
    for k in range(n):
        u = law(s)
        k1 = _rhs(s, u)
        k2 = _rhs(s + 0.5 * h * k1, u)
        k3 = _rhs(s + 0.5 * h * k2, u)
        k4 = _rhs(s + h * k3, u)
        s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[k + 1] = s
    return out


def pycontrol_loop(duration: float, ctrl) -> np.ndarray:  # noqa: ANN001
    """python-control's input_output_response over each sample, torque held."""
    import control as ct

    from mwip.pycontrol import plant_system

    sys = plant_system(REAL)
    law = _law(ctrl)
    s = np.zeros(8)
    s[1] = THETA0
    n = int(round(duration / TS))
    out = np.empty((n + 1, 8))
    out[0] = s
    T = np.array([0.0, TS])
    for k in range(n):
        u = law(s)
        r = ct.input_output_response(sys, T, np.repeat(u[:, None], 2, axis=1), X0=s,
                                     return_states=True)  # fmt: skip
        s = np.asarray(r.states)[:, -1]
        out[k + 1] = s
    return out


def timed(fn, *args, repeat: int = 1, **kwargs):  # noqa: ANN001, ANN201
    """(median, min, max) CPU time of this thread over ``repeat`` calls, and the last result.

    Every run timed here is single-threaded, so the calling thread's CPU time measures the
    work without the time other processes hold the core (this machine is shared); the wall
    time is printed beside it in the summary. Not the process's CPU time: after a BLAS call
    (a controller's design: ``expm``, Riccati) OpenBLAS's worker thread spins for ~0.1 s, and
    the process's CPU time counted that spin in the runs that followed (the first four 25 s
    HODOSMC runs after its build measured ~17 ms instead of ~7 ms)."""
    ts, res = [], None
    for _ in range(repeat):
        t0 = time.thread_time()
        w0 = time.perf_counter()
        res = fn(*args, **kwargs)
        ts.append(time.thread_time() - t0)
        WALL.append(time.perf_counter() - w0)
        CPU.append(ts[-1])
    return (float(np.median(ts)), min(ts), max(ts)), res


WALL: list[float] = []
CPU: list[float] = []


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    rep = 3 if args.quick else args.repeat
    duration = 5.0 if args.quick else 25.0
    probe = 1.0 if args.quick else 4.0
    ctrl = registry.build("lqr", NOMINAL)
    simulate(ctrl, REAL, q0=(0, THETA0, 0), duration=0.1)  # load the compiled loop

    rows: list[tuple[str, tuple[float, float, float], float]] = []
    (tm, lo, hi), res = timed(simulate, ctrl, REAL, q0=(0, THETA0, 0), duration=duration,
                              repeat=rep)  # fmt: skip
    mwip_rate = duration / tm
    rows.append((f"mwip, lqr {duration:g} s (compiled loop, {res.settings['integrator']} "
                 f"{res.settings['dt'] * 1e3:g} ms)", (tm, lo, hi), duration))  # fmt: skip
    refs = {}
    for name, fn, n_rep in (
        ("solve_ivp LSODA loop", lambda d: solve_ivp_loop("LSODA", d, ctrl), 1),
        ("solve_ivp RK45 loop", lambda d: solve_ivp_loop("RK45", d, ctrl), 1),
        ("NumPy RK4 loop, one step per sample", lambda d: numpy_rk4_loop(d, ctrl), 3),
        ("python-control input_output_response per sample",
         lambda d: pycontrol_loop(d, ctrl), 1),
    ):  # fmt: skip
        d = probe if "control" not in name else probe / 4
        (t, lo, hi), states = timed(fn, d, repeat=1 if args.quick else n_rep)
        refs[name] = (d / t, states)
        rows.append((name, (t, lo, hi), d))

    # accuracy of the NumPy RK4 loop and mwip against a tight reference
    tight = simulate(ctrl, REAL, q0=(0, THETA0, 0), duration=probe, dt=TS / 64)
    mw = simulate(ctrl, REAL, q0=(0, THETA0, 0), duration=probe)
    err_mwip = np.abs(mw.theta - tight.theta).max()
    err_rk4 = np.abs(refs["NumPy RK4 loop, one step per sample"][1][:, 1] - tight.theta).max()
    err_ivp = np.abs(refs["solve_ivp LSODA loop"][1][:, 1] - tight.theta).max()

    hodo = registry.build("hodosmc", NOMINAL, Ts=0.001)
    simulate(hodo, REAL, q0=(0, THETA0, 0), duration=0.01)
    # the first full-length runs of a process also pay the kernel's first touch of the records'
    # fresh memory (25,000 samples x 15 numbers, ~3 MB: ~700 page faults, ~1.5 ms) until the
    # allocator keeps such blocks: timed on its own, then the steady state
    (t_cold, _, _), _ = timed(simulate, hodo, REAL, q0=(0, THETA0, 0), duration=duration,
                              repeat=1)  # fmt: skip
    for _ in range(4):
        simulate(hodo, REAL, q0=(0, THETA0, 0), duration=duration)
    (th, hlo, hhi), _ = timed(simulate, hodo, REAL, q0=(0, THETA0, 0), duration=duration,
                              repeat=rep)  # fmt: skip

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, "
          f"{platform.python_implementation()} {platform.python_version()}; "
          f"load average now: {os.getloadavg()[0]:.2f}; wall/CPU time over all timed runs: "
          f"{sum(WALL) / max(sum(CPU), 1e-9):.2f}")  # fmt: skip
    print()
    print("| run | CPU time (s), median [min, max] | plant-s per CPU-s | mwip is faster by |")
    print("|---|---|---|---|")
    for name, (t, lo, hi), d in rows:
        rate = d / t
        vs = "" if name.startswith("mwip") else f"{mwip_rate / rate:.0f}x"
        print(f"| {name}, {d:g} s | {t:.4f} [{lo:.4f}, {hi:.4f}] | {rate:.1f} | {vs} |")
    print(f"| mwip, hodosmc at 1 ms, {duration:g} s, steady state | {th:.4f} [{hlo:.4f}, "
          f"{hhi:.4f}] | {duration / th:.0f} | |")  # fmt: skip
    print(f"| mwip, hodosmc at 1 ms, {duration:g} s, first full-length run of the process | "
          f"{t_cold:.4f} | {duration / t_cold:.0f} | |")  # fmt: skip
    print()
    print(f"max |theta error| over {probe:g} s vs RK4 at Ts/64: mwip {err_mwip:.1e}, NumPy RK4 "
          f"loop {err_rk4:.1e}, solve_ivp LSODA loop {err_ivp:.1e} rad")  # fmt: skip

    # every registered controller: cost of a run relative to the LQR
    print()
    print("| controller | loop | 5 s run, CPU s, median | cost / lqr's |")
    print("|---|---|---|---|")
    base = None
    for name in registry.names():
        c = registry.build(name, NOMINAL)
        simulate(c, REAL, q0=(0, 0.05, 0), duration=0.05)
        (t, _, _), r = timed(lambda c=c: simulate(c, REAL, q0=(0, 0.05, 0), duration=5.0),
                             repeat=3)  # fmt: skip
        base = t if name == "lqr" else base
        loop = "compiled" if r.settings.get("compiled") else "Python"
        print(f"| {name} | {loop} | {t:.4f} | {t / base:.1f} |")


if __name__ == "__main__":
    main()
