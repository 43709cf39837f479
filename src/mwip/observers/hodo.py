"""The n-th order (high-order) disturbance observer HODO, (3.20)-(3.23), sampled.

For the reduced model (2.36), ``q'' = F(q, q') + G(q) [u_A, u_B] + tau_d``, the observer of
order n keeps auxiliary states ``p_i`` (i = 1..n) and estimates ``tau_d`` and its first n-1
derivatives:

.. math::

    \\hat\\tau_d^{(i-1)} &= p_i + L_i \\dot q                        && (3.20), (3.22)\\\\
    \\dot p_i &= -L_i (F + G u + \\hat\\tau_d) + \\hat\\tau_d^{(i)},\\ i < n  && (3.21)\\\\
    \\dot p_n &= -L_n (F + G u + \\hat\\tau_d)                       && (3.23)

Writing ``z = [tau^_d, tau^_d', ..., tau^_d^(n-1)]`` (3n,) and ``Lc = [L_1; ...; L_n]``
(3n, 3), these are equivalent to

.. math::

    \\dot z = D_n z + L_c (\\ddot q - F - G u),

with ``D_n`` of (3.31)-(3.32): driven by the true ``q''`` (= ``F + G u + tau_d``) the error
``e = [tau_d, ..., tau_d^(n-1)] - z`` obeys ``e' = D_n e + E tau_d^(n)`` (3.31).

Discretisation over one sample ``[t_k, t_k + Ts]``
--------------------------------------------------
The observer only sees samples. Over a sample it holds the model term constant,
``f_k = F + G [u_A, u_B]`` evaluated with the zero-order-held torque ``u_k`` (at the state
chosen by ``model_hold``, below), and treats the velocity as a ramp between the measured
``q'_k`` and ``q'_{k+1}``, i.e. ``q''`` constant and equal to ``(q'_{k+1} - q'_k) / Ts``. The
observer input is then the constant "measured disturbance"
``d_k = (q'_{k+1} - q'_k) / Ts - f_k`` (the sample mean of ``tau_d`` when ``f_k`` is the
sample mean of the model term) and

- ``"exact"`` (default): the linear ODE is integrated exactly,
  ``z_{k+1} = Phi z_k + Gamma d_k`` with ``Phi = expm(D_n Ts)`` and
  ``Gamma = int_0^Ts expm(D_n s) ds Lc`` (one block matrix exponential, computed once). It is
  stable for every Hurwitz ``D_n`` at every ``Ts`` (``|eig(Phi)| = exp(Re(lambda) Ts) < 1``),
  and when ``d_k`` is exact and ``tau_d`` is constant the error obeys
  ``e_{k+1} = expm(D_n Ts) e_k`` exactly. For a polynomial ``tau_d`` of degree < n the
  steady-state error is ``O(Ts^2)`` (zero in the continuous limit), from holding the sample
  mean over the sample.
- ``"euler"``: forward Euler on ``p``, ``p_{k+1} = p_k + Ts p'_k`` with ``p'`` of (3.21)/(3.23)
  evaluated at ``t_k``; equivalently ``Phi = I + Ts D_n``, ``Gamma = Ts Lc``. With
  ``substeps = m`` the sample is split into m Euler steps (same held ``d_k``):
  ``Phi = (I + h D_n)^m``. Forward Euler is only stable when ``|1 + h lambda| < 1`` for every
  eigenvalue of ``D_n``; the constructor refuses an unstable combination and says how many
  substeps would be needed (the book's second-order set ``v2 = (7.5213, 9755.8)`` has poles
  ``-3.76 +- 98.7j`` and needs ``m >= 7`` at ``Ts = 5 ms``).

``model_hold`` chooses where ``F, G`` are evaluated for ``f_k`` (always with the held
``u_k``): ``"end"`` (default: the new measurement ``q_{k+1}, q'_{k+1}``), ``"start"`` (the
previous one, ``q_k, q'_k``) or ``"trapezoid"`` (the mean of both). All three are first- or
second-order accurate in ``Ts`` for a smooth model. Under the default damping reading
(SPEC.md section 2) the plant is not stiff and ``"end"`` is only somewhat better at 5 ms
(1.3x for the book's 4th-order DO, closed loop); under the literal reading, whose damping
modes near -3000 rad/s relax within ~1 ms of a 5 ms sample, it was 4-40x better than
``"start"`` (docs/observers.md).

``p_i`` of the book is available as :attr:`HighOrderDO.auxiliary` ``= z_i - L_i q'``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import HOLD_CODES
from mwip.numerics import expm
from mwip.observers.design import GainsLike, as_gain_matrices, error_dynamics, stacked_gain
from mwip.params import Params
from mwip.validate import choice, integer, params_arg, real

__all__ = ["HighOrderDO", "HODO", "FGFunction", "discretize_observer", "euler_substeps_needed"]

_TO_AB = np.array([[1.0, 1.0], [1.0, -1.0]])  # [u_r, u_l] @ _TO_AB = [u_A, u_B]

#: ``f_g(params, q, qdot) -> (F (N, 3), G (N, 3, 2))`` of (2.36); ``G`` multiplies ``[u_A, u_B]``.
FGFunction = Callable[[Params, NDArray[np.float64], NDArray[np.float64]], tuple[
    NDArray[np.float64], NDArray[np.float64]
]]  # fmt: skip

Discretization = Literal["exact", "euler"]
ModelHold = Literal["start", "end", "trapezoid"]


def discretize_observer(
    gains: GainsLike,
    Ts: float,
    discretization: Discretization = "exact",
    substeps: int = 1,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sample-to-sample matrices ``(Phi (3n, 3n), Gamma (3n, 3))`` of the observer.

    ``z_{k+1} = Phi z_k + Gamma d_k`` for ``z' = D_n z + Lc d`` with ``d`` held over the
    sample (module docstring). ``"exact"``: ``Phi = expm(D_n Ts)``,
    ``Gamma = int_0^Ts expm(D_n s) ds Lc`` (block matrix exponential). ``"euler"``:
    ``substeps`` forward-Euler steps of ``h = Ts / substeps``.
    """
    if not (np.isfinite(Ts) and Ts > 0):
        raise ValueError(f"sample period Ts must be finite and > 0, got {Ts!r}")
    if not (isinstance(substeps, int | np.integer) and substeps >= 1):
        raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
    D, _ = error_dynamics(gains)  # (3.31)-(3.32)
    Lc = stacked_gain(gains)
    k = D.shape[0]
    if discretization == "exact":
        if substeps != 1:
            raise ValueError("substeps applies to discretization='euler' only")
        M = np.zeros((k + 3, k + 3))
        M[:k, :k] = D
        M[:k, k:] = Lc
        ex = expm(M * Ts)
        return ex[:k, :k], ex[:k, k:]
    if discretization == "euler":
        h = Ts / substeps
        step = np.eye(k) + h * D
        Phi = np.eye(k)
        Gam = np.zeros((k, 3))
        for _ in range(substeps):
            Phi = step @ Phi
            Gam = step @ Gam + h * Lc
        return Phi, Gam
    raise ValueError(f"discretization must be 'exact' or 'euler', got {discretization!r}")


