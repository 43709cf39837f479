"""The body from balancing logs: a linear least-squares stage for the lumped coefficients of
(2.32), and the physical body fields they give (issue 37, item 2).

Model. The planar part of (2.32)/(2.33) (the forward/pitch plane: rows ``psi`` and ``theta``;
yaw is ignored: the ``alpha'^2`` terms are dropped, so a log that turns a lot is flagged, see
:data:`YAW_RATE_FLAG`) with ``phi = psi - theta`` the mean wheel angle relative to the body
(the encoders' mean), ``u_A = u_r + u_l`` the delivered wheel torques:

- row 1: ``m11 psi'' + m12 (cos th th'' - sin th th'^2) + 2 Dw psi' + 2 Db phi' = u_A``;
- row 2: ``m12 cos th psi'' + m22 th'' - Gb sin th - 2 Db phi' = -u_A``

(the damping ``O = D q'`` of (2.33) with ``2 (Dw + Db) psi' - 2 Db th' = 2 Dw psi' + 2 Db
phi'``). Both rows are linear in ``c = (m11, m12, m22, Gb, Db, Dw)``.

Weak form (no second derivative of any signal). Each row is multiplied by a smooth test
function ``w`` of compact support (a window of :data:`WINDOW` s, ``w = (1 - s^2)^4``, ``s``
in [-1, 1]: ``w`` and ``w'`` vanish at both ends) and integrated; by parts,
``int w psi'' = int w'' psi``, ``int w (cos th th'' - sin th th'^2) = int w (sin th)'' =
int w'' sin th``, ``int w phi' = -int w' phi``, so row 1 is *exactly*

``m11 int w'' psi + m12 int w'' sin th - 2 Dw int w' psi - 2 Db int w' phi = int w u_A``

and row 2, with ``cos th psi'' = (cos th psi')' + sin th th' psi'``,

``m12 [int w'' psi + int w' (1 - cos th) psi' + int w sin th th' psi'] + m22 int w'' th
- Gb int w sin th + 2 Db int w' phi = -int w u_A``.

The test function is the smoothing differentiator, applied identically to both sides of each
equation (the equation holds pointwise, so it holds against every ``w``); it needs the signals
themselves, not their derivatives, so encoder quantisation and gyro noise are averaged over
the window instead of amplified, and a constant (a gyro bias in ``th'``, an encoder offset)
vanishes against ``w'`` and ``w''``. Only the two small terms of second order in the pitch
use ``psi'`` (a Savitzky-Golay derivative of the encoders, :func:`scipy.signal.savgol_filter`,
plus the gyro). The windows hop by :data:`HOP` s; the torque, held over each sample, is
weighted by ``w`` at the sample's midpoint.

Signals and their biases (measured on the twin: a 5 s log under ``lqr``):

- the pitch ``th`` is the gyro less its bias (``imu.gyro_bias``: the fit's, else the twin's),
  integrated (trapezoid) over each balancing run, started at the median of the board's fused
  pitch less that integral (the fused pitch itself lags the motion and starts from its own
  transient); ``th'`` is the gyro less its bias. The pitch's error is its start's offset
  and a drift (the bias it is corrected with is off by the IMU's bias random walk):
  ``delta_0 + delta_1 t``; it enters row 2 as ``-Gb cos th (delta_0 + delta_1 t)``, fitted as
  two nuisances per run (``Gb`` comes from the pitch's motion within each run, not from its
  mean). A constant torque per run in row 1 is a nuisance too;
- the delivered torque is not logged: it is the twin's drive chain
  (:meth:`mwip.hardware.twin.Twin.actuator`: delay, torque-to-duty map, back-EMF
  compensation, PWM, dead-band, current limit, sag, Coulomb friction, backlash) driven by
  the logged command and the measured state, with the drive values given (the stand fit's,
  else the robot file's). The lumped coefficients are then those of the plant the twin
  integrates for the body (:meth:`~mwip.hardware.twin.Twin.plant`: with the reflected rotor
  inertia in ``m11, m12, m22`` and the back-EMF and gearbox viscous damping in ``Db``), and
  the physical body is mapped through that same plant (:func:`body_map`). An error of the
  drive model (friction at a reversal) is an error in ``u_A``: it goes into the residuals and
  the intervals, not into a regressor.

Statistics. Ordinary least squares on the stacked rows (columns scaled to unit norm), the
covariance cluster-robust by blocks of :data:`BLOCK` s of the log (the windows overlap and
the residuals are correlated in time; blocks are nearly independent): the delete-one-block
jackknife (CR3, as :func:`mwip.identify.fit.cluster_covariance`), 95 % intervals with the
Student t of ``blocks - 1`` degrees of freedom. Identifiability: the singular values of the
scaled regressors (a direction with ``sigma / sigma_max`` below :data:`RANK_TOL` is a
combination the logs do not inform) and each coefficient's relative standard error (above
:data:`RSE_MAX`, or an interval that holds 0: not identified).

Excitation and accuracy (measured on the twin). Under its controller alone a balancing
robot's command follows its measured state, the regressors move together and the sensors'
noise enters them as errors in variables: from a 0.25 rad lean under ``lqr`` (5 s), ``m12``
and ``m22`` came back 0.7-0.8x with relative standard errors above :data:`RSE_MAX` (reported
not identified), and a 0.05 rad lean leaves ``m12, m22, Dw`` unidentified. A known signal
added to the command (``mwip twin log --dither``, :mod:`mwip.identify.dither`; on a robot,
the firmware adds it and logs the sum) identifies all six: on development seeds 1-4 (10 s,
dither 0.03 and 0.1 N m) within 0.5 % (m11), 1.5 % (m12), 1.7 % (m22), 2 % (Gb), 3.3 % (Db)
and 16 % (Dw). The intervals are sampling intervals: the method's bias beyond them is
:data:`BIAS`, which the comparison with the robot file allows for. The body fields ``l``
and ``Iyy`` follow with the file's mass held (:func:`physical`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.logs import Log, runs

__all__ = ["LUMPED", "BodyResult", "body_stage", "delivered_torque", "regression"]

#: The lumped coefficients of (2.32) the planar rows are linear in.
LUMPED: tuple[str, ...] = ("m11", "m12", "m22", "Gb", "Db", "Dw")
#: Test-function support (s), hop between windows (s), blocks of the cluster-robust
#: covariance (s).
WINDOW = 0.4
HOP = 0.05
BLOCK = 0.5
#: Singular value ratio below which a direction is not identified; relative standard error
#: above which a coefficient is not identified.
RANK_TOL = 1e-3
RSE_MAX = 0.25
#: The method's own bias, beyond its sampling intervals, measured on synthetic truth
#: (development seeds 1-4 of ``lqr`` with a dither of 0.03 and 0.1 N m, 10 s, the book's body
#: and one with ``l`` +15 %, ``mb`` +10 %; the errors in variables of the gyro and encoders
#: and the drive model's torque): at most 0.5 % (m11), 1.5 % (m12), 1.7 % (m22), 2.0 % (Gb),
#: while the 95 % intervals are 0.2-1 % wide. A robot file's coefficient is said to disagree
#: with the logs only outside the interval widened by :data:`BIAS` of the estimate. The
#: damping (Db, Dw: errors up to 3 % and 16 %, the drive model's friction) is not compared.
BIAS = 0.03
#: A body field derived from the coefficients replaces the robot file's in the fitted
#: robot.toml when its 95 % sampling interval is within this share of its value.
WRITE_RSE = 0.05
COMPARED: tuple[str, ...] = ("m11", "m12", "m22", "Gb")
#: Yaw-rate RMS (rad/s) above which the dropped yaw terms are flagged.
YAW_RATE_FLAG = 0.5
_P = 4  # w = (1 - s^2)^_P


@dataclass
class BodyResult:
    """The body stage's result (``to_json`` for fit.json's ``"body"``)."""

    estimate: dict[str, float]
    stderr: dict[str, float]
    interval: dict[str, tuple[float, float]]
    identifiable: dict[str, bool]
    file: dict[str, float]
    unidentified: list[dict[str, float]]
    condition: float
    windows: int
    blocks: int
    residual_rms: float
    flags: list[str] = field(default_factory=list)
    #: the body fields the coefficients give with the file's mass held
    #: (:func:`physical`): name -> (value, standard error, the file's value)
    fields: dict[str, tuple[float, float, float]] = field(default_factory=dict)

    def written(self) -> dict[str, float]:
        """The fields precise enough to replace the file's (:data:`WRITE_RSE`)."""
        return {n: v for n, (v, se, _) in self.fields.items()
                if v > 0 and 1.96 * se <= WRITE_RSE * v}  # fmt: skip

    def file_inside(self, n: str) -> bool:
        """The robot file's ``n`` within its interval widened by :data:`BIAS` of the
        estimate."""
        lo, hi = self.interval[n]
        pad = BIAS * abs(self.estimate[n])
        return bool(lo - pad <= self.file[n] <= hi + pad)

    def file_outside(self) -> list[str]:
        """The compared coefficients (:data:`COMPARED`) the robot file's body puts outside
        their intervals widened by the method's measured bias (:data:`BIAS`)."""
        return [n for n in COMPARED if self.identifiable[n] and not self.file_inside(n)]

    def summary(self) -> str:
        """One line: the identified coefficients with their 95 % intervals, the others named."""
        ok = [f"{n} {self.estimate[n]:.4g} [{self.interval[n][0]:.4g}, {self.interval[n][1]:.4g}]"
              for n in LUMPED if self.identifiable[n]]  # fmt: skip
        no = [n for n in LUMPED if not self.identifiable[n]]
        return (f"body (2.32) from {self.windows} balancing windows: " + ("; ".join(ok) or "-")
                + (f"; not identified: {', '.join(no)}" if no else "")
                + (f"; robot file outside: {', '.join(self.file_outside())}"
                   if self.file_outside() else ""))  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        def num(x: Any) -> Any:
            return float(x) if x is not None and np.isfinite(x) else None

        return {
            "method": "weak-form linear least squares of the planar (2.32), "
                      "cluster-robust by blocks (docs/twin_fit.md)",
            "bias_allowance": BIAS, "compared": list(COMPARED),
            "lumped": {n: {"estimate": num(self.estimate[n]), "stderr": num(self.stderr[n]),
                           "interval_95": [num(v) for v in self.interval[n]],
                           "identifiable": bool(self.identifiable[n]),
                           "file": num(self.file[n]),
                           "file_inside": (self.file_inside(n) if n in COMPARED
                                           else None)}
                       for n in LUMPED},
            "unidentified_combinations": self.unidentified,
            "condition_number": num(self.condition),
            "windows": self.windows, "blocks": self.blocks,
            "residual_rms": num(self.residual_rms),
            "flags": list(self.flags),
            "fields": {n: {"estimate": num(v), "stderr": num(se), "file": num(f),
                           "written": n in self.written()}
                       for n, (v, se, f) in self.fields.items()},
            "write_rse": WRITE_RSE,
        }  # fmt: skip


