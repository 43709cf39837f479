"""Pilot of stage 4's proposal (revision 3 of book-evidence.toml), on calibration facts only.

    python benchmarks/mixture_pilot.py DIR [N]

``DIR`` a book calibration folder with stages 1-3 (``mwip twin fit --evidence book``). For
each kernel factor, ``N`` draws (seed 7, never the declared seed) from the mixture fitted to
the twins stages 1-3 evaluated that meet the facts of the original rule over all of them;
prints the hit rate (draws meeting those facts) and the Kish effective size of the hits
under weights 1/q. Only calibration facts are read: no held-out claim or number.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mwip.calibration.evidence import load_evidence
from mwip.calibration.mixture import KernelMixture
from mwip.calibration.posterior import consistent_subset, facts
from mwip.calibration.runs import run_names
from mwip.calibration.sample import evaluate
from mwip.hardware.prior import PRIOR


def main(folder: Path, n: int) -> None:
    ev = load_evidence()
    names = list(PRIOR.names)
    b = np.asarray(PRIOR.bounds, dtype=float)
    parts = [pd.read_parquet(folder / "prior-draws" / "results.parquet")]
    parts += [pd.read_parquet(p) for p in sorted((folder / "proposal").glob("block-*.parquet"))]
    chains = [pd.read_parquet(p) for p in sorted((folder / "chains").glob("gen-*.parquet"))]
    parts += [c[c["inside"]] for c in chains]
    allt = pd.concat(parts, ignore_index=True)
    cols = {c: allt[c].to_numpy(dtype=float) for c in allt.columns
            if c.endswith(".stands") or c in {m.key for m in ev.numbers}}  # fmt: skip
    f = facts(cols, run_names(), ev)
    mask, _ = consistent_subset(f)
    sel = np.all(f.S[:, mask], axis=1)
    seeds = allt[[f"param.{m}" for m in names]].to_numpy(dtype=float)[sel]
    print(f"{int(mask.sum())} facts; seed set {len(seeds)} twins of {len(allt)} evaluated")
    for factor in (0.5, 1.0, 2.0):
        q = KernelMixture.fit(seeds, b, [factor])
        x = q.draw(7, range(n))
        t0 = time.perf_counter()
        got = evaluate({m: x[:, j].copy() for j, m in enumerate(names)}, jobs=2, block=64)
        hit = np.all(facts(got, run_names(), ev).S[:, mask], axis=1)
        w = 1.0 / q.density(x[hit])
        ess = w.sum() ** 2 / np.sum(w * w) if hit.any() else 0.0
        print(f"factor {factor}: hits {int(hit.sum())}/{n} ({hit.mean():.3f}), Kish ESS of "
              f"hits {ess:.1f}, {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 150)
