"""The test oracles: the control laws' NumPy forms, written term by term from the book's
equations, independent of the compiled kernels that are the library's one implementation
(:mod:`mwip.laws.smc.kernel`, :mod:`~mwip.laws.tsmc.kernel`,
:mod:`~mwip.laws.asta.kernel`, :mod:`mwip.observers._hodo_kernel`,
:mod:`mwip.laws.fig53.kernel`). ``F, G`` come from
:func:`mwip.models.reduced.f_g` (the NumPy closed forms of (2.36)), not from the kernels'
compiled ``f_g_scalar``; the fuzzy law is composed of the NumPy building blocks
:mod:`mwip.fuzzy.sets` (memberships, minimum t-norm), :mod:`mwip.fuzzy.reducers` (BMM,
weighted average) and :func:`mwip.fuzzy.ts_model.memberships` (Fig. 5.1).

tests/test_kernels.py holds the kernels equal to these on random, non-zero inputs for every
term; benchmarks/mutate_kernels.py checks that those tests catch every sign flip in the
kernels.

- SMC: sliding surface (3.49) and law (3.50) (Sec. 3.5);
- ASTA/ASMC: sliding variables (4.1) and ``sigma' = a + b u`` (4.10)-(4.11), the laws (4.7)
  and ASMC's, the integrator (4.4) and the adaptive law (4.5) over one sample (Sec. 4.2);
- TSMC: model (2.31)/(4.24), subsystem (4.26)-(4.27), augmenting cubics (4.43), surface
  (4.30), switching gain and law (4.32) (Sec. 4.3);
- HODO: the sampled observer update of (3.20)-(3.23) (:mod:`mwip.observers.hodo`).
- Fig. 5.3: the Mamdani FLSs (Sec. 5.3.2, Tables 5.1-5.2), the PDC weights (5.7)-(5.8) and
  the balance law (5.10) on ``theta - theta_off`` (Sec. 5.3).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.fuzzy.mamdani import MamdaniFLS
from mwip.fuzzy.reducers import bmm, weighted_average
from mwip.fuzzy.sets import firing_grid
from mwip.fuzzy.ts_model import first_weight, memberships
from mwip.laws.smc.controller import SMCGains
from mwip.laws.switching import Switching
from mwip.models.reduced import f_g
from mwip.params import Params

__all__ = [
    "sliding_surface", "smc_law", "asta_surface", "surface_dynamics", "asta_step",
    "model_2_31",
    "subsystem", "augmenting", "tsmc_surface", "tsmc_gain", "tsmc_law", "hodo_step", "mamdani",
    "pdc_weights", "fig53",
]  # fmt: skip


def sliding_surface(
    q: NDArray[np.float64],
    qdot: NDArray[np.float64],
    t: float,
    lambdas: Sequence[float],
    q1d_dot: float = 0.0,
    q3d: float = 0.0,
) -> NDArray[np.float64]:
    """``[S1, S2]`` of (3.49), shape (N, 2)."""
    l1, l2, l3, l4 = lambdas
    s1 = qdot[:, 1] + l1 * q[:, 1] + l2 * (q[:, 0] - q1d_dot * t) + l3 * (qdot[:, 0] - q1d_dot)
    s2 = qdot[:, 2] + l4 * (q[:, 2] - q3d)
    return np.column_stack([s1, s2])


def smc_law(
    F: NDArray[np.float64],
    G: NDArray[np.float64],
    qdot: NDArray[np.float64],
    S: NDArray[np.float64],
    tau_hat: NDArray[np.float64],
    gains: SMCGains,
    switching: Switching,
    q1d_dot: float = 0.0,
) -> NDArray[np.float64]:
    """``[u_A, u_B]`` of (3.50), shape (N, 2), from ``F`` (N,3), ``G`` (N,3,2) of (2.36)."""
    l1, l2, l3, l4 = gains.lambdas
    f1, f2, f3 = F[:, 0], F[:, 1], F[:, 2]
    g1, g2, g3 = G[:, 0, 0], G[:, 1, 0], G[:, 2, 1]
    uA = (
        -f2 - l3 * f1 - l1 * qdot[:, 1] - l2 * (qdot[:, 0] - q1d_dot)
        - tau_hat[:, 1] - l3 * tau_hat[:, 0] - gains.K1 * switching(S[:, 0])
    ) / (g2 + l3 * g1)  # fmt: skip
    uB = (-f3 - l4 * qdot[:, 2] - tau_hat[:, 2] - gains.K2 * switching(S[:, 1])) / g3
    return np.column_stack([uA, uB])


def asta_surface(
    q: ArrayLike, qdot: ArrayLike, lam: ArrayLike, ref: ArrayLike = (0.0, 0.0, 0.0, 0.0)
) -> NDArray[np.float64]:
    """Sliding variables (4.1), (..., 2). ``ref = (psi'_d, theta_d, alpha_d, alpha'_d)``."""
    q, qd = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    l1, l2, l3 = np.asarray(lam, dtype=float)
    psid_d, th_d, al_d, ald_d = np.asarray(ref, dtype=float)
    s1 = qd[..., 1] + l1 * (q[..., 1] - th_d) + l2 * (qd[..., 0] - psid_d)
    s2 = (qd[..., 2] - ald_d) + l3 * (q[..., 2] - al_d)
    return np.stack([s1, s2], axis=-1)


def surface_dynamics(
    p: Params, q: ArrayLike, qdot: ArrayLike, lam: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``a`` (..., 2) and ``b`` (..., 2) of ``sigma' = a + b [u_A, u_B]`` (4.10)-(4.11), nominal.

    Constant references (``psi'_d``, ``theta_d``, ``alpha_d``) are assumed, as in the book.
    """
    F, G = f_g(p, q, qdot)
    qd = np.asarray(qdot, dtype=float)
    l1, l2, l3 = np.asarray(lam, dtype=float)
    a = np.stack([F[..., 1] + l2 * F[..., 0] + l1 * qd[..., 1], F[..., 2] + l3 * qd[..., 2]], -1)
    b = np.stack([G[..., 1, 0] + l2 * G[..., 0, 0], G[..., 2, 1]], axis=-1)
    return a, b


