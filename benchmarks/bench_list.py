"""Wall time of `mwip list` and of an unknown study name (`mwip run no-such-study`), whole
processes, against `python -c pass` and `mwip --help` in the same run.

Issue 25: both under a second on an idle machine. The study names and sources are read from
the study modules' source (:func:`mwip.studies.registry.declared`) without importing any study
module, NumPy or Matplotlib; this script also checks that no such module is loaded.

Usage::

    python benchmarks/bench_list.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time


def _time(cmd: list[str], codes: tuple[int, ...]) -> float:
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if res.returncode not in codes:
        raise SystemExit(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr.strip()}")
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    py = sys.executable
    mwip = [py, "-m", "mwip"]
    cmds: dict[str, tuple[list[str], tuple[int, ...]]] = {
        "python -c pass": ([py, "-c", "pass"], (0,)),
        "mwip --help": ([*mwip, "--help"], (0,)),
        "mwip list": ([*mwip, "list"], (0,)),
        "mwip run no-such-study": ([*mwip, "run", "no-such-study"], (2,)),
    }
    probe = ("import sys; from mwip.cli import main; main(['list']); "
             "print(sorted(m for m in ('numpy', 'matplotlib', 'mwip.studies.study') "
             "if m in sys.modules))")  # fmt: skip
    loaded = subprocess.run([py, "-c", probe], capture_output=True, text=True, check=True)
    for cmd, codes in cmds.values():  # warm the file system cache
        _time(cmd, codes)
    times: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(args.repeat):
        for k, (cmd, codes) in cmds.items():
            times[k].append(_time(cmd, codes))
    print(f"machine: {os.cpu_count()} cores, CPython {sys.version.split()[0]}; load average "
          f"{os.getloadavg()[0]:.2f}; {args.repeat} repeats, interleaved")  # fmt: skip
    print(f"heavy modules loaded by `mwip list`: {loaded.stdout.strip().splitlines()[-1]}\n")
    print("| command | wall (s), median [min, max] |")
    print("|---|---|")
    for k, ts in times.items():
        print(f"| `{k}` | {statistics.median(ts):.3f} [{min(ts):.3f}, {max(ts):.3f}] |")


if __name__ == "__main__":
    main()
