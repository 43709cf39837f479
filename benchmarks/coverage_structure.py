"""Does `mwip twin fit` cover the truth on a robot whose structure differs from its twin's?
(issue 37, item 3): the primary intervals, the structure test, the widened intervals.

Stand logs (wheels off the ground, the body held, static hold, duty steps and a chirp of
`mwip twin excite`) from the second simulator written apart from the twin's code,
``tests/independent_stand.py`` (its docstring lists how its ``off`` and ``near`` structures
differ from the twin's), or from the twin's own structure (``--structure twin``,
:mod:`mwip.identify.synth`). For each seed the seven drive parameters are drawn inside their
ranges, the log is fitted with the default robot file and each fitted parameter's interval of
2 standard errors (primary, widened, and the reported one: widened where the structure test
rejects) is checked against the truth.

    PYTHONPATH=src python benchmarks/coverage_structure.py --seeds 20 --structure off
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from independent_stand import DRIVE, consts_of, simulate  # noqa: E402
from independent_stand import truth as draw


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--structure", choices=["off", "near", "twin"], default="off",
                    help="twin: logs of the twin's own structure (mwip.identify.synth)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--static", type=float, default=0.5)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--chirp", type=float, default=1.0)
    args = ap.parse_args()

    from mwip.identify import excite, synth
    from mwip.identify.fit import fit
    from mwip.identify.logs import read_log
    from mwip.robot import default_robot

    robot = default_robot()
    tw = robot.twin
    consts = consts_of(robot)
    _, duty, mode = excite.schedule(tw.Ts, args.static, args.step, args.chirp)
    hits = {n: 0 for n in DRIVE}
    wide = {n: 0 for n in DRIVE}
    shown = {n: 0 for n in DRIVE}  # the reported interval: widened where rejected
    rejected = 0
    tried = {n: 0 for n in DRIVE}
    devs: dict[str, list[float]] = {n: [] for n in DRIVE}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            truth = draw(seed)
            if args.structure == "twin":
                truth = synth.draw_truth(seed)
                cols = synth.stand_log(truth, duty, mode, seed=seed)
            else:
                cols = simulate(truth, duty, mode, consts, args.structure, seed)
            path = Path(tmp) / f"log{seed}.csv"
            path.write_text(synth.csv_text(cols))
            res = fit([read_log(str(path))], tw, body=robot.body)
            chk = res.structure
            rej = chk is not None and chk.rejected
            rejected += rej
            for n in DRIVE:
                se = res.stderr.get(n)
                if res.status[n] != "fitted" or se is None or not se > 0:
                    continue
                z = (res.estimates[n] - truth[n]) / se
                tried[n] += 1
                hits[n] += abs(z) <= 2.0
                sw = se if chk is None else chk.widened.get(n, se)
                zw = abs(res.estimates[n] - truth[n]) / sw
                wide[n] += zw <= 2.0
                shown[n] += (zw if rej else abs(z)) <= 2.0
                devs[n].append(z)
            if chk is not None:
                print(f"  structure ratio {chk.ratio:.3g} (rms {chk.rms:.3g}, floor "
                      f"{chk.floor:.3g}), rejected {rej}", flush=True)
            print(f"seed {seed}: " + ", ".join(
                f"{n.split('.')[-1]} {devs[n][-1]:+.1f}" for n in DRIVE if devs[n]
                and len(devs[n]) == tried[n]), flush=True)  # fmt: skip
    print(f"\nstructure {args.structure}, {args.seeds} seeds, {time.perf_counter() - t0:.0f} s")
    print(f"structure rejected on {rejected} of {args.seeds} logs")
    print("| parameter | covered by +-2 s.e. | by +-2 widened s.e. | by the reported interval "
          "| median abs(z) | max abs(z) |")
    print("|---|---|---|---|---|---|")
    for n in DRIVE:
        z = np.abs(devs[n]) if devs[n] else np.array([np.nan])
        print(f"| {n} | {hits[n]} of {tried[n]} | {wide[n]} | {shown[n]} | "
              f"{np.median(z):.1f} | {np.max(z):.1f} |")
    total_t = max(sum(tried.values()), 1)
    print("| all | " + " | ".join(f"{sum(d.values())} of {total_t} "
                                  f"({100 * sum(d.values()) / total_t:.0f} %)"
                                  for d in (hits, wide, shown)) + " | | |")


if __name__ == "__main__":
    main()
