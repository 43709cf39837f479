"""Step-size convergence of the engine on a closed loop (the table in docs/engine.md).

Sampled LQR (5 ms hold, designed for 5 ms) and the book's continuous LQR in continuous mode,
both on the real plant from theta0 = 0.1745 rad for 10 s (5 s continuous). For each step the
max |difference| of the recorded states [psi, theta, alpha, psi', theta', alpha'] against the
run with half the step.

    python benchmarks/convergence.py
"""

from __future__ import annotations

import numpy as np

from mwip.control.lqr import LQR, design_lqr
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate


def table(mode: str, steps: list[float], duration: float) -> None:
    ctrl = LQR(design_lqr(NOMINAL, Ts=None if mode == "continuous" else 0.005))
    runs = {
        dt: simulate(ctrl, REAL, q0=(0, 0.1745, 0), duration=duration, Ts=0.005, dt=dt, mode=mode)
        for dt in steps
    }
    print(f"\n{mode}: | dt (ms) | max diff vs dt/2, angles (rad) | rates (rad/s) |")
    for a, b in zip(steps[:-1], steps[1:], strict=True):
        d = np.abs(runs[a].state[:, :6] - runs[b].state[:, :6])
        print(f"| {a * 1e3:g} | {d[:, :3].max():.2e} | {d[:, 3:].max():.2e} |")


if __name__ == "__main__":
    table("sampled", [1e-3, 5e-4, 2.5e-4, 1.25e-4], 10.0)
    table("continuous", [1e-3, 5e-4, 2.5e-4], 5.0)
