"""Convergence diagnostics of a set of Markov chains: effective sample size and split R-hat.

For ``C`` chains of ``M`` draws ``x[c, m]`` of one quantity (Gelman et al., *Bayesian Data
Analysis*, 3rd ed., Sec. 11.4-11.5; Vehtari, Gelman, Simpson, Carpenter & Buerkner 2021,
"Rank-normalization, folding, and localization: an improved R-hat", Bayesian Analysis 16(2),
without the rank normalisation):

- ``W`` the mean within-chain variance (``ddof = 1``), ``B / M`` the variance of the chain
  means, ``var+ = (M - 1) / M W + B / M``;
- the lag-``t`` autocorrelation over all chains ``rho_t = 1 - (W - mean_c gamma_c(t)) / var+``
  with ``gamma_c`` chain ``c``'s autocovariance (FFT, biased ``1 / M`` normalisation);
- Geyer's (1992) initial monotone sequence: the sums ``P_k = rho_{2k} + rho_{2k+1}`` while
  positive, made non-increasing; ``tau = -1 + 2 sum_k P_k``; ``ESS = C M / tau``, at most
  ``C M log10(C M)`` (Stan's cap against antithetic chains);
- split R-hat: each chain cut in halves, ``R = sqrt(var+ / W)`` over the ``2 C`` halves.

A quantity constant over every draw has no defined ESS: :func:`ess` returns ``nan`` (callers
fall back to the smallest ESS of the quantities that vary).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["autocovariance", "ess", "split_rhat"]


def autocovariance(x: ArrayLike) -> NDArray[np.float64]:
    """Biased autocovariance ``gamma(t) = 1/M sum_m (x_m - xbar)(x_{m+t} - xbar)`` of a 1-D
    series, all lags ``0 .. M - 1`` (by FFT, zero-padded to avoid wrap-around)."""
    v = np.asarray(x, dtype=float)
    m = v.size
    z = v - v.mean()
    n = 1 << (2 * m - 1).bit_length()
    f = np.fft.rfft(z, n)
    return np.fft.irfft(f * np.conj(f), n)[:m] / m


def _chains(x: ArrayLike) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=float)
    if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 4:
        raise ValueError(f"chains must be (C, M) with M >= 4 draws, got shape {a.shape}")
    return a


def ess(x: ArrayLike) -> float:
    """Effective sample size of the draws ``x`` (C chains, M draws each; module docstring)."""
    a = _chains(x)
    c, m = a.shape
    w = float(np.mean(np.var(a, axis=1, ddof=1)))
    b_over_m = float(np.var(a.mean(axis=1), ddof=1)) if c > 1 else 0.0
    var_plus = (m - 1) / m * w + b_over_m
    if not var_plus > 0:
        return float("nan")
    gamma = np.mean([autocovariance(row) for row in a], axis=0)
    rho = 1.0 - (w - gamma) / var_plus
    rho[0] = 1.0
    total = 0.0
    prev = np.inf
    for k in range(m // 2):
        p = rho[2 * k] + rho[2 * k + 1] if 2 * k + 1 < m else rho[2 * k]
        if p <= 0:
            break
        p = min(p, prev)  # initial monotone sequence
        total += p
        prev = p
    tau = -1.0 + 2.0 * total
    n = c * m
    return float(min(n / tau, n * np.log10(n))) if tau > 0 else float(n * np.log10(n))


def split_rhat(x: ArrayLike) -> float:
    """Split R-hat of the draws ``x`` (C, M): each chain halved, ``sqrt(var+ / W)``;
    ``nan`` for a quantity constant within every half."""
    a = _chains(x)
    h = a.shape[1] // 2
    halves = np.concatenate([a[:, :h], a[:, a.shape[1] - h:]], axis=0)
    m = halves.shape[1]
    w = float(np.mean(np.var(halves, axis=1, ddof=1)))
    b_over_m = float(np.var(halves.mean(axis=1), ddof=1))
    if not w > 0:
        return float("nan")
    return float(np.sqrt(((m - 1) / m * w + b_over_m) / w))
