"""Time `mwip.identify.fit.fit` on a 60 s wheels-off-ground + static log at 5 ms.

    PYTHONPATH=src python benchmarks/bench_twin_fit.py

The log is synthetic (mwip.identify.synth: the twin's own elements), the schedule the
excitation of ``mwip twin excite`` with longer holds and chirp (60 s in all).
"""

from __future__ import annotations

import time

import numpy as np

from mwip.identify import excite, synth
from mwip.identify.fit import fit
from mwip.identify.logs import Log


def main() -> None:
    t, duty, mode = excite.schedule(static=5.0, step=1.0, chirp=31.0)
    truth = synth.draw_truth(0)
    t0 = time.perf_counter()
    cols = synth.stand_log(truth, duty, mode, seed=0)
    gen = time.perf_counter() - t0
    num = {k: np.asarray(v, dtype=float) for k, v in cols.items() if k != "mode"}
    lg = Log("bench", "0" * 64, num, np.asarray(cols["mode"]), inputs="duty")
    t0 = time.perf_counter()
    res = fit([lg])
    dt = time.perf_counter() - t0
    print(f"log: {t[-1] + 0.005:.1f} s, {t.size} samples (generated in {gen:.1f} s)")
    print(f"fit: {dt:.1f} s, {len(res.free)} parameters fitted")
    for n in res.free:
        print(f"  {n:24s} {res.estimates[n]:+.5g} +- {res.stderr[n]:.2g}  (truth {truth[n]:+.5g})")


if __name__ == "__main__":
    main()
