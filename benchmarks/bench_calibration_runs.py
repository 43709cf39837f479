"""The book calibration's 25 Chapter 6 runs on a batch of twins: compiled twin loop against the
Python loop, in one process (issue 23).

Reference: :func:`mwip.calibration.runs.run_batch` with ``drive_logs=True`` (the controller
wrapped for the twin's drive and IMU logs, so the Python loop of the engine). Against it: the
default ``drive_logs=False``, where every law runs packed in the compiled twin loop, which
records the measurement itself. Both give the same columns to round-off
(tests/test_twin_loop.py). The twins are the default twin's unknowns, repeated: every run
stands for its whole duration, the costly case (a chain of stage 3 spends its time there).
Wall time after one warm-up call of each (Numba caches warm).

Usage::

    python benchmarks/bench_calibration_runs.py [--twins 16] [--repeat 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mwip.calibration.runs import run_batch
from mwip.hardware.identified import default_twin


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    values = {k: np.full(a.twins, v) for k, v in default_twin().values().items()}
    small = {k: v[:1] for k, v in values.items()}
    times: dict[bool, float] = {}
    for logs in (True, False):
        run_batch(small, drive_logs=logs, duration=0.5)  # warm-up
        best = np.inf
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            run_batch(values, drive_logs=logs)
            best = min(best, time.perf_counter() - t0)
        times[logs] = best
        print(f"drive_logs={logs}: {best:.2f} s for {a.twins} twins x 25 runs")
    print(f"compiled twin loop: {times[True] / times[False]:.1f}x faster")


if __name__ == "__main__":
    main()