def euler_substeps_needed(gains: GainsLike, Ts: float) -> int:
    """Smallest number of forward-Euler substeps per sample that is stable for these gains.

    Stability needs ``|1 + h lambda| < 1`` for every eigenvalue of ``D_n``, i.e.
    ``h < 2 |Re lambda| / |lambda|^2``.
    """
    D, _ = error_dynamics(gains)
    lam = np.linalg.eigvals(D)
    if not np.max(lam.real) < 0:
        raise ValueError("D_n is not Hurwitz: no step size makes forward Euler stable")
    h_max = float(np.min(2.0 * -lam.real / np.abs(lam) ** 2))
    return int(np.floor(Ts / h_max)) + 1


class HighOrderDO:
    """n-th order disturbance observer (3.20)-(3.23), sampled, batch-first.

    Parameters
    ----------
    params : Params
        Nominal parameters the model ``F, G`` of (2.36) is built from.
    gains : sequence of n items
        ``L_1 .. L_n`` (3.24): each a 3x3 array or a scalar ``v_i`` meaning ``v_i I3``.
        ``D_n`` must be Hurwitz.
    Ts : float
        Sample period (s); :meth:`update` is called once per sample.
    discretization : "exact" or "euler"
        How the internal state advances over a sample (module docstring).
    substeps : int
        Forward-Euler substeps per sample (``"euler"`` only).
    model_hold : "start", "end" or "trapezoid"
        Where ``F, G`` are evaluated over a sample (module docstring).
    f_g : callable, optional
        ``f_g(params, q, qdot) -> (F, G)``; default :func:`mwip.models.reduced.f_g`.

    Examples
    --------
    >>> import numpy as np
    >>> from mwip.params import NOMINAL
    >>> obs = HighOrderDO(NOMINAL, [22.9778, 357.2853, 1831.5, 5737.7], Ts=0.005)
    >>> obs.reset(np.zeros((2, 3)))
    >>> obs.update(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 2))).shape
    (2, 3)
    """

    def __init__(
        self,
        params: Params,
        gains: GainsLike,
        Ts: float,
        discretization: Discretization = "exact",
        *,
        substeps: int = 1,
        model_hold: ModelHold = "end",
        f_g: FGFunction | None = None,
    ) -> None:
        params_arg("params", params)
        Ts = real("Ts", Ts, 0.0, 1.0)
        choice("discretization", discretization, ("exact", "euler"))
        choice("model_hold", model_hold, ("start", "end", "trapezoid"))
        substeps = integer("substeps", substeps, 1, 10**6)
        if f_g is not None and not callable(f_g):
            raise TypeError(f"f_g must be callable or None, got {type(f_g).__name__}")
        self.gains: tuple[NDArray[np.float64], ...] = as_gain_matrices(gains)
        if any(not np.all(np.isfinite(g)) or np.any(np.abs(g) > 1e9) for g in self.gains):
            raise ValueError("gains must be finite with entries in [-1e9, 1e9] (beyond, the "
                             "observer's matrix exponential overflows)")  # fmt: skip
        D, _ = error_dynamics(self.gains)
        lam = np.linalg.eigvals(D)
        if not np.max(lam.real) < 0:
            raise ValueError(
                f"observer gains do not make D_n Hurwitz (max Re(eig) = {np.max(lam.real):.4g})"
            )
        if model_hold not in ("start", "end", "trapezoid"):
            raise ValueError(
                f"model_hold must be 'start', 'end' or 'trapezoid', got {model_hold!r}"
            )
        Phi, Gam = discretize_observer(self.gains, Ts, discretization, substeps)
        rho = float(np.max(np.abs(np.linalg.eigvals(Phi))))
        if not rho < 1.0:
            need = euler_substeps_needed(self.gains, Ts)
            raise ValueError(
                f"forward Euler with {substeps} substep(s) at Ts={Ts:g} s is unstable for these "
                f"gains (spectral radius {rho:.4f}); use discretization='exact' or "
                f"substeps >= {need}"
            )
        self._coef: NDArray[np.float64] | None = None
        if f_g is None:
            from mwip.models.reduced import coefficients
            from mwip.models.reduced import f_g as default_f_g

            f_g = default_f_g
            coef = np.asarray(coefficients(params), dtype=float).reshape(-1)
            self._coef = coef if coef.shape == (10,) else None  # a batch: the NumPy path
        self.params = params
        self.Ts = float(Ts)
        self.discretization: str = discretization
        self.substeps = int(substeps)
        self.model_hold: str = model_hold
        self.order = len(self.gains)
        self.D_n = D
        self.Lc = stacked_gain(self.gains)
        self.Phi = Phi
        self.Gamma = Gam
        self._f_g = f_g
        self._z: NDArray[np.float64] | None = None
        self._q_prev: NDArray[np.float64] | None = None
        self._qdot_prev: NDArray[np.float64] | None = None

    # ---- state ----------------------------------------------------------------------------
    def reset(
        self,
        qdot0: ArrayLike,
        estimates0: ArrayLike | None = None,
        q0: ArrayLike | None = None,
    ) -> None:
        """Start a run of N plants.

        Parameters
        ----------
        qdot0 : (N, 3)
            Measured velocities at the first sample.
        estimates0 : (N, n, 3) or (n, 3), optional
            Initial ``[tau^_d, ..., tau^_d^(n-1)]``; default 0, i.e. ``p_i = -L_i q'_0``
            (3.20).
        q0 : (N, 3), optional
            Measured positions at the first sample, used for ``F, G`` over the first sample
            when ``model_hold`` is ``"start"``/``"trapezoid"``; without it the first sample
            uses the positions passed to the first :meth:`update`.
        """
        qd = np.array(qdot0, dtype=float, ndmin=2)
        if qd.ndim != 2 or qd.shape[1] != 3:
            raise ValueError(f"qdot0 must have shape (N, 3), got {np.shape(qdot0)}")
        N, n = qd.shape[0], self.order
        if estimates0 is None:
            z = np.zeros((N, 3 * n))
        else:
            est = np.asarray(estimates0, dtype=float)
            try:
                est = np.broadcast_to(est, (N, n, 3))
            except ValueError:
                raise ValueError(
                    f"estimates0 must have shape (N, n, 3) = ({N}, {n}, 3) or (n, 3), "
                    f"got {est.shape}"
                ) from None
            z = est.reshape(N, 3 * n).copy()
        if q0 is not None:
            qq = np.array(q0, dtype=float, ndmin=2)
            if qq.shape != (N, 3):
                raise ValueError(f"q0 must have shape ({N}, 3), got {np.shape(q0)}")
            self._q_prev = qq.copy()
        else:
            self._q_prev = None
        self._z = z
        self._qdot_prev = qd.copy()

    def _model(
        self, q: NDArray[np.float64], qdot: NDArray[np.float64], uAB: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """``F + G [u_A, u_B]`` of (2.36) on the nominal parameters."""
        if self._coef is not None:  # the default model: one compiled loop
            from mwip.models._compiled import f_plus_g_u  # Numba: loaded by the Python loop

            return f_plus_g_u(self._coef, np.ascontiguousarray(q), np.ascontiguousarray(qdot),
                              np.ascontiguousarray(uAB), np.empty((q.shape[0], 3)))  # fmt: skip
        F, G = self._f_g(self.params, q, qdot)  # (2.36)
        return np.asarray(F) + np.einsum("nij,nj->ni", np.asarray(G), uAB)

    def update(self, q: ArrayLike, qdot: ArrayLike, u: ArrayLike) -> NDArray[np.float64]:
        """Advance one sample and return the new estimate ``tau^_d`` (N, 3).

        Parameters
        ----------
        q, qdot : (N, 3)
            Measured ``[psi, theta, alpha]`` and rates at the new sample instant.
        u : (N, 2)
            Wheel torques ``[u_r, u_l]`` (N m) applied over the sample just ended (ZOH);
            ``G`` multiplies ``[u_A, u_B] = [u_r + u_l, u_r - u_l]`` (2.36).
        """
        if self._z is None or self._qdot_prev is None:
            raise RuntimeError("call reset(qdot0) before update()")
        N = self._z.shape[0]
        qq = np.asarray(q, dtype=float)
        qd = np.asarray(qdot, dtype=float)
        uu = np.asarray(u, dtype=float)
        if qq.shape != (N, 3) or qd.shape != (N, 3) or uu.shape != (N, 2):
            raise ValueError(
                f"update expects q (N, 3), qdot (N, 3), u (N, 2) with N={N}; got "
                f"{qq.shape}, {qd.shape}, {uu.shape}"
            )
        if self._coef is not None:  # the default model: the compiled update, one loop
            from mwip.observers._hodo_kernel import hodo_update  # Numba: the Python loop only

            z = np.ascontiguousarray(self._z)
            q_prev = np.array(qq if self._q_prev is None else self._q_prev, dtype=float)
            qd_prev = np.array(self._qdot_prev, dtype=float)
            Phi, Gam = np.ascontiguousarray(self.Phi), np.ascontiguousarray(self.Gamma)
            hodo_update(self._coef, Phi, Gam, self.Ts, HOLD_CODES[self.model_hold], z, q_prev,
                        qd_prev, np.ascontiguousarray(qq), np.ascontiguousarray(qd),
                        np.ascontiguousarray(uu), np.empty(z.shape[1]))  # fmt: skip
            self._z, self._q_prev, self._qdot_prev = z, q_prev, qd_prev
            return self._z[:, :3].copy()
        uAB = uu @ _TO_AB  # [u_A, u_B] = [u_r + u_l, u_r - u_l]
        q_start = qq if self._q_prev is None else self._q_prev
        if self.model_hold == "start":
            f = self._model(q_start, self._qdot_prev, uAB)
        elif self.model_hold == "end":
            f = self._model(qq, qd, uAB)
        else:
            f = 0.5 * (self._model(q_start, self._qdot_prev, uAB) + self._model(qq, qd, uAB))
        d = (qd - self._qdot_prev) / self.Ts - f  # measured disturbance over the sample
        self._z = self._z @ self.Phi.T + d @ self.Gamma.T  # z_{k+1} = Phi z_k + Gamma d_k
        self._q_prev = qq.copy()
        self._qdot_prev = qd.copy()
        return self._z[:, :3].copy()

    # ---- read-outs ------------------------------------------------------------------------
    @property
    def estimates(self) -> NDArray[np.float64]:
        """``[tau^_d, tau^_d', ..., tau^_d^(n-1)]`` per plant, shape (N, n, 3)."""
        if self._z is None:
            raise RuntimeError("call reset(qdot0) first")
        return self._z.reshape(-1, self.order, 3).copy()

    @property
    def tau_hat(self) -> NDArray[np.float64]:
        """Current estimate of ``tau_d``, shape (N, 3)."""
        if self._z is None:
            raise RuntimeError("call reset(qdot0) first")
        return self._z[:, :3].copy()

    @property
    def auxiliary(self) -> NDArray[np.float64]:
        """The book's auxiliary states ``p_i = tau^_d^(i-1) - L_i q'`` (3.20), (N, n, 3)."""
        if self._z is None or self._qdot_prev is None:
            raise RuntimeError("call reset(qdot0) first")
        Lq = np.einsum("kj,nj->nk", self.Lc, self._qdot_prev)
        return (self._z - Lq).reshape(-1, self.order, 3)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(order={self.order}, Ts={self.Ts:g}, "
            f"discretization={self.discretization!r}, model_hold={self.model_hold!r})"
        )


#: Short alias.
HODO = HighOrderDO
