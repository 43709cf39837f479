"""The compiled control-law kernels equal their oracles (tests/oracle_laws.py, the NumPy forms
written from the book's equations) with every term driven by random, non-zero values.

Each ``*_mismatch(kernel)`` returns the largest scaled difference between ``kernel`` and its
oracle over random cases (random robots' coefficients, states, gains, references, times,
disturbance estimates; both switching functions, rows inside and outside the boundary
layer). The tests hold it below ``TOL``; benchmarks/mutate_kernels.py runs the same functions
on mutated kernels (every arithmetic sign and operator flipped, one at a time) and counts the
mutants they catch.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from mwip.fuzzy._kernel import _pairwise, fls_batch, pdc_weights_batch
from mwip.fuzzy.mamdani import MamdaniFLS, RuleBase, direction_controller, position_controller
from mwip.fuzzy.sets import UniformPartition
from mwip.laws.asta.kernel import asta_sample, asta_terms
from mwip.laws.fig53.kernel import ROW_WIDTH, fig53_law
from mwip.laws.smc.controller import SMCGains
from mwip.laws.smc.kernel import smc_step
from mwip.laws.switching import Switching
from mwip.laws.tsmc.kernel import tsmc_step
from mwip.models.reduced import coefficients
from mwip.observers._hodo_kernel import HOLD_CODES, hodo_update
from mwip.observers.hodo import discretize_observer
from mwip.params import NOMINAL, Params
from oracle_laws import (
    asta_step,
    asta_surface,
    augmenting,
    fig53,
    hodo_step,
    mamdani,
    pdc_weights,
    sliding_surface,
    smc_law,
    subsystem,
    surface_dynamics,
    tsmc_gain,
    tsmc_law,
    tsmc_surface,
)

TOL = 1e-9
N = 48
SEEDS = (0, 1, 2)


def _robot(rng: np.random.Generator) -> Params:
    """A random robot: every nominal parameter scaled by a factor in [0.7, 1.3]."""
    names = ("mb", "mw", "Iby", "Ibz", "Iwa", "Iwd", "l", "b", "r", "Db", "Dw")
    return replace(NOMINAL, **{k: float(getattr(NOMINAL, k)) * rng.uniform(0.7, 1.3)
                               for k in names})  # fmt: skip


def _nonzero(rng: np.random.Generator, lo: float, hi: float, shape: Any = None) -> Any:
    """Uniform magnitudes in [lo, hi] with random signs (never zero)."""
    return rng.uniform(lo, hi, shape) * rng.choice([-1.0, 1.0], shape)


def _states(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = _nonzero(rng, 0.05, 1.0, (N, 3))
    q[:, 1] = _nonzero(rng, 0.02, 0.6, N)  # pitch inside the model's range
    return q, _nonzero(rng, 0.1, 3.0, (N, 3))


def _err(got: np.ndarray, want: np.ndarray) -> float:
    scale = 1.0 + np.abs(want)
    return float(np.max(np.abs(got - want) / scale))


def _phi(s: np.ndarray) -> float:
    """A boundary layer with about half the rows inside it (the linear part of sat)."""
    return float(np.median(np.abs(s)))


def smc_mismatch(kernel: Callable[..., Any] = smc_step, seeds: tuple[int, ...] = SEEDS) -> float:
    """(3.49)-(3.50): the kernel vs ``sliding_surface`` + ``smc_law`` on ``f_g``."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        p = _robot(rng)
        c = np.ascontiguousarray(coefficients(p).reshape(-1))
        q, qd = _states(rng)
        tau = _nonzero(rng, 0.05, 2.0, (N, 3))
        lam = tuple(rng.uniform(0.2, 4.0, 4))
        K1, K2 = rng.uniform(0.5, 20.0, 2)
        t, q1d, q3d = rng.uniform(0.3, 5.0), _nonzero(rng, 0.2, 3.0), _nonzero(rng, 0.1, 1.0)
        from mwip.models.reduced import f_g

        F, G = f_g(p, q, qd)
        S = sliding_surface(q, qd, t, lam, q1d, q3d)
        for sw in (Switching("sign"), Switching("sat", _phi(S))):
            u, S_k = np.empty((N, 2)), np.empty((N, 2))
            kernel(c, q, qd, tau, t, np.array(lam), K1, K2, sw.kind == "sat", sw.phi, q1d, q3d,
                   u, S_k)  # fmt: skip
            uAB = smc_law(F, G, qd, S, tau, SMCGains(lam, K1, K2), sw, q1d)
            want = np.column_stack([0.5 * (uAB[:, 0] + uAB[:, 1]), 0.5 * (uAB[:, 0] - uAB[:, 1])])
            worst = max(worst, _err(S_k, S), _err(u, want))
    return worst


