"""docs/extending.md, "Adding a twin element": the element file and the registration it shows
make a working element. The package is copied, the file written as ``hardware/lag.py`` and
the three registration lines into ``hardware/dispatch.py``; a fresh
process (its own caches) then checks that the element runs in the compiled twin loop (its log
is the analytic lag of the law's command, sample by sample), that its effect is the physics'
(a slow lag makes the robot fall, none passes the command bit for bit), that it runs batched
(B = 3 robots of different gear ratios; per robot: a robot whose motor element is off passes
its command) and in a campaign (a slow lag takes the success rate from all to none)."""

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
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from mwip.hardware import lag
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.registry import DRIVE_CHAIN, ELEMENTS_BY_NAME
from mwip.hardware.twin import run_on_twin
from mwip.laws.registry import build
from mwip.robot import load_robot

assert DRIVE_CHAIN[0] is lag.ELEMENT and ELEMENTS_BY_NAME["lag"] is lag.ELEMENT
robot = load_robot(sys.argv[2])  # a fixed robot: the book calibration's twin of record
Ts = robot.Ts


def run(tau, **kw):
    lag.TAU = tau  # read when the chain is packed, at the start of each run
    ctrl = build("lqr", robot.design, {}, Ts=Ts)
    return run_on_twin(ctrl, 1, twin=robot.twin, base=robot.body, duration=3.0,
                       record_every=1, **kw)


def lagged(u, tau):
    # the analytic lag of the commands u (samples, 2): y_k = a u_k + (1 - a) y_{k-1}
    a = 1.0 - np.exp(-Ts / tau)
    out, y = np.empty_like(u), np.zeros(2)
    for k in range(u.shape[0]):
        y = a * u[k] + (1.0 - a) * y
        out[k] = y
    return out


# compiled, one robot: the log is the lag of the law's command (the chain's first element)
one = run(0.02)
assert one.settings["compiled"] is True, one.settings
assert list(one.status) == ["ok"], one.status
u = np.asarray(one.u).reshape(-1, 2)
y = np.asarray(one.logs["drive_lag"]).reshape(-1, 2)
assert u.shape == y.shape and u.shape[0] == 601
assert np.allclose(y, lagged(u, 0.02), rtol=1e-12, atol=1e-15)
assert np.abs(y - u).max() > 1e-3  # it lags

# the effect: a slow current loop (0.5 s) loses the robot; none passes the command unchanged
slow = run(0.5)
assert list(slow.status) == ["fell"], slow.status
none = run(0.0)
assert list(none.status) == ["ok"]
assert np.array_equal(np.asarray(none.logs["drive_lag"]).reshape(-1, 2),
                      np.asarray(none.u).reshape(-1, 2))

# batched: three robots (gear ratios 5, 8, 12), each lagging its own command
ratios = np.array([5.0, 8.0, 12.0])
bat = run(0.02, values={"drive.gear_ratio": ratios})
assert bat.settings["compiled"] is True and list(bat.status) == ["ok"] * 3, bat.status
U, Y = np.asarray(bat.u), np.asarray(bat.logs["drive_lag"])
assert U.shape == Y.shape == (3, 601, 2)
for i in range(3):
    assert np.allclose(Y[i], lagged(U[i], 0.02), rtol=1e-12, atol=1e-15), i
assert not np.allclose(U[0], U[2])  # three different robots

# per robot: the same slow lag with the motor element on falls, with it off passes the command
rows = [list(ELEMENTS), [e for e in ELEMENTS if e != "motor"]]
two = run(0.5, rows=rows)
assert list(two.status) == ["fell", "ok"], two.status
U2, Y2 = np.asarray(two.u), np.asarray(two.logs["drive_lag"])
assert np.array_equal(Y2[1], U2[1])

# a campaign (a block of 4 robots on the twin, in this process): all stand, then none
from mwip.campaign.execute import run_campaign
from mwip.campaign.spec import parse_campaign

camp = parse_campaign({
    "campaign": {"title": "lag", "samples": 4, "seed": 0, "duration": 2.0, "block": 4,
                 "sensors": "twin", "success_theta": 0.2},
    "robot": {"file": sys.argv[2]},
    "controllers": [{"name": "lqr"}],
    "initial": {"theta": {"uniform": [-0.05, 0.05]}},
})
out = Path(sys.argv[1])
success = {}
for tau in (0.0, 0.5):
    lag.TAU = tau
    summary = run_campaign(camp, out / f"tau{tau}", jobs=1, progress=None)
    df = pd.read_parquet(summary.path)
    assert len(df) == 4, df
    success[tau] = float(df["success"].mean())
