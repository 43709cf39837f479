"""What the logs inform before the fit: identifiability of the stand parameters.

:func:`check` takes the logs, the free drive parameters (:data:`~mwip.identify.model.
STAND_PARAMS`) and the values held, and computes the **Fisher information** of the scaled free
globals (each in [0, 1] of its prior range, :data:`~mwip.identify.bounds.BOUNDS`) in the
wheels-off-ground segments the fit uses (:func:`mwip.identify.fit.stand_segments`): the
forward-difference Jacobian of the smooth stand model's residuals
(:func:`mwip.identify.solve.global_jacobian`) with each segment's start-state nuisances at their
first guesses, projected off the nuisances (:func:`mwip.identify.solve.project_out`: what the
start states can absorb informs nothing), ``F = sum_s A~_s^T A~_s / sigma^2``. ``sigma`` is the
encoder noise of the logs (:func:`encoder_noise`). Nothing is fitted: the cost is some
Jacobians of the segments' batch rollout (a few per cent of the fit's).

The information of a kink parameter (the current limit, the dead-band, Coulomb friction)
depends on where it lies: a current limit above every current of the log informs nothing.
So ``F`` is evaluated at the prior centre and at :data:`DRAWS` fixed prior draws (seed
:data:`SEED`, uniform in the central 80 % of each range, as :func:`mwip.identify.synth.
draw_truth` draws), and their mean is used (the prior-averaged information). Then:

- a parameter is **not informed** when its projected Jacobian column is zero at every point
  (norm below :data:`ZERO` of the largest column's: the fit's own test at its optimum);
- a direction ``v`` (unit vector) of the mean ``F`` of the informed parameters, normalised to
  a unit diagonal, is a **confounded** combination when its eigenvalue is below
  :data:`MU_MIN` (for a pair: a correlation above 0.9, the fit's own flag); the parameters
  with weight ``|v_i| >=`` :data:`WEIGHT` make up the combination, reported with their
  correlation (from ``F^-1``) and the direction's standard error ``1 / sqrt(lambda)`` in units
  of the prior span. Where that error is at most :data:`SE_MAX` the parameters are
  correlated but each still well within its range, and no experiment is advised; above it
  (or for a single parameter: **weakly informed**) an experiment is sought, below.

:data:`SE_MAX` = 0.05: the information matrix assumes white encoder noise, and the fit's
cluster-robust errors, which allow for the residuals' correlation within a segment and some
structure error, are 2-3 times larger on the synthetic logs (docs/twin_fit.md); a direction
whose white-noise error is 5 % of its prior span is then 10-15 %, a 2-sigma interval of a
quarter to a half of the prior range: the logs have not told it apart from its partners.

For each confounded direction (and each parameter not informed), candidate schedules of
``mwip twin excite`` (:data:`CANDIDATES`: the default, longer steps, a longer chirp) are
simulated with the stand model from rest at the same points (the schedule's duty as the
command), their information is added to the logs', and the shortest one that brings the
direction's standard error (the largest of the marginal covariance block of its parameters)
under :data:`SE_MAX` (for a parameter not informed: any information at all) is advised, with
its command line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.bounds import BOUNDS
from mwip.identify.logs import Log
from mwip.identify.model import STAND_PARAMS, Known, stand_rollout
from mwip.identify.solve import global_jacobian, nuisance_jacobian, project_out

__all__ = ["Identifiability", "Direction", "check", "encoder_noise", "SE_MAX", "MU_MIN", "ZERO",
           "WEIGHT", "DRAWS", "SEED", "CANDIDATES"]  # fmt: skip

#: A direction is confounded when its standard error exceeds this fraction of the prior span
#: (module docstring).
SE_MAX = 0.05
#: A direction of the information normalised to a unit diagonal with an eigenvalue below this
#: is a confounded combination: for a pair, ``1 - |rho| < 0.1``, the fit's own flag of a
#: correlation above 0.9 (module docstring).
MU_MIN = 0.1
#: A parameter's projected Jacobian column below this fraction of the largest column's norm
#: carries no information (the fit's test of ``not informed`` at its optimum).
ZERO = 1e-6
#: A parameter belongs to a confounded combination when its weight in the direction is at
#: least this (a unit vector: two equal partners weigh 0.71 each, three 0.58).
WEIGHT = 0.3
#: Prior draws besides the centre, and their seed (fixed: the check is deterministic).
DRAWS = 2
SEED = 37
#: Candidate experiments: (what, ``mwip twin excite`` options static, step, chirp (s)).
CANDIDATES: tuple[tuple[str, float, float, float], ...] = (
    ("the default schedule", 2.0, 0.25, 4.0),
    ("longer steps", 2.0, 1.0, 4.0),
    ("a longer chirp", 2.0, 0.25, 30.0),
)


@dataclass
class Direction:
    """A confounded combination: ``weights`` name -> component of the unit direction (scaled
    parameters), its standard error in prior spans, the correlation of its two heaviest
    parameters, and the experiment that separates it (``None``: none of the candidates)."""

    weights: dict[str, float]
    stderr: float
    correlation: float | None
    #: the direction's eigenvalue of the information normalised to a unit diagonal (a pair of
    #: correlation ``rho``: ``1 - |rho|``); NaN for a single weakly informed parameter
    normalised: float = float("nan")
    advice: str | None = None
    command: str | None = None

    def text(self) -> str:
        names = list(self.weights)
        if len(names) == 1:
            head = f"{names[0]} is weakly informed"
        else:
            head = " + ".join(names) + " are confounded"
        corr = (f" (correlation {self.correlation:+.2f})" if self.correlation is not None
                else "")  # fmt: skip
        if self.command:
            tail = f"; {self.advice} separates it: `{self.command}`"
        elif self.stderr <= SE_MAX:  # correlated, but each still well within its prior range
            tail = "; no schedule of `mwip twin excite` tried separates it further"
        else:
            tail = ("; no schedule of `mwip twin excite` tried separates it: hold one with "
                    "--fix NAME=VALUE")  # fmt: skip
        along = f" along {_combo(self.weights)}" if len(names) > 1 else ""
        return f"{head}{corr}, standard error {self.stderr:.2g} of the prior span{along}{tail}"


def _combo(w: Mapping[str, float]) -> str:
    return " ".join(f"{'+' if v >= 0 else '-'}{abs(v):.2f} {n}" for n, v in w.items()).lstrip("+")


@dataclass
class Identifiability:
    """The result of :func:`check` (``to_json`` for fit.json's ``identifiability``)."""

    names: list[str]
    #: name -> standard error in prior spans (inf: not informed), of the mean information
    stderr: dict[str, float]
    #: name -> "informed", "confounded", "weakly informed" or "not informed"
    status: dict[str, str]
    confounded: list[Direction]
    condition: float | None
    sigma: float
    points: int
    #: not-informed name -> (what, command) of the shortest candidate that informs it
    inform: dict[str, tuple[str, str] | None] = field(default_factory=dict)

    @property
    def not_informed(self) -> list[str]:
        return [n for n in self.names if self.status[n] == "not informed"]

    def advice(self, name: str) -> str:
        """What would inform the not-informed ``name``."""
        got = self.inform.get(name)
        if got is None:
            return ("no schedule of `mwip twin excite` tried informs it (for the current limit: "
                    "steps whose current reaches it)")  # fmt: skip
        return f"{got[0]} informs it: `{got[1]}`"

    def lines(self) -> list[str]:
        """The findings, one line each."""
        out = []
        ok = [n for n in self.names if self.status[n] == "informed"]
        if ok:
            out.append(f"informed: {', '.join(ok)}")
        for n in self.not_informed:
            out.append(f"{n}: the logs carry no information on it (zero sensitivity at the "
                       f"prior centre and {self.points - 1} prior draws); {self.advice(n)}")
        out += [d.text() for d in self.confounded]
        if self.condition is not None:
            out.append(f"condition number of the scaled information {self.condition:.3g}")
        return out

    def to_json(self) -> dict[str, Any]:
        def num(x: float | None) -> float | None:
            return None if x is None or not np.isfinite(x) else float(x)

        return {
            "names": list(self.names),
            "stderr_of_span": {k: num(v) for k, v in self.stderr.items()},
            "status": dict(self.status),
            "confounded": [{"weights": d.weights, "stderr_of_span": d.stderr,
                            "normalised_information": None if np.isnan(d.normalised)
                            else d.normalised,
                            "correlation": d.correlation, "advice": d.advice,
                            "command": d.command} for d in self.confounded],
            "condition_number": num(self.condition),
            "encoder_noise": self.sigma,
            "points": self.points,
            "inform": {k: (None if v is None else {"advice": v[0], "command": v[1]})
                       for k, v in self.inform.items()},
            "thresholds": {"se_max": SE_MAX, "mu_min": MU_MIN, "zero": ZERO, "weight": WEIGHT},
            "lines": self.lines(),
        }  # fmt: skip


def encoder_noise(logs: Sequence[Log]) -> float:
    """The encoder noise (rad, one sample) of the wheels-off-ground rows: the quantisation
    ``q / sqrt(12)`` (``q`` the smallest encoder increment) with, in quadrature, the robust
    spread of the third differences (``1.4826 MAD / sqrt(20)``: white noise, the trajectory's
    smooth part differenced away); at least 1e-7 rad."""
    q2, d3s = [], []
    for lg in logs:
        on = lg.mode == "wheels-off-ground"
        if on.sum() < 8:
            continue
        e = lg.enc[on]
        d = np.abs(np.diff(e, axis=0)).ravel()
        d = d[d > 1e-12]
        if d.size:
            q2.append(float(d.min()) ** 2 / 12.0)
        d3s.append(np.diff(e, n=3, axis=0).ravel())
    var = max(q2) if q2 else 0.0
    if d3s:
        d3 = np.concatenate(d3s)
        mad = float(np.median(np.abs(d3 - np.median(d3))))
        var += (1.4826 * mad) ** 2 / 20.0
    return float(max(np.sqrt(var), 1e-7))


def _points(free: Sequence[str], values: Mapping[str, float]) -> list[dict[str, float]]:
    """The prior centre (``values``) and :data:`DRAWS` seeded draws of the free parameters."""
    rng = np.random.default_rng(SEED)
    out = [dict(values)]
    for _ in range(DRAWS):
        p = dict(values)
        u = rng.uniform(0.1, 0.9, len(STAND_PARAMS))
        for n, ui in zip(STAND_PARAMS, u, strict=True):
            if n in free:
                lo, hi = BOUNDS[n]
                p[n] = float(lo + ui * (hi - lo))
        out.append(p)
    return out


def _projected(seg: Any, known: Known, free: Sequence[str],
               p: Mapping[str, float]) -> NDArray[np.float64]:  # fmt: skip
    """The nuisance-projected Jacobian (S, n, g) of the smooth model's segment residuals at
    ``p``, the start states at their first guesses."""
    from mwip.identify.fit import _NUIS, _Problem

    prob = _Problem(seg, replace(known, pwm_levels=0), free, p)
    x0 = prob.x0(p)
    g = len(free)
    xg, z = x0[:g], x0[g:].reshape(seg.n, _NUIS)
    r0 = prob.segment_residual(xg, z)
    A = global_jacobian(prob.segment_residual, xg, z, r0)
    Jn = nuisance_jacobian(prob.segment_residual, xg, z, np.arange(seg.n), r0)
    return project_out(Jn, A)


def _info(At: NDArray[np.float64], sigma: float) -> tuple[NDArray, NDArray]:
    """``(F, column norms)`` of a projected Jacobian (residual units: the fit's 1e-3 rad)."""
    from mwip.identify.fit import _RES

    F = np.einsum("sni,snj->ij", At, At) * (_RES / sigma) ** 2
    return F, np.sqrt(np.maximum(np.diag(F), 0.0))


def _simulated(Ts: float, static: float, step: float, chirp: float,
               pts: Sequence[Mapping[str, float]], known: Known) -> list[Log]:  # fmt: skip
    """The noise-free stand log of a schedule of ``mwip twin excite`` at each point (its
    wheels-off-ground rows, from rest)."""
    from mwip.identify.excite import schedule

    _, duty, mode = schedule(Ts, static, step, chirp)
    d = duty[mode == "wheels-off-ground"]
    n = d.shape[0]
    P = len(pts)
    cmd = np.concatenate([np.zeros((P, 1, 2)), np.broadcast_to(d, (P, n, 2))], axis=1)
    batch = {k: np.array([p[k] for p in pts]) for k in STAND_PARAMS}
    phi, _ = stand_rollout(batch, cmd, np.ones(P, dtype=bool), np.zeros((P, 2)),
                           replace(known, pwm_levels=0), cmd_prev2=np.zeros((P, 2)))  # fmt: skip
    t = np.arange(n) * Ts
    out = []
    for i in range(P):
        cols = {"t": t, "duty_r": d[:, 0], "duty_l": d[:, 1], "enc_r": phi[i, :, 0],
                "enc_l": phi[i, :, 1]}  # fmt: skip
        out.append(Log("candidate", "", cols, np.full(n, "wheels-off-ground"), inputs="duty"))
    return out


@lru_cache(maxsize=64)
def _candidate(Ts: float, static: float, step: float, chirp: float,
               pts: tuple[tuple[tuple[str, float], ...], ...], known: Known,
               free: tuple[str, ...], segment: int) -> tuple[NDArray, NDArray] | None:  # fmt: skip
    """A candidate schedule's information at the points ``pts``, for a noise of the fit's
    residual unit (scale by ``(1e-3 / sigma)^2``), and which parameters it informs; it
    depends on the robot (``known``), the points and the free set only, not on the logs, so
    it is computed once per process (a campaign of fits of one robot reuses it)."""
    from mwip.identify.fit import _RES, stand_segments

    points = [dict(p) for p in pts]
    sims = _simulated(Ts, static, step, chirp, points, known)
    Fc, lc = [], np.zeros(len(free), dtype=bool)
    for p, lg in zip(points, sims, strict=True):
        cs = stand_segments([lg], segment)
        if cs is None:
            continue
        F, norms = _info(_projected(cs, known, list(free), p), _RES)
        Fc.append(F)
        lc |= norms > ZERO * max(float(norms.max()), 1e-300)
    return (np.mean(Fc, axis=0), lc) if Fc else None


def _command(Ts: float, static: float, step: float, chirp: float) -> str:
    ts = "" if abs(Ts - 0.005) < 1e-12 else f" --ts {Ts:g}"
    return (f"mwip twin excite{ts} --static {static:g} --step {step:g} --chirp {chirp:g} "
            "--out schedule.csv")


def _block(F: NDArray[np.float64], idx: Sequence[int]) -> tuple[float, float]:
    """``(largest standard error, smallest eigenvalue of the correlation matrix)`` of the
    marginal covariance of the parameters ``idx`` (a pair of correlation ``rho``: ``1 - |rho|``)."""
    C = np.linalg.pinv(F, hermitian=True)[np.ix_(idx, idx)]
    d = np.sqrt(np.maximum(np.diag(C), 1e-300))
    return float(d.max()), float(np.linalg.eigvalsh(C / np.outer(d, d)).min())


def _separated(F: NDArray[np.float64], idx: Sequence[int]) -> bool:
    se, mu = _block(F, idx)
    return se <= SE_MAX and (len(idx) < 2 or mu >= MU_MIN)


def check(logs: Sequence[Log], free: Sequence[str], values: Mapping[str, float], known: Known,
          segment: int = 40) -> Identifiability:  # fmt: skip
    """What the wheels-off-ground rows of ``logs`` inform of the drive parameters ``free``
    (the others held at ``values``; ``known`` the base twin's constants; ``segment`` samples
    per segment, as the fit): module docstring. Pure and deterministic."""
    from mwip.identify.fit import stand_segments

    free = [n for n in free if n in STAND_PARAMS]
    g = len(free)
    seg = stand_segments(logs, segment)
    sigma = encoder_noise(logs)
    pts = _points(free, values)
    if seg is None or g == 0:
        return Identifiability(free, {n: float("inf") for n in free},
                               {n: "not informed" for n in free}, [], None, sigma, len(pts))
    Fs, live = [], np.zeros(g, dtype=bool)
    for p in pts:
        F, norms = _info(_projected(seg, known, free, p), sigma)
        Fs.append(F)
        live |= norms > ZERO * max(float(norms.max()), 1e-300)
    Fm = np.mean(Fs, axis=0)
    status = {n: ("informed" if ok else "not informed") for n, ok in zip(free, live, strict=True)}
    on = np.flatnonzero(live)
    stderr = {n: float("inf") for n in free}
    dirs: list[tuple[NDArray, float, list[int]]] = []
    cond = None
    if on.size:
        Fi = Fm[np.ix_(on, on)]
        C = np.linalg.pinv(Fi, hermitian=True)
        se = np.sqrt(np.maximum(np.diag(C), 0.0))
        for j, oi in enumerate(on.tolist()):
            stderr[free[oi]] = float(se[j])
        dn = np.sqrt(np.maximum(np.diag(Fi), 1e-300))
        mu, V = np.linalg.eigh(Fi / np.outer(dn, dn))
        mu = np.maximum(mu, 0.0)
        lam = np.linalg.eigvalsh(Fi)
        cond = float(lam.max() / lam.min()) if lam.min() > 0 else float("inf")
        for k in range(mu.size):
            if mu[k] >= MU_MIN:
                continue
            v = V[:, k] * (1.0 if V[np.argmax(np.abs(V[:, k])), k] > 0 else -1.0)
            heavy = [int(on[j]) for j in np.argsort(-np.abs(v)) if abs(v[j]) >= WEIGHT]
            if len(heavy) < 2:
                continue
            dirs.append((v, float(mu[k]), heavy))
            for i in heavy:
                status[free[i]] = "confounded"
        for j, oi in enumerate(on.tolist()):
            if status[free[oi]] == "informed" and se[j] > SE_MAX:
                dirs.append((np.eye(on.size)[j], float("nan"), [oi]))
                status[free[oi]] = "weakly informed"
        dscale = np.sqrt(np.maximum(np.diag(C), 1e-300))
        R = C / np.outer(dscale, dscale)
    # candidate experiments, shortest first, at the same points
    Ts = logs[0].Ts
    cands = sorted(CANDIDATES, key=lambda c: c[2] * 24 + c[3])
    need_any = [i for i in range(g) if not live[i]]
    out_dirs: list[Direction] = []
    inform: dict[str, tuple[str, str] | None] = {free[i]: None for i in need_any}
    if dirs or need_any:
        cand_F: list[tuple[str, str, NDArray, NDArray]] = []
        from mwip.identify.fit import _RES

        pkey = tuple(tuple(sorted(p.items())) for p in pts)
        for what, st, sp, ch in cands:
            got = _candidate(Ts, st, sp, ch, pkey, known, tuple(free), segment)
            if got is not None:
                F1, lc = got
                cand_F.append((what, _command(Ts, st, sp, ch), F1 * (_RES / sigma) ** 2, lc))
        for i in need_any:
            for what, cmd, _, lc in cand_F:
                if lc[i]:
                    inform[free[i]] = (what, cmd)
                    break
        for v, mu_d, heavy in dirs:
            jj = [int(np.flatnonzero(on == i)[0]) for i in heavy]
            corr = float(R[jj[0], jj[1]]) if len(jj) > 1 else None
            se_b, _ = _block(Fi, jj)
            d = Direction({free[i]: round(float(v[j]), 3) for i, j in zip(heavy, jj, strict=True)},
                          se_b, None if corr is None else round(corr, 3), mu_d)  # fmt: skip
            for what, cmd, Fc_, _ in cand_F:
                if _separated((Fm + Fc_)[np.ix_(on, on)], jj):
                    d.advice, d.command = what, cmd
                    break
            out_dirs.append(d)
    return Identifiability(free, stderr, status, out_dirs, cond, sigma, len(pts), inform)
