"""Per-sample cost of the compiled control laws against their NumPy composition, one process.

Reference: the same law built from the NumPy oracles of tests/oracle_laws.py (SMC: ``f_g`` +
``sliding_surface`` + ``smc_law``; TSMC: ``subsystem`` + ``augmenting`` + ``tsmc_surface`` +
``tsmc_gain`` + ``tsmc_law``), as the controllers evaluated it before the fused kernels. Both
are called on the same measurement, one robot, many times; the ratio is what a quasi-continuous
study (one law call per 0.5-1 ms) gains. The results agree to rounding (tested in
tests/test_kernels.py).

Usage::

    python benchmarks/bench_laws.py [--calls N]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from mwip.laws.smc.controller import SlidingModeController, SMCGains
from mwip.laws.switching import Switching
from mwip.laws.tsmc.controller import TSMC

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from mwip.models.reduced import f_g
from mwip.params import NOMINAL
from mwip.sim.sensors import Measurement
from oracle_laws import (  # noqa: E402
    augmenting,
    sliding_surface,
    smc_law,
    subsystem,
    tsmc_gain,
    tsmc_law,
    tsmc_surface,
)


def _time(fn, calls: int) -> float:  # noqa: ANN001
    fn()  # compile / warm up
    t0 = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t0) / calls


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=20000)
    calls = ap.parse_args().calls
    y = np.array([[0.3, 0.1, -0.2, 1.0, -0.5, 0.2, 0.0, 0.0]])
    meas = Measurement(t=0.7, y=y)
    q, qd = meas.q, meas.qdot

    gains = SMCGains((3.0, 0.2, 0.3, 3.0), 7.5, 4.0)
    smc = SlidingModeController(gains, params=NOMINAL, check=False)
    smc.reset(meas)
    zeros = np.zeros((1, 3))

    def smc_numpy() -> np.ndarray:
        F, G = f_g(NOMINAL, q, qd)
        S = sliding_surface(q, qd, 0.7, gains.lambdas)
        uAB = smc_law(F, G, qd, S, zeros, gains, Switching())
        return np.column_stack([0.5 * (uAB[:, 0] + uAB[:, 1]), 0.5 * (uAB[:, 0] - uAB[:, 1])])

    tsmc = TSMC(NOMINAL)
    tsmc.reset(Measurement(t=0.0, y=np.zeros((1, 8))))

    def tsmc_numpy() -> np.ndarray:
        e, ed = tsmc.errors(0.7, meas)
        a, ad, add = augmenting(0.7, tsmc._coeffs, tsmc.Tf)
        s = tsmc_surface(e, ed, a, ad, tsmc.C)
        F1, G1 = subsystem(NOMINAL, q, qd)
        k = tsmc_gain(F1, F1 + tsmc.C * ed - add - tsmc.C * ad, tsmc.Ftilde_ratio, tsmc.D,
                      tsmc.Gamma)  # fmt: skip
        return tsmc_law(F1, G1, ed, ad, add, 0.0, tsmc.C, k, tsmc.switching(s))

    print("| law | NumPy composition (us/call) | mwip controller (us/call) | speed-up |")
    print("|---|---|---|---|")
    for label, ref, fast in (
        ("SMC (3.49)-(3.50)", smc_numpy, lambda: smc(0.7, meas)),
        ("TSMC (4.30)-(4.32)", tsmc_numpy, lambda: tsmc(0.7, meas)),
    ):
        t_ref, t_fast = _time(ref, calls), _time(fast, calls)
        print(f"| {label} | {1e6 * t_ref:.1f} | {1e6 * t_fast:.1f} | {t_ref / t_fast:.1f}x |")


if __name__ == "__main__":
    main()
