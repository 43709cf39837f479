"""Campaign speed (issue 15): HODOSMC on the digital twin, 10 s per sample.

Prints plant-seconds per second of

1. a per-sample loop over ``mwip.sim.simulate`` (one robot per call, the twin's sensor and
   drive, the same samples), on ``--loop-samples`` samples;
2. the bare batch engine: the campaign's chunks run one after another in this process
   (``mwip campaign run --jobs 1``);
3. Dask with one worker (a LocalCluster started here, passed as ``--scheduler``): the same
   work as 2 plus Dask's overhead;
4. Dask with ``--jobs`` workers (the default ``mwip campaign run``), cluster start included;

and checks that 2, 3 and 4 wrote identical tables. Usage::

    python benchmarks/bench_campaign.py [--samples 10000] [--jobs J] [--skip-single-dask]
"""

from __future__ import annotations

import argparse
import copy
import os
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from mwip.campaign.blocks import build_controllers
from mwip.campaign.execute import run_campaign
from mwip.campaign.sampling import block_seed, draw
from mwip.campaign.spec import parse_campaign

CAMPAIGN = """
[campaign]
title = "bench: HODOSMC on the twin"
samples = {samples}
seed = 1
duration = 10.0
block = {block}
sensors = "twin"
[[controllers]]
name = "hodosmc"
[robot.uncertainty]
mb = {{ uniform = 0.2 }}
l = {{ uniform = 0.2 }}
Iby = {{ uniform = 0.2 }}
[initial]
theta = {{ uniform = [-0.17, 0.17] }}
[[disturbances]]
kind = "none"
[[disturbances]]
kind = "book"
"""


def quiet(*_a: object) -> None:
    return None


def per_sample_loop(campaign, n: int) -> float:
    """Wall time of ``n`` samples run one robot per ``simulate`` call."""
    from dataclasses import replace

    from mwip.hardware.twin import Twin
    from mwip.sim.disturbance import BOOK_SINUSOIDS
    from mwip.sim.engine import simulate

    proto = build_controllers(campaign)["hodosmc"]
    d = draw(campaign, np.arange(n))
    t0 = time.perf_counter()
    for i in range(n):
        p = replace(campaign.centre, mb=d["mb"][i], l=d["l"][i], Iby=d["Iby"][i])
        twin = Twin()
        simulate(
            copy.deepcopy(proto), p, q0=(0.0, d["theta0"][i], 0.0), duration=campaign.duration,
            Ts=twin.Ts, dt=twin.dt, sensor=twin.sensor(p), actuator=twin.actuator(p),
            disturbance=BOOK_SINUSOIDS if d["disturbance"][i] == "book" else None,
            seed=block_seed(campaign.seed, i // campaign.block),
        )  # fmt: skip
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=10_000)
    ap.add_argument("--block", type=int, default=250)
    ap.add_argument("--loop-samples", type=int, default=20)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--skip-single-dask", action="store_true")
    args = ap.parse_args()
    camp = parse_campaign(tomllib.loads(CAMPAIGN.format(samples=args.samples, block=args.block)))
    plant_s = args.samples * camp.duration
    print(f"load average at start: {os.getloadavg()}; CPUs: {os.cpu_count()}")
    rows = []
    t = per_sample_loop(camp, args.loop_samples)
    loop_rate = args.loop_samples * camp.duration / t
    rows.append(("per-sample loop over simulate", args.loop_samples, t, loop_rate))
    tables = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        t0 = time.perf_counter()
        run_campaign(camp, out / "bare", jobs=1, progress=quiet)
        rows.append(("bare batch engine (--jobs 1)", args.samples, time.perf_counter() - t0,
                     plant_s / (time.perf_counter() - t0)))  # fmt: skip
        tables["bare"] = pd.read_parquet(out / "bare" / "results.parquet")
        if not args.skip_single_dask:
            from dask.distributed import LocalCluster

            with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cluster:  # fmt: skip
                t0 = time.perf_counter()
                run_campaign(camp, out / "dask1", scheduler=cluster.scheduler_address,
                             chunk=4 * args.block, progress=quiet)  # fmt: skip
                t = time.perf_counter() - t0
            rows.append(("Dask, 1 worker (cluster up)", args.samples, t, plant_s / t))
            tables["dask1"] = pd.read_parquet(out / "dask1" / "results.parquet")
        t0 = time.perf_counter()
        run_campaign(camp, out / "daskJ", jobs=args.jobs, progress=quiet)
        t = time.perf_counter() - t0
        rows.append((f"Dask LocalCluster, {args.jobs} workers (incl. start)", args.samples, t,
                     plant_s / t))  # fmt: skip
        tables["daskJ"] = pd.read_parquet(out / "daskJ" / "results.parquet")
    for name, df in tables.items():
        pd.testing.assert_frame_equal(df, tables["bare"], check_exact=True, obj=name)
    print(f"tables identical: {', '.join(tables)}; success rate "
          f"{tables['bare']['success'].mean():.3f}")  # fmt: skip
    print(f"load average at end: {os.getloadavg()}")
    print("| run | samples | wall (s) | plant-s/s | vs per-sample loop |")
    print("|---|---|---|---|---|")
    for name, n, t, rate in rows:
        print(f"| {name} | {n} | {t:.1f} | {rate:.0f} | {rate / loop_rate:.1f}x |")


if __name__ == "__main__":
    main()