def _drive_twin(twin: Any, values: Mapping[str, float] | None) -> Any:
    from mwip.identify.model import STAND_PARAMS

    if not values:
        return twin
    return twin.with_values({n: float(v) for n, v in values.items() if n in STAND_PARAMS})


def delivered_torque(cmd: NDArray[np.float64], state: NDArray[np.float64], is_duty: bool,
                     twin: Any, plant: Any, chunk: int = 400,
                     warm: int = 40) -> NDArray[np.float64]:  # fmt: skip
    """Wheel torques (n, 2) the twin's drive chain delivers for the logged command ``cmd``
    (n, 2) at the measured states ``state`` (n, 8), each held over its sample. The log is cut
    into chunks run as one batch (each starts ``warm`` samples early, from rest: the delay,
    the current and the backlash forget their start within a few samples)."""
    n = cmd.shape[0]
    if is_duty:  # a duty as the torque the firmware was asked for (balance.rollout)
        m, d = twin.motor, twin.drive
        cmd = cmd * d.supply_voltage * d.gear_ratio * d.gear_efficiency * m.k_t \
            / m.resistance / twin.firmware.torque_gain  # fmt: skip
    starts = list(range(0, n, chunk))
    S, L = len(starts), chunk + warm
    idx = np.array([[min(max(s - warm + j, 0), n - 1) for j in range(L)] for s in starts])
    act = twin.actuator(plant)
    act.reset(S)
    out = np.zeros((S, L, 2))
    for j in range(L):
        k = idx[:, j]
        out[:, j] = act(float(j) * twin.Ts, cmd[k], state[k])
    u = np.zeros((n, 2))
    for i, s in enumerate(starts):
        e = min(s + chunk, n)
        u[s:e] = out[i, warm:warm + e - s]
    return u