def asta_step(
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    sigma: NDArray[np.float64],
    K: ArrayLike,
    rate: ArrayLike,
    eps: float,
    Ts: float,
    asmc: bool,
    Gamma: NDArray[np.float64],
    w: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One sample of ASTA (or ASMC, ``asmc``): ``(u, Gamma_next, w_next)``, all (N, 2).

    The law, per channel ``i`` (``u_A`` for ``i = 1``, ``u_B`` for ``i = 2``):

    - ASTA (4.7) with the auxiliary variable ``v_i`` of (4.3):
      ``u_i = [-a_i - K_i |sigma_i|^(1/2) sgn(sigma_i) + v_i] / b_i``;
    - ASMC (the book's baseline, "the adaptive SMC (ASMC) with the same adaptive law",
      Secs. 4.4, 6.2.2; its reading in docs/chapter4.md): the switching term applied
      directly, ``v_i`` replaced by ``-Gamma_i sgn(sigma_i)``.

    The wheel torques are the solution of ``u_A = u_r + u_l``, ``u_B = u_r - u_l`` (2.36).
    Then the state over the sample ``Ts`` (forward Euler, the derivative taken at the
    sample's start): (4.4) ``v_i' = -Gamma_i sgn(sigma_i)`` (ASTA only; ASMC has no
    integrator) and (4.5) ``Gamma_i' = rho_i |sigma_i|`` if ``|sigma_i| >= eps``, else ``0``.
    ``sgn(0) = 0``.
    """
    sg = np.sign(sigma)
    mag = np.abs(sigma)
    K, rate = np.asarray(K, dtype=float), np.asarray(rate, dtype=float)
    v = -Gamma * sg if asmc else w
    uAB = (-a - K * mag**0.5 * sg + v) / b
    mix = np.array([[1.0, 1.0], [1.0, -1.0]])  # [u_A, u_B] = mix @ [u_r, u_l]
    u = np.linalg.solve(mix, uAB.T).T
    w_dot = np.zeros_like(w) if asmc else -Gamma * sg
    Gamma_dot = np.where(mag >= eps, rate * mag, 0.0)
    return u, Gamma + Ts * Gamma_dot, w + Ts * w_dot


def model_2_31(
    p: Params, q: ArrayLike, qdot: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``F`` (..., 3) and ``G`` (..., 3, 2) of (2.31)/(4.24) in ``x = [theta', v, alpha']``.

    ``x' = F + G tau`` with ``tau = [u_r, u_l]``; derived from (2.36) with ``v = r psi'``.
    """
    F36, G36 = f_g(p, q, qdot)
    f1, f2, f3 = F36[..., 0], F36[..., 1], F36[..., 2]
    g1, g2, g3 = G36[..., 0, 0], G36[..., 1, 0], G36[..., 2, 1]
    r = p.r
    F = np.stack([f2, r * f1, f3], axis=-1)
    G = np.zeros((*F.shape[:-1], 3, 2))
    G[..., 0, 0] = G[..., 0, 1] = g2
    G[..., 1, 0] = G[..., 1, 1] = r * g1
    G[..., 2, 0] = g3
    G[..., 2, 1] = -g3
    return F, G


def subsystem(
    p: Params, q: ArrayLike, qdot: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``F1`` (..., 2), ``G1`` (..., 2, 2) of subsystem (4.26)/(4.27), ``[theta', alpha']``."""
    F, G = model_2_31(p, q, qdot)
    return F[..., [0, 2]], G[..., [0, 2], :]


def augmenting(
    t: float, coeffs: ArrayLike, Tf: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Augmenting function (4.43) and its first two derivatives at time ``t``: ``(a, a', a'')``.

    Zero for ``t > T_f`` (the cubic and its slope reach zero at ``T_f``; ``a''`` jumps there).
    """
    c = np.asarray(coeffs, dtype=float)
    if t > Tf:
        z = np.zeros(c.shape[:-1])
        return z, z.copy(), z.copy()
    a0, a1, a2, a3 = c[..., 0], c[..., 1], c[..., 2], c[..., 3]
    return (
        a0 + a1 * t + a2 * t**2 + a3 * t**3,
        a1 + 2.0 * a2 * t + 3.0 * a3 * t**2,
        2.0 * a2 + 6.0 * a3 * t,
    )


def tsmc_surface(
    e: ArrayLike, e_dot: ArrayLike, a: ArrayLike, a_dot: ArrayLike, C: ArrayLike
) -> NDArray[np.float64]:
    """Augmented sliding surface (4.30)/(4.31): ``s = e' + C e - a' - C a``, shape (..., 2).

    ``C`` is the diagonal ``[c1, c2]``.
    """
    C = np.asarray(C, dtype=float)
    e, e_dot = np.asarray(e, dtype=float), np.asarray(e_dot, dtype=float)
    return e_dot + C * e - np.asarray(a_dot, dtype=float) - C * np.asarray(a, dtype=float)


def tsmc_gain(
    F1: ArrayLike, nominal_term: ArrayLike, Ftilde_ratio: float, D: ArrayLike, Gamma: ArrayLike
) -> NDArray[np.float64]:
    """Switching gain of (4.32): ``k = (I - D)^-1 (F~ + D |F1 + C e' - a'' - C a'| + Gamma)``.

    ``nominal_term`` is ``F1 + C e' - a'' - C a'`` (..., 2); ``F~ = Ftilde_ratio |F1|``;
    ``D`` is (2, 2) with ``||D|| < 1`` (4.29); ``Gamma`` is (2,). Returns (..., 2).
    """
    D = np.asarray(D, dtype=float)
    F1 = np.asarray(F1, dtype=float)
    rhs = (
        Ftilde_ratio * np.abs(F1)
        + np.abs(np.asarray(nominal_term, dtype=float)) @ D.T
        + np.asarray(Gamma, dtype=float)
    )
    return rhs @ np.linalg.inv(np.eye(2) - D).T


def tsmc_law(
    F1: ArrayLike,
    G1: ArrayLike,
    e_dot: ArrayLike,
    a_dot: ArrayLike,
    a_ddot: ArrayLike,
    xd_ddot: ArrayLike,
    C: ArrayLike,
    k: ArrayLike,
    switch: ArrayLike,
) -> NDArray[np.float64]:
    """Control law (4.32): ``tau = G1^-1 [-F1 - C e' + a'' + C a' + x_d'' - k sw(s)]``.

    ``switch`` is ``sw(s)`` (..., 2); ``x_d''`` the target accelerations (zero for constant
    targets). Returns the wheel torques ``[u_r, u_l]`` (..., 2).
    """
    C = np.asarray(C, dtype=float)
    w = (
        -np.asarray(F1, dtype=float)
        - C * np.asarray(e_dot, dtype=float)
        + np.asarray(a_ddot, dtype=float)
        + C * np.asarray(a_dot, dtype=float)
        + np.asarray(xd_ddot, dtype=float)
        - np.asarray(k, dtype=float) * np.asarray(switch, dtype=float)
    )
    return np.einsum("...ij,...j->...i", np.linalg.inv(np.asarray(G1, dtype=float)), w)


def hodo_step(
    p: Params,
    Phi: NDArray[np.float64],
    Gam: NDArray[np.float64],
    Ts: float,
    hold: str,
    z: NDArray[np.float64],
    q_prev: NDArray[np.float64],
    qd_prev: NDArray[np.float64],
    q: NDArray[np.float64],
    qd: NDArray[np.float64],
    u: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The observer's sample (3.20)-(3.23), discretised (:mod:`mwip.observers.hodo`): the held
    model term ``f_k = F + G [u_A, u_B]`` at the start, the end or their mean, the measured
    disturbance ``d_k = (q'_{k+1} - q'_k) / Ts - f_k`` and ``z_{k+1} = Phi z_k + Gamma d_k``."""
    uAB = np.column_stack([u[:, 0] + u[:, 1], u[:, 0] - u[:, 1]])

    def model(qq: NDArray[np.float64], qqd: NDArray[np.float64]) -> NDArray[np.float64]:
        F, G = f_g(p, qq, qqd)
        return F + np.einsum("nij,nj->ni", G, uAB)

    if hold == "start":
        f = model(q_prev, qd_prev)
    elif hold == "end":
        f = model(q, qd)
    else:
        f = 0.5 * (model(q_prev, qd_prev) + model(q, qd))
    d = (qd - qd_prev) / Ts - f
    return z @ Phi.T + d @ Gam.T


def mamdani(fls: MamdaniFLS, x1: ArrayLike, x2: ArrayLike) -> NDArray[np.float64]:
    """Crisp output of a two-input Mamdani FLS (Sec. 5.3.2): lower and upper memberships of
    the saturated inputs (the type-1 sets for a type-1 FLS), firing intervals with the
    minimum t-norm, the consequents' centroids per rule; BMM (IT2) or the weighted average
    of the firing strengths (type 1)."""
    p1, p2 = (p if fls.kind == "it2" else p.type1() for p in (fls.in1, fls.in2))
    l1, u1 = p1.memberships(x1)
    l2, u2 = p2.memberships(x2)
    flo, fhi = firing_grid(l1, u1, l2, u2)
    flo = flo.reshape(*flo.shape[:-2], -1)
    fhi = fhi.reshape(*fhi.shape[:-2], -1)
    y = fls.out.centers[fls.rules.index].ravel()
    if fls.kind == "t1":
        return weighted_average(fhi, y)
    return bmm(flo, fhi, y, fls.m, fls.n)


def pdc_weights(theta: ArrayLike, kind: str) -> NDArray[np.float64]:
    """``m_i(theta)`` (..., 2) of (5.10): Nie-Tan (5.8) on the memberships of Fig. 5.1 (IT2),
    or M1 at the middle of the footprint and ``M2 = 1 - M1`` (type 1)."""
    if kind == "t1":
        m1 = first_weight(theta, type1=True)
        return np.stack([m1, 1.0 - m1], -1)
    lo, up = memberships(theta)
    return (lo + up) / (lo + up).sum(-1, keepdims=True)


def fig53(
    y: NDArray[np.float64], G: NDArray[np.float64], kind: str, p_d: float | None,
    alpha_d: float | None, r: float, position: MamdaniFLS, direction: MamdaniFLS,
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:  # fmt: skip
    """Fig. 5.3 for measurements ``y`` (N, 8), one design: ``u`` (N, 2), ``theta_off``,
    ``u_alpha`` (N,). ``u_alpha = b * direction(a1 (alpha - alpha_d), a2 alpha')`` with
    ``scale = (a1, a2, b)``::

        theta_off = position(r psi - p_d, theta')     (0 without p_d)
        x = [theta - theta_off, theta', psi (0 with p_d), psi'],  u_p = m(theta) G x / 2
        u = [u_p + u_alpha, u_p - u_alpha]
    """
    n = y.shape[0]
    th = np.zeros(n) if p_d is None else mamdani(position, r * y[:, 0] - p_d, y[:, 4])
    a1, a2, b = scale
    ua = (np.zeros(n) if alpha_d is None
          else b * mamdani(direction, a1 * (y[:, 2] - alpha_d), a2 * y[:, 5]))  # fmt: skip
    x = np.column_stack([y[:, 1] - th, y[:, 4], y[:, 0] * (p_d is None), y[:, 3]])
    up = 0.5 * np.einsum("ni,ij,nj->n", pdc_weights(y[:, 1], kind), G, x)
    return np.column_stack([up + ua, up - ua]), th, ua