def asta_mismatch(kernel: Callable[..., Any] = asta_terms, seeds: tuple[int, ...] = SEEDS) -> float:
    """(4.1), (4.10)-(4.11): the kernel vs ``asta_surface`` and ``surface_dynamics``."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        p = _robot(rng)
        c = np.ascontiguousarray(coefficients(p).reshape(-1))
        q, qd = _states(rng)
        lam = rng.uniform(0.2, 10.0, 3)
        ref = np.concatenate([_nonzero(rng, 0.1, 2.0, 3), [0.0]])
        ref[3] = _nonzero(rng, 0.1, 1.0)
        s, a, b = (np.empty((N, 2)) for _ in range(3))
        kernel(c, q, qd, lam, ref, s, a, b)
        a_ref, b_ref = surface_dynamics(p, q, qd, lam)
        worst = max(worst, _err(s, asta_surface(q, qd, lam, ref)), _err(a, a_ref),
                    _err(b, b_ref))  # fmt: skip
    return worst


def _sigma_around(rng: np.random.Generator, eps: float) -> np.ndarray:
    """Sliding variables (N, 2) with random signs: a third far from the boundary layer
    (``|sigma|`` in [0.01, 3]), a third within 30 % of ``eps`` on either side, a few exactly
    at ``+-eps`` (the edge of (4.5), where the gain adapts) and a few exactly zero
    (``sgn 0 = 0``: no switching term, no integration; ``sigma_2 = 0`` at a start from rest)."""
    s = _nonzero(rng, 0.01, 3.0, (N, 2))
    near = rng.random((N, 2)) < 0.35
    s[near] = _nonzero(rng, 0.7 * eps, 1.3 * eps, int(near.sum()))
    s[:3, 0], s[3:6, 1] = eps * rng.choice([-1.0, 1.0], 3), eps * rng.choice([-1.0, 1.0], 3)
    s[6, 0] = s[7, 1] = s[8] = 0.0
    return s


def asta_sample_mismatch(
    kernel: Callable[..., Any] = asta_sample, seeds: tuple[int, ...] = SEEDS
) -> float:
    """(4.7), (4.4)-(4.5) and ASMC's law: the kernel vs ``asta_step`` over two consecutive
    samples (the torques and the updated ``Gamma``, ``w`` after each), ASTA and ASMC, rows
    inside, at and outside the boundary layer ``eps``; ``w`` grows and shrinks with the sign
    of ``sigma``, ``Gamma`` grows outside the layer and holds inside it."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        a, b = _nonzero(rng, 0.1, 5.0, (N, 2)), _nonzero(rng, 0.2, 3.0, (N, 2))
        K, rate = rng.uniform(0.3, 10.0, 2), rng.uniform(0.5, 8.0, 2)
        eps, Ts = rng.uniform(0.05, 0.5), rng.uniform(1e-3, 0.05)
        Gamma0, w0 = rng.uniform(0.1, 6.0, (N, 2)), _nonzero(rng, 0.05, 3.0, (N, 2))
        sigmas = [_sigma_around(rng, eps) for _ in range(2)]
        for asmc in (False, True):
            Gamma_k, w_k = Gamma0.copy(), w0.copy()
            Gamma_o, w_o = Gamma0.copy(), w0.copy()
            for s in sigmas:
                u = np.full((N, 2), np.nan)
                kernel(a, b, s, K, rate, eps, Ts, asmc, Gamma_k, w_k, u)
                u_o, Gamma_o, w_o = asta_step(a, b, s, K, rate, eps, Ts, asmc, Gamma_o, w_o)
                worst = max(worst, _err(u, u_o), _err(Gamma_k, Gamma_o), _err(w_k, w_o))
    return worst


