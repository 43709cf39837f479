"""Every study runs on its context's plant and nominal model (:class:`StudyContext`), never on
module state, and shares code with other studies only through the library or a kit module."""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import mwip.studies
from mwip.params import NOMINAL, REAL
from mwip.studies import registry, run_study

STUDIES_DIR = Path(mwip.studies.__file__).parent
#: registry.py holds the defaults, study.py names them (plant_label); study_file.py maps a
#: study file's "real"/"nominal" to the book's parameter sets (it chooses the robot, it does
#: not run on one).
ALLOWED = {"registry.py", "study.py", "study_file.py"}
STUDY_MODULES = sorted(p for p in STUDIES_DIR.glob("*.py") if p.name not in ALLOWED)
#: modules that declare studies
DECLARING = sorted({registry.get(n).run.__module__ for n in registry.names()})


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
    assert _book_names(path) == [], f"{path.name}: use ctx.plant / ctx.nominal"


def _imports(path: Path) -> set[str]:
    """Modules ``path`` imports (``from a.b import c`` counts ``a.b`` and ``a.b.c``)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            found |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
    return found


@pytest.mark.parametrize("module", DECLARING)
def test_studies_do_not_import_each_other_or_module_state(module: str) -> None:
    path = STUDIES_DIR / f"{module.rsplit('.', 1)[1]}.py"
    imported = _imports(path)
    others = {m for m in DECLARING if m != module}
    assert not imported & others, f"{path.name} imports another study: {imported & others}"
    assert "mwip.studies.robot" not in imported, f"{path.name}: use ctx.plant / ctx.nominal"
    assert "mwip.studies.settings.current" not in imported


def _metrics(name: str, out: Path, **kw) -> dict:
    return run_study(name, out, quick=True, **kw)["metrics"]


def _val(m: dict, key: str) -> float:
    v = m[key]
    return float("nan") if v is None else float(v)


GAIN_KEYS = [f"{d}.K_{s}.{q}" for d in ("continuous", "sampled") for s in "rl"
             for q in ("theta", "alpha", "theta_dot", "v", "alpha_dot")]  # fmt: skip
PLANT_KEYS = [f"{k}.{q}" for k in ("continuous", "sampled") for q in ("max_abs_u", "settling_time")]


def test_lqr_gain_follows_the_robot(tmp_path: Path) -> None:
    base = _metrics("lqr-gain", tmp_path / "base")
    heavy = replace(REAL, mb=REAL.mb * 1.3, r=0.05)
    ctx = registry.context("lqr-gain", tmp_path, plant=heavy)
    assert ctx.plant is heavy and ctx.nominal is NOMINAL
    on_plant = _metrics("lqr-gain", tmp_path / "plant", plant=heavy)
    # the design is unchanged, the closed loop is not
    assert all(on_plant[k] == base[k] for k in GAIN_KEYS)
    assert any(_val(on_plant, k) != _val(base, k) for k in PLANT_KEYS)

    model = replace(NOMINAL, r=0.035, l=NOMINAL.l * 1.2)
    ctx = registry.context("lqr-gain", tmp_path, nominal=model)
    assert ctx.plant is REAL and ctx.nominal is model
    designed = _metrics("lqr-gain", tmp_path / "nominal", nominal=model)
    assert all(designed[k] != base[k] for k in GAIN_KEYS)

    # nothing is left behind by a run on another robot: the defaults give the same numbers
    again = _metrics("lqr-gain", tmp_path / "again")
    assert all(
        again[k] == base[k] or (np.isnan(_val(again, k)) and np.isnan(_val(base, k))) for k in base
    )


def test_chapter6_study_runs_on_the_robot(tmp_path: Path) -> None:
    keys = [f"{k}.case{c}.{q}" for k in ("asmc", "asta") for c in (1, 2)
            for q in ("rms_theta", "max_abs_u")]  # fmt: skip
    base = _metrics("exp-asta", tmp_path / "base")
    other = replace(REAL, mb=REAL.mb * 1.2, Iby=REAL.Iby * 1.2)
    moved = _metrics("exp-asta", tmp_path / "other", plant=other)
    # Case 1 is the user's robot, Case 2 the user's robot with the payload
    for c in (1, 2):
        ck = [k for k in keys if f".case{c}." in k]
        assert any(_val(moved, k) != _val(base, k) for k in ck), f"case {c} did not change"
