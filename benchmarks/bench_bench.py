"""Speed of ``mwip bench`` (issue 27): the whole default benchmark of every registered
controller, against the bare batch engine in the same process.

Prints, as a Markdown table:

1. the benchmark through :func:`mwip.bench.finish.run_bench` (the code of ``mwip bench --out
   DIR``: a local Dask cluster of ``--jobs`` workers, cluster start, scores and page included);
2. the bare batch engine on the same work: one block of the benchmark (``bench.block`` runs of
   every entrant on the twin, :func:`mwip.bench.run.run_rows`) in this process, no Dask;
3. the plain engine without the twin: one batch of ``bench.block`` HODOSMC robots, ideal
   sensor and drive (:func:`mwip.sim.simulate`).

Usage::

    PYTHONPATH=src python benchmarks/bench_bench.py [--jobs J] [--quick] [--out DIR] [CTRL ...]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from mwip.bench.entrants import resolve_entrants
from mwip.bench.finish import run_bench
from mwip.bench.run import BenchRun, _controllers, run_rows
from mwip.bench.spec import load_bench


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("controllers", nargs="*")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", type=Path, default=None, help="keep the results here (new folder)")
    args = ap.parse_args()
    work = BenchRun(load_bench(None, args.quick), resolve_entrants(args.controllers))
    b = work.bench
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_bench(work, args.out or Path(tmp) / "b", jobs=args.jobs, progress=None)
        wall = time.perf_counter() - t0
    assert res.status == "done"
    plant_s = res.runs * b.duration
    load1 = os.getloadavg()[0]

    ctrls = _controllers(work)  # designed here (the cached designs of the run above)
    run_rows(work, 0, ctrls)  # warm-up of the twin's path in this process
    t0 = time.perf_counter()
    run_rows(work, 1, ctrls)
    bare = len(work.entrants) * b.block * b.duration / (time.perf_counter() - t0)

    from mwip.laws.registry import build
    from mwip.params import book_params
    from mwip.sim.engine import simulate

    ctrl = build("hodosmc", book_params("nominal"))
    rng = np.random.default_rng(0)
    q0 = np.column_stack([np.zeros(b.block), rng.uniform(-b.theta0, b.theta0, b.block),
                          np.zeros(b.block)])  # fmt: skip
    simulate(ctrl, book_params("real"), q0=q0, duration=0.5)
    t0 = time.perf_counter()
    simulate(ctrl, book_params("real"), q0=q0, duration=b.duration)
    plain = b.block * b.duration / (time.perf_counter() - t0)

    rate = plant_s / wall
    print(f"{len(work.entrants)} entrants x {len(b.levels)} levels x {b.samples} runs x "
          f"{b.duration:g} s = {res.runs} runs, {plant_s:.0f} plant-s; --jobs {args.jobs}; "
          f"load average {load0:.1f} at the start, {load1:.1f} at the end")
    print("| run | wall (s) | plant-s/s | vs bare batch engine |")
    print("|---|---|---|---|")
    print(f"| `mwip bench` (run_bench, Dask {args.jobs} workers, scores + page) | {wall:.1f} | "
          f"{rate:.0f} | {rate / bare:.2f}x |")
    print(f"| bare batch engine: one block of every entrant on the twin, in process | - | "
          f"{bare:.0f} | 1.00x |")
    print(f"| plain engine, no twin (HODOSMC, {b.block} robots, ideal sensor and drive) | - | "
          f"{plain:.0f} | {plain / bare:.2f}x |")


if __name__ == "__main__":
    main()
