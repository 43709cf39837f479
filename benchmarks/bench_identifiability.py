"""Cost of the identifiability check (mwip.identify.identifiability) against the fit it
precedes, on the 60 s wheels-off-ground + static log at 5 ms of bench_twin_fit.py.

    PYTHONPATH=src python benchmarks/bench_identifiability.py

Prints the check's time, the whole fit's (which includes the check) and their ratio.
"""

from __future__ import annotations

import time

import numpy as np

from mwip.identify import excite, synth
from mwip.identify.bounds import NAMES, centre
from mwip.identify.fit import fit
from mwip.identify.identifiability import check
from mwip.identify.logs import Log
from mwip.identify.model import STAND_PARAMS, Known


def main() -> None:
    from mwip.hardware.twin import Twin

    t, duty, mode = excite.schedule(static=5.0, step=1.0, chirp=31.0)
    truth = synth.draw_truth(0)
    cols = synth.stand_log(truth, duty, mode, seed=0)
    num = {k: np.asarray(v, dtype=float) for k, v in cols.items() if k != "mode"}
    lg = Log("bench", "0" * 64, num, np.asarray(cols["mode"]), inputs="duty")
    known = Known.from_twin(Twin(), lg.Ts)
    t0 = time.perf_counter()
    res = check([lg], list(STAND_PARAMS), {n: centre(n) for n in NAMES}, known)
    dt_check = time.perf_counter() - t0
    t0 = time.perf_counter()
    fit([lg])
    dt_fit = time.perf_counter() - t0
    print(f"log: {t[-1] + 0.005:.1f} s, {t.size} samples")
    print(f"check: {dt_check:.2f} s; fit (check included): {dt_fit:.1f} s; ratio "
          f"{dt_check / dt_fit:.3f}")
    for line in res.lines():
        print(f"  identifiability: {line}")


if __name__ == "__main__":
    main()