def tsmc_mismatch(kernel: Callable[..., Any] = tsmc_step, seeds: tuple[int, ...] = SEEDS) -> float:
    """(4.30)-(4.32), (4.43): the kernel vs the oracle's subsystem, augmenting, surface, gain
    and law; before and after ``T_f``, fewer cubic sets than rows (row ``i`` uses ``i mod M``)."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        p = _robot(rng)
        c = np.ascontiguousarray(coefficients(p).reshape(-1))
        q, qd = _states(rng)
        M = N // 3
        coeffs = np.ascontiguousarray(_nonzero(rng, 0.05, 2.0, (M, 2, 4)))
        Tf = rng.uniform(0.5, 2.0)
        C = rng.uniform(0.3, 4.0, 2)
        Gam = rng.uniform(0.5, 20.0, 2)
        D = rng.uniform(0.05, 0.3, (2, 2))
        IDinv = np.ascontiguousarray(np.linalg.inv(np.eye(2) - D))
        ratio = rng.uniform(0.1, 1.0)
        refs = np.array([_nonzero(rng, 0.02, 0.2), _nonzero(rng, 0.1, 1.0),
                         _nonzero(rng, 0.1, 1.0)])  # fmt: skip
        t = rng.uniform(0.5, 3.0)
        rows = coeffs[np.arange(N) % M]
        F1, G1 = subsystem(p, q, qd)
        e = np.column_stack([q[:, 1] - refs[0], q[:, 2] - refs[1] - refs[2] * t])
        ed = np.column_stack([qd[:, 1], qd[:, 2] - refs[2]])
        for tau in (rng.uniform(0.05, 0.95) * Tf, Tf + rng.uniform(0.05, 1.0)):
            a, ad, add = augmenting(tau, rows, Tf)
            s = tsmc_surface(e, ed, a, ad, C)
            k = tsmc_gain(F1, F1 + C * ed - add - C * ad, ratio, D, Gam)
            for sw in (Switching("sign"), Switching("sat", _phi(s))):
                u, s_k, k_k, a_k = (np.empty((N, 2)) for _ in range(4))
                kernel(c, q, qd, t, tau, coeffs, Tf, C, ratio, D, IDinv, Gam, sw.kind == "sat",
                       sw.phi, refs, u, s_k, k_k, a_k)  # fmt: skip
                want = tsmc_law(F1, G1, ed, ad, add, 0.0, C, k, sw(s))
                worst = max(worst, _err(s_k, s), _err(k_k, k), _err(a_k, a), _err(u, want))
    return worst


def hodo_mismatch(
    kernel: Callable[..., Any] = hodo_update, seeds: tuple[int, ...] = SEEDS
) -> float:
    """The observer's sample update (3.20)-(3.23) vs ``hodo_step``: every hold, gains that keep
    the channels apart (diagonal ``L_i``: the structured product) and gains that couple them
    (dense ``Phi``); the previous measurement must become the new one."""
    worst = 0.0
    v = (22.9778, 357.2853, 1831.5, 5737.7)
    for seed in seeds:
        rng = np.random.default_rng(seed)
        p = _robot(rng)
        c = np.ascontiguousarray(coefficients(p).reshape(-1))
        qp, qdp = _states(rng)
        q, qd = _states(rng)
        u = _nonzero(rng, 0.05, 2.0, (N, 2))
        Ts = rng.uniform(0.001, 0.005)
        diag = [vi * np.diag(rng.uniform(0.8, 1.2, 3)) for vi in v]
        dense = [vi * (np.eye(3) + 0.03 * rng.normal(size=(3, 3))) for vi in v]
        for gains in (diag, dense):
            Phi, Gam = discretize_observer(gains, Ts)
            z = _nonzero(rng, 0.05, 5.0, (N, Phi.shape[0]))
            for hold, code in HOLD_CODES.items():
                zk, qpk, qdpk = z.copy(), qp.copy(), qdp.copy()
                kernel(c, Phi, Gam, Ts, code, zk, qpk, qdpk, q, qd, u, np.empty(Phi.shape[0]))
                want = hodo_step(p, Phi, Gam, Ts, hold, z, qp, qdp, q, qd, u)
                worst = max(worst, _err(zk, want), _err(qpk, q), _err(qdpk, qd))
    return worst


def _random_fls(rng: np.random.Generator, kind: str, n: int) -> MamdaniFLS:
    """A Mamdani FLS with ``n`` sets, random ranges, footprint, BMM weights and rule table
    (not symmetric: an exchange of the inputs or a transposed rule index shows)."""
    labels = tuple(f"S{k}" for k in range(n))
    parts = [UniformPartition(float(rng.uniform(0.2, 5.0)), n, float(rng.uniform(0.05, 0.45)),
                              labels) for _ in range(3)]  # fmt: skip
    table = tuple(tuple(labels[k] for k in row) for row in rng.integers(0, n, (n, n)))
    m = float(rng.uniform(0.2, 0.8))
    return MamdaniFLS(*parts, RuleBase(table, labels), kind, m, float(rng.uniform(0.2, 0.8)))


def fig53_mismatch(kernel: Callable[..., Any] = fig53_law, seeds: tuple[int, ...] = SEEDS) -> float:
    """Fig. 5.3 (5.7)-(5.10), Sec. 5.3.2: the kernel vs ``oracle_laws.fig53`` on random rows
    (kind, gains, targets on or off, wheel radius), random FLSs (3, 5, 7 or 13 sets: the
    pairwise sums above 128 rules too; plain and scaled direction blocks), inputs inside and
    beyond every range, a row offset and one row for all. The FLS outputs ``theta_off`` and
    ``u_alpha`` are computed with the oracle's operations in its order: any difference
    counts 1; ``u`` within round-off."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        fls: dict[str, tuple[MamdaniFLS, MamdaniFLS, tuple[float, float, float]]] = {}
        for kind in ("it2", "t1"):
            pos = _random_fls(rng, kind, int(rng.choice([3, 5, 7, 13])))
            plain = _random_fls(rng, kind, int(rng.choice([3, 5, 7, 13])))
            scaled = (float(rng.uniform(0.5, 4.0)), float(rng.uniform(0.5, 4.0)),
                      float(rng.uniform(0.1, 3.0)))  # fmt: skip
            fls[kind] = (pos, pos, scaled) if seed % 2 else (pos, plain, (1.0, 1.0, 1.0))
        blocks = [fls["it2"][0].block(), fls["t1"][0].block(),
                  *(fls[k][1].block(*fls[k][2]) for k in ("it2", "t1"))]  # fmt: skip
        fl = np.zeros((4, max(b.size for b in blocks)))
        for j, b in enumerate(blocks):
            fl[j, : b.size] = b
        first = 3
        rows = np.zeros((N + first, ROW_WIDTH))
        spec = []
        for i in range(N + first):
            kind = ("it2", "t1")[int(rng.integers(0, 2))]
            G = _nonzero(rng, 0.05, 50.0, (2, 4))
            p_d = _nonzero(rng, 0.1, 2.0) if rng.random() < 0.7 else None
            a_d = _nonzero(rng, 0.1, 1.0) if rng.random() < 0.7 else None
            r = rng.uniform(0.02, 0.2)
            rows[i] = [kind == "t1", *G.ravel(), p_d or 0.0, a_d or 0.0, p_d is not None,
                       a_d is not None, r]  # fmt: skip
            spec.append((G, kind, p_d, a_d, r))
        y = np.column_stack([_nonzero(rng, 0.1, 80.0, N), _nonzero(rng, 0.01, 0.8, N),
                             _nonzero(rng, 0.05, 6.0, N), _nonzero(rng, 0.1, 8.0, (N, 3)),
                             np.zeros((N, 2))])  # fmt: skip
        for tab, off in ((rows, first), (rows[first + 5 : first + 6], 0)):
            u, th, ua = np.empty((N, 2)), np.empty(N), np.empty(N)
            kernel(y, tab, fl, off, u, th, ua)
            for k in range(N):
                G, kind, p_d, a_d, r = spec[k + off] if tab.shape[0] > 1 else spec[first + 5]
                pos, dirn, sc = fls[kind]
                want = fig53(y[k : k + 1], G, kind, p_d, a_d, r, pos, dirn, sc)
                exact = th[k] == want[1][0] and ua[k] == want[2][0]
                worst = max(worst, _err(u[k], want[0][0]), 0.0 if exact else 1.0)
    return worst


