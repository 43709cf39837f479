"""Separable least squares over segments: globals shared by all segments, nuisances per segment.

The stand fit's residual ``r_s(x, z_s)`` of segment ``s`` (``n`` rows) depends on the ``g``
global parameters ``x`` and on the segment's own ``k`` nuisances ``z_s`` (its start state)
only. The normal matrix is an arrow: a ``g x g`` block, ``S`` diagonal ``k x k`` blocks and
their couplings. :func:`scipy.optimize.least_squares` with a sparse Jacobian and its
iterative trust-region solver (``tr_solver="lsmr"``) does not use that structure; on this
problem (the nuisances' columns differ by orders of magnitude, the globals are strongly
correlated) its inexact steps crawl along the globals' weakest direction and stop there:
on a noise-free development log (seed 108, encoder x1000, no PWM quantisation) it ended
after 2,000 evaluations at a residual of 6.5e-5 rad RMS, 1.7 standard errors from the truth
in every drive parameter, where the truth's residual is 3e-7 rad (docs/twin_fit.md).

Here the problem is solved by **variable projection** (Golub & Pereyra 1973, SIAM J. Numer.
Anal. 10, 413-432; Kaufman 1975, BIT 15, 49-57): for given globals the nuisances are the
minimisers of each segment's own small problem,

    z_s*(x) = argmin_z |r_s(x, z)|^2,

solved for all segments at once by a batched Levenberg-Marquardt (:func:`nuisance_solve`: each
segment's ``k x k`` normal equations, its own damping, its own acceptance: the segments are
independent given ``x``). The globals then minimise the reduced residual
``rho(x) = r(x, z*(x))`` with bounded :func:`scipy.optimize.least_squares` over ``g``
variables only, with the exact (dense SVD) trust-region solver and Kaufman's Jacobian

    d rho_s / dx  ~  (I - Q_s Q_s^T) d r_s / dx,

``Q_s`` an orthonormal basis of segment ``s``'s nuisance columns ``d r_s / d z_s``
(:func:`project_out`). That is the Gauss-Newton step of the full problem with the nuisances
eliminated exactly (the Schur complement of the arrow), so nothing is inverted but ``k x k``
and ``g x g`` matrices, and the cost per iteration grows linearly in the number of segments.

Derivatives are forward differences, the nuisances ``k`` columns at a time for all segments
(each segment's rows depend on its own nuisances only) and the globals one at a time. The
residual and its Jacobian may come from different models (``jac_res``): the PWM-quantised
residual with the smooth model's Jacobian (:mod:`mwip.identify.fit`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["Residual", "nuisance_solve", "nuisance_jacobian", "global_jacobian", "project_out",
           "Reduced"]  # fmt: skip

#: ``(x, z (B, k), idx (B,)) -> residuals (B, n)``: row ``b`` is segment ``idx[b]`` with the
#: nuisances ``z[b]`` and the globals ``x`` (g,), or ``x[b]`` when ``x`` is (B, g); any batch
#: is one evaluation of the model.
Residual = Callable[..., NDArray[np.float64]]

#: Forward-difference step (scaled variables: globals in [0, 1], nuisances ~ 1).
STEP = 1e-7


def nuisance_jacobian(res: Residual, x: NDArray[np.float64], z: NDArray[np.float64],
                      idx: NDArray[np.int64], r0: NDArray[np.float64] | None = None,
                      h: float = STEP) -> NDArray[np.float64]:  # fmt: skip
    """``d r_s / d z_s`` (B, n, k) of the segments ``idx`` (``z`` theirs) by forward
    differences: all ``k`` columns of all segments in one evaluation (``r0 = res(x, z, idx)``
    if known, else evaluated with them)."""
    B, k = z.shape
    zs = [z + h * np.eye(k)[c] for c in range(k)]
    if r0 is None:
        zs.insert(0, z)
    out = res(x, np.concatenate(zs), np.tile(idx, len(zs)))
    out = out.reshape(len(zs), B, -1)
    base = out[0] if r0 is None else r0
    d = out[1:] if r0 is None else out
    return np.asarray(((d - base) / h).transpose(1, 2, 0))


def global_jacobian(res: Residual, x: NDArray[np.float64], z: NDArray[np.float64],
                    r0: NDArray[np.float64] | None = None, h: float = STEP,
                    hi: float = 1.0) -> NDArray[np.float64]:  # fmt: skip
    """``d r / d x`` (S, n, g) of all segments by forward differences (backward at the upper
    bound), in one evaluation."""
    S = z.shape[0]
    g = x.size
    steps = np.where(x + h <= hi, h, -h)
    X = [x + np.diag(steps)[i] for i in range(g)]
    if r0 is None:
        X.insert(0, x)
    rows = np.repeat(np.array(X), S, axis=0)
    out = res(rows, np.tile(z, (len(X), 1)), np.tile(np.arange(S), len(X)))
    out = out.reshape(len(X), S, -1)
    base = out[0] if r0 is None else r0
    d = out[1:] if r0 is None else out
    return np.asarray(((d - base) / steps[:, None, None]).transpose(1, 2, 0))


def _basis(Jn: NDArray[np.float64]) -> NDArray[np.float64]:
    """Orthonormal bases (S, n, k) of each segment's nuisance columns; columns of a
    numerically rank-deficient block are zeroed (they span nothing)."""
    U, sv, _ = np.linalg.svd(Jn, full_matrices=False)
    top = np.maximum(sv.max(axis=1, keepdims=True), 1e-300)
    return U * (sv > 1e-10 * top)[:, None, :]


def project_out(Jn: NDArray[np.float64], A: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(I - Q_s Q_s^T) A_s`` per segment: ``A`` (S, n, g) with each segment's nuisance
    directions ``Jn`` (S, n, k) removed."""
    Q = _basis(Jn)
    return A - Q @ (Q.transpose(0, 2, 1) @ A)