assert success == {0.0: 1.0, 0.5: 0.0}, success
print("lag ok")
"""


def _element() -> dict[str, str]:
    return dict(re.findall(r"```python element=(\S+)\n(.*?)```", DOC, flags=re.DOTALL))


def _registration(tag: str) -> list[str]:
    (block,) = re.findall(rf"```python {tag}\n(.*?)```", DOC, flags=re.DOTALL)
    return block.strip("\n").splitlines()


def test_the_page_shows_one_file_and_three_lines_of_registration():
    assert sorted(_element()) == ["lag.py"]
    assert "element-registry" not in DOC
    assert len(_registration("element-dispatch")) == 3
    assert "three lines in one file" in " ".join(DOC.split())


def test_an_element_imported_without_its_branch_is_refused():
    """The registry reads the chains from the dispatcher's imports: an element module imported
    there without its branch would be packed and never run, so it is refused."""
    from mwip.hardware import delay, firmware
    from mwip.hardware.registry import registered

    source = "elif code == firmware.CODE:\n    firmware.step(k, p, s, bus, yi, z, lg)"
    assert [e.name for e in registered({"firmware": firmware}, source)] == ["firmware"]
    with pytest.raises(ImportError, match="'delay'.*without its branch"):
        registered({"firmware": firmware, "delay": delay}, source)


def test_elements_sharing_a_code_or_a_place_are_refused():
    import dataclasses
    import types

    from mwip.hardware import delay, firmware
    from mwip.hardware.registry import registered

    source = "code == firmware.CODE firmware.step( code == other.CODE other.step("
    other = types.ModuleType("other")
    other.ELEMENT = dataclasses.replace(delay.ELEMENT, name="other", code=99,  # type: ignore
                                        place=firmware.ELEMENT.place)  # fmt: skip
    with pytest.raises(ImportError, match="'firmware' and 'other' share the place 30"):
        registered({"firmware": firmware, "other": other}, source)
    other.ELEMENT = dataclasses.replace(other.ELEMENT, code=firmware.CODE, place=35)
    with pytest.raises(ImportError, match="share the code"):
        registered({"firmware": firmware, "other": other}, source)
    other.ELEMENT = dataclasses.replace(other.ELEMENT, code=99, place=25)  # before firmware
    assert [e.name for e in registered({"firmware": firmware, "other": other}, source)] == [
        "other", "firmware"]


def test_the_shipped_chains():
    from mwip.hardware.registry import DRIVE_CHAIN, SENSOR_CHAIN

    assert [e.name for e in SENSOR_CHAIN] == ["imu", "fusion", "encoder"]
    assert [e.name for e in DRIVE_CHAIN] == ["command", "delay", "firmware", "motor",
                                             "friction", "backlash"]  # fmt: skip


@pytest.mark.slow
def test_the_example_element_works_in_a_copy_of_the_package(tmp_path):
    pkg = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "mwip", pkg / "mwip",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    hw = pkg / "mwip" / "hardware"
    for name, code in _element().items():
        (hw / name).write_text(code)
    imports = "from mwip.hardware import backlash, command, delay, encoder, firmware, friction, " \
              "fusion, imu, motor\n"  # fmt: skip
    # dispatch.py, the whole registration: the import, and the branch after the last one
    disp_import, *branch = _registration("element-dispatch")
    dispatch = hw / "dispatch.py"
    text = dispatch.read_text()
    last = "        backlash.step(k, p, s, bus, yi, z, lg)\n"
    assert imports in text and text.endswith(last)
    dispatch.write_text(text.replace(imports, imports + disp_import + "\n")
                        + "\n".join(branch) + "\n")  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(pkg), "MWIP_CACHE_DIR": str(tmp_path / "cache"),
           "MWIP_AOT": "off", "NUMBA_CACHE_DIR": str(tmp_path / "nb"),
           "MWIP_NOTICES": "off"}  # fmt: skip
    res = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path / "campaigns"),
                          str(ROOT / "tests" / "data" / "record_robot.toml")],
                         capture_output=True, text=True, env=env, timeout=1800,
                         cwd=tmp_path)  # fmt: skip
    assert res.returncode == 0, res.stderr[-3000:]
    assert "lag ok" in res.stdout
