"""Adaptive super-twisting control (ASTA) and adaptive SMC (ASMC), Section 4.2.

Sliding surface (4.1), with ``e = q - q_d``, ``q = [psi, theta, alpha]``::

    sigma_1 = e_2' + lambda_1 e_2 + lambda_2 e_1'   (theta and the wheel speed)
    sigma_2 = e_3' + lambda_3 e_3                   (yaw)

``e_1' = psi' - psi'_d`` (the book's ``q1d_dot``, rad/s), ``e_2 = theta - theta_d``,
``e_3 = alpha - alpha_d``. Constraints (4.2): ``lambda_1, lambda_2 > 0`` and
``lambda_2 z2* - z1* < 0`` with ``z1* = m11 + m12``, ``z2* = m22 + m12`` (nominal); they make
the sliding motion's linearisation (4.21)-(4.22) Hurwitz (4.23) (:func:`check_constraints`,
:func:`sliding_jacobian`).

With (2.36), ``sigma' = a(q, q') + b(q) u + (disturbance)`` (4.10)-(4.11)::

    a_1 = f2 + lambda_2 f1 + lambda_1 theta',   b_1 = g2 + lambda_2 g1   (input u_A)
    a_2 = f3 + lambda_3 alpha',                 b_2 = g3                 (input u_B)

ASTA, control law (4.7) realising the super-twisting dynamics (4.3)-(4.4)::

    u_i = [ -a_i - K_i |sigma_i|^(1/2) sgn(sigma_i) + w_i ] / b_i,
    w_i' = -Gamma_i(t) sgn(sigma_i),

with the adaptive law (4.5): ``Gamma_i' = rho_i |sigma_i|`` while ``|sigma_i| >= eps`` and
``0`` inside the boundary layer ``|sigma_i| < eps``; ``rho_i = 1 / d_i`` (the book's
``1/partial_i``). (4.7) writes ``K_3`` in ``u_B``: a typo for ``K_2``.

ASMC (the baseline, "same sliding surface and control parameters"): the same terms with the
switching term acting directly instead of through the integrator::

    u_i = [ -a_i - K_i |sigma_i|^(1/2) sgn(sigma_i) - Gamma_i(t) sgn(sigma_i) ] / b_i,

and the same adaptive law (4.5) for ``Gamma_i``. ASTA's control is continuous (the ``sgn``
is integrated); ASMC's jumps by ``2 Gamma_i / b_i`` whenever ``sigma_i`` changes sign.

Reading of the printed numbers (4.41)-(4.42) ``K1 = 10, K2 = 0.3, Gamma1 = Gamma2 = 5``
(docs/chapter4.md): ``K_i`` are the proportional STA gains of (4.3); ``Gamma_i = 5`` are the
adaptation rates ``rho_i = 1/partial_i`` of (4.5), the only constants of (4.5) the book
does not print otherwise, with ``Gamma_i(0) = 0`` as Remark 4.1 allows ("small enough or
even equal to zero"). Both readings are parameters here (``rate``, ``Gamma0``).

The controllers are discrete: state (the STA integrators ``w`` and the gains ``Gamma``) is
advanced by forward Euler over the sample period after each call; run them with a small
``Ts`` for the book's quasi-continuous studies.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.laws.packing import PackedLaw
from mwip.models.reduced import coefficients
from mwip.params import NOMINAL, Params
from mwip.validate import params_arg, real, vector

__all__ = [
    "check_constraints",
    "sliding_jacobian",
    "asta_surface",
    "sta_term",
    "adaptive_rate",
    "asta_law",
    "asmc_law",
    "ASTA",
    "ASMC",
]


def check_constraints(p: Params, lam: ArrayLike) -> bool:
    """Constraints (4.2): ``lambda_1, lambda_2 > 0`` and ``lambda_2 z2* - z1* < 0``."""
    l1, l2, l3 = (float(x) for x in np.asarray(lam, dtype=float))
    z1, z2 = p.m11 + p.m12, p.m22 + p.m12
    return bool(l1 > 0 and l2 > 0 and l3 > 0 and l2 * z2 - z1 < 0)


def sliding_jacobian(p: Params, lam: ArrayLike) -> NDArray[np.float64]:
    """Linearised sliding motion (4.21)-(4.22) in ``x = [theta, theta']``: ``[[0, 1], [P1, P2]]``.

    ``P1 = lambda_2 Gb / (lambda_2 z2* - z1*)``, ``P2 = lambda_1 z1* / (lambda_2 z2* - z1*)``;
    Hurwitz iff ``P1, P2 < 0`` (4.23), which (4.2) guarantees.
    """
    l1, l2 = float(np.asarray(lam)[0]), float(np.asarray(lam)[1])
    z1, z2 = p.m11 + p.m12, p.m22 + p.m12
    den = l2 * z2 - z1
    return np.array([[0.0, 1.0], [l2 * p.Gb / den, l1 * z1 / den]])


def asta_surface(
    q: ArrayLike, qdot: ArrayLike, lam: ArrayLike, ref: ArrayLike = (0.0, 0.0, 0.0, 0.0)
) -> NDArray[np.float64]:
    """Sliding variables (4.1), (..., 2). ``ref = (psi'_d, theta_d, alpha_d, alpha'_d)``::

        sigma_1 = theta' + lambda_1 (theta - theta_d) + lambda_2 (psi' - psi'_d)
        sigma_2 = (alpha' - alpha'_d) + lambda_3 (alpha - alpha_d)

    Evaluated by the controllers' compiled kernel (:func:`mwip.laws.asta.kernel.
    asta_terms`, the one implementation; its ``a, b`` are not needed here and use the nominal
    coefficients).
    """
    from mwip.laws.asta.kernel import asta_terms

    q, qd = np.asarray(q, dtype=float), np.asarray(qdot, dtype=float)
    shape = np.broadcast_shapes(q.shape, qd.shape)
    q2 = np.ascontiguousarray(np.broadcast_to(q, shape).reshape(-1, 3))
    qd2 = np.ascontiguousarray(np.broadcast_to(qd, shape).reshape(-1, 3))
    n = q2.shape[0]
    s, a, b = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    asta_terms(_NOMINAL_COEF, q2, qd2, np.asarray(lam, dtype=float).reshape(3),
               np.asarray(ref, dtype=float).reshape(4), s, a, b)  # fmt: skip
    return s.reshape(*shape[:-1], 2)


_NOMINAL_COEF = np.ascontiguousarray(coefficients(NOMINAL).reshape(-1), dtype=float)


def sta_term(sigma: ArrayLike, K: ArrayLike) -> NDArray[np.float64]:
    """Proportional super-twisting term of (4.3): ``-K |sigma|^(1/2) sgn(sigma)``."""
    s = np.asarray(sigma, dtype=float)
    return -np.asarray(K, dtype=float) * np.sqrt(np.abs(s)) * np.sign(s)


def adaptive_rate(sigma: ArrayLike, rate: ArrayLike, eps: float) -> NDArray[np.float64]:
    """Adaptive law (4.5): ``Gamma' = rate |sigma|`` if ``|sigma| >= eps`` else ``0``."""
    s = np.abs(np.asarray(sigma, dtype=float))
    return np.where(s >= eps, np.asarray(rate, dtype=float) * s, 0.0)


def _torques(uAB: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[u_A, u_B] -> [u_r, u_l] = [(u_A + u_B)/2, (u_A - u_B)/2]``."""
    return np.stack([0.5 * (uAB[..., 0] + uAB[..., 1]), 0.5 * (uAB[..., 0] - uAB[..., 1])], -1)


def asta_law(
    a: ArrayLike, b: ArrayLike, sigma: ArrayLike, K: ArrayLike, w: ArrayLike
) -> NDArray[np.float64]:
    """Control law (4.7): ``u_i = (-a_i - K_i |sigma_i|^(1/2) sgn sigma_i + w_i) / b_i``.

    Returns the wheel torques ``[u_r, u_l]`` (..., 2).
    """
    uAB = (-np.asarray(a, dtype=float) + sta_term(sigma, K) + np.asarray(w, dtype=float)) / b
    return _torques(uAB)


def asmc_law(
    a: ArrayLike, b: ArrayLike, sigma: ArrayLike, K: ArrayLike, Gamma: ArrayLike
) -> NDArray[np.float64]:
    """ASMC baseline: ``u_i = (-a_i - K_i |sigma_i|^(1/2) sgn sigma_i - Gamma_i sgn sigma_i)
    / b_i`` (the switching term of (4.4) applied directly). Returns ``[u_r, u_l]``."""
    sw = -np.asarray(Gamma, dtype=float) * np.sign(np.asarray(sigma, dtype=float))
    uAB = (-np.asarray(a, dtype=float) + sta_term(sigma, K) + sw) / b
    return _torques(uAB)


class _AdaptiveSliding:
    """Shared state and bookkeeping of :class:`ASTA` and :class:`ASMC`."""

    static = False

    def __init__(
        self,
        params: Params = NOMINAL,
        *,
        lam: ArrayLike = (10.0, 0.3, 0.3),
        K: ArrayLike = (10.0, 0.3),
        rate: ArrayLike = (5.0, 5.0),
        Gamma0: ArrayLike = (0.0, 0.0),
        eps: float = 0.01,
        psi_dot_ref: float = 0.0,
        theta_ref: float = 0.0,
        alpha_ref: float = 0.0,
        Ts: float = 0.0005,
    ) -> None:
        self.params = params_arg("params", params)
        self.lam = vector("lam", lam, 3)
        if np.ndim(lam) == 0:
            raise ValueError(f"lam must be 3 numbers [lambda_1, lambda_2, lambda_3], got {lam!r}")
        self.K = vector("K", K, 2, 0.0, lo_closed=False)
        self.rate = vector("rate", rate, 2, 0.0)
        self.Gamma0 = vector("Gamma0", Gamma0, 2, 0.0)
        eps = real("eps", eps, 0.0, lo_closed=True)
        psi_dot_ref, theta_ref, alpha_ref = (real(n, v) for n, v in (
            ("psi_dot_ref", psi_dot_ref), ("theta_ref", theta_ref), ("alpha_ref", alpha_ref)))
        Ts = real("Ts", Ts, 0.0, 1.0)
        if not check_constraints(params, self.lam):
            raise ValueError(f"lambda = {self.lam.tolist()} violates the constraints (4.2)")
        if np.any(self.K <= 0) or np.any(self.rate < 0) or np.any(self.Gamma0 < 0):
            raise ValueError("K must be positive, rate and Gamma0 non-negative")
        if not (np.isfinite(eps) and eps >= 0):
            raise ValueError(f"eps must be finite and >= 0, got {eps!r}")
        if not (np.isfinite(Ts) and Ts > 0):
            raise ValueError(f"Ts must be finite and in (0, inf), got {Ts!r}")
        self.eps = float(eps)
        self.ref = np.array([psi_dot_ref, theta_ref, alpha_ref, 0.0])
        self.Ts: float | None = float(Ts)
        self.Gamma = np.zeros((1, 2))
        self.w = np.zeros((1, 2))
        self._coef = np.ascontiguousarray(coefficients(params).reshape(-1), dtype=float)
        if self._coef.shape != (10,):
            raise ValueError("the controller's nominal params must be one robot, not a batch")
        self._log: dict[str, NDArray[np.float64]] = {}

    def reset(self, meas: Measurement) -> None:
        """Gains to ``Gamma0``, STA integrators to zero."""
        n = meas.y.shape[0]
        self.Gamma = np.tile(self.Gamma0, (n, 1))
        self.w = np.zeros((n, 2))

    def sigma(self, meas: Measurement) -> NDArray[np.float64]:
        """Sliding variables (4.1) of a measurement, (N, 2)."""
        return asta_surface(meas.q, meas.qdot, self.lam, self.ref)

    #: ASMC: the switching term acts directly (no super-twisting integrator ``w``).
    _asmc = False

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        # the kernel (Numba) is loaded when the Python loop calls the law (mwip.sim.aot)
        from mwip.laws.asta.kernel import asta_sample, asta_terms

        if self.Gamma.shape[0] != meas.y.shape[0]:
            self.reset(meas)
        n = meas.y.shape[0]
        s, a, b = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
        # (4.1) and (4.10)-(4.11) in one compiled loop (the one implementation; the NumPy
        # oracle is tests/oracle_laws.py)
        asta_terms(self._coef, np.ascontiguousarray(meas.q), np.ascontiguousarray(meas.qdot),
                   self.lam, self.ref, s, a, b)  # fmt: skip
        self._log = {"sigma": s, "Gamma": self.Gamma.copy(), "w": self.w.copy()}
        # the law (4.7) (or ASMC's) and the updates (4.4)-(4.5) over Ts, compiled (the one
        # implementation; the compiled closed loop calls the same kernel)
        assert self.Ts is not None
        self.Gamma = np.ascontiguousarray(self.Gamma, dtype=float)
        self.w = np.ascontiguousarray(self.w, dtype=float)
        u = np.empty((n, 2))
        asta_sample(a, b, s, self.K, self.rate, self.eps, self.Ts, self._asmc, self.Gamma,
                    self.w, u)  # fmt: skip
        return u

    def packed_law(self) -> PackedLaw:
        """The law packed (:mod:`mwip.laws.asta.packing`) for the compiled closed loop
        (:mod:`mwip.sim.loop`) and the C export: the same kernels
        (:func:`~mwip.laws.asta.kernel.asta_terms`, ``asta_sample``); the gains start at
        ``Gamma0`` and ``w`` at zero, as after :meth:`reset`."""
        from mwip.laws.asta.packing import pack

        assert self.Ts is not None
        return pack(self._coef, self.lam, self.ref, self.K, self.rate, self.Gamma0, self.eps,
                    self.Ts, self._asmc)  # fmt: skip

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return self._log


class ASTA(_AdaptiveSliding):
    """Adaptive super-twisting controller (4.1), (4.3)-(4.5), (4.7), batch-first.

    Parameters: ``lam = (lambda_1, lambda_2, lambda_3)`` (4.41), ``K = (K_1, K_2)`` (4.42),
    ``rate = (1/d_1, 1/d_2)`` and ``Gamma0`` of the adaptive law (4.5), its boundary layer
    ``eps``, references ``psi_dot_ref`` (rad/s), ``theta_ref``, ``alpha_ref``, and the sample
    period ``Ts`` over which ``w`` (4.4) and ``Gamma`` (4.5) are integrated (forward Euler).
    Logs ``sigma``, ``Gamma`` and ``w`` (N, 2) at each sample.
    """

    _asmc = False


class ASMC(_AdaptiveSliding):
    """Adaptive SMC baseline: same surface (4.1), gains and adaptive law (4.5) as
    :class:`ASTA`, with the switching term ``-Gamma sgn(sigma)`` applied directly."""

    _asmc = True
