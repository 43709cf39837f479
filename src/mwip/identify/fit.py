"""Prediction-error fit of the twin's parameters over short segments (multiple shooting).

The plant is open-loop unstable and a wheel on a stand integrates its speed, so nothing is
replayed open-loop over a whole log: each log is cut into segments of ``segment`` samples;
every segment starts from its own state (nuisance parameters: the wheel speeds at its first
sample and at the sample before, whose back-EMF compensation the delayed first duty holds;
the angle offsets are projected out) and all segments are integrated in one batch
(:func:`mwip.identify.model.stand_rollout`). The global parameters (scaled to their bounds)
and the nuisances are fitted together by variable projection (:mod:`mwip.identify.solve`: the
nuisances eliminated segment by segment, bounded :func:`scipy.optimize.least_squares` with the
exact trust-region solver over the globals only), after a coarse search over the gear ratio,
the compensation and the current limit (a kink: started at its centre and at its upper bound).
Stage 1 fits the smooth model (no PWM quantisation); stage 2, for a quantising driver, refits
with the PWM rounding errors of the stage-1 trajectories held (the quantised model on that
trajectory, smooth in the parameters; docs/twin_fit.md).

Experiments (the ``mode`` column) and what they inform (docs/twin_fit.md):

- ``wheels-off-ground``: the drive model's :data:`~mwip.identify.model.STAND_PARAMS` from the
  encoders;
- ``static`` and ``wheels-off-ground`` (the body held level and still): ``imu.gyro_bias`` (the
  gyro's mean; its standard error includes the declared bias random walk) and, with
  ``accel_x``, ``imu.accel_bias`` (the mean of ``accel_x``);
- any log with ``accel_x, accel_y``: ``firmware.fusion.tau`` from the board's complementary filter,
  ``theta_k = a (theta_{k-1} + omega_k Ts) + (1 - a) atan2(a_x, a_y)`` (linear in ``a``);
- ``balancing``: read and validated, but no parameter is fitted from it in this version
  (``imu.height`` and the rigid-body terms are reported as not informed).

Statistics: standard errors from the cluster-robust (sandwich) covariance over segments,
:func:`cluster_covariance` (the residuals are correlated within a segment, independent
between segments; the nuisances are included in ``J``),
the correlation matrix (pairs above ``|0.9|`` flagged), the condition number of the scaled
information matrix, residual RMS per signal and whiteness
(the fraction of residual autocorrelations at lags 1..20 within ``+-1.96/sqrt(n)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.bounds import BOUNDS, NAMES, centre
from mwip.identify.logs import Log, LogError, window_starts
from mwip.identify.model import STAND_PARAMS, Known, stand_rollout
from mwip.identify.solve import (
    Reduced,
    Residual,
    global_jacobian,
    nuisance_solve,
    project_out,
)
from mwip.identify.structure import StructureCheck, check_structure, residual_floor
from mwip.identify.torque_map import TorqueMap, torque_to_duty

__all__ = ["FitResult", "Segments", "fit", "stand_segments", "predict_error", "predict",
           "whiteness", "at_bound", "summary_lines"]

#: Encoder residual scale (rad) the least-squares problem is written in.
_RES = 1e-3
_MAX_LAG = 20


@dataclass
class Segments:
    """Wheels-off-ground segments in one batch."""

    cmd: NDArray[np.float64]  # (S, L + 1, 2)
    enc: NDArray[np.float64]  # (S, L, 2), relative to the segment's first sample
    is_duty: NDArray[np.bool_]  # (S,)
    w0: NDArray[np.float64]  # (S, 2), first guess of the wheel speeds
    t: NDArray[np.float64]  # (S, L)
    log: NDArray[np.int64]  # (S,)
    prev2: NDArray[np.float64] | None = None  # (S, 2), the command two samples before
    dw0: NDArray[np.float64] | None = None  # (S, 2), first guess of w_0 - w_{-1}

    @property
    def n(self) -> int:
        return int(self.cmd.shape[0])


def stand_segments(logs: Sequence[Log], L: int) -> Segments | None:
    """Cut the wheels-off-ground rows of ``logs`` into segments of ``L`` samples."""
    cmds, encs, duty, w0s, ts, ids, prev2, dw0s = [], [], [], [], [], [], [], []
    for li, lg in enumerate(logs):
        on = lg.mode == "wheels-off-ground"
        cmd, enc, t = lg.command, lg.enc, lg.columns["t"]
        Ts = lg.Ts
        for k0 in window_starts(on, L):
            prev = cmd[k0 - 1] if k0 > 0 else np.zeros(2)
            prev2.append(cmd[k0 - 2] if k0 > 1 else np.zeros(2))
            cmds.append(np.concatenate([prev[None], cmd[k0:k0 + L]]))
            e = enc[k0:k0 + L]
            encs.append(e - e[0])
            duty.append(lg.inputs == "duty")
            w, dw = _start_guess(e - e[0], Ts)
            w0s.append(w)
            dw0s.append(dw)
            ts.append(t[k0:k0 + L])
            ids.append(li)
    if not cmds:
        return None
    return Segments(np.array(cmds), np.array(encs), np.array(duty), np.array(w0s),
                    np.array(ts), np.array(ids), np.array(prev2), np.array(dw0s))  # fmt: skip


def _start_guess(e: NDArray[np.float64], Ts: float, q: int = 6) -> tuple[NDArray, NDArray]:
    """First guess of a segment's start speed ``w_0`` and of ``w_0 - w_{-1}`` per wheel: the
    slope at 0 and ``Ts`` times the curvature of the least-squares parabola through the
    first ``q`` encoder samples ``e`` (L, 2) (a wheel reversing within the segment's first
    samples is far from its mean speed over them)."""
    q = min(q, e.shape[0])
    tk = np.arange(q) * Ts
    if q < 3:
        w = (e[q - 1] - e[0]) / max((q - 1) * Ts, Ts)
        return w, np.zeros(2)
    A = np.column_stack([np.ones(q), tk, tk * tk])
    coef = np.linalg.lstsq(A, e[:q], rcond=None)[0]
    return coef[1], 2.0 * coef[2] * Ts


def whiteness(r: NDArray[np.float64], max_lag: int = _MAX_LAG) -> float:
    """Fraction of the autocorrelations at lags 1..max_lag within ``+-1.96/sqrt(n)``."""
    r = np.asarray(r, dtype=float).ravel()
    r = r - r.mean()
    n = r.size
    if n < max_lag + 2 or not np.any(r):
        return float("nan")
    c0 = float(r @ r)
    acf = np.array([float(r[:-k] @ r[k:]) / c0 for k in range(1, max_lag + 1)])
    return float(np.mean(np.abs(acf) <= 1.96 / np.sqrt(n)))


def cluster_covariance(
    A: NDArray[np.float64], N: NDArray[np.float64], r: NDArray[np.float64], offsets: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cluster-robust (sandwich) covariance of a least-squares estimate whose residuals are
    correlated within clusters and independent between them: the segments.

    Cluster ``s`` has the residuals ``r_s`` (row ``s`` of ``r`` (G, n)), the Jacobian of the
    globals ``A_s`` (``A`` (G, n, g)) and of its own nuisances ``N_s`` (``N`` (G, n, k)),
    ``J_s = [A_s, N_s]`` its rows of the full Jacobian; its rows cycle over ``offsets``
    signals whose mean was projected out of ``r`` (the wheel-angle offsets: projector
    ``P_s``). With the bread
    ``B = (J^T J)^+``, the block's leverage ``H_s = J_s B J_s^T + P_s`` and the scores
    ``u_s = J_s^T (I - H_s)^{-1} r_s``,

    ``V = (G - 1) / G  B (sum_s u_s u_s^T) B``,

    the CR3 (CV3) estimator: the cluster form of the sandwich (Liang & Zeger 1986,
    Biometrika 73, 13-22) with the leave-one-cluster-out residuals ``(I - H_s)^{-1} r_s``,
    i.e. the delete-one-cluster jackknife (Bell & McCaffrey 2002, Survey Methodology 28,
    169-181), which MacKinnon, Nielsen & Webb (2023, "Cluster-robust inference: a guide to
    empirical practice", J. Econometrics 232, 272-299) recommend over CR1 when the clusters
    are few or of high leverage. Both hold here: a short log has ~15 segments, and every
    segment fits its own start state (:data:`_NUIS` nuisances and the offsets) to its ``2 L``
    residuals, so ``r_s`` is much smaller than the errors it stands for. It needs no model of
    the correlation within a segment (encoder quantisation, a staircase when the wheel is
    slow; PWM quantisation, an input error integrated twice). Measured 2-sigma coverage
    of the drive parameters on synthetic truth (development seeds 100-119, one earlier state
    of the fit, the same fits for each; docs/twin_fit.md): CR1 0.79, CR2
    (``(I - H_s)^{-1/2}``) 0.87, CR3 0.92. ``V`` is in ``J``'s column units per unit of
    ``r``. Computed for the globals only, by block elimination: ``Q_s`` an orthonormal basis
    of ``N_s``, ``A~_s = (I - Q_s Q_s^T) A_s``, ``B = (sum_s A~_s^T A~_s)^-1`` (the globals'
    block of ``(J^T J)^-1``), ``H_s = A~_s B A~_s^T + Q_s Q_s^T + P_s``,
    ``u_s = A~_s^T (I - H_s)^-1 r_s``: the same numbers as the full matrices, without
    inverting the ill-conditioned full normal matrix. Returns ``(V, B)`` of the globals.
    """
    u, B, _ = cluster_scores(A, N, r, offsets)
    return sandwich(u, B), B


