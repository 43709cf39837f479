"""Every study runs on :mod:`mwip.studies.robot`'s plant and nominal model, read at call time."""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mwip.studies
from mwip.params import NOMINAL, REAL
from mwip.studies import robot, run_study

STUDIES_DIR = Path(mwip.studies.__file__).parent
#: robot.py holds the defaults; study_file.py maps a study file's "real"/"nominal" to the book's
#: parameter sets (it chooses the robot, it does not run on one).
ALLOWED = {"robot.py", "study_file.py"}
STUDY_MODULES = sorted(p for p in STUDIES_DIR.glob("*.py") if p.name not in ALLOWED)


def _book_names(path: Path) -> list[str]:
    """``REAL``/``NOMINAL`` used anywhere in ``path``: names, attributes, imports."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Name) and node.id in ("REAL", "NOMINAL"):
            found.append(f"{node.id} (line {node.lineno})")
        elif isinstance(node, ast.Attribute) and node.attr in ("REAL", "NOMINAL"):
            found.append(f".{node.attr} (line {node.lineno})")
        elif isinstance(node, ast.ImportFrom):
            found += [f"import {a.name} (line {node.lineno})" for a in node.names
                      if a.name in ("REAL", "NOMINAL")]  # fmt: skip
    return found


def test_study_modules_found() -> None:
    names = {p.name for p in STUDY_MODULES}
    assert {"lqr_gain.py", "exp_asta.py", "exp_it2.py", "it2_balance.py"} <= names


@pytest.mark.parametrize("path", STUDY_MODULES, ids=lambda p: p.name)
def test_no_study_module_uses_the_book_parameters_directly(path: Path) -> None:
    assert _book_names(path) == [], f"{path.name}: use robot.plant() / robot.nominal()"


def _metrics(name: str, out: Path) -> dict:
    return run_study(name, out, quick=True)["metrics"]


def _val(m: dict, key: str) -> float:
    v = m[key]
    return float("nan") if v is None else float(v)


GAIN_KEYS = [f"{d}.K_{s}.{q}" for d in ("continuous", "sampled") for s in "rl"
             for q in ("theta", "alpha", "theta_dot", "v", "alpha_dot")]  # fmt: skip
PLANT_KEYS = [f"{k}.{q}" for k in ("continuous", "sampled") for q in ("max_abs_u", "settling_time")]


def test_lqr_gain_follows_the_robot(tmp_path: Path) -> None:
    base = _metrics("lqr-gain", tmp_path / "base")
    heavy = replace(REAL, mb=REAL.mb * 1.3, r=0.05)
    with robot.using(plant=heavy):
        assert robot.plant() is heavy and robot.nominal() is NOMINAL
        on_plant = _metrics("lqr-gain", tmp_path / "plant")
    # the design is unchanged, the closed loop is not
    assert all(on_plant[k] == base[k] for k in GAIN_KEYS)
    assert any(_val(on_plant, k) != _val(base, k) for k in PLANT_KEYS)

    model = replace(NOMINAL, r=0.035, l=NOMINAL.l * 1.2)
    with robot.using(nominal=model):
        assert robot.plant() is REAL and robot.nominal() is model
        designed = _metrics("lqr-gain", tmp_path / "nominal")
    assert all(designed[k] != base[k] for k in GAIN_KEYS)

    # the defaults are back after the blocks, also after an exception inside one
    with pytest.raises(RuntimeError), robot.using(plant=heavy, nominal=model):
        raise RuntimeError
    assert robot.plant() is REAL and robot.nominal() is NOMINAL
    again = _metrics("lqr-gain", tmp_path / "again")
    assert all(
        again[k] == base[k] or (np.isnan(_val(again, k)) and np.isnan(_val(base, k))) for k in base
    )


def test_chapter6_study_runs_on_the_robot(tmp_path: Path) -> None:
    keys = [f"{k}.case{c}.{q}" for k in ("asmc", "asta") for c in (1, 2)
            for q in ("rms_theta", "max_abs_u")]  # fmt: skip
    base = _metrics("exp-asta", tmp_path / "base")
    other = replace(REAL, mb=REAL.mb * 1.2, Iby=REAL.Iby * 1.2)
    with robot.using(plant=other):
        moved = _metrics("exp-asta", tmp_path / "other")
    # Case 1 is the user's robot, Case 2 the user's robot with the payload
    for c in (1, 2):
        ck = [k for k in keys if f".case{c}." in k]
        assert any(_val(moved, k) != _val(base, k) for k in ck), f"case {c} did not change"
    assert robot.plant() is REAL
