"""docs/extending.md, "Adding a compiled, exportable law": the five files and the dispatch
branch it shows make a working law. The package is copied, the files written into
``laws/satfb/`` and the branch into ``laws/dispatch.py``; a fresh process (its own caches)
then checks that the law is registered, balances the real robot in the Python loop and in the
compiled loop with the same numbers, holds its torque limit, runs one setting per robot in one
batch, and exports C whose closed loop equals it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "extending.md").read_text()

SCRIPT = r"""
import numpy as np
from mwip.laws.batch import batch
from mwip.laws.registry import build, names
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate

assert "satfb" in names()
free = simulate(build("satfb", NOMINAL, {"u_max": 100.0}, Ts=0.005), REAL, q0=(0.0, 0.1, 0.0),
                duration=3.0)
u_max = 0.75 * float(np.nanmax(np.abs(free.u)))  # a limit that bites
ctrl = build("satfb", NOMINAL, {"u_max": u_max}, Ts=0.005)
py = simulate(ctrl, REAL, q0=(0.0, 0.1, 0.0), duration=3.0, compiled=False)
cc = simulate(build("satfb", NOMINAL, {"u_max": u_max}, Ts=0.005), REAL, q0=(0.0, 0.1, 0.0),
              duration=3.0)
assert py.settings["compiled"] is False and cc.settings["compiled"] is True
theta = np.ravel(cc.theta)
assert (np.asarray(cc.status) == "ok").all() and np.abs(theta[-100:]).max() < 0.01, cc.status
assert np.array_equal(py.states, cc.states)
peak = np.nanmax(np.abs(cc.u))
assert peak <= u_max and np.isclose(peak, u_max), (peak, u_max)
two = simulate(batch("satfb", [{"u_max": u_max}, {"u_max": 100.0}], NOMINAL, Ts=0.005), REAL,
               q0=np.array([[0.0, 0.1, 0.0], [0.0, 0.1, 0.0]]), duration=3.0)
assert np.array_equal(two.states[0], np.reshape(cc.states, two.states[0].shape))
assert np.array_equal(two.states[1], np.reshape(free.states, two.states[1].shape))
import shutil
if shutil.which("cc") or shutil.which("gcc"):
    from mwip.export import CController, generate_c, verify
    code = generate_c(ctrl, prefix="t_satfb")
    rep = verify(build("satfb", NOMINAL, {"u_max": u_max}, Ts=0.005), CController(code),
                 q0=(0.0, 0.1, 0.0), duration=3.0)
    assert rep.status_c == "ok" and rep.max_state_diff <= 1e-9, rep
print("satfb ok")
"""


def _files() -> dict[str, str]:
    return dict(re.findall(r"```python file=(\S+)\n(.*?)```", DOC, flags=re.DOTALL))


def test_the_page_shows_five_files_and_one_branch():
    assert sorted(_files()) == ["c_export.py", "controller.py", "kernel.py", "packing.py",
                                "spec.py"]  # fmt: skip
    (branch,) = re.findall(r"```python dispatch\n(.*?)```", DOC, flags=re.DOTALL)
    assert len(branch.strip().splitlines()) == 3


@pytest.mark.slow
def test_the_example_law_works_in_a_copy_of_the_package(tmp_path):
    pkg = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "mwip", pkg / "mwip",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    folder = pkg / "mwip" / "laws" / "satfb"
    folder.mkdir()
    (folder / "__init__.py").write_text('"""Saturated state feedback (docs/extending.md)."""\n')
    for name, code in _files().items():
        (folder / name).write_text(code)
    (branch,) = re.findall(r"```python dispatch\n(.*?)```", DOC, flags=re.DOTALL)
    lines = branch.strip("\n").splitlines()
    imports, cases = lines[0] + "\n", "\n".join(lines[1:]) + "\n"
    dispatch = pkg / "mwip" / "laws" / "dispatch.py"
    text = dispatch.read_text()
    anchor_import = "from mwip.laws.tsmc import kernel as tsmc\n"
    anchor_case = "        fig53.step(p, x, k, t, ym, u, lg)\n"
    assert anchor_import in text and anchor_case in text
    dispatch.write_text(text.replace(anchor_import, anchor_import + imports)
                        .replace(anchor_case, anchor_case + cases))  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(pkg), "MWIP_CACHE_DIR": str(tmp_path / "cache"),
           "MWIP_AOT": "off", "NUMBA_CACHE_DIR": str(tmp_path / "nb")}  # fmt: skip
    res = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         env=env, timeout=1800, cwd=tmp_path)  # fmt: skip
    assert res.returncode == 0, res.stderr[-3000:]
    assert "satfb ok" in res.stdout
