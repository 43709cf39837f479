"""IT2 parallel distributed compensation (PDC) balance control, (5.9)-(5.26).

Controller (5.9)-(5.10): rule i "if theta is M_i then u = G_i x", defuzzified by Nie-Tan:
``u = sum_i m_i(theta) G_i x`` with ``x = [theta, theta', psi, psi']`` and ``u = u_r + u_l``
(the total wheel torque, N m; each wheel gets ``u / 2``). Closed loop (5.11):
``x' = sum_ij m_i m_j K_ij x``, ``K_ij = A_i + B_i G_j``.

LMI design (Lemma 5.1, (5.12)), in the variables of (5.16)-(5.19): ``Q = P^{-1}``,
``N_i = -G_i Q`` (so ``G_i = -N_i Q^{-1}``), ``Y_ij = Q W_ij Q``::

    Q > 0,     Y = [[Y11, Y12], [Y12, Y22]] > 0                                    (5.19)
    Q A_i^T + A_i Q - N_i^T B_i^T - B_i N_i + Y_ii < 0          i = 1, 2
    Q A_i^T + A_i Q - N_j^T B_i^T - B_i N_j + Y_12 <= 0         i != j

(the extraction loses (5.16)-(5.18); this is the congruence of (5.12) with ``Q``, the only
reading in which the printed (5.19) is linear). ``W12`` appears in both off-diagonal blocks of
``W`` in (5.12), so ``Y12`` is symmetric and shared by ``K_12`` and ``K_21``.

Input bound (Lemma 5.2, (5.20)): for ``||x0|| <= epsilon``::

    epsilon^2 I <= Q,     [[Q, N_i^T], [N_i, rho^2]] >= 0     =>   |u(t)| <= rho  (5.26)

(the lemma needs ``V`` non-increasing along the closed loop, which Lemma 5.1 gives for the
TS model; the Schur step (5.23)-(5.24) gives ``G_i^T G_i <= rho^2 P`` and (5.25) uses
convexity of ``x -> (sum m_i G_i x)^2``).

Strict inequalities carry an explicit margin (``margin`` times the identity). The LMIs are
homogeneous in ``(Q, N, Y)``; without (5.20) we normalise by ``Q >= I`` (any feasible point
can be scaled to it), so the margin has a meaning. Solved with cvxpy, Clarabel by default;
the status is reported; infeasibility raises :class:`PDCInfeasibleError` (one-line message).

Every returned design is verified, whatever the solver's status (``optimal_inaccurate``
included): :func:`verify_design` recomputes the LMI residuals at the solved point
(:func:`check_design`) and the vertex closed loops ``K_ii = A_i + B_i G_i`` of every model,
and raises :class:`PDCInfeasibleError` naming what fails. (A status is the solver's opinion:
near the edge of feasibility, e.g. epsilon = 0.2, rho = 0.47097 on the literal-damping
nominal model, Clarabel reports ``optimal_inaccurate`` for a point whose (5.12) residual is
positive and whose vertex loop 1 is unstable.)
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.fuzzy.ts_model import Reading, TSModel, first_weight, vertex_matrices
from mwip.params import NOMINAL, Params

if TYPE_CHECKING:  # cvxpy (~2 s to import) is loaded only when an LMI is solved
    import cvxpy as cp

__all__ = [
    "PDCInfeasibleError",
    "PDCDesign",
    "BOOK_G1",
    "BOOK_G2",
    "design_pdc",
    "uncertainty_models",
    "check_design",
    "verify_design",
    "pdc_gain",
    "PDCBalance",
]

#: The book's printed gains (Section 5.4), ``u = G_i x`` on ``[theta, theta', psi, psi']``.
BOOK_G1 = (-3.19e4, -807.0, 90.5, -28.6)
BOOK_G2 = (-1.8e5, -1.6e3, 734.6, 89.9)


class PDCInfeasibleError(RuntimeError, ValueError):
    """The LMIs of Lemma 5.1 (and 5.2) have no solution, or the solver failed (also a
    ``ValueError``: the settings asked for admit no design; the CLI answers exit 2)."""


@dataclass(frozen=True)
class PDCDesign:
    """A solved PDC design. ``G`` (2, 4): rows ``G1, G2``; ``P = Q^{-1}``; ``W`` (8, 8)."""

    G: NDArray[np.float64]
    P: NDArray[np.float64]
    Q: NDArray[np.float64]
    N: NDArray[np.float64]
    Y: NDArray[np.float64]
    W: NDArray[np.float64]
    status: str
    solver: str
    epsilon: float | None
    rho: float | None
    margin: float
    model: TSModel = field(repr=False)
    decay: float = 0.0
    n_models: int = 1

    @property
    def G1(self) -> NDArray[np.float64]:
        return self.G[0]

    @property
    def G2(self) -> NDArray[np.float64]:
        return self.G[1]

    def closed_loop(self) -> NDArray[np.float64]:
        """``K_ij = A_i + B_i G_j`` (2, 2, 4, 4), (5.11)."""
        A, B = self.model.A, self.model.B
        return A[:, None] + B[:, None] @ self.G[None, :, None, :]


def _sym(M: cp.Expression) -> cp.Expression:
    return 0.5 * (M + M.T)


def uncertainty_models(
    p: Params = NOMINAL,
    rel: float = 0.35,
    names: Sequence[str] = ("r", "mb", "l"),
    reading: Reading = "sector",
) -> list[TSModel]:
    """Nominal TS model plus one per parameter in ``names`` scaled by ``1 -+ rel`` (ours).

    Passed as ``model=`` to :func:`design_pdc`, the LMIs are imposed at every vertex of every
    model with a common ``Q, N_i`` (quadratic stability of the whole set). This is our
    robustness extension, not the book's: the nominal-only design of Lemma 5.1 leaves so
    little margin that it does not balance the real-parameter plant (r 0.04 vs 0.03 m);
    see docs/fuzzy.md. Only nominal values and a stated relative uncertainty are used.
    """
    if not (0.0 <= rel < 1.0):
        raise ValueError(f"rel must be in [0, 1), got {rel!r}")
    out = [vertex_matrices(p, reading)]
    for name in names:
        base = float(getattr(p, name))
        for s in (1.0 - rel, 1.0 + rel):
            out.append(vertex_matrices(dataclasses.replace(p, **{name: base * s}), reading))
    return out


def design_pdc(
    model: TSModel | Sequence[TSModel] | None = None,
    *,
    epsilon: float | None = None,
    rho: float | None = None,
    margin: float = 1e-6,
    solver: str = "CLARABEL",
    params: Params = NOMINAL,
    reading: Reading = "sector",
    decay: float = 0.0,
    **solver_options: Any,
) -> PDCDesign:
    """Solve the LMIs of Lemma 5.1 (5.12)/(5.19), plus (5.20) when ``epsilon, rho`` are given.

    ``model`` defaults to :func:`~mwip.fuzzy.ts_model.vertex_matrices` of ``params`` (nominal)
    with the given ``reading``; a sequence of models imposes the LMIs on all of them with a
    common ``Q, N_i`` (see :func:`uncertainty_models`); ``P, W`` refer to the first.
    ``decay > 0`` (our option, not the book's) replaces ``A_i`` by ``A_i + decay I`` in the
    LMIs, which certifies ``V' <= -2 decay V``; the default 0 is Lemma 5.1 as printed.
    Raises :class:`PDCInfeasibleError` when the solver does not report an optimal (feasible)
    point or the point fails :func:`verify_design`, and ``ValueError`` for bad arguments.

    A design solved before with the same models, settings, solver versions and this module's
    source is read from :mod:`mwip.cache` and verified again instead of solved (cvxpy is then
    not even imported; ``MWIP_CACHE=off`` always solves).
    """
    for name, val in (("epsilon", epsilon), ("rho", rho)):
        if val is not None and not (np.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be a finite positive number, got {val!r}")
    if (epsilon is None) != (rho is None):
        raise ValueError("give both epsilon and rho (Lemma 5.2) or neither")
    if not (np.isfinite(decay) and decay >= 0):
        raise ValueError(f"decay must be finite and >= 0, got {decay!r}")
    if not (np.isfinite(margin) and margin > 0):
        raise ValueError(f"margin must be finite and > 0, got {margin!r}")
    if model is None:
        models: list[TSModel] = [vertex_matrices(params, reading)]
    elif isinstance(model, TSModel):
        models = [model]
    else:
        models = list(model)
        if not models or not all(isinstance(m, TSModel) for m in models):
            raise ValueError("model must be a TSModel or a non-empty sequence of TSModels")
    ts = models[0]
    key = _design_key(models, epsilon, rho, margin, solver, decay, solver_options)
    cached = _cached_design(key, models, epsilon, rho, margin, solver, decay)
    if cached is not None:
        return cached
    from mwip.notice import once

    once("pdc", "solving the IT2 PDC LMI design with cvxpy (Theorem 5.1; once per design: "
         "the result is cached, seconds to a minute)")  # fmt: skip
    import cvxpy as cp

    n = ts.A.shape[-1]
    Qv = cp.Variable((n, n), symmetric=True)
    Nv = [cp.Variable((1, n)) for _ in range(2)]
    eye = np.eye(n)
    cons = [Qv >> (epsilon**2 if epsilon is not None else 1.0) * eye]
    Ys = []
    for mdl in models:
        A, B = mdl.A, mdl.B
        Ai = A + decay * eye  # decay > 0: V' <= -2 decay V (our option; 0 = the book's)
        Yv = cp.Variable((2 * n, 2 * n), symmetric=True)
        Ys.append(Yv)
        Y11, Y12, Y22 = Yv[:n, :n], Yv[:n, n:], Yv[n:, n:]
        Yd = (Y11, Y22)
        cons += [Yv >> margin * np.eye(2 * n), Y12 == Y12.T]
        for i in range(2):
            for j in range(2):
                He = _sym(Qv @ Ai[i].T + Ai[i] @ Qv - Nv[j].T @ B[i].T - B[i] @ Nv[j])
                if i == j:
                    cons.append(He + Yd[i] << -margin * eye)
                else:
                    cons.append(_sym(He + Y12) << 0)
    if rho is not None:
        for i in range(2):
            cons.append(cp.bmat([[Qv, Nv[i].T], [Nv[i], np.array([[rho**2]])]]) >> 0)
    prob = cp.Problem(cp.Minimize(0), cons)
    try:
        with warnings.catch_warnings():  # "may be inaccurate": verify_design decides below
            warnings.filterwarnings("ignore", message="Solution may be inaccurate")
            prob.solve(solver=solver, **solver_options)
    except cp.error.SolverError as exc:
        raise PDCInfeasibleError(f"solver {solver} failed: {exc}".splitlines()[0]) from None
    status = str(prob.status)
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or Qv.value is None:
        what = "" if epsilon is None else f" with epsilon={epsilon:g}, rho={rho:g}"
        raise PDCInfeasibleError(f"PDC LMIs (5.12)/(5.19){'/(5.20)' * (rho is not None)}"
                                 f" infeasible{what}: solver status {status}")  # fmt: skip
    Q = 0.5 * (Qv.value + Qv.value.T)
    P = np.linalg.inv(Q)
    P = 0.5 * (P + P.T)
    N = np.vstack([np.asarray(Nv[0].value), np.asarray(Nv[1].value)])
    G = -N @ P
    Y0 = np.asarray(Ys[0].value)
    Y = 0.5 * (Y0 + Y0.T)
    T = np.kron(np.eye(2), P)
    W = T @ Y @ T
    design = PDCDesign(
        G=G, P=P, Q=Q, N=N, Y=Y, W=0.5 * (W + W.T), status=status, solver=solver,
        epsilon=epsilon, rho=rho, margin=margin, model=ts, decay=decay,
        n_models=len(models),
    )  # fmt: skip
    verify_design(design, models)
    from mwip.cache import save_arrays

    arrays = {k: getattr(design, k) for k in _ARRAYS}
    save_arrays("pdc", key, {**arrays, "status": np.array(status), "n_models": len(models)})
    return design


_ARRAYS = ("G", "P", "Q", "N", "Y", "W")


def _design_key(models: Sequence[TSModel], *settings: Any) -> str:
    """The cache name of a design: this module's source, cvxpy's and the solver's versions,
    every model's matrices and the settings (:mod:`mwip.cache`)."""
    from mwip.cache import digest, versions

    arrays = [a for m in models for a in (m.A, m.B)]
    return digest([Path(__file__), *versions(["cvxpy", "clarabel", "scs"]), *arrays, *settings])


def _cached_design(key: str, models: Sequence[TSModel], epsilon: float | None,
                   rho: float | None, margin: float, solver: str,
                   decay: float) -> PDCDesign | None:  # fmt: skip
    """The design solved before with the same inputs, checked again by :func:`verify_design`
    (an entry that fails it is ignored); ``None`` if there is none. Saves loading cvxpy and
    solving the LMIs (~2.5 s) on every run of a fuzzy controller."""
    from mwip.cache import load_arrays

    z = load_arrays("pdc", key)
    if z is None or not set(_ARRAYS) <= set(z):
        return None
    design = PDCDesign(
        **{k: np.asarray(z[k], dtype=float) for k in _ARRAYS}, status=str(z["status"]),
        solver=solver, epsilon=epsilon, rho=rho, margin=margin, model=models[0], decay=decay,
        n_models=int(z["n_models"]),
    )  # fmt: skip
    try:
        verify_design(design, models)
    except PDCInfeasibleError:
        return None
    return design


#: Feasibility tolerance of the non-strict LMIs in :func:`verify_design` (relative, as
#: :func:`check_design` scales them): what an interior-point solver's "optimal" leaves.
CHECK_TOL = 1e-7


def verify_design(d: PDCDesign, models: Sequence[TSModel] | None = None) -> None:
    """Check a solved design; raise :class:`PDCInfeasibleError` (one line) if it fails.

    At the solved point (:func:`check_design`): ``P > 0``, ``W > 0`` and the diagonal LMIs of
    (5.12) negative definite (strict: ``< 0``); the cross LMIs of (5.12), the ball
    ``epsilon^2 I <= Q`` and the input bound (5.20) within :data:`CHECK_TOL`. And the vertex
    closed loops ``K_ii = A_i + B_i G_i`` (5.11) Hurwitz for every model in ``models``
    (default: the design's own). The status does not exempt a point from these checks.
    """
    c = check_design(d)
    bad = [f"{k} = {c[k]:.3g} (must be > 0)" for k in ("P_min", "W_min") if not c[k] > 0]
    if not c["lmi_ii"] < 0:
        bad.append(f"lmi_ii = {c['lmi_ii']:.3g} (must be < 0)")
    for k in ("lmi_ij", "input"):
        if k in c and not c[k] <= CHECK_TOL:
            bad.append(f"{k} = {c[k]:.3g} (must be <= {CHECK_TOL:g})")
    if "eps_ball" in c and not c["eps_ball"] <= CHECK_TOL * d.epsilon**2:  # type: ignore[operator]
        bad.append(f"eps_ball = {c['eps_ball']:.3g} (must be <= 0)")
    for m, mdl in enumerate(models if models is not None else [d.model]):
        for i in range(2):
            lam = float(np.linalg.eigvals(mdl.A[i] + np.outer(mdl.B[i], d.G[i])).real.max())
            if not lam < 0:
                which = f"vertex loop {i + 1}" + (f" of model {m + 1}" if m else "")
                bad.append(f"{which} unstable (max Re eig = {lam:.3g})")
    if bad:
        what = "" if d.epsilon is None else f" (epsilon={d.epsilon:g}, rho={d.rho:g})"
        raise PDCInfeasibleError(
            f"PDC design{what} fails its check (solver status {d.status}): " + "; ".join(bad)
        )


def check_design(d: PDCDesign) -> dict[str, float]:
    """Largest eigenvalues of the LMIs (5.12), (5.19), (5.20) at the solved point.

    Returned as a flat dict (negative = satisfied): ``P_min`` / ``W_min`` (smallest
    eigenvalues, must be > 0), ``lmi_ii`` / ``lmi_ij`` (largest eigenvalue of
    ``K^T P + P K + W``, must be < 0 resp. <= 0, relative to ``||P||``), ``hurwitz`` (largest
    real part over the four ``K_ij``), and for (5.20) ``eps_ball`` (``epsilon^2 - lambda_min(Q)``)
    and ``input`` (``max_i lambda_max(G_i^T G_i - rho^2 P)`` relative to ``rho^2 ||P||``).
    """
    K = d.closed_loop()
    n = d.P.shape[0]
    Wb = [[d.W[:n, :n], d.W[:n, n:]], [d.W[n:, :n], d.W[n:, n:]]]
    scale = np.linalg.norm(d.P, 2)
    out: dict[str, float] = {
        "P_min": float(np.linalg.eigvalsh(d.P)[0]),
        "W_min": float(np.linalg.eigvalsh(d.W)[0]),
    }
    ii: list[float] = []
    ij: list[float] = []
    for i in range(2):
        for j in range(2):
            M = K[i, j].T @ d.P + d.P @ K[i, j] + (Wb[i][i] if i == j else Wb[0][1])
            lam = float(np.linalg.eigvalsh(0.5 * (M + M.T))[-1] / scale)
            (ii if i == j else ij).append(lam)
    out["lmi_ii"] = max(ii)
    out["lmi_ij"] = max(ij)
    out["hurwitz"] = float(max(np.linalg.eigvals(K[i, j]).real.max() for i in range(2)
                               for j in range(2)))  # fmt: skip
    if d.epsilon is not None and d.rho is not None:
        out["eps_ball"] = float(d.epsilon**2 - np.linalg.eigvalsh(d.Q)[0])
        out["input"] = float(
            max(float(np.linalg.eigvalsh(np.outer(g, g) - d.rho**2 * d.P)[-1]) for g in d.G)
            / (d.rho**2 * scale)
        )
    return out


def pdc_gain(G: ArrayLike, theta: ArrayLike, *, type1: bool = False) -> NDArray[np.float64]:
    """Blended gain ``sum_i m_i(theta) G_i`` (5.10), (..., 4); ``type1``: the T1 counterpart."""
    G = np.asarray(G, dtype=float)
    m1 = first_weight(theta, type1=type1)[..., None]
    return G[1] + m1 * (G[0] - G[1])


class PDCBalance:
    """The PDC balance controller (5.10) as a static state feedback on measurements.

    ``x = [theta - theta_off, theta', psi - psi_ref, psi']``; ``u = u_r + u_l`` split equally.
    ``kind="it2"`` uses the Nie-Tan weights of Fig. 5.1, ``"t1"`` the type-1 counterpart
    (M1 at the middle of the footprint). ``psi_ref=None`` drops the wheel-angle feedback
    (used when a position controller closes that loop through ``theta_off``, Fig. 5.3).
    Static: runs sampled at any ``Ts`` or inside the right-hand side (``mode="continuous"``).
    """

    static = True

    def __init__(
        self,
        design: PDCDesign | ArrayLike,
        *,
        kind: str = "it2",
        theta_off: float = 0.0,
        psi_ref: float | None = 0.0,
        Ts: float | None = None,
    ) -> None:
        G = design.G if isinstance(design, PDCDesign) else np.asarray(design, dtype=float)
        if G.shape != (2, 4) or not np.all(np.isfinite(G)):
            raise ValueError(f"gains must be a finite (2, 4) array, got shape {G.shape}")
        if kind not in ("it2", "t1"):
            raise ValueError(f"kind must be 'it2' or 't1', got {kind!r}")
        self.G = G
        self.kind = kind
        self.theta_off = float(theta_off)
        self.psi_ref = psi_ref
        self.Ts = Ts
        self._last_u = np.zeros((0,))

    def reset(self, meas: Measurement) -> None:
        """Nothing to reset (static law)."""

    def state(self, meas: Measurement, theta_off: ArrayLike | None = None) -> NDArray[np.float64]:
        """``x = [theta - theta_off, theta', psi - psi_ref, psi']`` (N, 4)."""
        y = meas.y
        x = y[:, [1, 4, 0, 3]]
        x[:, 0] -= self.theta_off if theta_off is None else np.asarray(theta_off, dtype=float)
        if self.psi_ref is None:
            x[:, 2] = 0.0
        else:
            x[:, 2] -= self.psi_ref
        return x

    def total_torque(
        self, meas: Measurement, theta_off: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """``u = sum_i m_i(theta) G_i x`` (N,), (5.10). Memberships use the measured theta."""
        x = self.state(meas, theta_off)
        K = pdc_gain(self.G, meas.y[:, 1], type1=self.kind == "t1")
        return (K * x).sum(-1)

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        u = self.total_torque(meas)
        self._last_u = u
        return np.repeat(0.5 * u[:, None], 2, axis=1)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return {"u_total": self._last_u}