def _kernels(Lw: int, Ts: float) -> list[NDArray[np.float64]]:
    """``w, w', w'', w'''`` at the samples of a window of ``Lw`` samples, then ``w`` and
    ``w'`` at the sample midpoints (the window spans ``(Lw - 1) Ts``)."""
    from numpy.polynomial import Polynomial

    half = 0.5 * (Lw - 1) * Ts
    s = (np.arange(Lw) * Ts - half) / half
    sm = np.clip(s + 0.5 * Ts / half, -1.0, 1.0)
    w = Polynomial([1.0, 0.0, -1.0]) ** _P
    out = [np.asarray(w.deriv(i)(s) / half**i if i else w(s)) for i in range(4)]
    return out + [np.asarray(w(sm)), np.asarray(w.deriv(1)(sm) / half)]


def _window_sums(x: NDArray[np.float64], k: NDArray[np.float64], starts: NDArray[np.int64],
                 Ts: float, detrend: bool = False) -> NDArray[np.float64]:  # fmt: skip
    """``int K(t - t_j) x(t) dt`` for the windows starting at ``starts`` (rectangle rule: the
    kernels vanish smoothly at the ends, where it is the trapezoid rule)."""
    from numpy.lib.stride_tricks import sliding_window_view

    v = sliding_window_view(x, k.size)[starts]
    if detrend:  # kernels that annihilate a line: the quadrature error on a steep signal
        tt = np.linspace(-1.0, 1.0, k.size)
        v = v - v.mean(axis=1, keepdims=True) - np.outer(v @ tt / (tt @ tt), tt)
    return np.asarray(v @ k * Ts, dtype=float)


