"""Cost of the generated C step functions (issue 17): time per call and instructions per call.

    python benchmarks/bench_export.py [--calls 1000000]

For every registered controller: generate the C (double), compile it with a small harness
(-O2, as the software-in-the-loop build), time ``n`` calls of ``PREFIX_step`` on a varying
measurement, and count the instructions per call with valgrind's callgrind (the difference
between runs of 2000 and 1000 calls, so start-up cancels). Instruction counts are repeatable
whatever the machine's load; times are not (the machine and its load are printed).
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from mwip.export import generate_c
from mwip.export.sil import find_compiler
from mwip.laws import registry
from mwip.params import NOMINAL

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "{p}.h"
int main(int argc, char **argv)
{{
    {p}_state s;
    mwip_real y[8] = {{0, 0.05, 0, 0.1, 0.02, 0.01, 0, 0}}, u[2];
    long n = atol(argv[1]), k;
    double acc = 0;
    struct timespec a, b;
    {p}_init(&s, y);
    clock_gettime(CLOCK_MONOTONIC, &a);
    for (k = 0; k < n; ++k) {{
        y[1] = 0.05 + 1e-3 * (double)(k % 7);
        y[4] = 0.02 - 1e-3 * (double)(k % 5);
        {p}_step(&s, 0.005 * (double)k, y, u);
        acc += u[0] - u[1];
    }}
    clock_gettime(CLOCK_MONOTONIC, &b);
    printf("%.3f %g\n", ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / n, acc);
    return 0;
}}
"""


def _instructions(exe: Path, calls: int, folder: Path) -> int:
    out = folder / f"cg.{calls}"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(exe),
                    str(calls)], capture_output=True, check=True)  # fmt: skip
    text = out.read_text()
    m = re.search(r"^summary:\s+(\d+)", text, re.M) or re.search(r"^totals:\s+(\d+)", text, re.M)
    assert m, "callgrind output without a summary line"
    return int(m.group(1))


def main(calls: int) -> None:
    cc = find_compiler()
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()}; "
          f"compiler {cc}; -O2 -ffp-contract=off")  # fmt: skip
    print(f"{'controller':10s} {'ns/call':>9s} {'instr/call':>11s}")
    for name in registry.names():
        code = generate_c(registry.build(name, NOMINAL), prefix=f"b_{name}")
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            for fname, text in code.files().items():
                (d / fname).write_text(text)
            (d / "main.c").write_text(HARNESS.format(p=code.prefix))
            exe = d / "bench"
            subprocess.run([cc, "-std=c99", "-O2", "-ffp-contract=off", "-o", str(exe),
                            str(d / "main.c"), str(d / f"{code.prefix}.c"), "-lm"],
                           check=True)  # fmt: skip
            ns = float(subprocess.run([str(exe), str(calls)], capture_output=True, text=True,
                                      check=True).stdout.split()[0])  # fmt: skip
            instr = "n/a"
            if shutil.which("valgrind"):
                instr = str((_instructions(exe, 2000, d) - _instructions(exe, 1000, d)) // 1000)
        print(f"{name:10s} {ns:9.1f} {instr:>11s}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=1_000_000)
    main(ap.parse_args().calls)