def nuisance_solve(
    res: Residual, x: NDArray[np.float64], z0: NDArray[np.float64],
    jac_res: Residual | None = None, max_iter: int = 12,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:  # fmt: skip
    """Minimise every segment's ``|r_s(x, z_s)|^2`` over its nuisances, ``x`` held: batched
    Levenberg-Marquardt (Marquardt's scaling ``diag(J^T J)``), one damping, one acceptance
    and one stopping test per segment; the model is evaluated only for the segments not yet
    converged. Returns ``(z, r, Jn)`` at the solution (``Jn`` (S, n, k) from ``jac_res``,
    default ``res``)."""
    jr = res if jac_res is None else jac_res
    z = np.array(z0, dtype=float)
    S, k = z.shape
    r = res(x, z, np.arange(S))
    cost = np.sum(r * r, axis=1)
    lam = np.full(S, 1e-3)
    eye = np.eye(k)
    act = np.arange(S)
    Jn = nuisance_jacobian(jr, x, z, act, None if jac_res is not None else r)
    for _ in range(max_iter):
        J = Jn[act]
        H = J.transpose(0, 2, 1) @ J
        grad = np.einsum("snk,sn->sk", J, r[act])
        dg = np.diagonal(H, axis1=1, axis2=2)
        floor = 1e-12 * np.maximum(dg.max(axis=1, keepdims=True), 1e-300)
        Dm = np.maximum(dg, floor)[:, :, None] * eye
        step = -np.linalg.solve(H + lam[act, None, None] * Dm + floor[:, :, None] * eye,
                                grad[:, :, None])[:, :, 0]  # fmt: skip
        zt = z[act] + step
        rt = res(x, zt, act)
        ct = np.sum(rt * rt, axis=1)
        ok = ct <= cost[act]
        gain = cost[act] - ct
        small = np.abs(step).max(axis=1) <= 1e-11 * (1.0 + np.abs(z[act]).max(axis=1))
        # converged: an accepted step that lowers the cost by a relative 1e-10 or less, or a
        # step below 1e-11 of the variables
        done = (ok & (gain <= 1e-10 * np.maximum(cost[act], 1e-300))) | small
        moved = act[ok]
        z[moved], r[moved], cost[moved] = zt[ok], rt[ok], ct[ok]
        lam[act] = np.where(ok, np.maximum(lam[act] * 0.2, 1e-12),
                            np.minimum(lam[act] * 10.0, 1e12))  # fmt: skip
        if moved.size:
            Jn[moved] = nuisance_jacobian(jr, x, z[moved], moved,
                                          None if jac_res is not None else r[moved])  # fmt: skip
        act = act[~done]
        if act.size == 0:
            break
    return z, r, Jn


@dataclass
class _Subset:
    """A :data:`Residual` over the segments ``idx`` of another only (index ``i`` here is
    segment ``idx[i]`` there)."""

    res: Residual
    idx: NDArray[np.int64]

    def __call__(self, x: NDArray[np.float64], z: NDArray[np.float64],
                 idx: NDArray[np.int64]) -> NDArray[np.float64]:  # fmt: skip
        return self.res(x, z, self.idx[idx])


@dataclass
class Reduced:
    """The reduced problem ``rho(x) = r(x, z*(x))`` for :func:`scipy.optimize.least_squares`:
    ``fun`` and ``jac`` (Kaufman's projected Jacobian).

    A segment's own problem can have spurious minima (a start-speed change that drives the
    first sample's duty into the clip or the current limit, where the residual no longer
    depends on it), so each segment's nuisances are solved from two starts, the first
    guesses ``z`` and ``warm``, those of the lowest cost met so far (or given): from ``warm``,
    then from ``z`` for the segments whose cost is more than 4 times the median segment's,
    and the lower of the two is kept (deterministic: so is the sequence of calls)."""

    res: Residual
    z: NDArray[np.float64]
    jac_res: Residual | None = None
    warm: NDArray[np.float64] | None = None
    best: float = np.inf
    _x: NDArray[np.float64] | None = None
    _zx: NDArray[np.float64] | None = None
    _rx: NDArray[np.float64] | None = None
    _Jn: NDArray[np.float64] | None = None

    def solve(self, x: NDArray[np.float64]) -> None:
        x = np.asarray(x, dtype=float)
        if self._x is not None and np.array_equal(x, self._x):
            return
        if self.warm is None:
            z, r, Jn = nuisance_solve(self.res, x, self.z, self.jac_res)
        else:
            z, r, Jn = nuisance_solve(self.res, x, self.warm, self.jac_res)
            cs = np.sum(r * r, axis=1)
            # the first guesses again for the segments far above the typical segment cost
            bad = np.flatnonzero(cs > 4.0 * np.median(cs))
            if bad.size:
                sub = _Subset(self.res, bad)
                jsub = None if self.jac_res is None else _Subset(self.jac_res, bad)
                z2, r2, J2 = nuisance_solve(sub, x, self.z[bad], jsub)
                b = np.sum(r2 * r2, axis=1) < cs[bad]
                z[bad[b]], r[bad[b]], Jn[bad[b]] = z2[b], r2[b], J2[b]
        c = float(np.sum(r * r))
        if c < self.best:
            self.best, self.warm = c, z.copy()
        self._x, self._zx, self._rx, self._Jn = x.copy(), z, r, Jn

    def fun(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        self.solve(x)
        assert self._rx is not None
        return self._rx.ravel()

    def state(self, x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                     NDArray[np.float64]]:  # fmt: skip
        """``(z*(x), r (S, n), Jn (S, n, k))``."""
        self.solve(x)
        assert self._zx is not None and self._rx is not None and self._Jn is not None
        return self._zx, self._rx, self._Jn

    def jac(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        z, r, Jn = self.state(x)
        jr = self.res if self.jac_res is None else self.jac_res
        A = global_jacobian(jr, np.asarray(x, dtype=float), z,
                            r if self.jac_res is None else None)  # fmt: skip
        Jt = project_out(Jn, A)
        return Jt.reshape(-1, Jt.shape[2])
