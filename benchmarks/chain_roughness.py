"""Why the book calibration's stage-3 chains mix badly: a diagnosis over a finished folder.

Reads ``DIR/chains/gen-*.parquet`` and ``DIR/posterior.json`` (``mwip twin fit --evidence book
--out DIR``) and prints, for the kept generations:

1. each conditioned fact's share of the rejected proposals (which fact stops the chains);
2. how often each chain moved (the least and most mobile chains);
3. around the final state of the 3 least and the 2 most mobile chains (and around the default
   twin, stages 1-2's consistent twin), the fraction of
   ``--neighbours`` random neighbours at relative distances 1e-6, 1e-3 and 1e-2 of the prior
   widths (Gaussian, clipped to the box, seed 1) on which the most rejecting fact's run still
   stands. A smooth set would keep nearly every near neighbour; a set that is rough at that
   scale keeps a fraction well below 1 already at 1e-3.

Usage::

    python benchmarks/chain_roughness.py DIR [--neighbours 24]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from mwip.calibration.evidence import load_evidence
from mwip.calibration.posterior import facts
from mwip.calibration.runs import RUNS, run_batch, run_names


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--neighbours", type=int, default=24)
    a = ap.parse_args()
    doc = json.loads((a.dir / "posterior.json").read_text())
    post = doc["posterior"]
    burn = int(post["sampler"]["burn"])
    gens = [pd.read_parquet(p) for p in sorted((a.dir / "chains").glob("gen-*.parquet"))]
    names = [c for c in gens[0].columns if c.startswith("param.")]
    b = np.asarray(doc["prior"]["bounds"], dtype=float)
    w = np.where(b[:, 1] > b[:, 0], b[:, 1] - b[:, 0], 1.0)
    x = np.tile([doc["map_values"][n[6:]] for n in names], (len(gens[0]), 1))
    for g in gens:
        ok = g["moved"].to_numpy(dtype=bool)
        x[ok] = g[names].to_numpy(dtype=float)[ok]
    moved = np.array([g["moved"].to_numpy(dtype=bool) for g in gens])[burn:]
    rej = pd.concat(gens[burn:])
    rej = rej[rej["inside"] & ~rej["moved"]]
    cols = {c: rej[c].to_numpy(dtype=float) for c in rej.columns
            if c not in ("chain", "generation", "inside", "moved")}  # fmt: skip
    f = facts(cols, run_names(), load_evidence())
    used = set(post["used"])
    share = {n: float(1.0 - f.S[:, j].mean()) for j, n in enumerate(f.names) if n in used}
    print(f"kept generations {moved.shape[0]}, acceptance {moved.mean():.3f}; rejected "
          f"proposals {len(rej)}; share failing each conditioned fact:")  # fmt: skip
    for n, v in sorted(share.items(), key=lambda kv: -kv[1]):
        print(f"  {v:6.3f}  {n}")
    worst = max(share, key=lambda k: share[k])[len("up:"):]
    run = next(r for r in RUNS if r.name == worst)
    m = moved.sum(axis=0)
    print(f"moves per chain over the kept generations: min {m.min()}, median "
          f"{int(np.median(m))}, max {m.max()}; chains that never moved: {(m == 0).sum()}")
    rng = np.random.default_rng(1)
    order = np.argsort(m, kind="stable")
    centre = np.array([doc["map_values"][n[6:]] for n in names])
    for c in [*order[:3], *order[-2:], -1]:
        out = []
        for rel in (1e-6, 1e-3, 1e-2):
            at = centre if c < 0 else x[c]
            X = np.clip(at + rel * w * rng.standard_normal((a.neighbours, len(names))),
                        b[:, 0], b[:, 1])  # fmt: skip
            st = run_batch({n[6:]: X[:, j] for j, n in enumerate(names)}, runs=(run,))
            out.append(f"{rel:g}: {np.mean(st[f'{run.name}.stands']):.2f}")
        who = "the default twin" if c < 0 else f"chain {c} ({m[c]} moves)"
        print(f"{who}: {worst} stands on neighbours at " + ", ".join(out))


if __name__ == "__main__":
    main()
