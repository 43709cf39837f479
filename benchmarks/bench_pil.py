"""Processor in the loop (issue 36): every controller on the emulated Cortex-M3, double and float.

    python benchmarks/bench_pil.py [--names lqr,hodosmc] [--probe 20000] [--board hodosmc]

For every registered controller and both precisions: cross-compile the exported C for the
LM3S2965 (mwip.export.firmware), run the closed loop of ``mwip.export.pil.COST_RUN`` (10 s,
2,000 samples: a lean of 0.1 rad, the steady state, a 0.5 N m push for 0.1 s at 5 s) through
the emulated processor and through the host's build of the same C, and print

- the closed-loop differences of the emulated processor from the host (state, torque), the
  step computation alone (the host fed the emulated run's measurements: the largest torque
  difference and the number of steps that differ), and for float the float build's own
  deviation from the double Python controller on the same run; and the same closed loops
  with sin/cos replaced by fixed polynomials in both builds (``without_libm``: identical);
- instructions per step (first, median, maximum), the cycle bound of the largest step, its
  time at 50 MHz and its share of the 5 ms period, the image's flash/RAM/stack;
- the wall time of the emulated 10 s run (instruction counts are repeatable whatever the
  machine's load; times are not: the machine and its load are printed).

``--probe N``: newlib's ``sin``/``cos``/``sqrt`` (the board's) against glibc's (the host's) on
N arguments in [-0.6, 0.6] (the pitch range of the runs; ``sqrt`` on [0, 2]): how many
results differ and by how many units in the last place; and libgcc's soft-float addition
``2^k - y`` for ``y`` every number of binary orders ``d`` below (the one corner where it
misrounds, docs/export.md). ``--board NAME``: the whole-board
check, the same object code on QEMU's lm3s6965evb over its UART, against the in-process run.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from mwip.export import generate_c
from mwip.export.firmware import build_firmware
from mwip.export.pil import (
    CLOCK_HZ,
    CONTROL_SHARE,
    COST_RUN,
    PILController,
    math_probe,
    run_pil,
    uses_libm,
    without_libm,
)
from mwip.export.sil import CController
from mwip.laws import registry
from mwip.params import NOMINAL


def _probe(n: int) -> None:
    from mwip.core import Measurement

    rng = np.random.default_rng(0)
    print(f"\nnewlib (board) vs glibc (host) on {n} arguments:")
    print("| function | precision | results that differ | largest difference (ulp) |")
    print("|---|---|---|---|")
    for precision in ("double", "float"):
        dt = np.float32 if precision == "float" else np.float64
        for fn in ("sin", "cos", "sqrt"):
            lo = 0.0 if fn == "sqrt" else -0.6
            hi = 2.0 if fn == "sqrt" else 0.6
            x = rng.uniform(lo, hi, (n, 8)).astype(dt).astype(float)
            code = math_probe(fn, precision)
            pil, host = PILController(code), CController(code)
            m0 = Measurement(0.0, x[:1])
            pil.reset(m0)
            host.reset(m0)
            a = np.array([pil(0.0, Measurement(0.0, x[k : k + 1]))[0] for k in range(n)])
            b = np.array([host(0.0, Measurement(0.0, x[k : k + 1]))[0] for k in range(n)])
            a, b = a.astype(dt), b.astype(dt)
            differ = int(np.sum(a != b))
            ulp = int(
                np.max(
                    np.abs(
                        a.view(np.int64 if dt is np.float64 else np.int32).astype(np.int64)
                        - b.view(np.int64 if dt is np.float64 else np.int32).astype(np.int64)
                    )
                )
            )
            print(f"| {fn} | {precision} | {differ} of {2 * n} | {ulp} |")


def _add_scan(n: int) -> None:
    """libgcc's soft-float addition on the board against the host's: a power of two plus a
    number of the other sign ``d`` binary orders smaller, for every ``d``."""
    from mwip.core import Measurement

    rng = np.random.default_rng(0)
    print(f"\nsoft-float addition 2^k - y, y in 2^(k-d) [1, 2), {n} pairs per d (host: exact):")
    for precision, dt, top in (("double", np.float64, 60), ("float", np.float32, 30)):
        pil = PILController(math_probe("add", precision))
        pil.reset(Measurement(0.0, np.zeros((1, 8))))
        wrong = {}
        for d in range(1, top):
            a = 2.0 ** rng.integers(-4, 4, n)
            b = -rng.uniform(1, 2, n) * a * 2.0**-d
            a, b = a.astype(dt), b.astype(dt)
            bad = 0
            for k in range(0, n - 1, 2):
                y = np.array([[a[k], b[k], a[k + 1], b[k + 1], 0, 0, 0, 0]], dtype=float)
                u = pil(0.0, Measurement(0.0, y))[0].astype(dt)
                bad += int(u[0] != a[k] + b[k]) + int(u[1] != a[k + 1] + b[k + 1])
            if bad:
                wrong[d] = bad
        print(f"  {precision}: misrounded at d = {wrong or 'none'} (of {n} each)")


def _board(name: str) -> None:
    from mwip.export.board import BoardController, qemu_available
    from mwip.params import REAL
    from mwip.sim import simulate

    if not qemu_available():
        print("\nwhole-board check: qemu-system-arm not found, skipped")
        return
    for precision in ("double", "float"):
        code = generate_c(registry.build(name, NOMINAL), prefix=f"mwip_{name}",
                          precision=precision)  # fmt: skip
        fw = build_firmware(code)
        runs = []
        t0 = time.perf_counter()
        with BoardController(fw) as board:
            runs.append(simulate(board, REAL, q0=(0, COST_RUN.theta0, 0),
                                 duration=COST_RUN.duration,
                                 disturbance=COST_RUN.disturbance()))  # fmt: skip
        t_board = time.perf_counter() - t0
        runs.append(
            simulate(
                PILController(fw),
                REAL,
                q0=(0, COST_RUN.theta0, 0),
                duration=COST_RUN.duration,
                disturbance=COST_RUN.disturbance(),
            )
        )
        ds = float(np.max(np.abs(runs[0].state - runs[1].state)))
        du = float(np.nanmax(np.abs(runs[0].u - runs[1].u)))
        print(
            f"\nwhole board (QEMU lm3s6965evb, UART) vs in-process PIL, {name} {precision}: "
            f"max state diff {ds:.3g}, max u diff {du:.3g}; {t_board:.1f} s for 10 s"
        )


def main(names: list[str], probe: int, board: str | None) -> None:
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, load "
          f"{tuple(round(x, 2) for x in os.getloadavg())}")  # fmt: skip
    print(f"run: {COST_RUN}; clock {CLOCK_HZ / 1e6:g} MHz; control share {CONTROL_SHARE:.0%} "
          "of Ts")  # fmt: skip
    rows = []
    for name in names:
        for precision in ("double", "float"):
            code = generate_c(registry.build(name, NOMINAL), prefix=f"mwip_{name}",
                              precision=precision)  # fmt: skip
            fw = build_firmware(code)
            t0 = time.perf_counter()
            rep = run_pil(name, registry.build(name, NOMINAL), code, firmware=fw)
            wall = time.perf_counter() - t0
            same = "(no sin/cos)"
            if uses_libm(code):
                alt = run_pil(name, registry.build(name, NOMINAL), without_libm(code))
                same = "identical" if alt.identical else f"{alt.max_state_diff:.2g}"
            rows.append((rep, wall, same))
            print(f"  {name} {precision}: {wall:.1f} s", flush=True)
    print(f"\nflags: {rows[0][0].flags}; {rows[0][0].compiler}")
    print("\n| controller | precision | PIL vs host: max state diff | max theta diff | max u "
          "diff | step u diff (steps) | sin/cos as polynomials | float vs double: state "
          "(theta) | status |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for rep, _, same in rows:
        fd = ("" if rep.float_state_diff is None
              else f"{rep.float_state_diff:.2g} ({rep.float_theta_diff:.2g})")  # fmt: skip
        print(f"| {rep.controller} | {rep.precision} | {rep.max_state_diff:.2g} | "
              f"{rep.max_theta_diff:.2g} | {rep.max_u_diff:.2g} | {rep.step_u_diff:.2g} "
              f"({rep.steps_differing}) | {same} | {fd} | {rep.status_pil} |")  # fmt: skip
    print("\n| controller | precision | first | median | max (transient/steady/push/after) "
          "| cycle bound | CPI | time at 50 MHz | share of 5 ms | fits | flash/RAM/stack B "
          "| wall s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for rep, wall, _ in rows:
        ph = "/".join(str(v) for v in rep.phase_max().values())
        t = rep.time_s()
        print(f"| {rep.controller} | {rep.precision} | {rep.first} | {rep.median:.0f} | "
              f"{rep.max} ({ph}) | {rep.max_cycles} | {rep.cpi_bound:.2f} | {t * 1e3:.3f} ms | "
              f"{t / rep.Ts:.1%} | {'yes' if rep.fits() else 'NO'} | {rep.flash_bytes}/"
              f"{rep.ram_bytes}/{rep.stack_bytes} | {wall:.1f} |")  # fmt: skip
    if probe:
        _probe(probe)
        _add_scan(max(probe // 20, 100))
    if board:
        _board(board)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--names", default=",".join(registry.names()))
    ap.add_argument("--probe", type=int, default=20000)
    ap.add_argument("--board", default="hodosmc")
    a = ap.parse_args()
    main([n for n in a.names.split(",") if n], a.probe, a.board or None)