def pairwise_mismatch(kernel: Callable[..., Any] = _pairwise) -> float:
    """The kernel's sum over the rules vs ``numpy.sum`` (pairwise summation) on dense random
    data of every length 8..600 and a few long ones, at an offset: 0 if every sum is bit for
    bit NumPy's, else 1 (the FLS's firing grids are sparse: a changed order rarely shows
    there)."""
    rng = np.random.default_rng(11)
    for n in [*range(8, 601), 1031, 4099]:
        a = rng.normal(size=n + 3) * rng.choice([1e-3, 1.0, 1e4], n + 3)
        if kernel(a, 3, n) != a[3:].sum():
            return 1.0
    return 0.0


def fls_mismatch(kernel: Callable[..., Any] = fls_batch, seeds: tuple[int, ...] = SEEDS) -> float:
    """``fls_batch`` (what ``MamdaniFLS.__call__`` runs) vs ``oracle_laws.mamdani`` on random
    FLSs (IT2 and type 1, 3 to 13 sets) and inputs inside and beyond the ranges: 0 if bit for
    bit equal, else 1."""
    for seed in seeds:
        rng = np.random.default_rng(100 + seed)
        for kind in ("it2", "t1"):
            for n in (3, 7, 13):
                fls = _random_fls(rng, kind, n)
                x1 = _nonzero(rng, 0.01, 1.3 * fls.in1.half_range, N)
                x2 = _nonzero(rng, 0.01, 1.3 * fls.in2.half_range, N)
                out = np.empty(N)
                kernel(x1, x2, fls.block(), out)
                if not np.array_equal(out, mamdani(fls, x1, x2)):
                    return 1.0
    return 0.0


