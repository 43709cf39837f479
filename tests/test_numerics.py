"""mwip.numerics: SciPy's solvers behind checks and the design cache (issue 24, item 4).

- The designs used by the studies and the registry agree with the values of mwip's former
  NumPy solvers (``mwip.linalg``, deleted), recorded before the change in
  tests/data/old_designs.json (every ``lqr``/``dlqr``/``zoh``/``discretize_observer`` call
  of ``mwip reproduce --quick`` and of building each registered controller, and the
  impulse-to-energy gains of the published observer sets): within 1e-8 relative to the
  largest entry (observed: 4.8e-10 on the literal-reading continuous gain, whose CARE has a
  condition number ~1e11; <= 5e-13 elsewhere).
- Every check raises its named error: a residual off, a non-stabilising Riccati solution
  (SciPy can return one where no stabilising solution exists), a failure inside SciPy.
- A warm cache answers without SciPy; a warm whole-process ``mwip simulate`` imports none.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mwip import numerics
from mwip.laws.lqr.controller import lqr, lqr_sampled, zoh
from mwip.observers.design import impulse_to_energy_gain
from mwip.observers.hodo import discretize_observer

DATA = Path(__file__).parent / "data" / "old_designs.json"
OLD = json.loads(DATA.read_text())
GAIN_RTOL = 1e-8


def _rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    """An empty design cache in ``tmp_path / "cache"``, and no answers kept in this process."""
    monkeypatch.setenv("MWIP_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(numerics, "_MEMO", {})


# --------------------------------------------------------------------------------------------
# Agreement with the former solvers on the book's problems
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", OLD["lqr"], ids=lambda c: f"K0={c['K'][0][0]:.4g}")
def test_continuous_gains_agree_with_the_former_solver(case):
    K = lqr(case["A"], case["B"], case["Q"], case["R"])[0]
    assert _rel(K, case["K"]) < GAIN_RTOL


@pytest.mark.parametrize("case", OLD["dlqr"], ids=lambda c: f"Ts={c['Ts']}-K0={c['K'][0][0]:.4g}")
def test_sampled_gains_agree_with_the_former_solver(case):
    K = lqr_sampled(case["A"], case["B"], case["Q"], case["R"], case["Ts"])[0]
    assert _rel(K, case["K"]) < GAIN_RTOL


@pytest.mark.parametrize("case", OLD["zoh"], ids=lambda c: f"Ts={c['Ts']}")
def test_zero_order_hold_agrees_with_the_former_expm(case):
    Ad, Bd = zoh(case["A"], case["B"], case["Ts"])
    assert _rel(Ad, case["Ad"]) < GAIN_RTOL and _rel(Bd, case["Bd"]) < GAIN_RTOL


@pytest.mark.parametrize("case", OLD["discretize_observer"], ids=lambda c: f"Ts={c['Ts']}")
def test_observer_discretisation_agrees_with_the_former_expm(case):
    Phi, Gam = discretize_observer(case["gains"], case["Ts"])
    assert _rel(Phi, case["Phi"]) < GAIN_RTOL and _rel(Gam, case["Gamma"]) < GAIN_RTOL


@pytest.mark.parametrize("case", OLD["impulse_to_energy_gain"], ids=lambda c: str(len(c["gains"])))
def test_impulse_to_energy_gain_agrees_with_the_former_lyapunov_solver(case):
    assert _rel(impulse_to_energy_gain(case["gains"]), case["ie"]) < GAIN_RTOL


def test_scalar_care_is_the_analytic_answer():
    """Scalar LQR: ``a = 0, b = 1``: ``X = sqrt(q r)``, ``K = sqrt(q / r)``."""
    K, P, _ = lqr([[0.0]], [[1.0]], [[4.0]], [[0.25]])
    assert P[0, 0] == pytest.approx(1.0, rel=1e-14) and K[0, 0] == pytest.approx(4.0, rel=1e-14)


# --------------------------------------------------------------------------------------------
# The checks and their errors
# --------------------------------------------------------------------------------------------
def test_errors_are_value_errors_with_their_own_names():
    for err in (numerics.RiccatiError, numerics.LyapunovError, numerics.MatrixExponentialError):
        assert issubclass(err, numerics.NumericsError) and issubclass(err, ValueError)


def test_a_non_stabilising_riccati_solution_is_refused():
    """``2 X - X^2 + 1 = 0`` has ``X = 1 +- sqrt(2)``: both have zero residual, only the
    ``+`` root stabilises ``A - G X``. The check refuses the other, whoever returned it."""
    A, B, Q, R = (np.array([[v]]) for v in (1.0, 1.0, 1.0, 1.0))
    numerics._check_care(A, B, Q, R, np.array([[1.0 + np.sqrt(2.0)]]))
    with pytest.raises(numerics.RiccatiError, match="does not stabilise"):
        numerics._check_care(A, B, Q, R, np.array([[1.0 - np.sqrt(2.0)]]))
    with pytest.raises(numerics.RiccatiError, match="relative residual"):
        numerics._check_care(A, B, Q, R, np.array([[2.5]]))
    # DARE, scalar a = 2, b = 1, q = 1, r = 1: X^2 - 4 X - 1 = 0, X = 2 +- sqrt(5)
    A = np.array([[2.0]])
    numerics._check_dare(A, B, Q, R, np.array([[2.0 + np.sqrt(5.0)]]))
    with pytest.raises(numerics.RiccatiError, match="does not stabilise"):
        numerics._check_dare(A, B, Q, R, np.array([[2.0 - np.sqrt(5.0)]]))
    with pytest.raises(numerics.RiccatiError, match="relative residual"):
        numerics._check_dare(A, B, Q, R, np.array([[3.0]]))


def test_a_non_stabilisable_plant_raises_riccati_error():
    """An unstable mode the input cannot reach: no stabilising solution."""
    A = np.diag([1.0, -1.0])
    B = np.array([[0.0], [1.0]])
    with pytest.raises(numerics.RiccatiError):
        numerics.solve_continuous_are(A, B, np.eye(2), np.eye(1))
    with pytest.raises(numerics.RiccatiError):
        numerics.solve_discrete_are(np.diag([2.0, 0.5]), B, np.eye(2), np.eye(1))


def test_lyapunov_and_expm_checks():
    A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    X = numerics.solve_continuous_lyapunov(A, -np.eye(2))
    np.testing.assert_allclose(A @ X + X @ A.T, -np.eye(2), atol=1e-14)
    with pytest.raises(numerics.LyapunovError, match="relative residual"):
        numerics._check_lyapunov(A, -np.eye(2), X + 1e-3)
    with pytest.raises(numerics.LyapunovError, match="sum to zero"):  # +-1: singular
        numerics.solve_continuous_lyapunov(np.diag([1.0, -1.0]), np.ones((2, 2)))
    M = np.array([[0.0, 1.0], [-1.0, 0.0]])
    E = numerics.expm(M)
    np.testing.assert_allclose(E, [[np.cos(1), np.sin(1)], [-np.sin(1), np.cos(1)]], atol=1e-15)
    with pytest.raises(numerics.MatrixExponentialError, match="commute"):
        numerics._check_expm(M, E + np.array([[1e-3, 0.0], [0.0, 0.0]]))
    with pytest.raises(numerics.MatrixExponentialError, match="non-finite"):
        numerics._check_expm(M, np.full((2, 2), np.nan))


def test_bad_shapes_raise_value_error():
    with pytest.raises(ValueError, match="square"):
        numerics.expm(np.ones((2, 3)))
    with pytest.raises(ValueError, match="b must be"):
        numerics.solve_continuous_are(np.eye(2), np.ones((3, 1)), np.eye(2), np.eye(1))


# --------------------------------------------------------------------------------------------
# The cache
# --------------------------------------------------------------------------------------------
def test_answers_are_cached_and_checked_again(fresh_cache, tmp_path, monkeypatch):
    case = OLD["lqr"][0]
    args = (case["A"], case["B"], case["Q"], case["R"])
    X = numerics.solve_continuous_are(*args)
    files = list((tmp_path / "cache" / "numerics").glob("*.npz"))
    assert len(files) == 1
    monkeypatch.setattr(numerics, "_MEMO", {})
    np.testing.assert_array_equal(numerics.solve_continuous_are(*args), X)  # read back
    # a corrupted entry fails its check and is solved again (and rewritten)
    np.savez(files[0], x=-np.asarray(X))
    monkeypatch.setattr(numerics, "_MEMO", {})
    np.testing.assert_array_equal(numerics.solve_continuous_are(*args), X)
    with np.load(files[0]) as z:
        np.testing.assert_array_equal(z["x"], X)


def test_cache_off_writes_nothing(fresh_cache, tmp_path, monkeypatch):
    monkeypatch.setenv("MWIP_CACHE", "off")
    numerics.expm(np.eye(2))
    assert not (tmp_path / "cache").exists()


_PROBE = """
import sys
from mwip.laws import registry
from mwip.params import NOMINAL
registry.build({name!r}, NOMINAL, Ts={Ts!r})
scipy_sub = sorted(m for m in sys.modules if m.startswith("scipy.")
                   and not m.startswith("scipy._") and m not in ("scipy.version",))
