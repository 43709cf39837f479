"""Tests of the observer gain design: (3.31)-(3.32), (3.35)/(3.39)-(3.41), the LMI (3.36)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

from mwip.observers import design as dz
from mwip.observers.design import (
    ObserverDesignError,
    compare_published,
    design_for_ie,
    error_dynamics,
    format_comparison,
    impulse_to_energy_gain,
    lmi_matrices,
    published_gain_sets,
    solve_ie_lmi,
)

# ---------------------------------------------------------------------------------------------
# error dynamics (3.31)-(3.32)
# ---------------------------------------------------------------------------------------------


def test_error_dynamics_block_structure() -> None:
    rng = np.random.default_rng(1)
    L = [rng.normal(size=(3, 3)) for _ in range(3)]
    D, E = error_dynamics(L)
    assert D.shape == (9, 9) and E.shape == (9, 3)
    for i in range(3):
        np.testing.assert_array_equal(D[3 * i : 3 * i + 3, :3], -L[i])
    np.testing.assert_array_equal(D[0:3, 3:6], np.eye(3))
    np.testing.assert_array_equal(D[3:6, 6:9], np.eye(3))
    np.testing.assert_array_equal(D[0:3, 6:9], 0.0)
    np.testing.assert_array_equal(D[6:9, 3:9], 0.0)
    np.testing.assert_array_equal(E, np.vstack([np.zeros((6, 3)), np.eye(3)]))
    # D_n = A + X B (3.46) with X = [-L_1; ...; -L_n]
    A, B, E2 = lmi_matrices(3)
    np.testing.assert_array_equal(D, A - np.vstack(L) @ B)
    np.testing.assert_array_equal(E, E2)


@pytest.mark.parametrize(
    "v", [(5.0,), (3.0, 2.0), (6.0, 11.0, 6.0), (22.9778, 357.2853, 1831.5, 5737.7)]
)
def test_error_dynamics_eigenvalues_are_the_characteristic_roots(v: tuple[float, ...]) -> None:
    # L_i = v_i I3: each channel has s^n + v_1 s^(n-1) + ... + v_n, three times over.
    D, _ = error_dynamics(list(v))
    roots = np.roots([1.0, *v])
    got = np.linalg.eigvals(D)
    assert got.size == 3 * len(v)
    for r in roots:  # every root appears three times (to rounding)
        assert np.sum(np.abs(got - r) < 1e-6 * max(1.0, abs(r))) == 3, (r, got)


def test_gain_validation() -> None:
    with pytest.raises(ValueError, match="at least one"):
        error_dynamics([])
    with pytest.raises(ValueError, match="L_2"):
        error_dynamics([1.0, np.ones((2, 2))])
    with pytest.raises(ValueError, match="finite"):
        error_dynamics([np.nan])


# ---------------------------------------------------------------------------------------------
# impulse-to-energy gain (3.35), (3.39)-(3.41)
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("v", [0.5, 2.0, 20.0, 1e3])
def test_ie_first_order_closed_form(v: float) -> None:
    assert impulse_to_energy_gain([v]) == pytest.approx(1.0 / math.sqrt(2.0 * v), rel=1e-12)


def test_ie_matrix_gain_is_worst_channel() -> None:
    # L = diag(1, 4, 9): ie = max over channels = 1/sqrt(2 * 1)
    assert impulse_to_energy_gain([np.diag([1.0, 4.0, 9.0])]) == pytest.approx(
        1.0 / math.sqrt(2.0), rel=1e-12
    )


@pytest.mark.parametrize("v", [(3.0, 5.0), (6.1211, 423.8938, 1078.3)])
def test_ie_equals_impulse_response_energy(v: tuple[float, ...]) -> None:
    # (3.38): ||e||_2^2 = int |exp(D t) E w0|^2 dt, maximised over |w0| = 1 (any w0 here).
    D, E = error_dynamics(list(v))
    lam = np.linalg.eigvals(D)
    t_end = 40.0 / float(np.min(-lam.real))
    t = np.linspace(0.0, t_end, 20001)
    step = sla.expm(D * (t[1] - t[0]))
    x = E[:, 0].copy()
    energy = np.empty_like(t)
    for k in range(t.size):
        energy[k] = x @ x
        x = step @ x
    integral = float(np.sum(0.5 * (energy[1:] + energy[:-1])) * (t[1] - t[0]))
    assert impulse_to_energy_gain(list(v)) == pytest.approx(math.sqrt(integral), rel=1e-4)


def test_ie_not_hurwitz_raises_naming_gains() -> None:
    with pytest.raises(ValueError, match=r"not Hurwitz.*v = \(1, -2\)"):
        impulse_to_energy_gain([1.0, -2.0])
    with pytest.raises(ValueError, match="not Hurwitz"):
        impulse_to_energy_gain([0.0, 1.0])  # s^2 + 1: poles on the imaginary axis


# ---------------------------------------------------------------------------------------------
# the book's gain sets (SPEC.md sections 3-4)
# ---------------------------------------------------------------------------------------------


def _sig3(x: float) -> float:
    return float(f"{x:.3g}")


def test_published_sets_ie_recomputed_matches_spec() -> None:
    sets = published_gain_sets()
    assert list(sets) == ["do2", "do3", "do4", "do4_optimal"]
    expected = {"do2": 0.259, "do3": 0.458, "do4": 0.540, "do4_optimal": 0.293}
    for name, ie in expected.items():
        assert _sig3(impulse_to_energy_gain(list(sets[name].v))) == ie
        assert sets[name].ie_spec == ie
    # what the book prints
    assert sets["do4_optimal"].ie_printed == 1.8820e-6
    assert sets["do4_optimal"].v == (47.1084, 1960.1, 36256.0, 393980.0)
    assert all(sets[k].ie_printed == 0.3 for k in ("do2", "do3", "do4"))


def test_compare_published_table() -> None:
    rows = compare_published()
    assert [r["name"] for r in rows] == ["do2", "do3", "do4", "do4_optimal"]
    for r in rows:
        assert _sig3(r["ie"]) == r["ie_spec"]
        assert r["max_abs_eig"] > 0 and 0 < r["min_damping"] <= 1
    # v2 = (7.5213, 9755.8): lightly damped poles near |s| = 98.8 rad/s
    assert rows[0]["max_abs_eig"] == pytest.approx(math.sqrt(9755.8), rel=1e-9)
    text = format_comparison(rows)
    assert text.count("\n") == 5 and "0.2586" in text and "1.882e-06" in text


# ---------------------------------------------------------------------------------------------
# LMI (3.36)
# ---------------------------------------------------------------------------------------------


def _lmi_eigs(d: dz.GainDesign, n: int) -> dict[str, float]:
    """Max eigenvalue of each LMI at the returned P, W (congruence-scaled for conditioning).

    Congruence with the positive diagonal ``T^-1`` preserves the sign of every eigenvalue
    (Sylvester), so the check is of the LMIs as printed; ``T = diag(rho^-(i-1)) (x) I3``.
    """
    A, B, E = lmi_matrices(n)
    P, W = d.P, d.W
    rho = d.scale
    t = np.kron(rho ** -np.arange(n, dtype=float), np.ones(3))
    c = rho ** (2 * (n - 1))
    S = np.diag(1.0 / t)

    def scaled(M: np.ndarray) -> np.ndarray:
        return S @ M @ S / c

    lyap = P @ A + A.T @ P + W @ B + B.T @ W.T + np.eye(3 * n)  # (3.48)
    out = {
        "lyap": float(np.max(np.linalg.eigvalsh(scaled(0.5 * (lyap + lyap.T))))),
        "bound": float(np.max(np.linalg.eigvalsh(E.T @ P @ E - d.alpha * np.eye(3)))),
        "P": -float(np.min(np.linalg.eigvalsh(scaled(P)))),
    }
    if d.radius is not None:
        PD = P @ A + W @ B
        S2 = np.kron(np.eye(2), S)
        disk = np.block([[-d.radius * P, PD], [PD.T, -d.radius * P]])
        out["disk"] = float(np.max(np.linalg.eigvalsh(S2 @ disk @ S2 / c)))
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_lmi_solution_satisfies_its_constraints(n: int) -> None:
    d = solve_ie_lmi(n, radius=30.0, structure="full" if n <= 2 else "scalar")
    assert d.status == "optimal" and d.solver == "CLARABEL"
    eigs = _lmi_eigs(d, n)
    tol = 1e-9
    assert eigs["lyap"] < tol and eigs["P"] < tol and eigs["disk"] < tol
    assert eigs["bound"] < tol * max(1.0, d.alpha)
    # the certified bound holds for the recomputed gain, and the poles are in the disk
    assert d.ie <= d.ie_lmi * (1 + 1e-6)
    assert d.ie == pytest.approx(impulse_to_energy_gain(list(d.gains)), rel=1e-12)
    assert np.all(d.eigenvalues.real < 0) and np.max(np.abs(d.eigenvalues)) < 30.0
    # X = P^-1 W = [-L_1; ...; -L_n]  (3.36)
    X = np.linalg.solve(d.P, d.W)
    np.testing.assert_allclose(-X, np.vstack(d.gains), rtol=1e-6, atol=1e-9)


def test_lmi_full_and_scalar_structures_agree() -> None:
    full = solve_ie_lmi(2, radius=30.0, structure="full")
    scal = solve_ie_lmi(2, radius=30.0, structure="scalar")
    assert full.ie_lmi == pytest.approx(scal.ie_lmi, rel=1e-5)
    assert full.scalar_gains is not None  # the symmetric optimum: L_i = v_i I3
    np.testing.assert_allclose(full.scalar_gains, scal.scalar_gains, rtol=1e-3)


def test_lmi_n1_matches_closed_form() -> None:
    # n = 1 with |eig| < r: the best is L = r, ie = 1/sqrt(2 r).
    d = solve_ie_lmi(1, radius=50.0)
    assert d.ie_lmi == pytest.approx(1.0 / math.sqrt(100.0), rel=1e-4)
    assert d.scalar_gains == pytest.approx((50.0,), rel=1e-4)


def test_lmi_optimum_decreases_as_the_radius_grows() -> None:
    for n in (2, 3, 4):
        ies = [solve_ie_lmi(n, radius=r, structure="scalar").ie_lmi for r in (10.0, 30.0, 100.0)]
        assert ies[0] > ies[1] > ies[2], (n, ies)


def test_lmi_optimum_versus_order_at_fixed_radius() -> None:
    # Finding (docs/observers.md): at a fixed pole radius the minimum ie *grows* with the
    # order n = 1..4 (an impulse in tau^(n) is a step in tau^(n-1), which a longer chain
    # tracks more slowly). The book's unconstrained problem has no minimiser for any n.
    ies = [solve_ie_lmi(n, radius=30.0, structure="scalar").ie_lmi for n in (1, 2, 3, 4)]
    assert ies == sorted(ies) and ies[0] == pytest.approx(1 / math.sqrt(60.0), rel=1e-4)


@pytest.mark.filterwarnings("ignore:Input .a. has an eigenvalue pair:RuntimeWarning")
def test_lmi_unbounded_problem_drives_gains_up() -> None:
    # (3.36) as printed: inf ie = 0 is not attained; the solver stops at huge gains.
    d = solve_ie_lmi(1)
    assert d.radius is None and d.ie < 1e-2 and d.scalar_gains is not None
    assert d.scalar_gains[0] > 1e4
    d2 = solve_ie_lmi(2, structure="scalar")
    assert d2.ie < 1e-2 and np.max(np.abs(d2.eigenvalues)) > 1e4


def test_lmi_scs_solver_option() -> None:
    ref = solve_ie_lmi(2, radius=30.0, structure="scalar")
    d = solve_ie_lmi(2, radius=30.0, structure="scalar", solver="SCS")
    assert d.solver == "SCS" and d.status in ("optimal", "optimal_inaccurate")
    assert d.ie_lmi == pytest.approx(ref.ie_lmi, rel=1e-3)


def test_lmi_failures_raise() -> None:
    with pytest.raises(ObserverDesignError, match="status 'user_limit'"):
        with pytest.warns(UserWarning):
            solve_ie_lmi(2, radius=30.0, structure="scalar", solver_options={"max_iter": 1})
    with pytest.raises(ObserverDesignError, match="NOPE"):
        solve_ie_lmi(2, radius=30.0, solver="NOPE")
    assert issubclass(ObserverDesignError, RuntimeError)
    with pytest.raises(ValueError, match="order"):
        solve_ie_lmi(0)
    with pytest.raises(ValueError, match="structure"):
        solve_ie_lmi(2, structure="diag")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="radius"):
        solve_ie_lmi(2, radius=-1.0)


# ---------------------------------------------------------------------------------------------
# prescribed-ie design
# ---------------------------------------------------------------------------------------------


def _binomial_radius(n: int, target: float) -> float:
    """Pole size w of (s + w)^n giving ie = target exactly (reference for gain sizes)."""

    def f(w: float) -> float:
        v = [math.comb(n, i) * w**i for i in range(1, n + 1)]
        return impulse_to_energy_gain(v) - target

    return brentq(f, 0.1, 1e3)


@pytest.mark.parametrize("n", [1, 2, 4])
def test_design_for_ie_meets_target_with_small_gains(n: int) -> None:
    target = 0.3
    d = design_for_ie(n, target)
    assert d.ie <= target  # recomputed from the gains (3.39)-(3.41)
    assert d.ie == pytest.approx(impulse_to_energy_gain(list(d.gains)), rel=1e-12)
    assert d.ie_lmi <= target
    assert np.all(d.eigenvalues.real < 0)
    assert np.max(np.abs(d.eigenvalues)) <= d.radius  # type: ignore[operator]
    # not over-designed: within 10 % of the pole size of the binomial design with ie = target
    assert d.radius <= 1.1 * _binomial_radius(n, target)  # type: ignore[operator]
    assert d.ie >= 0.8 * target
    if n == 1:
        assert d.scalar_gains == pytest.approx((1 / (2 * target**2),), rel=0.02)


def test_design_for_ie_validates() -> None:
    with pytest.raises(ValueError, match="ie_target"):
        design_for_ie(2, 0.0)
    with pytest.raises(ValueError, match="rtol"):
        design_for_ie(2, 0.3, rtol=2.0)
