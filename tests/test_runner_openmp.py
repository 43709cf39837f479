"""A threaded batch, then several studies in parallel, in one process (CI, when
tests/test_chain.py ran before the session's `mwip reproduce --jobs 2`): the forked study
workers aborted ("fork() called from a process already using GNU OpenMP") as soon as one ran
a threaded loop, and the command failed with BrokenProcessPool. The studies now run in this
process, with a one-line notice, once Numba's OpenMP threads have started here."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = """
import sys
from dataclasses import replace

import numpy as np

from mwip import NOMINAL, REAL
from mwip.laws import LQR, design_lqr
from mwip.sim import simulate

ctrl = LQR(design_lqr(NOMINAL, Ts=0.005))
robots = replace(REAL, mb=REAL.mb * np.linspace(0.9, 1.1, 256))
q0 = np.column_stack([np.zeros(256), np.full(256, 0.1), np.zeros(256)])
simulate(ctrl, robots, q0=q0, duration=1)  # a threaded batch: Numba's threads start here
import numba

print("layer", numba.threading_layer(), flush=True)
from mwip.cli import main

sys.exit(main(["run", "exp-it2", "lqr-gain", "--quick", "--jobs", "2", "--out", sys.argv[1]]))
"""


@pytest.mark.slow
def test_studies_after_a_threaded_batch_in_the_same_process(tmp_path: Path) -> None:
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "MWIP_NOTICES": "on"}
    res = subprocess.run([sys.executable, "-c", SCRIPT, str(out)], capture_output=True,
                         text=True, env=env, timeout=900)  # fmt: skip
    if "layer omp" not in res.stdout:
        pytest.skip(f"Numba's threading layer here is not OpenMP ({res.stdout.strip()!r})")
    assert res.returncode == 0, res.stderr[-2000:]
    assert "BrokenProcessPool" not in res.stderr
    assert "running the studies one after another in this process" in res.stderr
    for name in ("exp-it2", "lqr-gain"):
        assert (out / name / "metrics.json").is_file(), name