def pdc_mismatch(kernel: Callable[..., Any] = pdc_weights_batch,
                 seeds: tuple[int, ...] = SEEDS) -> float:  # fmt: skip
    """The PDC weights (5.8) / type 1 of the kernel against ``oracle_laws.pdc_weights`` on
    pitches inside and beyond the model's domain, both kinds."""
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        theta = _nonzero(rng, 1e-3, 0.8, 4 * N)  # beyond pi/6 too (saturated)
        for kind in ("it2", "t1"):
            out = np.empty((theta.size, 2))
            kernel(theta, kind == "t1", out)
            worst = max(worst, _err(out, pdc_weights(theta, kind)))
    return worst


def test_pdc_weights_kernel_equals_oracle():
    assert pdc_mismatch() < TOL


def test_fls_batch_equals_oracle():
    assert fls_mismatch() == 0.0


def test_pairwise_sum_is_numpys():
    assert pairwise_mismatch() == 0.0


def test_fls_kernel_equals_oracle_on_the_book_fls():
    """MamdaniFLS.__call__ (the kernel) is the NumPy composition bit for bit: Table 5.1's
    position and direction FLSs, IT2 and type 1, on a grid beyond the ranges."""
    x1, x2 = np.meshgrid(np.linspace(-4.0, 4.0, 41), np.linspace(-5.0, 5.0, 37))
    for kind in ("it2", "t1"):
        for fls in (position_controller(kind), direction_controller(kind)):
            np.testing.assert_array_equal(fls(x1, x2), mamdani(fls, x1, x2))
            assert float(fls(0.3, -0.2)) == float(mamdani(fls, 0.3, -0.2))