print(repr((scipy_sub, "cvxpy" in sys.modules, "matplotlib" in sys.modules)))
"""


def _registered():
    from mwip.laws import registry

    return [(name, 0.005) for name in registry.names()] + [("hodosmc", 0.001)]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "Ts"), _registered())
def test_building_a_controller_with_a_warm_cache_imports_no_scipy_subpackage(name, Ts):
    """Issue 18/24: building a controller whose designs are in the cache (LQR gains, the
    ZOH model and the observer discretisation here; the fuzzy LMIs in mwip.fuzzy.pdc) imports
    no SciPy subpackage, cvxpy or matplotlib. Numba imports the top-level ``scipy`` package
    for its version check, so ``scipy`` itself may be there with a compiled kernel."""
    from mwip.laws import registry
    from mwip.params import NOMINAL

    registry.build(name, NOMINAL, Ts=Ts)  # warms the caches (this test's folder)
    out = subprocess.run([sys.executable, "-c", _PROBE.format(name=name, Ts=Ts)],
                         capture_output=True, text=True, check=True, timeout=300,
                         env=os.environ.copy()).stdout  # fmt: skip
    scipy_sub, has_cvxpy, has_mpl = eval(out.strip().splitlines()[-1])
    assert scipy_sub == [] and not has_cvxpy and not has_mpl, (scipy_sub, has_cvxpy, has_mpl)


@pytest.mark.slow
def test_warm_whole_process_simulate_imports_no_scipy(tmp_path):
    """``python -X importtime -m mwip simulate`` (the default controller, LQR) run twice: the
    second, with the loop built and the design cached, imports no ``scipy`` module at all.
    The cache folder is fresh but for the ahead-of-time loop, copied from the suite's."""
    import shutil

    from mwip.sim import aot

    shutil.copy2(aot.build(), tmp_path / "loop")
    (tmp_path / "cache").mkdir()
    shutil.copy2(tmp_path / "loop", tmp_path / "cache" / aot.module_path().name)
    cmd = [sys.executable, "-X", "importtime", "-m", "mwip", "simulate", "--duration", "1",
           "--out", str(tmp_path / "o"), "--force"]  # fmt: skip
    env = {**os.environ, "MWIP_CACHE_DIR": str(tmp_path / "cache")}
    first = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    assert "scipy.linalg" in first.stderr  # the cold run solved the design with SciPy
    second = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert second.returncode == 0, second.stderr[-2000:]
    imported = [ln.rsplit("|", 1)[-1].strip() for ln in second.stderr.splitlines()
                if ln.startswith("import time:")]  # fmt: skip
    assert "mwip.numerics" in imported
    assert not [m for m in imported if m.split(".")[0] == "scipy"], "warm simulate imported SciPy"
