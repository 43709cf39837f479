"""Terminal sliding-mode control (TSMC) with augmented sliding surfaces, Section 4.3.

The model (2.31)/(4.24) in ``x = [theta', v, alpha']`` is obtained from the reduced model
(2.36) by the change of variables ``v = r psi'`` (nominal parameters)::

    theta'' = f2 + g2 u_A,   v' = r (f1 + g1 u_A),   alpha'' = f3 + g3 u_B,

with ``u_A = u_r + u_l``, ``u_B = u_r - u_l``. In the wheel torques ``tau = [u_r, u_l]`` the
rows of ``G`` are ``[g2, g2]``, ``[r g1, r g1]`` and ``[g3, -g3]``. The TSMC acts on the
subsystem (4.26)-(4.27) ``x1 = [theta', alpha']``, ``F1 = [f2, f3]``,
``G1 = [[g2, g2], [g3, -g3]]`` (invertible whenever ``g2, g3 != 0``).

Sliding surface (4.30) (Park and Tsuji), per channel ``i`` (``e = [theta - theta*, alpha -
alpha*(t)]``, ``a_i(t)`` the augmenting function the book writes ``v_i(t)``)::

    s_i = e_i' + c_i e_i - a_i' - c_i a_i.

The printed (4.31) drops ``- a_1'`` in ``s_1`` and flips the sign of ``c_2 (alpha - alpha*)``
in ``s_2``; both are extraction/typesetting slips: we use (4.30) for both channels (which is
also what (4.36) writes), so that ``s = 0`` means ``(e - a)' + C (e - a) = 0``.

Augmenting functions (4.43): cubics with ``a(0) = e(0)``, ``a'(0) = e'(0)`` and
``a(T_f) = a'(T_f) = 0``, zero after ``T_f``. Hence ``s(0) = 0`` by construction and, while
``s = 0``, ``e(t) = a(t)``: the errors reach zero at ``T_f`` (finite time) and stay there.

Control law (4.32), with ``x_d'' `` the target accelerations (zero unless the yaw target
accelerates)::

    tau = G1^-1 [ -F1 - C e' + a'' + C a' - k sw(s) ],
    k   = (I - D)^-1 ( F~ + D |F1 + C e' - a'' - C a'| + Gamma ),

everything nominal. ``F~`` bounds ``|F - F^|`` (4.28); the book sets ``F~ = 0.8 F^`` (or
``0.9 F^``), read element-wise as ``F~_i = rho |f^_i|`` (a bound must be non-negative).
``D`` bounds the input-gain uncertainty ``G = (I + Delta) G^``, ``|Delta_ij| <= D_ij`` (4.29).
``sw`` is the saturation ``sat(s / phi)`` (the book's simulations, Section 4.4.2) or ``sgn``.

Speed. The TSMC does not act on ``v``: ``v`` obeys the internal dynamics (4.35)/(4.37).
Summing the wheel and pitch rows of (2.33) gives at any steady motion ``2 Dw psi' =
sin(theta) (Gb + (m12 + Ibl cos theta) alpha'^2)``: with any ``Dw > 0`` a non-zero speed
needs a lean (about 0.041 rad for 1 m/s on the real plant, ``Dw`` read as ``D r^2``, SPEC.md
sections 2-3), and with ``theta -> 0`` (4.38) makes ``v`` decay. :func:`lean_for_speed` gives
that lean (the equilibrium of (4.40); :mod:`mwip.models.steady`); ``TSMC(..., v_ref=...,
speed="lean")`` uses it as the pitch target (our extension). See docs/chapter4.md for why the
book's ``v -> v*`` with ``theta -> 0`` cannot hold as worded.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.laws.packing import PackedLaw
from mwip.laws.switching import Switching
from mwip.models.reduced import coefficients
from mwip.models.steady import lean_for_speed
from mwip.params import NOMINAL, Params
from mwip.validate import choice, finite_array, params_arg, real, vector

__all__ = [
    "cubic_coefficients",
    "lean_for_speed",
    "TSMC",
]


def cubic_coefficients(e0: ArrayLike, ed0: ArrayLike, Tf: float) -> NDArray[np.float64]:
    """Coefficients ``[a0, a1, a2, a3]`` (..., 4) of the augmenting cubic (4.43).

    ``a0 = e(0)``, ``a1 = e'(0)``, ``a2 = -3 e(0)/T_f^2 - 2 e'(0)/T_f``,
    ``a3 = 2 e(0)/T_f^3 + e'(0)/T_f^2``, so that ``a(T_f) = a'(T_f) = 0``.
    """
    if not (np.isfinite(Tf) and Tf > 0):
        raise ValueError(f"T_f must be finite and in (0, inf), got {Tf!r}")
    e0 = np.asarray(e0, dtype=float)
    ed0 = np.asarray(ed0, dtype=float)
    return np.stack(
        np.broadcast_arrays(
            e0, ed0, -3.0 * e0 / Tf**2 - 2.0 * ed0 / Tf, 2.0 * e0 / Tf**3 + ed0 / Tf**2
        ),
        axis=-1,
    )


def _inv2(A: NDArray[np.float64]) -> NDArray[np.float64]:
    """Closed-form inverse of (..., 2, 2) matrices."""
    a, b, c, d = A[..., 0, 0], A[..., 0, 1], A[..., 1, 0], A[..., 1, 1]
    det = a * d - b * c
    out = np.empty_like(A)
    out[..., 0, 0], out[..., 0, 1] = d / det, -b / det
    out[..., 1, 0], out[..., 1, 1] = -c / det, a / det
    return out


class TSMC:
    """Terminal SMC (4.30)-(4.32), (4.43) for a batch of robots (nominal model).

    Parameters
    ----------
    C : (c1, c2), the surface slopes (book: 2.5 I, or diag(2.5, 0.5)).
    Gamma : (gamma1, gamma2), the reaching margins (book: 10 I, [5, 20], 5 I).
    D : scalar or (2, 2), the input-gain uncertainty bound (book: 0.4 I).
    Ftilde_ratio : ``F~ = Ftilde_ratio |F^|`` (book: 0.8 or 0.9).
    Tf : time by which the augmenting functions (and so the errors) reach zero (book: 1 s).
    switching : ``Switching("sat", phi)`` (book, Section 4.4.2) or ``Switching("sign")``.
    theta_ref, alpha_ref, alpha_dot_ref : targets ``theta*``, ``alpha*(0)``, ``alpha'*``; the
        yaw target is the ramp ``alpha*(t) = alpha_ref + alpha_dot_ref t`` (circle motion).
    v_ref, speed : with ``speed="lean"`` the pitch target is :func:`lean_for_speed` of
        ``v_ref`` on the nominal parameters (clipped to ``theta_max``); ``speed="none"``
        (default, the book) leaves ``v`` to the internal dynamics.
    Ts : sample period (``None``: whatever the simulation uses; run it quasi-continuously).

    Logs ``s`` (N, 2), ``k`` (N, 2), ``aug`` (N, 2) (the augmenting functions).
    """

    static = True  # a fixed function of (t, measurement) once reset() fitted the cubics

    def __init__(
        self,
        params: Params = NOMINAL,
        *,
        C: ArrayLike = (2.5, 2.5),
        Gamma: ArrayLike = (10.0, 10.0),
        D: ArrayLike = 0.4,
        Ftilde_ratio: float = 0.8,
        Tf: float = 1.0,
        switching: Switching | None = None,
        theta_ref: float = 0.0,
        alpha_ref: float = 0.0,
        alpha_dot_ref: float = 0.0,
        v_ref: float = 0.0,
        speed: Literal["none", "lean"] = "none",
        theta_max: float = 0.5,
        Ts: float | None = None,
    ) -> None:
        self.params = params_arg("params", params)
        self.C = vector("C", C, 2, 0.0, lo_closed=False)
        self.Gamma = vector("Gamma", Gamma, 2, 0.0, lo_closed=False)
        D = finite_array("D", D)
        if D.shape not in ((), (2, 2)):
            raise ValueError(f"D must be a number d (D = d I) or a 2x2 matrix, got shape {D.shape}")
        self.D = D * np.eye(2) if D.ndim == 0 else D
        Ftilde_ratio = real("Ftilde_ratio", Ftilde_ratio, 0.0, lo_closed=True)
        Tf = real("Tf", Tf, 1e-3, 1e6, lo_closed=True)  # beyond: (4.43)'s 1/Tf^3 over/underflows
        theta_ref, alpha_ref, alpha_dot_ref, v_ref = (real(n, v) for n, v in (
            ("theta_ref", theta_ref), ("alpha_ref", alpha_ref), ("alpha_dot_ref", alpha_dot_ref),
            ("v_ref", v_ref)))  # fmt: skip
        theta_max = real("theta_max", theta_max, 0.0, np.pi / 2, hi_closed=False)
        speed = choice("speed", speed, ("none", "lean"))  # type: ignore[assignment]
        if switching is not None and not isinstance(switching, Switching):
            raise TypeError(f"switching must be a Switching or None, got "
                            f"{type(switching).__name__}")  # fmt: skip
        if Ts is not None:
            Ts = real("Ts", Ts, 0.0, 1.0)
        if np.any(self.C <= 0) or np.any(self.Gamma <= 0):
            raise ValueError("C and Gamma must be positive")
        if np.any(self.D < 0) or np.linalg.norm(self.D, 2) >= 1.0:
            raise ValueError("D must be non-negative with norm < 1 (4.29)")
        if not Ftilde_ratio >= 0:
            raise ValueError(f"Ftilde_ratio must be >= 0, got {Ftilde_ratio!r}")
        if speed not in ("none", "lean"):
            raise ValueError(f"speed must be 'none' or 'lean', got {speed!r}")
        self.Ftilde_ratio = float(Ftilde_ratio)
        self.Tf = float(Tf)
        cubic_coefficients(0.0, 0.0, self.Tf)  # validates Tf
        self.switching = Switching("sat", 0.05) if switching is None else switching
        self.speed = speed
        self.v_ref = float(v_ref)
        self.lean = float("nan")
        if speed == "lean":
            self.lean = lean_for_speed(params, self.v_ref, alpha_dot_ref)
            th = self.lean if np.isfinite(self.lean) else np.sign(self.v_ref) * theta_max
            theta_ref = float(np.clip(th, -theta_max, theta_max))
        self.theta_ref = float(theta_ref)
        self.alpha_ref = float(alpha_ref)
        self.alpha_dot_ref = float(alpha_dot_ref)
        self.Ts = Ts
        self._coeffs: NDArray[np.float64] | None = None
        self._log: dict[str, NDArray[np.float64]] = {}
        self._coef = np.ascontiguousarray(coefficients(params).reshape(-1), dtype=float)
        if self._coef.shape != (10,):
            raise ValueError("the controller's nominal params must be one robot, not a batch")
        self._IDinv = np.ascontiguousarray(_inv2(np.eye(2) - self.D))
        self._refs = np.array([self.theta_ref, self.alpha_ref, self.alpha_dot_ref])

    def errors(
        self, t: float, meas: Measurement
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``e = [theta - theta*, alpha - alpha*(t)]`` and ``e'`` (N, 2)."""
        q, qd = meas.q, meas.qdot
        e = np.column_stack(
            [q[:, 1] - self.theta_ref, q[:, 2] - self.alpha_ref - self.alpha_dot_ref * t]
        )
        ed = np.column_stack([qd[:, 1], qd[:, 2] - self.alpha_dot_ref])
        return e, ed

    def reset(self, meas: Measurement) -> None:
        """Fit the augmenting cubics (4.43) to the initial errors so that ``s(0) = 0``."""
        e, ed = self.errors(meas.t, meas)
        self._coeffs = np.ascontiguousarray(
            np.broadcast_to(cubic_coefficients(e, ed, self.Tf), (e.shape[0], 2, 4))
        )
        self._t0 = float(meas.t)

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        """(4.30)-(4.32) at ``(t, meas)`` in one compiled loop (:mod:`mwip.laws.tsmc.kernel`;
        the law's one implementation; NumPy oracle in tests/oracle_laws.py)."""
        # the kernel (Numba) is loaded when the Python loop calls the law (mwip.sim.aot)
        from mwip.laws.tsmc.kernel import tsmc_step

        if self._coeffs is None:
            self.reset(meas)
        assert self._coeffs is not None
        q = np.ascontiguousarray(meas.q)
        qd = np.ascontiguousarray(meas.qdot)
        n = q.shape[0]
        u, s, k, a = (np.empty((n, 2)) for _ in range(4))
        sw = self.switching
        tsmc_step(
            self._coef, q, qd, float(t), float(t) - self._t0, self._coeffs, self.Tf, self.C,
            self.Ftilde_ratio, self.D, self._IDinv, self.Gamma, sw.kind == "sat", float(sw.phi),
            self._refs, u, s, k, a,
        )  # fmt: skip
        self._log = {"s": s, "k": k, "aug": a}
        return u

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return self._log

    def packed_law(self) -> PackedLaw | None:
        """The law packed (:mod:`mwip.laws.tsmc.packing`) for the compiled closed loop
        (:mod:`mwip.sim.loop`) and the C export, one parameter vector per robot (its fitted
        cubics); the same kernel (:func:`~mwip.laws.tsmc.kernel.tsmc_step`); after
        :meth:`reset` (the fitted cubics are part of it), else ``None``."""
        from mwip.laws.tsmc.packing import pack

        if self._coeffs is None:
            return None
        sw = self.switching
        return pack(self._coef, self.Tf, self.Ftilde_ratio, sw.kind == "sat", sw.phi,
                    self._t0, self.C, self.Gamma, self.D, self._IDinv, self._refs,
                    self._coeffs)  # fmt: skip
