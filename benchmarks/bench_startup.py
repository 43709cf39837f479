"""Start-up of whole `mwip` processes, against the interpreter's own start-up in the same run.

Issue 18: ``mwip --help`` under 0.3 s; a whole-process 25 s ``mwip simulate`` of any
registered controller under 0.5 s with a warm cache (the ahead-of-time loop built, Numba's
cache warm). Each command is run ``--repeat`` times, interleaved with the references
(``python -c pass``, ``python -c "import numpy"``), and timed in wall time; the table gives
the median [min, max] and the ratio of the median to ``python -c "import numpy"`` (every mwip
command that simulates imports NumPy, so this is the floor).

Usage::

    python benchmarks/bench_startup.py [--repeat 5] [--controllers lqr,hodosmc]

Before timing, ``mwip kernels build`` and one untimed run of each command warm the caches.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _time(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if res.returncode not in (0, 1):  # 1: the run fell (still a whole run)
        raise SystemExit(f"{' '.join(cmd)} failed ({res.returncode}): {res.stderr.strip()}")
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--controllers", default="")
    args = ap.parse_args()
    py = sys.executable
    mwip = [py, "-m", "mwip"]
    from mwip.laws.registry import names

    ctrls = [c for c in args.controllers.split(",") if c] or names()
    tmp = Path(tempfile.mkdtemp(prefix="mwip-startup-"))
    cmds: dict[str, list[str]] = {
        "python -c pass": [py, "-c", "pass"],
        'python -c "import numpy"': [py, "-c", "import numpy"],
        "mwip --help": [*mwip, "--help"],
    }
    for c in ctrls:
        cmds[f"mwip simulate --controller {c} --duration 25 --out D"] = [
            *mwip, "simulate", "--controller", c, "--theta0", "0.1745", "--duration", "25",
            "--out", str(tmp / c), "--force",
        ]  # fmt: skip
    subprocess.run([*mwip, "kernels", "build"], check=True, capture_output=True)
    for cmd in cmds.values():  # warm every cache
        _time(cmd)
    times: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(args.repeat):
        for k, cmd in cmds.items():
            times[k].append(_time(cmd))
    floor = statistics.median(times['python -c "import numpy"'])
    load = os.getloadavg()[0]
    print(f"machine: {os.cpu_count()} cores, CPython {sys.version.split()[0]}; load average "
          f"{load:.2f}; {args.repeat} repeats, interleaved\n")  # fmt: skip
    print("| command | wall (s), median [min, max] | / `import numpy` |")
    print("|---|---|---|")
    for k, ts in times.items():
        med = statistics.median(ts)
        print(f"| `{k}` | {med:.3f} [{min(ts):.3f}, {max(ts):.3f}] | {med / floor:.1f} |")


if __name__ == "__main__":
    main()