def test_fig53_kernel_equals_oracle():
    assert fig53_mismatch() < TOL


def test_smc_kernel_equals_oracle():
    assert smc_mismatch() < TOL


def test_asta_kernel_equals_oracle():
    assert asta_mismatch() < TOL


def test_asta_sample_kernel_equals_oracle():
    assert asta_sample_mismatch() < TOL


def test_the_asta_sample_check_sees_the_boundary_layer():
    """Kernels that move the edge of (4.5)'s boundary layer are caught: adapting everywhere
    (``eps = 0``) and stopping at ``|sigma| = eps`` (``>`` for ``>=``, the rows exactly at
    ``+-eps``)."""

    def no_layer(a, b, s, K, rate, eps, *rest):  # noqa: ANN001, ANN202
        asta_sample(a, b, s, K, rate, 0.0, *rest)

    def open_edge(a, b, s, K, rate, eps, *rest):  # noqa: ANN001, ANN202
        asta_sample(a, b, s, K, rate, eps * (1.0 + 1e-12), *rest)

    assert asta_sample_mismatch(no_layer, seeds=(0,)) > 1e-4
    assert asta_sample_mismatch(open_edge, seeds=(0,)) > 1e-4


def test_tsmc_kernel_equals_oracle():
    assert tsmc_mismatch() < TOL


def test_hodo_kernel_equals_oracle():
    assert hodo_mismatch() < TOL


def test_the_check_can_fail():
    """A kernel that drops one term (the disturbance estimate of (3.50)) is caught."""

    def no_tau(c, q, qd, tau, *rest):  # noqa: ANN001, ANN202
        smc_step(c, q, qd, np.zeros_like(tau), *rest)

    assert smc_mismatch(no_tau, seeds=(0,)) > 1e-3


# ---- the packed laws: each family's ``step`` (mwip/laws/<family>/kernel.py) -----------------
# ``*_packed_mismatch(step)`` drives ``step`` with the controller's packed vectors over a
# sequence of random measurements and compares torques and logs with the controller's own
# ``__call__`` (the batch kernels, checked against the oracles above).
K_SAMPLES = 6
N_PACKED = 4
T0 = 0.37  # the run starts at t0 != 0 (TSMC's cubics run on t - t0)


