"""The three models of Chapter 2: consistency, invariants, symmetries, and where they agree."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from conftest import random_states
from mwip.models import planar, reduced, spatial
from mwip.params import NOMINAL, REAL


@pytest.mark.parametrize("p", [REAL, NOMINAL], ids=["real", "nominal"])
def test_accelerations_equal_mass_matrix_solve(p, rng):
    q, qd, u, e = random_states(rng)
    rhs = (
        reduced.input_forces(p, u)
        + e
        - reduced.bias_forces(p, q, qd)
        - reduced.damping_forces(p, qd)
    )
    expected = np.linalg.solve(reduced.mass_matrix(p, q), rhs[..., None])[..., 0]
    np.testing.assert_allclose(
        reduced.accelerations(p, q, qd, u, e), expected, rtol=1e-12, atol=1e-9
    )


@pytest.mark.parametrize("p", [REAL, NOMINAL], ids=["real", "nominal"])
def test_closed_form_f_g_equals_mass_matrix_solve(p, rng):
    """(2.36) printed closed forms agree with solving (2.33) (SPEC.md section 3)."""
    q, qd, u, _ = random_states(rng)
    F, G = reduced.f_g(p, q, qd)
    uAB = np.stack([u[:, 0] + u[:, 1], u[:, 0] - u[:, 1]], axis=-1)
    acc = F + np.einsum("nij,nj->ni", G, uAB)
    np.testing.assert_allclose(acc, reduced.accelerations(p, q, qd, u), rtol=1e-11, atol=1e-9)
    # G has the structure of (2.36)
    assert np.all(G[:, 0, 1] == 0) and np.all(G[:, 1, 1] == 0) and np.all(G[:, 2, 0] == 0)


def test_lumped_disturbance_is_zero_without_mismatch_and_carries_tau_ext(rng):
    q, qd, u, e = random_states(rng)
    acc = reduced.accelerations(REAL, q, qd, u)
    np.testing.assert_allclose(reduced.lumped_disturbance(REAL, q, qd, acc, u), 0.0, atol=1e-9)
    acc_e = reduced.accelerations(REAL, q, qd, u, e)
    td = reduced.lumped_disturbance(REAL, q, qd, acc_e, u)
    np.testing.assert_allclose(
        td,
        np.linalg.solve(reduced.mass_matrix(REAL, q), e[..., None])[..., 0],
        rtol=1e-10,
        atol=1e-12,
    )  # tau_d = M^{-1} tau_ext
    assert np.abs(reduced.lumped_disturbance(NOMINAL, q, qd, acc, u)).max() > 1.0  # mismatch


def _rhs(p, u=(0.0, 0.0)):
    def f(t, s):
        return np.r_[s[3:], reduced.accelerations(p, s[:3], s[3:], np.asarray(u))]

    return f


def test_energy_conserved_without_damping_and_input():
    """T + Gb cos(theta) conserved (SPEC.md section 3): relative drift < 1e-8 over 10 s."""
    p = replace(REAL, Db=0.0, Dw=0.0)
    s0 = np.array([0.0, 0.4, 0.0, 2.0, -1.0, 1.5])
    sol = solve_ivp(
        _rhs(p), (0, 10), s0, method="DOP853", rtol=1e-13, atol=1e-13, dense_output=True
    )
    t = np.linspace(0, 10, 2001)
    s = sol.sol(t)
    E = reduced.energy(p, s[:3].T, s[3:].T)
    assert np.abs(E - E[0]).max() / abs(E[0]) < 1e-8
    assert np.ptp(s[1]) > 1.0  # the body really swings: the check is not trivial


def test_power_balance_with_damping(rng):
    """dE/dt = q'^T tau(u) + q'^T tau_ext - q'^T D q' at random states."""
    q, qd, u, e = random_states(rng, 32)
    qdd = reduced.accelerations(REAL, q, qd, u, e)
    eps = 1e-6
    dE = (
        reduced.energy(REAL, q + eps * qd, qd + eps * qdd)
        - reduced.energy(REAL, q - eps * qd, qd - eps * qdd)
    ) / (2 * eps)
    expected = (
        reduced.input_power(REAL, qd, u)
        + np.einsum("ni,ni->n", qd, e)
        - reduced.dissipated_power(REAL, qd)
    )
    np.testing.assert_allclose(dE, expected, rtol=1e-6, atol=1e-8)
    assert np.all(reduced.dissipated_power(REAL, qd) >= 0)


def test_equal_torques_never_create_yaw(rng):
    q, qd, u, _ = random_states(rng)
    qd[:, 2] = 0.0
    u[:, 1] = u[:, 0]
    assert np.all(reduced.accelerations(REAL, q, qd, u)[:, 2] == 0.0)


def test_mirror_symmetries(rng):
    q, qd, u, e = random_states(rng)
    a = reduced.accelerations(REAL, q, qd, u, e)
    # point reflection (theta, u) -> (-theta, -u) with all coordinates and rates negated
    np.testing.assert_allclose(reduced.accelerations(REAL, -q, -qd, -u, -e), -a, atol=1e-10)
    # left-right mirror: yaw and yaw rate flip, wheels swap
    m = np.array([1.0, 1.0, -1.0])
    a_m = reduced.accelerations(REAL, q * m, qd * m, u[:, ::-1], e * m)
    np.testing.assert_allclose(a_m, a * m, atol=1e-10)


# --- spatial model (2.24)-(2.31) -------------------------------------------------------------
def _spatial_state(rng, n=32):
    qf = rng.uniform(-1.0, 1.0, (n, 6))
    z = rng.uniform(-2.0, 2.0, (n, 3))  # [theta', v, alpha']
    tau = rng.uniform(-1.0, 1.0, (n, 2))
    return qf, z, tau


def test_constraint_null_space():
    rng = np.random.default_rng(1)
    sp = spatial.SpatialParams.from_params(REAL)
    qf, _, _ = _spatial_state(rng)
    A = spatial.constraint_matrix(sp, qf)
    S = spatial.null_space(sp, qf)
    np.testing.assert_allclose(A @ S, 0.0, atol=1e-14)
    assert np.all(np.linalg.matrix_rank(S) == 3)


@pytest.mark.parametrize(("Ibz", "Iyaw"), [(REAL.Ibz, 0.0), (2.4e-3, 1.1e-3)],
                         ids=["book-Izz0", "general-body"])  # fmt: skip
def test_spatial_matches_reduced_where_the_book_agrees(Ibz, Iyaw):
    """With Iwd = Db = 0 the projected (2.31) equals (2.32) after v = r psi', Izz = Iyaw: the
    book's Izz = 0 and a general body (Ibz != Iby, Iyaw != 0; (2.20)'s Izz cos^2 th term is
    Params' Iyaw in m33 and -Iyaw in Ibl)."""
    rng = np.random.default_rng(2)
    p = replace(REAL, Iwd=0.0, Db=0.0, Ibz=Ibz, Iyaw=Iyaw)
    sp = spatial.SpatialParams.from_params(p)
    assert sp.Izz == Iyaw
    qf, z, tau = _spatial_state(rng)
    zd = spatial.reduced_accelerations(sp, qf, z, tau)
    q = np.column_stack([np.zeros(len(qf)), qf[:, 3], qf[:, 2]])
    qd = np.column_stack([z[:, 1] / p.r, z[:, 0], z[:, 2]])
    a = reduced.accelerations(p, q, qd, tau)
    np.testing.assert_allclose(
        zd, np.column_stack([a[:, 1], p.r * a[:, 0], a[:, 2]]), rtol=1e-10, atol=1e-10
    )


