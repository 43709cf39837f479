"""Sliding-mode control with (optional) disturbance observer: SMC, DO1SMC, HODOSMC (Sec. 3.5).

Sliding surface (3.49), for balance with speed tracking and yaw::

    S1 = q2' + l1 q2 + l2 (q1 - q1d' t) + l3 (q1' - q1d')
    S2 = q3' + l4 (q3 - q3d)

Control law (3.50), with ``F, G`` of (2.36) on the nominal parameters and the observer's
estimate ``tau^`` of the lumped disturbance (zero without observer)::

    u_A = [-f2 - l3 f1 - l1 q2' - l2 (q1' - q1d') - tau^2 - l3 tau^1 - K1 sw(S1)] / (g2 + l3 g1)
    u_B = [-f3 - l4 q3' - tau^3 - K2 sw(S2)] / g3

so that ``S1' = (tau_d2 - tau^2) + l3 (tau_d1 - tau^1) - K1 sw(S1)`` and
``S2' = (tau_d3 - tau^3) - K2 sw(S2)`` (3.54)-(3.57). Switching gains (3.51):
``K1 = dbar2 + l3 dbar1 + gamma1``, ``K2 = dbar3 + gamma2``, with ``dbar`` bounds on the
estimation error (HODOSMC) or on the whole lumped disturbance (conventional SMC); or given
directly (Table 6.3 gives K1, K2; SPEC.md section 3: take them as given). ``sw`` is ``sgn``
(book default) or a saturation with boundary layer (:mod:`mwip.laws.switching`).

Wheel torques: ``u_r = (u_A + u_B) / 2``, ``u_l = (u_A - u_B) / 2``.

Discrete use: at each sample the observer is first advanced with the new measurement and the
torque held over the sample just ended, then the law is evaluated (the same order as on the
robot). With no observer and ``static`` switching the law is a static function of the
measurement and time.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement, Observer
from mwip.laws.packing import PackedLaw
from mwip.laws.switching import Switching
from mwip.models.reduced import coefficients
from mwip.params import NOMINAL, Params
from mwip.validate import params_arg, real

__all__ = [
    "SMCGains",
    "gains_from_bounds",
    "SlidingModeController",
    "SMCDesignWarning",
]


class SMCDesignWarning(UserWarning):
    """The sliding-surface coefficients fail a design condition (3.52)/(3.66)."""


@dataclass(frozen=True)
class SMCGains:
    """Coefficients of (3.49)-(3.51): ``lambdas = (l1, l2, l3, l4)`` and switching ``K1, K2``."""

    lambdas: tuple[float, float, float, float]
    K1: float
    K2: float

    def __post_init__(self) -> None:
        lam = tuple(float(x) for x in self.lambdas)
        if len(lam) != 4 or not all(np.isfinite(x) and x > 0 for x in lam):
            raise ValueError(f"lambdas must be 4 finite numbers in (0, inf), got {self.lambdas!r}")
        object.__setattr__(self, "lambdas", lam)
        for name in ("K1", "K2"):
            k = getattr(self, name)
            if not (np.isfinite(k) and k >= 0):
                raise ValueError(f"{name} must be finite and in [0, inf), got {k!r}")
            object.__setattr__(self, name, float(k))


def gains_from_bounds(
    lambdas: Sequence[float], dbar: Sequence[float], gamma: Sequence[float]
) -> SMCGains:
    """Switching gains of (3.51): ``K1 = dbar2 + l3 dbar1 + gamma1``, ``K2 = dbar3 + gamma2``.

    >>> gains_from_bounds((3, 0.2, 0.3, 3), (3, 3, 3), (1, 1)).K1
    4.9
    """
    d = [float(x) for x in dbar]
    g = [float(x) for x in gamma]
    if len(d) != 3 or any(not np.isfinite(x) or x < 0 for x in d):
        raise ValueError(f"dbar must be 3 finite numbers in [0, inf), got {dbar!r}")
    if len(g) != 2 or any(not np.isfinite(x) or x <= 0 for x in g):
        raise ValueError(f"gamma must be 2 finite numbers in (0, inf), got {gamma!r}")
    lam = tuple(float(x) for x in lambdas)
    return SMCGains(lam, round(d[1] + lam[2] * d[0] + g[0], 12), d[2] + g[1])  # type: ignore[arg-type]


class SlidingModeController:
    """SMC / DOnSMC / HODOSMC of (3.49)-(3.51), sampled at ``Ts``.

    Parameters
    ----------
    gains : SMCGains
        ``lambdas`` and ``K1, K2`` (see :func:`gains_from_bounds`).
    observer : optional
        A disturbance observer with ``reset(qdot0, q0=...)``, ``update(q, qdot, u)`` and
        ``tau_hat`` (e.g. :class:`mwip.observers.HighOrderDO`); ``None`` gives conventional
        SMC. Order 1 gives DO1SMC, order 4 DO4SMC.
    params : Params
        Nominal parameters for ``F, G`` (the controller never sees the plant).
    Ts : float
        Sample period (must equal the observer's).
    switching : Switching
        ``sgn`` (default) or saturation.
    q1d_dot, q3d : float
        Desired wheel speed (rad/s) and yaw (rad).
    check : bool
        Check the design conditions (3.52)/(3.66) on construction and warn
        (:class:`SMCDesignWarning`) when one fails; the controller still runs.
    """

    def __init__(
        self,
        gains: SMCGains,
        observer: Observer | None = None,
        params: Params = NOMINAL,
        Ts: float = 0.005,
        switching: Switching | None = None,
        q1d_dot: float = 0.0,
        q3d: float = 0.0,
        check: bool = True,
    ) -> None:
        if not isinstance(gains, SMCGains):
            raise TypeError(f"gains must be an SMCGains, got {type(gains).__name__}")
        params_arg("params", params)
        Ts = real("Ts", Ts, 0.0, 1.0)
        q1d_dot, q3d = real("q1d_dot", q1d_dot), real("q3d", q3d)
        if observer is not None and not callable(getattr(observer, "update", None)):
            raise TypeError(f"observer must be a mwip observer or None, got "
                            f"{type(observer).__name__}")  # fmt: skip
        if switching is not None and not isinstance(switching, Switching):
            raise TypeError(f"switching must be a Switching or None, got "
                            f"{type(switching).__name__}")  # fmt: skip
        if observer is not None and abs(observer.Ts - Ts) > 1e-12:
            raise ValueError(f"observer Ts={observer.Ts:g} differs from the controller's {Ts:g}")
        self.gains = gains
        self.observer = observer
        self.params = params
        self.Ts = Ts
        self.switching = switching if switching is not None else Switching()
        self.q1d_dot = float(q1d_dot)
        self.q3d = float(q3d)
        self._coef = np.ascontiguousarray(coefficients(params).reshape(-1), dtype=float)
        if self._coef.shape != (10,):
            raise ValueError("the controller's nominal params must be one robot, not a batch")
        self._lam = np.array(gains.lambdas, dtype=float)
        self._u: NDArray[np.float64] | None = None
        self._S = np.zeros((0, 2))
        self._tau = np.zeros((0, 3))
        if check:
            from mwip.laws.smc.design import check_smc_design

            report = check_smc_design(gains.lambdas, params, q1d_dot=q1d_dot)
            if not report.ok:
                failed = "; ".join(
                    f"{c.name}: {c.expression} = {c.value:.4g}" for c in report.failed
                )
                warnings.warn(
                    f"sliding-surface coefficients {gains.lambdas} fail {failed}",
                    SMCDesignWarning,
                    stacklevel=2,
                )

    @property
    def static(self) -> bool:
        """Without an observer the law is a static function of ``(t, measurement)``."""
        return self.observer is None

    def reset(self, meas: Measurement) -> None:
        if self.observer is not None:
            self.observer.reset(meas.qdot, q0=meas.q)
        self._u = None

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        """(3.49)-(3.50) at a sample, in one compiled loop (:mod:`mwip.laws.smc.kernel`,
        the law's one implementation)."""
        from mwip.laws.smc.kernel import smc_step  # Numba: loaded by the Python loop only

        q = np.ascontiguousarray(meas.q)
        qd = np.ascontiguousarray(meas.qdot)
        tau_hat = np.ascontiguousarray(self.disturbance_estimate(t, meas), dtype=float)
        n = q.shape[0]
        u, S = np.empty((n, 2)), np.empty((n, 2))
        sw = self.switching
        smc_step(
            self._coef, q, qd, tau_hat, float(t), self._lam, self.gains.K1, self.gains.K2,
            sw.kind == "sat", float(sw.phi), self.q1d_dot, self.q3d, u, S,
        )  # fmt: skip
        self._u, self._S, self._tau = u, S, tau_hat
        return u

    def packed_law(self) -> PackedLaw | None:
        """The law packed (:mod:`mwip.laws.smc.packing`) for the compiled closed loop
        (:mod:`mwip.sim.loop`) and the C export; its kernel calls the same
        :func:`~mwip.laws.smc.kernel.smc_law` and the observer's
        :func:`~mwip.observers._hodo_kernel.hodo_sample`; ``None`` when the observer is not a
        :class:`~mwip.observers.HighOrderDO` on the default model (the Python loop runs it)."""
        from mwip.core import HOLD_CODES
        from mwip.laws.smc.packing import pack
        from mwip.observers.hodo import HighOrderDO

        sw = self.switching
        common: dict[str, Any] = dict(
            coef=self._coef, lam=self._lam, K1=self.gains.K1, K2=self.gains.K2,
            sat=sw.kind == "sat", phi=sw.phi, q1d_dot=self.q1d_dot, q3d=self.q3d,
            name="dosmc" if self.observer is not None else "smc",
        )  # fmt: skip
        if self.observer is None:
            return pack(**common)
        obs = self.observer
        if type(obs) is not HighOrderDO or obs._coef is None:
            return None
        return pack(Phi=np.ascontiguousarray(obs.Phi, dtype=float),
                    Gamma=np.ascontiguousarray(obs.Gamma, dtype=float), obs_Ts=obs.Ts,
                    hold=HOLD_CODES[obs.model_hold], **common)  # fmt: skip

    def disturbance_estimate(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        """``tau^`` for the law: advance the observer with the torque just held (or zeros)."""
        if self.observer is None:
            return np.zeros((meas.q.shape[0], 3))
        if self._u is not None:
            self.observer.update(meas.q, meas.qdot, self._u)
        return np.asarray(self.observer.tau_hat, dtype=float)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        """Sliding variables ``S1, S2`` and the disturbance estimate ``tau_hat`` (N, 3)."""
        return {"S1": self._S[:, 0], "S2": self._S[:, 1], "tau_hat": self._tau}


def make_smc(
    kind: str,
    lambdas: Sequence[float],
    *,
    dbar: Sequence[float] | None = None,
    gamma: Sequence[float] = (1.0, 1.0),
    K: tuple[float, float] | None = None,
    observer_gains: Sequence[ArrayLike] | None = None,
    params: Params = NOMINAL,
    Ts: float = 0.005,
    switching: Switching | None = None,
    q1d_dot: float = 0.0,
    q3d: float = 0.0,
    check: bool = True,
) -> SlidingModeController:
    """Build ``"smc"``, ``"do1smc"``, ``"do4smc"``/``"hodosmc"``; gains from ``dbar`` or ``K``.

    Observer gains default to the book's: order 1 ``L = 50 I3`` (no printed value; our
    choice, documented in docs/smc.md) and order 4 the Sec. 3.6.1 set.
    """
    from mwip.observers import HighOrderDO
    from mwip.observers.design import published_gain_sets

    if (dbar is None) == (K is None):
        raise ValueError("give exactly one of dbar (with gamma) or K = (K1, K2)")
    gains = (
        gains_from_bounds(lambdas, dbar, gamma)
        if dbar is not None
        else SMCGains(tuple(lambdas), K[0], K[1])  # type: ignore[arg-type,index]
    )
    kind = kind.lower()
    if kind == "smc":
        obs = None
    elif kind == "do1smc":
        obs = HighOrderDO(params, observer_gains or [DO1_GAIN], Ts)
    elif kind in ("do4smc", "hodosmc"):
        obs = HighOrderDO(params, observer_gains or published_gain_sets()["do4"].gains, Ts)
    else:
        raise ValueError(f"kind must be one of smc, do1smc, do4smc, hodosmc; got {kind!r}")
    return SlidingModeController(gains, obs, params, Ts, switching, q1d_dot, q3d, check)


#: First-order observer gain used for DO1SMC (the book prints none): a 50 rad/s pole per
#: channel, ie = 1/sqrt(100) = 0.1.
DO1_GAIN = 50.0