@dataclass
class _Rows:
    phi: NDArray[np.float64]  # (m, 6 + nuisances)
    y: NDArray[np.float64]  # (m,)
    block: NDArray[np.int64]  # (m,)
    nuis: int
    gyro_noise: float  # rad/s, per sample (white, from the second differences)
    pitch_rms: float  # rad, RMS of the pitch about its per-run mean


def regression(logs: Sequence[Log], twin: Any, body: Any,
               values: Mapping[str, float] | None = None) -> tuple[_Rows, list[str]]:  # fmt: skip
    """The weak-form rows (module docstring) of the balancing rows of ``logs``: regressors
    ``[m11, m12, m22, Gb, Db, Dw, nuisances...]``, right-hand sides, block ids, the gyro
    noise; and flags."""
    from scipy.integrate import cumulative_trapezoid
    from scipy.signal import savgol_filter

    tw = _drive_twin(twin, values)
    bias = float((values or {}).get("imu.gyro_bias",
                                    getattr(getattr(twin, "imu", None), "gyro_bias", 0.0)))
    plant = tw.plant(body)
    br = float(plant.b / plant.r)
    flags: list[str] = []
    parts_x, parts_y, parts_id, parts_n = [], [], [], []
    var_all: list[float] = []
    pitch: list[NDArray[np.float64]] = []
    block0 = 0
    for lg in logs:
        Ts = lg.Ts
        Lw = int(round(WINDOW / Ts)) + 1
        hop = max(int(round(HOP / Ts)), 1)
        w, w1, w2, _w3, wm, _w1m = _kernels(Lw, Ts)
        c = lg.columns
        for k0, k1 in runs(lg.mode == "balancing", Lw + 2):
            n = k1 - k0
            gy = c["theta_rate"][k0:k1]
            d2 = np.diff(gy, 2)
            var_all.append(float(np.mean(d2 * d2)) / 6.0)  # white: var(2nd difference) = 6 s^2
            # the pitch: the gyro less its bias, integrated, from the fused pitch's median
            # offset (module docstring)
            thd = gy - bias
            G = cumulative_trapezoid(thd, dx=Ts, initial=0.0)
            th = G + float(np.median(c["theta"][k0:k1] - G))
            pitch.append(th - th.mean())
            enc = np.column_stack([c["enc_r"][k0:k1], c["enc_l"][k0:k1]])
            ph = enc.mean(axis=1)
            win = min(11, n // 2 * 2 - 1)
            encd = savgol_filter(enc, win, 2, deriv=1, delta=Ts, axis=0)
            psid = encd.mean(axis=1) + thd
            ald = (encd[:, 0] - encd[:, 1]) / (2.0 * br)
            yaw = float(np.sqrt(np.mean(ald**2)))
            if yaw > YAW_RATE_FLAG:
                flags.append(f"{lg.path}: yaw rate RMS {yaw:.2g} rad/s: the planar model drops "
                             "the yaw terms of (2.32); the body's estimates carry their error")
            state = np.zeros((n, 8))
            state[:, 0] = ph + th
            state[:, 1] = th
            state[:, 2] = (enc[:, 0] - enc[:, 1]) / (2.0 * br)
            state[:, 3] = psid
            state[:, 4] = thd
            state[:, 5] = ald
            u = delivered_torque(lg.command[k0:k1], state, lg.inputs == "duty", tw, plant)
            uA = u.sum(axis=1)
            starts = np.arange(0, n - Lw + 1, hop)
            sn, cs = np.sin(th), np.cos(th)

            def S(x: NDArray[np.float64], k: NDArray[np.float64],
                  st: NDArray[np.int64] = starts, T: float = Ts) -> NDArray[np.float64]:
                return _window_sums(x, k, st, T)

            m = starts.size
            zero = np.zeros(m)
            mp = S(ph, w2) - S(thd, w1)  # int w'' psi
            r1 = np.column_stack([mp, -S(cs * thd, w1), zero, zero, -2.0 * S(ph, w1),
                                  -2.0 * S(ph, w1) + 2.0 * S(thd, w)])
            small = S((1.0 - cs) * psid, w1) + S(sn * thd * psid, w)
            r2 = np.column_stack([zero, mp + small, -S(thd, w1), -S(sn, w), 2.0 * S(ph, w1),
                                  zero])
            # nuisances: a constant torque in row 1; the pitch's offset and drift in row 2
            # (Gb (delta_0 + delta_1 t): the integrated gyro drifts by the error of the bias it
            # is corrected with, a random walk in the IMU; without the drift term m12, m22 and
            # Gb came back up to 8 % low on development seeds, with it within 2 %)
            tr = (np.arange(n) - 0.5 * n) * Ts
            n1 = np.column_stack([S(np.ones(n), w), zero, zero])
            n2 = np.column_stack([zero, -S(cs, w), -S(cs * tr, w)])
            blk = block0 + ((starts + 0.5 * Lw) * Ts // BLOCK).astype(int)
            block0 = int(blk.max()) + 1
            parts_x.append(np.vstack([r1, r2]))
            parts_y.append(np.concatenate([S(uA, wm), -S(uA, wm)]))
            parts_id.append(np.concatenate([blk, blk]))
            parts_n.append(np.vstack([n1, n2]))
    if not parts_x:
        raise ValueError("no balancing run long enough for the body stage "
                         f"({WINDOW:g} s windows)")  # fmt: skip
    total = sum(n.shape[1] for n in parts_n)
    rows = sum(p.shape[0] for p in parts_x)
    nu = np.zeros((rows, total))
    r0 = c0 = 0
    for nc in parts_n:
        nu[r0:r0 + nc.shape[0], c0:c0 + nc.shape[1]] = nc
        r0 += nc.shape[0]
        c0 += nc.shape[1]
    phi = np.hstack([np.vstack(parts_x), nu])
    return _Rows(phi, np.concatenate(parts_y), np.concatenate(parts_id), total,
                 float(np.sqrt(np.mean(var_all))),
                 float(np.sqrt(np.mean(np.concatenate(pitch) ** 2)))), flags  # fmt: skip


def _solve(phi: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Ordinary least squares, columns scaled to unit norm."""
    d = np.linalg.norm(phi, axis=0)
    d = np.where(d > 0, d, 1.0)
    return np.asarray(np.linalg.lstsq(phi / d, y, rcond=None)[0] / d, dtype=float)


def physical(est: Mapping[str, float], cov: NDArray[np.float64], ok: Mapping[str, bool],
             twin: Any, body: Any) -> dict[str, tuple[float, float, float]]:  # fmt: skip
    """The body fields the lumped coefficients give, the robot file's mass ``mb`` held (the
    user weighs it): from (2.32), ``Gb = mb g l`` gives the centre of mass's height
    ``l = Gb / (mb g)``, and ``m22 = mb l^2 + Iby + c`` the body's pitch inertia
    ``Iyy = Iby = m22 - mb l^2 - c``, with ``c`` what the twin's plant adds to ``m22`` for this
    robot (the reflected rotor inertia ``2 (N - 1)^2 J_r``, :meth:`mwip.hardware.twin.Twin.
    plant`; taken from the plant itself). Standard errors by the delta method with the
    coefficients' covariance ``cov`` (order :data:`LUMPED`). Only from identified
    coefficients: ``{"l": (value, se, file's)}``, and ``"Iyy"`` where ``m22`` is too."""
    out: dict[str, tuple[float, float, float]] = {}
    if not ok["Gb"]:
        return out
    ig, i22 = LUMPED.index("Gb"), LUMPED.index("m22")
    mb, g = float(body.mb), float(body.g)
    lv = est["Gb"] / (mb * g)
    out["l"] = (lv, float(np.sqrt(max(cov[ig, ig], 0.0))) / (mb * g), float(body.l))
    if ok["m22"]:
        plant = twin.plant(body)
        c = float(plant.m22) - mb * float(body.l) ** 2 - float(body.Iby)
        iv = est["m22"] - mb * lv * lv - c
        d = -2.0 * lv / g  # d Iyy / d Gb
        var = cov[i22, i22] + d * d * cov[ig, ig] + 2.0 * d * cov[i22, ig]
        out["Iyy"] = (iv, float(np.sqrt(max(var, 0.0))), float(body.Iby))
    return out


def lumped_of(plant: Any) -> NDArray[np.float64]:
    """The lumped coefficients :data:`LUMPED` of a plant."""
    return np.array([float(getattr(plant, n)) for n in LUMPED])


def body_stage(logs: Sequence[Log], twin: Any, body: Any,
               values: Mapping[str, float] | None = None) -> BodyResult:
    """The body stage on the balancing rows of ``logs`` (module docstring): the lumped
    coefficients with 95 % intervals and identifiability, beside the robot file's ``body``
    (its plant's coefficients). ``values``: the drive's fitted values and ``imu.gyro_bias``
    (default the twin's)."""
    from scipy import stats

    rows, flags = regression(logs, twin, body, values)
    X, y = rows.phi, rows.y
    beta = _solve(X, y)
    res = y - X @ beta
    ids = np.unique(rows.block)
    G = ids.size
    if G < 3:
        raise ValueError(f"the balancing rows span {G} blocks of {BLOCK:g} s; the body stage "
                         "needs at least 3 (a longer balancing log)")  # fmt: skip
    loo = np.array([_solve(X[rows.block != g], y[rows.block != g]) for g in ids])
    dev = loo - beta
    V = (G - 1) / G * (dev.T @ dev)
    p = len(LUMPED)
    Vc = V[:p, :p]
    se = np.sqrt(np.maximum(np.diag(Vc), 0.0))
    q = float(stats.t.ppf(0.975, G - 1))
    # identifiability: singular directions of the scaled regressors (the lumped part, the
    # nuisances projected out)
    Xn = X[:, p:]
    Xc = X[:, :p]
    if Xn.shape[1]:
        Q = np.linalg.qr(Xn)[0]
        Xc = Xc - Q @ (Q.T @ Xc)
    d = np.linalg.norm(Xc, axis=0)
    d = np.where(d > 0, d, 1.0)
    _, sv, Vt = np.linalg.svd(Xc / d, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    unident = []
    for s_, v in zip(sv, Vt, strict=True):
        if s_ < RANK_TOL * sv[0]:
            unident.append({"ratio": float(s_ / sv[0]),
                            **{n: round(float(x), 4) for n, x in zip(LUMPED, v, strict=True)}})
    tw = _drive_twin(twin, values)
    filec = lumped_of(tw.plant(body))
    est, sed, itv, ok, filed = {}, {}, {}, {}, {}
    for i, n in enumerate(LUMPED):
        b, s_ = float(beta[i]), float(se[i])
        est[n], sed[n] = b, s_
        itv[n] = (b - q * s_, b + q * s_)
        weak = any(abs(u[n]) > 0.3 for u in unident)
        ok[n] = bool(s_ > 0 and s_ <= RSE_MAX * abs(b) and not weak
                     and not (itv[n][0] <= 0.0 <= itv[n][1]))  # fmt: skip
        filed[n] = float(filec[i])
    fields_ = physical(est, Vc, ok, tw, body)
    out = BodyResult(est, sed, itv, ok, filed, unident, cond, int(y.size // 2), G,
                     float(np.sqrt(np.mean(res**2))), flags=flags, fields=fields_)  # fmt: skip
    for n in LUMPED:
        if not ok[n]:
            out.flags.append(f"body: {n} is not identified by the balancing rows (estimate "
                             f"{est[n]:.3g} +- {sed[n]:.2g}); the robot file's value is kept")
    for n in out.file_outside():
        out.flags.append(f"body: the robot file's {n} = {filed[n]:.4g} (its plant's) is outside "
                         f"the logs' 95 % interval [{itv[n][0]:.4g}, {itv[n][1]:.4g}] widened "
                         f"by the method's measured bias ({100 * BIAS:g} %): the file's body "
                         "disagrees with the logs")  # fmt: skip
    return out