@pytest.mark.parametrize("Iyaw", [0.0, 1.1e-3])
def test_spatial_and_reduced_differ_as_documented(Iyaw):
    """Printed (2.20)/(2.22) differ from (2.32): Iwd in pitch, Db absolute (Izz = Iyaw)."""
    p = replace(REAL, Iyaw=Iyaw)
    sp = spatial.SpatialParams.from_params(p)
    qf = np.zeros(6)
    S = spatial.null_space(sp, qf)
    H = S.T @ spatial.mass_matrix(sp, qf) @ S
    assert H[0, 0] - p.m22 == pytest.approx(p.Iwd)  # pitch inertia has Iwd in (2.20)
    assert p.m33 - H[2, 2] == pytest.approx(2 * p.Iwd)  # yaw inertia lacks 2 Iwd of (2.32)


def test_planar_kinematics():
    v = spatial.planar_velocity(np.array([0.0, np.pi / 2]), np.array([2.0, 3.0]))
    np.testing.assert_allclose(v, [[2.0, 0.0], [0.0, 3.0]], atol=1e-15)


# --- planar model on a slope (2.12) ---------------------------------------------------------
def test_planar_at_zero_slope_matches_reduced_rows(rng):
    pp = planar.PlanarParams.from_params(REAL)
    q, qd, u, _ = random_states(rng)
    qd[:, 2] = 0.0
    a = reduced.accelerations(REAL, q, qd, u)
    a2 = planar.accelerations(pp, q[:, :2], qd[:, :2], u.sum(axis=1), slope=0.0)
    np.testing.assert_allclose(a2, a[:, :2], rtol=1e-11, atol=1e-10)


def test_planar_energy_on_slope_conserved():
    pp = replace(planar.PlanarParams.from_params(REAL), Db=0.0, Dw=0.0)
    slope = 0.2

    def f(t, s):
        return np.r_[s[2:], planar.accelerations(pp, s[:2], s[2:], 0.0, slope)]

    s0 = np.array([0.0, 0.3, 1.0, -0.5])
    sol = solve_ivp(f, (0, 5), s0, method="DOP853", rtol=1e-13, atol=1e-13, dense_output=True)
    s = sol.sol(np.linspace(0, 5, 501))
    E = planar.energy(pp, s[:2].T, s[2:].T, slope)
    assert np.abs(E - E[0]).max() / np.abs(E).max() < 1e-9
    assert s[0, -1] < -1.0  # it rolls down the slope (gravity along the slope is felt)


def test_compiled_and_numpy_f_g_agree(rng):
    """f_g has a compiled batch loop (2-D inputs, one robot) and a NumPy path (any shape)."""
    q, qd, _, _ = random_states(rng)
    F, G = reduced.f_g(NOMINAL, q, qd)  # compiled
    F3, G3 = reduced.f_g(NOMINAL, q[:, None, :], qd[:, None, :])  # NumPy broadcasting path
    np.testing.assert_allclose(F, F3[:, 0], rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(G, G3[:, 0], rtol=1e-13, atol=1e-12)