def sandwich(u: NDArray[np.float64], B: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(G - 1) / G  B (sum_s u_s u_s^T) B`` (:func:`cluster_covariance`)."""
    G = u.shape[0]
    return np.asarray((G - 1) / max(G, 1) * (B @ (u.T @ u) @ B), dtype=float)


def cluster_scores(
    A: NDArray[np.float64], N: NDArray[np.float64], r: NDArray[np.float64], offsets: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The pieces of :func:`cluster_covariance`: the clusters' leave-one-out scores ``u``
    (G, g), the bread ``B`` (g, g) and the nuisance-projected Jacobians ``A~`` (G, n, g)."""
    G, n, g = A.shape
    Pe = np.zeros((n, n))
    if offsets:
        for j in range(offsets):
            e = np.zeros(n)
            e[j::offsets] = 1.0
            Pe += np.outer(e, e) / float(e @ e)
    Q = np.zeros((G, n, 0))
    if N.shape[2]:
        from mwip.identify.solve import _basis

        Q = _basis(N)
    At = project_out(N, A) if N.shape[2] else A
    info = np.einsum("sni,snj->ij", At, At)
    d = np.sqrt(np.maximum(np.diag(info), 0.0))
    d = np.where(d > 0, d, 1.0)
    B = np.linalg.pinv(info / np.outer(d, d), rcond=1e-13, hermitian=True) / np.outer(d, d)
    Mi = (np.eye(n) - At @ B @ At.transpose(0, 2, 1) - Q @ Q.transpose(0, 2, 1) - Pe)
    lam, U = np.linalg.eigh(Mi)
    inv = np.where(lam > 1e-9, 1.0 / np.maximum(lam, 1e-9), 0.0)
    loo = np.einsum("snk,sk->sn", U, inv * np.einsum("snk,sn->sk", U, r))
    u = np.einsum("sni,sn->si", At, loo)
    return u, np.asarray(B, dtype=float), At


@dataclass
class FitResult:
    """Estimates and statistics of :func:`fit` (``to_json`` for ``fit.json``)."""

    estimates: dict[str, float]
    stderr: dict[str, float | None]
    status: dict[str, str]  # "fitted", "fixed", "not informed", "not identified", "prior"
    free: list[str]
    fixed: dict[str, float]
    correlation: dict[str, Any]
    flags: list[str]
    condition: float | None
    residuals: dict[str, dict[str, float]]
    Ts: float
    segment: int
    experiments: dict[str, int]
    validation: dict[str, Any] | None = None
    #: measured and predicted signals of the fitted logs per mode present (``fit.png``; not in
    #: ``fit.json``): ``"wheels-off-ground"`` (``t`` (S, L), ``enc``, ``pred`` (S, L, 2): each
    #: segment from its own start), ``"static"`` (the rows with the body held still, static
    #: and wheels-off-ground: ``t``, ``theta_rate``, ``theta_rate_pred`` (the gyro bias) and
    #: with an accelerometer ``accel_x``, ``accel_x_pred``), ``"balancing"``
    #: (:func:`mwip.identify.balance.balance_prediction`'s trace) and ``"fusion"`` (``t``,
    #: ``theta``, ``theta_pred``: the complementary filter one sample ahead with the fitted
    #: ``firmware.fusion.tau``, logs with ``accel_x, accel_y``)
    trace: dict[str, dict[str, NDArray[np.float64]]] = field(default_factory=dict, repr=False)
    #: the validation log's traces (:func:`predict`): ``{"log": name, "fitted": trace,
    #: "prior_centre": trace}`` (``trace`` as :attr:`trace`, without ``"fusion"``), else ``{}``
    validation_trace: dict[str, Any] = field(default_factory=dict, repr=False)
    known: Known | None = field(default=None, repr=False)
    #: the firmware's torque gain from logs with both pairs (:mod:`mwip.identify.torque_map`):
    #: ``{"torque_gain", "stderr", "a", "se_a", "misfit", "rows"}``, else ``None``
    torque_map: dict[str, float] | None = None
    #: the structure test of the stand fit (:mod:`mwip.identify.structure`), else ``None``
    structure: StructureCheck | None = None
    #: what the logs inform, checked before the fit (:mod:`mwip.identify.identifiability`)
    identifiability: Any = None
    #: the body stage's lumped coefficients of (2.32) from balancing rows
    #: (:mod:`mwip.identify.body`), else ``None``
    body: Any = None

    def robot_values(self, twin: Any) -> dict[str, float]:
        """The values of the robot the fit describes: the fitted and fixed ones, the robot
        file's twin (``twin``) for the rest (a parameter no log informs keeps the file's value,
        as the fitted robot.toml does; ``estimates`` holds its prior centre)."""
        out = {n: float(v) for n, v in twin.values().items() if n in self.estimates}
        out.update({n: v for n, v in self.estimates.items()
                    if self.status[n] in ("fitted", "fixed", "not identified")})  # fmt: skip
        return out

    def to_json(self) -> dict[str, Any]:
        def num(x: Any) -> Any:
            if x is None:
                return None
            x = float(x)
            return x if np.isfinite(x) else None

        return {
            "estimates": {k: num(v) for k, v in self.estimates.items()},
            "stderr": {k: num(v) for k, v in self.stderr.items()},
            "status": dict(self.status),
            "bounds": {k: list(v) for k, v in BOUNDS.items()},
            "free": list(self.free),
            "fixed": {k: num(v) for k, v in self.fixed.items()},
            "correlation": self.correlation,
            "flags": list(self.flags),
            "condition_number": num(self.condition),
            "residuals": {k: {kk: num(vv) for kk, vv in v.items()}
                          for k, v in self.residuals.items()},  # fmt: skip
            "Ts": self.Ts,
            "segment": self.segment,
            "experiments": dict(self.experiments),
            "validation": self.validation,
            "torque_to_duty": self.torque_map,
            "structure": None if self.structure is None else self.structure.to_json(),
            "identifiability": (None if self.identifiability is None
                                else self.identifiability.to_json()),
            "body": None if self.body is None else self.body.to_json(),
        }


_STAND = ("wheels-off-ground rows (the robot on a stand running the steps and chirp of "
          "`mwip twin excite`)")  # fmt: skip
#: What informs each parameter (:func:`_informed`), for the refusal of ``--free``.
NEEDS: dict[str, str] = {
    **{n: _STAND for n in STAND_PARAMS},
    "imu.gyro_bias": "static or wheels-off-ground rows (the body held still)",
    "imu.accel_bias": "static or wheels-off-ground rows with accel_x, accel_y",
    "firmware.fusion.tau": "a log with accel_x, accel_y",
    "imu.height": "an experiment no schedule of `mwip twin excite` holds (the accelerometer's "
                  "height above the axle: measure it)",
}  # fmt: skip


def _informed(logs: Sequence[Log]) -> dict[str, str]:
    """name -> experiment that informs it (absent: none)."""
    modes = set().union(*(set(lg.mode.tolist()) for lg in logs))
    out: dict[str, str] = {}
    if "wheels-off-ground" in modes:
        for n in STAND_PARAMS:
            out[n] = "wheels-off-ground"
    if modes & {"static", "wheels-off-ground"}:
        out["imu.gyro_bias"] = "static"
        if any(lg.has("accel_x") and np.any(lg.mode != "balancing") for lg in logs):
            out["imu.accel_bias"] = "static"
    if any(lg.has("accel_x") for lg in logs):
        out["firmware.fusion.tau"] = "any log with accel_x, accel_y"
    return out


#: Stage 2 (PWM quantisation): at most this many refits with the rounding errors held, until
#: none moves by more than :data:`_QUANT_TOL` of a duty step.
_QUANT_ITERS = 1
_QUANT_TOL = 0.01

#: Nuisances per segment: the wheel speeds at its first sample and their change over the
#: sample before (``w_0 - w_{-1}``), both / 10 rad/s.
_NUIS = 4


class _Problem:
    """The stand least-squares problem in scaled variables: globals in [0, 1] of their
    bounds, then per segment the nuisances (:data:`_NUIS`): ``w_0 / 10`` (right, left) and
    ``(w_0 - w_{-1}) / 10`` (right, left), rad/s."""

    def __init__(self, seg: Segments, known: Known, free: Sequence[str],
                 values: Mapping[str, float],
                 qerr: NDArray[np.float64] | None = None) -> None:  # fmt: skip
        self.seg, self.known, self.free = seg, known, list(free)
        self.values = dict(values)
        #: held PWM rounding errors (S, L, 2) (:func:`~mwip.identify.model.stand_rollout`)
        self.qerr = qerr
        self.lo = np.array([BOUNDS[n][0] for n in self.free])
        self.span = np.array([BOUNDS[n][1] - BOUNDS[n][0] for n in self.free])
        self.S = seg.n
        self.L = seg.enc.shape[1]

    def params(self, x: NDArray[np.float64]) -> dict[str, float]:
        p = dict(self.values)
        for i, n in enumerate(self.free):
            p[n] = float(self.lo[i] + self.span[i] * x[i])
        return p

    def params_rows(self, x: NDArray[np.float64]) -> dict[str, Any]:
        """:meth:`params` of ``x`` (g,), or one set per row of ``x`` (B, g) as (B,) arrays."""
        if np.ndim(x) == 1:
            return self.params(x)
        p: dict[str, Any] = dict(self.values)
        for i, n in enumerate(self.free):
            p[n] = self.lo[i] + self.span[i] * x[:, i]
        return p

    def split(self, x: NDArray[np.float64]) -> tuple[dict[str, float], NDArray[np.float64],
                                                     NDArray[np.float64]]:  # fmt: skip
        """``(parameters, w0 (S, 2), w_prev (S, 2))``."""
        g = len(self.free)
        nu = 10.0 * x[g:].reshape(self.S, _NUIS)
        return self.params(x), nu[:, :2], nu[:, :2] - nu[:, 2:]

    def x0(self, values: Mapping[str, float]) -> NDArray[np.float64]:
        """The start: ``values`` scaled, the segments' first guesses (:func:`_start_guess`)."""
        g = np.clip((np.array([values[n] for n in self.free]) - self.lo) / self.span, 0.0, 1.0)
        dw = self.seg.dw0 if self.seg.dw0 is not None else np.zeros_like(self.seg.w0)
        nu = np.concatenate([self.seg.w0, dw], axis=1) / 10.0
        return np.concatenate([g, nu.ravel()])

    def rollout(self, p: Mapping[str, Any], w0: NDArray[np.float64],
                w_prev: NDArray[np.float64], idx: Any = slice(None),
                qerr_out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:  # fmt: skip
        """Wheel angles (S', L, 2) of the segments ``idx`` (default all; repeats allowed)."""
        sg = self.seg
        prev2 = None if sg.prev2 is None else sg.prev2[idx]
        q = None if self.qerr is None else self.qerr[idx]
        phi, _ = stand_rollout(p, sg.cmd[idx], sg.is_duty[idx], w0, self.known,
                               w_prev=w_prev, cmd_prev2=prev2, qerr=q,
                               qerr_out=qerr_out)  # fmt: skip
        return phi

    def residual_arr(self, p: Mapping[str, Any], w0: NDArray[np.float64],
                     w_prev: NDArray[np.float64], idx: Any = slice(None)) -> NDArray:  # fmt: skip
        r = self.seg.enc[idx] - self.rollout(p, w0, w_prev, idx)
        return r - r.mean(axis=1, keepdims=True)

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        p, w0, wp = self.split(x)
        return (self.residual_arr(p, w0, wp) / _RES).ravel()

    def segment_residual(self, xg: NDArray[np.float64], z: NDArray[np.float64],
                         idx: Any = slice(None)) -> NDArray[np.float64]:  # fmt: skip
        """Residuals (S', 2 L) of the segments ``idx`` (default all) for the scaled globals
        ``xg`` (g,) or one row each (S', g) and their nuisances ``z`` (S', :data:`_NUIS`), the
        form :mod:`mwip.identify.solve` takes: any batch of (globals, segment) pairs is one
        rollout."""
        nu = 10.0 * np.asarray(z, dtype=float)
        r = self.residual_arr(self.params_rows(xg), nu[:, :2], nu[:, :2] - nu[:, 2:], idx)
        return (r / _RES).reshape(nu.shape[0], -1)

    def rounding_errors(self, xg: NDArray[np.float64],
                        z: NDArray[np.float64]) -> NDArray[np.float64]:  # fmt: skip
        """The PWM rounding errors (S, L, 2) along the quantised model's trajectories."""
        nu = 10.0 * np.asarray(z, dtype=float)
        out = np.zeros((self.S, self.L, 2))
        self.rollout(self.params(xg), nu[:, :2], nu[:, :2] - nu[:, 2:], qerr_out=out)
        return out


def _all_segments(idx: Any, S: int) -> bool:
    """``idx`` selects every segment once, in order (``slice(None)`` or ``arange(S)``)."""
    if isinstance(idx, slice):
        return idx == slice(None)
    a = np.asarray(idx)
    return bool(a.ndim == 1 and a.size == S and np.array_equal(a, np.arange(S)))


class _Progress:
    """Counts the model evaluations of a stage and says every 100 how far it has come: the
    lowest encoder residual RMS so far over all segments, in rad (the units of the final
    ``residuals.enc.rms`` of fit.json; an evaluation of some segments only is not comparable
    and is not shown; stage 2's evaluations name every segment by index)."""

    def __init__(self, stage: str, progress: Callable[[str], None] | None) -> None:
        self.stage, self.progress, self.n = stage, progress, 0
        self.best = math.inf

    def wrap(self, prob: _Problem) -> Residual:
        """``prob.segment_residual``, counted."""
        if self.progress is None:
            return prob.segment_residual

        def fun(x: NDArray, z: NDArray, idx: Any = slice(None)) -> NDArray:
            r = prob.segment_residual(x, z, idx)
            self.n += 1
            if _all_segments(idx, prob.S) and r.size:
                self.best = min(self.best, float(np.sqrt(np.mean(r**2))) * _RES)
            if self.n % 100 == 0 and self.progress is not None:
                best = "-" if not math.isfinite(self.best) else f"{self.best:.3g} rad"
                self.progress(f"fit: {self.stage}: {self.n} model evaluations; encoder "
                              f"residual RMS, best so far: {best}")  # fmt: skip
            return r

        return fun


def _descend(res: Residual, jac_res: Residual | None, x: NDArray[np.float64],
             z: NDArray[np.float64], nfev: int,
             warm: NDArray[np.float64] | None = None) -> tuple[Any, Reduced]:  # fmt: skip
    """Bounded least squares over the globals of the reduced problem (:mod:`.solve`): the
    nuisances from the first guesses ``z`` and from ``warm``."""
    from scipy.optimize import least_squares

    red = Reduced(res, np.array(z, dtype=float), jac_res, warm)
    out = least_squares(red.fun, np.clip(x, 0.0, 1.0), jac=red.jac, bounds=(0.0, 1.0),
                        method="trf", tr_solver="exact", x_scale="jac", xtol=1e-8,
                        ftol=1e-8, gtol=1e-8, max_nfev=nfev)  # fmt: skip
    return out, red


@dataclass
class _StandFit:
    """The stand fit at its optimum: parameters, scaled globals ``x``, nuisances ``z``
    (S, :data:`_NUIS`), residuals ``r`` (S, n), the smooth model's Jacobians of the globals
    ``A`` (S, n, g) and of each segment's nuisances ``Jn`` (S, n, :data:`_NUIS`)."""

    p: dict[str, float]
    x: NDArray[np.float64]
    z: NDArray[np.float64]
    r: NDArray[np.float64]
    A: NDArray[np.float64]
    Jn: NDArray[np.float64]
    prob: _Problem


def _fit_stand(
    seg: Segments, known: Known, free: Sequence[str], values: Mapping[str, float], search: bool,
    progress: Callable[[str], None] | None = None,
) -> _StandFit:
    """Coarse search, then variable projection (:mod:`mwip.identify.solve`): stage 1 the
    smooth model, stage 2 (a quantising driver) the twin's quantised duty with the smooth
    model's Jacobian."""
    from dataclasses import replace

    smooth = _Problem(seg, replace(known, pwm_levels=0), free, values)
    prob = smooth
    g = len(free)
    x0 = smooth.x0(values)
    z0 = x0[g:].reshape(seg.n, _NUIS)
    xg = x0[:g]
    warm: NDArray[np.float64] | None = None
    n_stages = 2 if known.pwm_levels > 0 else 1
    res1 = _Progress(f"stage 1 of {n_stages}", progress).wrap(smooth)
    if search and "drive.gear_ratio" in free:
        i = free.index("drive.gear_ratio")
        j = free.index("firmware.emf_compensation") if "firmware.emf_compensation" in free else None
        # the current limit is a kink: below the currents the log reaches it binds, above
        # them its Jacobian column is zero; a descent started where it binds can stall at a
        # local minimum (it cannot leave upwards), one started where it does not bind cannot
        # move it at all. So the best grid point of each start (its centre, its upper bound)
        # gets a short first descent, and the lower cost goes on.
        m = free.index("drive.current_limit") if "drive.current_limit" in free else None
        best: dict[Any, tuple[float, NDArray[np.float64]]] = {}
        for N in (4.5, 6.0, 8.0, 11.0, 15.0, 20.0, 27.0, 36.0, 45.0, 50.0):
            for c in ((0.15, 0.5, 0.85) if j is not None else (0.0,)):
                for lim in ((float(x0[m]), 1.0) if m is not None else (None,)):
                    x = xg.copy()
                    x[i] = (N - smooth.lo[i]) / smooth.span[i]
                    if j is not None:
                        x[j] = c
                    if m is not None and lim is not None:
                        x[m] = lim
                    cost = float(np.sum(res1(x, z0) ** 2))
                    if cost < best.get(lim, (np.inf, x))[0]:
                        best[lim] = (cost, x)
        starts = [x for _, x in best.values()]
        if len(starts) > 1:
            tries = [_descend(res1, None, x, z0, 8) for x in starts]
            out, red = min(tries, key=lambda t: float(t[0].cost))
            xg, warm = out.x, red.warm
        else:
            xg = starts[0]
    out, red = _descend(res1, None, xg, z0, 60, warm)
    xg, warm = out.x, red.warm
    z, r, Jn = red.state(xg)
    if n_stages == 2:
        # stage 2: the quantised model, as the fixed point of the smooth model with its
        # rounding errors held at those of its own trajectory (docs/twin_fit.md)
        quant = _Problem(seg, known, free, values)
        count = _Progress("stage 2 of 2", progress)
        q = quant.rounding_errors(xg, z)
        for _ in range(_QUANT_ITERS):
            prob = _Problem(seg, smooth.known, free, values, qerr=q)
            out, red = _descend(count.wrap(prob), None, xg, z0, 30, z)
            xg = out.x
            z, r, Jn = red.state(xg)
            q_new = quant.rounding_errors(xg, z)
            moved = float(np.max(np.abs(q_new - q))) * known.pwm_levels
            q = q_new
            if moved < _QUANT_TOL:
                break
    # the statistics' Jacobians: the smooth model (with the held rounding errors of stage 2)
    # at the optimum
    A = global_jacobian(prob.segment_residual, xg, z)
    return _StandFit(smooth.params(xg), xg, z, r, A, Jn, prob)


def _rest_rows(logs: Sequence[Log]) -> list[tuple[Log, NDArray[np.bool_]]]:
    return [(lg, np.isin(lg.mode, ("static", "wheels-off-ground"))) for lg in logs]


def _gyro_bias(logs: Sequence[Log], walk: float) -> tuple[float, float, NDArray]:
    vals, var_walk, n_all = [], 0.0, 0
    for lg, on in _rest_rows(logs):
        if not on.any():
            continue
        w = lg.columns["theta_rate"][on]
        t = np.sort(lg.columns["t"][on] - lg.columns["t"][0])
        k = np.arange(t.size)
        var_walk += float(np.sum(t * (2 * (t.size - 1 - k) + 1)))
        vals.append(w)
        n_all += w.size
    x = np.concatenate(vals)
    est = float(x.mean())
    se = float(np.sqrt(x.var(ddof=1) / x.size + walk**2 * var_walk / n_all**2))
    return est, se, x - est


def _accel_bias(logs: Sequence[Log]) -> tuple[float, float, NDArray]:
    x = np.concatenate([lg.columns["accel_x"][on] for lg, on in _rest_rows(logs)
                        if lg.has("accel_x") and on.any()])  # fmt: skip
    est = float(x.mean())
    return est, float(x.std(ddof=1) / np.sqrt(x.size)), x - est


def _fusion_tau(logs: Sequence[Log]) -> tuple[float, float, NDArray]:
    xs, ys = [], []
    for lg in logs:
        if not lg.has("accel_x"):
            continue
        c = lg.columns
        tilt = np.arctan2(c["accel_x"], c["accel_y"])
        th = c["theta"]
        xs.append(th[:-1] + c["theta_rate"][1:] * lg.Ts - tilt[1:])
        ys.append(th[1:] - tilt[1:])
    x, y = np.concatenate(xs), np.concatenate(ys)
    a = float(x @ y / (x @ x))
    r = y - a * x
    s2 = float(r @ r) / max(x.size - 1, 1)
    se_a = max(float(np.sqrt(s2 / float(x @ x))), 1e-9 * (1.0 - a))  # float precision
    Ts = logs[0].Ts
    a = min(a, 1.0 - 1e-12)
    tau = a * Ts / (1.0 - a)
    return tau, float(se_a * Ts / (1.0 - a) ** 2), r


def fit(
    logs: Sequence[Log],
    twin: object | None = None,
    *,
    free: Iterable[str] | None = None,
    fixed: Mapping[str, float] | None = None,
    segment: int = 40,
    search: bool = True,
    progress: Callable[[str], None] | None = None,
    body: object | None = None,
) -> FitResult:
    """Fit the twin's parameters (:data:`mwip.identify.bounds.BOUNDS`) to ``logs``
    (``progress`` receives the findings of :func:`mwip.identify.identifiability.check`, one
    line each, then a line every 100 model evaluations of each stage) on the robot's
    ``body`` (its :class:`mwip.params.Params`, held fixed; default Table 6.1).

    ``free``: the names to fit (default: every name an experiment present informs);
    ``fixed``: name -> value held (and not fitted). A free name no segment informs keeps its
    prior centre and is reported ``not informed``; a drive parameter the logs carry no
    information on (the identifiability check) is refused (``ValueError``) when named in
    ``free``, else left out of the fit and reported.
    """
    from mwip.hardware.twin import Twin

    if not logs:
        raise ValueError("no logs given")
    tw = Twin() if twin is None else twin
    Ts = logs[0].Ts
    for lg in logs[1:]:
        if abs(lg.Ts - Ts) > 0.01 * Ts:
            raise LogError(f"log {lg.path!r}, column 't': sample period {lg.Ts:g} s differs "
                           f"from the first log's {Ts:g} s")  # fmt: skip
    if not (5 <= segment <= 400):
        raise ValueError(f"'segment' must be in [5, 400] samples, got {segment!r}")
    tm = torque_to_duty(logs)  # before any fitting: duties that follow no map are refused
    fixed = dict(fixed or {})
    for n, v in fixed.items():
        if n not in BOUNDS:
            raise ValueError(f"--fix: unknown parameter {n!r}; allowed: {', '.join(NAMES)}")
        lo, hi = BOUNDS[n]
        if not (np.isfinite(v) and lo <= v <= hi):
            raise ValueError(f"--fix {n}: {v!r} is outside its bounds [{lo:g}, {hi:g}]")
    informed = _informed(logs)
    if free is None:
        want = [n for n in NAMES if n in informed and n not in fixed]
    else:
        want = list(dict.fromkeys(free))
        for n in want:
            if n not in BOUNDS:
                raise ValueError(f"--free: unknown parameter {n!r}; allowed: {', '.join(NAMES)}")
            if n in fixed:
                raise ValueError(f"parameter {n!r} is both --free and --fix")
            if n not in informed:  # issue 37: a parameter nothing informs is not fitted
                raise ValueError(f"--free {n}: no log informs it; it needs {NEEDS[n]}. Give "
                                 f"such a log, or hold it with --fix {n}=VALUE")  # fmt: skip
    values = {n: fixed.get(n, centre(n)) for n in NAMES}
    status = {n: ("fixed" if n in fixed else "prior") for n in NAMES}
    stderr: dict[str, float | None] = {n: None for n in NAMES}
    for n in NAMES:
        if n not in informed and n not in fixed:
            status[n] = "not informed"
    residuals: dict[str, dict[str, float]] = {}
    trace: dict[str, dict[str, NDArray[np.float64]]] = {}
    known = Known.from_twin(tw, Ts, body)
    seg = stand_segments(logs, segment)
    corr: dict[str, Any] = {"names": [], "matrix": []}
    flags: list[str] = []
    cond: float | None = None
    structure: StructureCheck | None = None
    stand_free = [n for n in STAND_PARAMS if n in want and n in informed]
    ident = None
    if seg is not None and stand_free:  # issue 37: what the logs inform, before the fit
        from mwip.identify.identifiability import check

        ident = check(logs, stand_free, values, known, segment)
        for n in ident.not_informed:
            if free is not None:
                raise ValueError(f"--free {n}: the logs carry no information on it; "
                                 f"{ident.advice(n)}. Or hold it with --fix {n}=VALUE")
            stand_free.remove(n)
            status[n] = "not informed"
        found = [f"identifiability: {line}" for line in ident.lines()]
        flags += found
        for line in found if progress is not None else []:
            progress(line)  # type: ignore[misc]
    if seg is not None and stand_free:
        sf = _fit_stand(seg, known, stand_free, values, search, progress)
        p, r = sf.p, sf.r
        norms = np.sqrt(np.einsum("sni,sni->i", sf.A, sf.A))
        ok = norms > 1e-6 * max(float(norms.max()), 1e-300)
        u, bread, _ = cluster_scores(sf.A[:, :, ok], sf.Jn, r, offsets=2)
        cov_all = sandwich(u, bread)
        names_ok = [n for n, o in zip(stand_free, ok, strict=True) if o]
        ng = len(names_ok)
        cov = cov_all[:ng, :ng]
        span = np.array([BOUNDS[n][1] - BOUNDS[n][0] for n in names_ok])
        se = np.sqrt(np.maximum(np.diag(cov), 0.0)) * span
        for n, o in zip(stand_free, ok, strict=True):
            if o:
                values[n] = p[n]
                status[n] = "fitted"
            else:
                status[n] = "not informed"
        # a parameter whose information comes from one segment alone has no cluster-robust
        # error (deleting that segment leaves it unidentified): V's diagonal vanishes there
        scale_b = np.sqrt(np.maximum(np.diag(bread)[:ng], 0.0)) * span * float(np.std(r))
        for n, s, sb in zip(names_ok, se, scale_b, strict=True):
            if s > 1e-6 * sb:
                stderr[n] = float(s)
            else:
                status[n] = "not identified"
                flags.append(f"{n}: informed by a single segment only; no standard error "
                             f"(estimate {p[n]:g} kept)")  # fmt: skip
        d = np.sqrt(np.maximum(np.diag(cov), 1e-300))
        R = cov / np.outer(d, d)
        corr = {"names": names_ok, "matrix": np.round(R, 4).tolist()}
        for i in range(ng):
            for j in range(i + 1, ng):
                if abs(R[i, j]) > 0.9:
                    flags.append(f"{names_ok[i]} and {names_ok[j]} are not separately "
                                 f"identified (correlation {R[i, j]:+.3f})")  # fmt: skip
        try:
            cond = float(np.linalg.cond(np.linalg.inv(bread[:ng, :ng])))
        except np.linalg.LinAlgError:
            cond = float("inf")
        res_arr = r.reshape(seg.n, -1, 2) * _RES
        residuals["enc"] = {"rms": float(np.sqrt(np.mean(res_arr**2))),
                            "whiteness": whiteness(res_arr.transpose(0, 2, 1).ravel()),
                            "n": float(res_arr.size)}  # fmt: skip
        w0 = 10.0 * sf.z[:, :2]
        wp = w0 - 10.0 * sf.z[:, 2:]
        phi = _Problem(seg, known, [], values).rollout(values, w0, wp)
        trace["wheels-off-ground"] = {"t": seg.t, "enc": seg.enc,
                                      "pred": phi + (seg.enc - phi).mean(1, keepdims=True)}
        floor = residual_floor(logs, values, tw, body, known, segment)
        if floor is not None:
            structure = check_structure(residuals["enc"]["rms"], floor,
                                        {n: s for n in names_ok if (s := stderr[n]) is not None})
            flags.append(structure.summary())
    walk = float(getattr(getattr(tw, "imu", None), "gyro_bias_walk", 0.0))
    for n, fn in (("imu.gyro_bias", lambda: _gyro_bias(logs, walk)),
                  ("imu.accel_bias", lambda: _accel_bias(logs)),
                  ("firmware.fusion.tau", lambda: _fusion_tau(logs))):  # fmt: skip
        if n in want and n in informed:
            est, se_n, rr = fn()
            lo, hi = BOUNDS[n]
            values[n] = float(np.clip(est, lo, hi))
            stderr[n] = se_n
            status[n] = "fitted"
            sig = {"imu.gyro_bias": "theta_rate", "imu.accel_bias": "accel_x",
                   "firmware.fusion.tau": "theta"}[n]  # fmt: skip
            residuals[sig] = {"rms": float(np.sqrt(np.mean(rr**2))), "whiteness": whiteness(rr),
                              "n": float(rr.size)}  # fmt: skip
    for n in NAMES:
        if status[n] == "not informed":
            flags.append(f"{n}: no segment informs it; left at its prior value {values[n]:g}")
        elif status[n] in ("fitted", "not identified") and (side := at_bound(n, values[n])):
            lo, hi = BOUNDS[n]
            flags.append(f"{n}: the estimate {values[n]:g} is at the {side} bound of its "
                         f"prior range [{lo:g}, {hi:g}]: the logs ask for a value outside it "
                         "(a structure the model lacks, a confounded partner, or a wrong "
                         "fixed value?); its standard error does not hold there")  # fmt: skip
    experiments = {m: int(sum(int(np.sum(lg.mode == m)) for lg in logs))
                   for m in ("balancing", "wheels-off-ground", "static")}  # fmt: skip
    file_values: dict[str, float] = tw.values()  # type: ignore[attr-defined]
    own = {n: float(v) for n, v in file_values.items() if n in values}  # the file's values,
    own.update({n: values[n] for n in NAMES if status[n] in ("fitted", "fixed",
                                                             "not identified")})  # fmt: skip
    trace.update(_traces(logs, own, tw, body))  # (for the rest: FitResult.robot_values)
    tmap = None if tm is None else _torque_gain(tm, values, stderr, status, known, flags)
    bres = None
    if experiments["balancing"]:  # the body stage, on the drive values just fitted
        from mwip.identify.body import body_stage
        from mwip.params import REAL

        try:
            bres = body_stage(logs, tw, REAL if body is None else body, own)
            flags.extend(bres.flags)
        except ValueError as e:
            flags.append(f"body: {e}")
    return FitResult(
        estimates=values, stderr=stderr, status=status,
        free=[n for n in want if status[n] == "fitted"], fixed=fixed, correlation=corr,
        flags=flags, condition=cond, residuals=residuals, Ts=Ts, segment=segment,
        experiments=experiments, trace=trace, known=known, torque_map=tmap,
        structure=structure, identifiability=ident, body=bres,
    )  # fmt: skip


def _cat(parts: Sequence[Mapping[str, NDArray[np.float64]]]) -> dict[str, NDArray]:
    """The traces of several logs, joined along their first axis (the keys all share)."""
    parts = [p for p in parts if p]
    if not parts:
        return {}
    keys = [k for k in parts[0] if all(k in p for p in parts)]
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


def _rest_trace(log: Log, values: Mapping[str, float]) -> dict[str, NDArray[np.float64]]:
    """The rows with the body held still: the gyro against ``imu.gyro_bias`` and the
    accelerometer's ``accel_x`` against ``imu.accel_bias``."""
    on = np.isin(log.mode, ("static", "wheels-off-ground"))
    if not on.any():
        return {}
    c = log.columns
    out = {"t": c["t"][on], "theta_rate": c["theta_rate"][on],
           "theta_rate_pred": np.full(int(on.sum()), float(values["imu.gyro_bias"]))}
    if log.has("accel_x"):
        out["accel_x"] = c["accel_x"][on]
        out["accel_x_pred"] = np.full(int(on.sum()), float(values["imu.accel_bias"]))
    return out


def _fusion_trace(log: Log, tau: float) -> dict[str, NDArray[np.float64]]:
    """The logged pitch against the complementary filter one sample ahead,
    ``a (theta_{k-1} + omega_k Ts) + (1 - a) atan2(a_x, a_y)``, ``a = tau / (tau + Ts)``."""
    if not log.has("accel_x") or log.n < 2:
        return {}
    c = log.columns
    a = tau / (tau + log.Ts)
    tilt = np.arctan2(c["accel_x"], c["accel_y"])
    th = c["theta"]
    pred = a * (th[:-1] + c["theta_rate"][1:] * log.Ts) + (1.0 - a) * tilt[1:]
    return {"t": c["t"][1:], "theta": th[1:], "theta_pred": pred}


def _traces(logs: Sequence[Log], values: Mapping[str, float], twin: Any,
            body: Any) -> dict[str, dict[str, NDArray[np.float64]]]:  # fmt: skip
    """:attr:`FitResult.trace` of the modes other than wheels-off-ground (that one is the
    stand fit's own)."""
    from mwip.identify.balance import balance_prediction

    out = {"static": _cat([_rest_trace(lg, values) for lg in logs]),
           "balancing": _cat([balance_prediction(lg, values, twin, body=body)[1]
                              for lg in logs if np.any(lg.mode == "balancing")]),
           "fusion": _cat([_fusion_trace(lg, float(values["firmware.fusion.tau"]))
                           for lg in logs])}  # fmt: skip
    return {k: v for k, v in out.items() if v}


def at_bound(name: str, value: float) -> str | None:
    """``"lower"`` / ``"upper"`` where ``value`` sits within 1e-6 of the span of a bound of
    ``name``'s prior range (:data:`mwip.identify.bounds.BOUNDS`), else ``None``."""
    lo, hi = BOUNDS[name]
    tol = 1e-6 * (hi - lo)
    return "lower" if value <= lo + tol else "upper" if value >= hi - tol else None


def summary_lines(result: FitResult) -> list[str]:
    """The estimates as a person reads them: one line per parameter (estimate, 1 standard
    error, status, prior range; a value at a bound of its range says so), the torque gain
    where both pairs were logged, and the validation log's prediction errors against the
    prior centre's. Where the structure test rejects the twin's structure
    (:mod:`mwip.identify.structure`), the widened standard errors are shown, and the primary
    ones beside them."""
    sc = result.structure
    wide = sc.widened if sc is not None and sc.rejected else {}
    head = "+- 1 s.e. (widened; primary)" if wide else "+- 1 s.e."
    rows = [("parameter", "estimate", head, "status", "prior range")]
    for n in result.estimates:
        v, se, st = result.estimates[n], result.stderr.get(n), result.status[n]
        lo, hi = BOUNDS[n]
        side = at_bound(n, v) if st in ("fitted", "not identified") else None
        err = "-" if se is None else f"{se:.2g}"
        if n in wide and se is not None:
            err = f"{wide[n]:.2g}; {se:.2g}"
        rows.append((n, f"{v:.5g}", err,
                     st + (f" (at its {side} bound)" if side else ""), f"[{lo:g}, {hi:g}]"))
    tm = result.torque_map
    if tm is not None:
        rows.append(("firmware.torque_gain", f"{tm['torque_gain']:.5g}", f"{tm['stderr']:.2g}",
                     "fitted (torque-to-duty map)", "-"))  # fmt: skip
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    val = result.validation
    if val:
        fit_e, pri_e = val.get("fitted") or {}, val.get("prior_centre") or {}
        parts = []
        for key, what, unit in (("enc_rms", "encoders", "rad"),
                                ("balance_enc_rms", "encoders (balancing, 50 ms ahead)", "rad"),
                                ("balance_gyro_rms", "gyro (balancing)", "rad/s"),
                                ("theta_rate_rms", "gyro", "rad/s")):  # fmt: skip
            if fit_e.get(key) is not None and pri_e.get(key) is not None:
                parts.append(f"{what} {fit_e[key]:.3g} {unit} (prior centre {pri_e[key]:.3g})")
        if parts:
            out.append(f"validation on {val.get('log')}: RMS prediction error: "
                       + "; ".join(parts))  # fmt: skip
    return out


def _torque_gain(tm: TorqueMap, values: Mapping[str, float],
                 stderr: Mapping[str, float | None], status: Mapping[str, str], known: Known,
                 flags: list[str]) -> dict[str, float]:  # fmt: skip
    """The firmware's torque gain from the torque-to-duty map ``tm`` of the logs that hold
    both pairs (:mod:`mwip.identify.torque_map`), with the gear ratio of this fit and the
    robot's motor data (the stand model's ``k_e`` is its ``k_t``, SI units)."""
    n = "drive.gear_ratio"
    k, se = tm.torque_gain(values[n], stderr[n], known.eta, known.ke, known.Vs, known.R)
    if status[n] not in ("fitted", "fixed"):
        flags.append(f"firmware.torque_gain: the gear ratio is {status[n]}, so the torque gain "
                     f"{k:.4g} rests on its value {values[n]:g}")  # fmt: skip
    return {"torque_gain": k, "stderr": se, **tm.to_json()}


def _start_states(smooth: _Problem, seg: Segments, Ts: float) -> NDArray[np.float64]:
    """Each segment's start state (nuisances) for parameters held: the smooth model's own
    problem solved to convergence from the first guesses (the encoders' slope and curvature
    over the first 6 samples); a segment left with more than 4 times the median segment's
    cost (as :class:`mwip.identify.solve.Reduced` tests) is solved again from seven more
    guesses (the slope and curvature over the first 3 samples; ``w_0 - w_{-1}`` that
    curvature, 0, and 30 rad/s either way of it), the lowest cost kept. One guess is not
    enough: on a fast chirp the first samples' parabola misses the start speed by half, and a
    segment's problem has spurious minima: from one guess, a log's own fitted parameters left a
    residual 70 times the fit's on the log the fit had seen."""
    from mwip.identify.solve import _Subset

    none = np.zeros(0)
    starts = []
    for q in (6, 3):
        guess = [_start_guess(e, Ts, q) for e in seg.enc]
        w0 = np.array([g[0] for g in guess])
        dw = np.array([g[1] for g in guess])
        for curv in (dw, np.zeros_like(dw), dw + 30.0 * np.sign(w0), dw - 30.0 * np.sign(w0)):
            starts.append(np.concatenate([w0, curv], axis=1) / 10.0)
    best_z, r, _ = nuisance_solve(smooth.segment_residual, none, starts[0], max_iter=200)
    best_c = np.sum(r * r, axis=1)
    bad = np.flatnonzero(best_c > 4.0 * np.median(best_c))
    if bad.size:
        sub = _Subset(smooth.segment_residual, bad)
        for z0 in starts[1:]:
            z, r, _ = nuisance_solve(sub, none, z0[bad], max_iter=200)
            c = np.sum(r * r, axis=1)
            better = c < best_c[bad]
            best_z[bad[better]], best_c[bad[better]] = z[better], c[better]
    return np.asarray(best_z, dtype=float)


def predict_error(log: Log, values: Mapping[str, float], known: Known,
                  segment: int = 40, twin: object | None = None,
                  body: object | None = None) -> dict[str, float]:  # fmt: skip
    """Prediction error of ``values`` on a held-out log: the wheels-off-ground encoder RMS
    (segment start states refitted with the parameters held), the rest rows' gyro RMS about
    ``imu.gyro_bias`` and, for balancing rows (whatever controller drove them), the encoder
    and gyro RMS of 50 ms predictions from fitted start states
    (:func:`mwip.identify.balance.balance_error` on the base ``twin``, default the default
    twin, with ``values``; ``body`` the robot's, default Table 6.1, as ``known``'s)."""
    return predict(log, values, known, segment, twin, body)[0]


def predict(log: Log, values: Mapping[str, float], known: Known, segment: int = 40,
            twin: object | None = None, body: object | None = None,
            ) -> tuple[dict[str, float], dict[str, dict[str, NDArray[np.float64]]]]:  # fmt: skip
    """:func:`predict_error` and the traces behind it: ``(errors, trace)``, ``trace`` per mode
    present as :attr:`FitResult.trace` (``"wheels-off-ground"``: ``enc - pred`` are the
    residuals of ``enc_rms``; ``"static"``; ``"balancing"``), without ``"fusion"``."""
    from dataclasses import replace

    from mwip.identify.balance import balance_prediction

    out: dict[str, float] = {}
    trace: dict[str, dict[str, NDArray[np.float64]]] = {}
    seg = stand_segments([log], segment)
    if seg is not None:
        prob = _Problem(seg, known, [], values)
        smooth = _Problem(seg, replace(known, pwm_levels=0), [], values)
        none = np.zeros(0)
        z = _start_states(smooth, seg, log.Ts)
        r = smooth.segment_residual(none, z)
        if known.pwm_levels:
            _, r, _ = nuisance_solve(prob.segment_residual, none, z,
                                     smooth.segment_residual, max_iter=50)  # fmt: skip
        out["enc_rms"] = float(np.sqrt(np.mean(r**2))) * _RES
        trace["wheels-off-ground"] = {"t": seg.t, "enc": seg.enc,
                                      "pred": seg.enc - r.reshape(seg.enc.shape) * _RES}
    on = np.isin(log.mode, ("static", "wheels-off-ground"))
    if on.any():
        g = log.columns["theta_rate"][on] - values["imu.gyro_bias"]
        out["theta_rate_rms"] = float(np.sqrt(np.mean(g**2)))
        trace["static"] = _rest_trace(log, values)
    if log.has("accel_x") and on.any():
        a = log.columns["accel_x"][on] - values["imu.accel_bias"]
        out["accel_x_rms"] = float(np.sqrt(np.mean(a**2)))
    errors, btr = balance_prediction(log, values, twin, body=body)
    out.update(errors)
    if btr:
        trace["balancing"] = btr
    return out, trace