def _drive(step: Callable[..., Any], law: Any, ys: np.ndarray, Ts: float
           ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    n = ys.shape[1]
    P, X = law.arrays(n)
    us = np.empty((ys.shape[0], n, 2))
    lgs = np.empty((ys.shape[0], n, law.log_width))
    ym, u, lg = np.empty((1, 8)), np.empty((1, 2)), np.zeros(law.log_width)
    for k in range(ys.shape[0]):
        for i in range(n):
            ym[0] = ys[k, i]
            step(P[i if P.shape[0] > 1 else 0], X[i], np.int64(k), T0 + k * Ts, ym, u, lg)
            us[k, i], lgs[k, i] = u[0], lg
    return us, lgs


def _own(ctrl: Any, law_of: Callable[[], Any], ys: np.ndarray, Ts: float
         ) -> tuple[Any, np.ndarray, np.ndarray]:  # fmt: skip
    from mwip.core import Measurement

    ctrl.reset(Measurement(T0, ys[0]))
    law = law_of()
    us = np.empty((ys.shape[0], ys.shape[1], 2))
    lgs = np.empty((ys.shape[0], ys.shape[1], law.log_width))
    for k in range(ys.shape[0]):
        us[k] = ctrl(T0 + k * Ts, Measurement(T0 + k * Ts, ys[k]))
        logs = ctrl.log()
        lgs[k] = np.column_stack([np.asarray(logs[name], dtype=float).reshape(ys.shape[1], -1)
                                  for name, _ in law.log_names]) if law.log_names else \
            np.zeros((ys.shape[1], 0))  # fmt: skip
    return law, us, lgs


def _measurements(rng: np.random.Generator) -> np.ndarray:
    ys = np.empty((K_SAMPLES, N_PACKED, 8))
    for k in range(K_SAMPLES):
        q, qd = _states(rng)
        ys[k, :, 0:3], ys[k, :, 3:6] = q[:N_PACKED], qd[:N_PACKED]
        ys[k, :, 6:8] = _nonzero(rng, 0.1, 2.0, (N_PACKED, 2))
    return ys


def _packed_mismatch(step: Callable[..., Any], make: Callable[[np.random.Generator], Any],
                     seeds: tuple[int, ...]) -> float:  # fmt: skip
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        ctrl = make(rng)
        ys = _measurements(rng)
        law, u_own, lg_own = _own(ctrl, ctrl.packed_law, ys, 0.005)
        u, lg = _drive(step, law, ys, 0.005)
        worst = max(worst, _err(u, u_own), _err(lg, lg_own) if lg.size else 0.0)
    return worst


def _lqr_ctrl(rng: np.random.Generator) -> Any:
    from mwip.laws.lqr.controller import LQR, design_lqr

    Q = np.diag(rng.uniform(1.0, 1000.0, 5))
    R = np.diag(rng.uniform(0.005, 0.1, 2))
    return LQR(design_lqr(_robot(rng), Q, R, Ts=0.005),
               reference=(0.0, 0.0, 0.0, float(rng.uniform(-1, 1)), 0.0))  # fmt: skip


def _smc_ctrl(rng: np.random.Generator) -> Any:
    from mwip.laws.smc.controller import make_smc

    kind = ("smc", "do1smc", "hodosmc")[int(rng.integers(3))]
    obs = {"smc": None, "do1smc": [float(rng.uniform(20, 80))],
           "hodosmc": [5.0, 30.0, 80.0]}[kind]  # fmt: skip
    return make_smc(kind, tuple(rng.uniform(0.05, 3.0, 4)), K=tuple(rng.uniform(1.0, 20.0, 2)),
                    observer_gains=obs, params=_robot(rng), Ts=0.005,
                    switching=Switching(("sat", "sign")[int(rng.integers(2))],
                                        float(rng.uniform(0.01, 0.5))),
                    q1d_dot=float(_nonzero(rng, 0.1, 5.0)), q3d=float(_nonzero(rng, 0.1, 1.0)),
                    check=False)  # fmt: skip


def _asta_ctrl(rng: np.random.Generator) -> Any:
    from mwip.laws.asta.controller import ASMC, ASTA, check_constraints

    cls = (ASTA, ASMC)[int(rng.integers(2))]
    robot = _robot(rng)
    lam = np.array([10.0, 0.3, 3.0]) * rng.uniform(0.8, 1.2, 3)
    while not check_constraints(robot, lam):  # (4.2)
        lam = np.array([10.0, 0.3, 3.0]) * rng.uniform(0.8, 1.2, 3)
    return cls(robot, lam=tuple(lam),
               K=tuple(rng.uniform(1.0, 10.0, 2)), rate=tuple(rng.uniform(0.5, 5.0, 2)),
               Gamma0=tuple(rng.uniform(0.0, 2.0, 2)), eps=float(rng.uniform(0.0, 0.5)),
               psi_dot_ref=float(_nonzero(rng, 0.1, 5.0)),
               theta_ref=float(_nonzero(rng, 0.01, 0.1)),
               alpha_ref=float(_nonzero(rng, 0.1, 1.0)), Ts=0.005)  # fmt: skip


def _tsmc_ctrl(rng: np.random.Generator) -> Any:
    from mwip.laws.tsmc.controller import TSMC

    return TSMC(_robot(rng), C=tuple(rng.uniform(0.5, 5.0, 2)),
                Gamma=tuple(rng.uniform(1.0, 20.0, 2)), D=float(rng.uniform(0.0, 0.8)),
                Ftilde_ratio=float(rng.uniform(0.0, 1.0)), Tf=float(rng.uniform(0.01, 0.05)),
                switching=Switching(("sat", "sign")[int(rng.integers(2))],
                                    float(rng.uniform(0.01, 0.5))),
                theta_ref=float(_nonzero(rng, 0.01, 0.1)),
                alpha_ref=float(_nonzero(rng, 0.1, 1.0)),
                alpha_dot_ref=float(_nonzero(rng, 0.1, 1.0)), Ts=0.005)  # fmt: skip


def _fig53_ctrl(rng: np.random.Generator) -> Any:
    from mwip.laws.registry import build

    kind = ("it2", "t1")[int(rng.integers(2))]
    return build(kind, NOMINAL, {"p_d": float(_nonzero(rng, 0.1, 1.0)),
                                 "alpha_d": float(_nonzero(rng, 0.1, 1.0))}, Ts=0.005)


def lqr_mismatch(kernel: Callable[..., Any] | None = None, seeds: tuple[int, ...] = SEEDS
                 ) -> float:  # fmt: skip
    """``lqr_law`` against ``y[:, :6] @ gain + offset`` (NumPy)."""
    from mwip.laws.lqr.kernel import lqr_law

    kernel = kernel or lqr_law
    worst = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        y = _nonzero(rng, 0.05, 2.0, (N, 8))
        gain, offset = _nonzero(rng, 0.1, 50.0, (6, 2)), _nonzero(rng, 0.1, 5.0, 2)
        u = np.empty((N, 2))
        kernel(y, gain, offset, u)
        worst = max(worst, _err(u, y[:, :6] @ gain + offset))
    return worst


def lqr_packed_mismatch(step: Callable[..., Any] | None = None,
                        seeds: tuple[int, ...] = SEEDS) -> float:  # fmt: skip
    from mwip.laws.lqr.kernel import step as default

    return _packed_mismatch(step or default, _lqr_ctrl, seeds)


def smc_packed_mismatch(step: Callable[..., Any] | None = None,
                        seeds: tuple[int, ...] = (0, 1, 2, 3, 4, 5)) -> float:  # fmt: skip
    from mwip.laws.smc.kernel import step as default

    return _packed_mismatch(step or default, _smc_ctrl, seeds)


def asta_packed_mismatch(step: Callable[..., Any] | None = None,
                         seeds: tuple[int, ...] = SEEDS) -> float:  # fmt: skip
    from mwip.laws.asta.kernel import step as default

    return _packed_mismatch(step or default, _asta_ctrl, seeds)


def tsmc_packed_mismatch(step: Callable[..., Any] | None = None,
                         seeds: tuple[int, ...] = SEEDS) -> float:  # fmt: skip
    from mwip.laws.tsmc.kernel import step as default

    return _packed_mismatch(step or default, _tsmc_ctrl, seeds)


def fig53_packed_mismatch(step: Callable[..., Any] | None = None,
                          seeds: tuple[int, ...] = (0, 1)) -> float:  # fmt: skip
    from mwip.laws.fig53.kernel import step as default

    return _packed_mismatch(step or default, _fig53_ctrl, seeds)


def test_lqr_kernel_equals_oracle():
    assert lqr_mismatch() < TOL


def test_packed_steps_equal_the_controllers():
    """Each family's packed ``step`` (the compiled loop's law) gives the controller's own
    torques and logs over a sequence of samples (observer and adaptive state carried in the
    state vector)."""
    for check in (lqr_packed_mismatch, smc_packed_mismatch, asta_packed_mismatch,
                  tsmc_packed_mismatch, fig53_packed_mismatch):  # fmt: skip
        assert check() < TOL, check.__name__


def test_the_packed_check_can_fail():
    """A step that forgets the observer's state between samples is caught."""
    from mwip.laws.smc.kernel import step

    def amnesic(p, x, k, t, ym, u, lg):  # noqa: ANN001, ANN202
        x[:] = 0.0
        step(p, x, k, t, ym, u, lg)

    assert smc_packed_mismatch(amnesic, seeds=(2, 3, 4, 5)) > 1e-6
