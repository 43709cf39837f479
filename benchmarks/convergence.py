"""Step-size convergence of the engine per loop (the tables in docs/engine.md).

For each loop on the units-reading plant (`mwip.params.REAL`, from theta0 = 0.1745 rad):

- sampled at 5 ms: the registered ``lqr`` (discrete design) and ``hodosmc``, 10 s;
- sampled at 1 ms: ``hodosmc`` designed for 1 ms, 10 s;
- continuous: the book's continuous LQR gain (closed-loop poles near -1e5 rad/s), 5 s,
  ROS2 with the closed loop's Jacobian (the only stiff loop left on this plant);

and, for comparison, the sampled LQR on the literal-reading plant (``REAL_LITERAL``, stiff).
Each integrator/step is compared with a tight reference (RK4 at Ts/64, or ROS2 at 1/32 of the
coarsest step for the continuous loop) and with the same method at a 4x finer step: the max
|error| of theta (rad) and of the rates (rad/s), and the largest relative change of the
run's metrics (RMS theta, max |theta|, RMS u, final psi').

    python benchmarks/convergence.py
"""

from __future__ import annotations

import numpy as np

from mwip.laws import registry
from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.params import NOMINAL, NOMINAL_LITERAL, REAL, REAL_LITERAL
from mwip.sim import simulate

Q0 = (0.0, 0.1745, 0.0)


def metrics(res) -> np.ndarray:  # noqa: ANN001
    th, u = res.theta, res.u
    return np.array([np.sqrt(np.mean(th**2)), np.abs(th).max(), np.sqrt(np.mean(u**2)),
                     res.q_dot[-1, 0]])  # fmt: skip


def compare(title: str, make, plant, Ts, duration, runs, ref, mode="sampled") -> None:  # noqa: ANN001
    """``runs``: list of (label, integrator, dt, dt/4); ``ref``: (integrator, dt)."""

    def go(integ: str, dt: float):
        return simulate(make(), plant, q0=Q0, duration=duration, Ts=Ts, dt=dt, mode=mode,
                        integrator=integ)  # fmt: skip

    r = go(*ref)
    print(f"\n{title} (reference {ref[0]} at {ref[1] * 1e3:g} ms)")
    print("| method, step | steps per sample | theta err (rad) | rate err (rad/s) "
          "| max rel. metric change vs dt/4 | vs reference |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    mr = metrics(r)
    for label, integ, dt in runs:
        a, b = go(integ, dt), go(integ, dt / 4)
        ok = a.ok and b.ok
        e_th = np.abs(a.theta - r.theta).max() if ok else np.nan
        e_rt = np.abs(a.q_dot - r.q_dot).max() if ok else np.nan
        ma, mb = metrics(a), metrics(b)
        scale = np.maximum(np.abs(mb), 1e-12)
        rel4 = np.max(np.abs(ma - mb) / scale) if ok else np.nan
        relr = np.max(np.abs(ma - mr) / np.maximum(np.abs(mr), 1e-12)) if ok else np.nan
        print(f"| {label} | {round(Ts / dt)} | {e_th:.1e} | {e_rt:.1e} | {rel4:.1e} | {relr:.1e} |")


def main() -> None:
    lqr = lambda: registry.build("lqr", NOMINAL)  # noqa: E731
    hodo5 = lambda: registry.build("hodosmc", NOMINAL)  # noqa: E731
    hodo1 = lambda: registry.build("hodosmc", NOMINAL, Ts=0.001)  # noqa: E731
    five = [("RK4 5 ms", "rk4", 0.005), ("RK4 2.5 ms", "rk4", 0.0025),
            ("RK4 1 ms", "rk4", 0.001), ("ROS2-W 1 ms", "ros2w", 0.001),
            ("ROS2-W 0.5 ms (old default)", "ros2w", 0.0005)]  # fmt: skip
    compare("sampled 5 ms, lqr, units plant, 10 s", lqr, REAL, 0.005, 10.0, five,
            ("rk4", 0.005 / 64))  # fmt: skip
    compare("sampled 5 ms, hodosmc, units plant, 10 s", hodo5, REAL, 0.005, 10.0, five,
            ("rk4", 0.005 / 64))  # fmt: skip
    one = [("RK4 1 ms", "rk4", 0.001), ("RK4 0.5 ms", "rk4", 0.0005),
           ("ROS2-W 0.5 ms (old default)", "ros2w", 0.0005)]  # fmt: skip
    compare("sampled 1 ms, hodosmc, units plant, 10 s", hodo1, REAL, 0.001, 10.0, one,
            ("rk4", 0.001 / 64))  # fmt: skip
    book = lambda: LQR(design_lqr(NOMINAL, Ts=None))  # noqa: E731
    cont = [("ROS2 (Jacobian) 1 ms", "ros2w", 0.001), ("ROS2 0.5 ms (default)", "ros2w", 0.0005),
            ("ROS2 0.25 ms", "ros2w", 0.00025)]  # fmt: skip
    compare("continuous, book LQR gain, units plant, 5 s", book, REAL, 0.005, 5.0, cont,
            ("ros2w", 0.001 / 32), mode="continuous")  # fmt: skip
    lit = lambda: LQR(design_lqr(NOMINAL_LITERAL, Ts=0.005))  # noqa: E731
    stiff = [("RK4 0.5 ms", "rk4", 0.0005), ("ROS2-W 1 ms", "ros2w", 0.001),
             ("ROS2-W 0.5 ms (default)", "ros2w", 0.0005)]  # fmt: skip
    compare("sampled 5 ms, dlqr, literal (stiff) plant, 10 s", lit, REAL_LITERAL, 0.005, 10.0,
            stiff, ("ros2w", 0.005 / 160))  # fmt: skip


if __name__ == "__main__":
    main()
