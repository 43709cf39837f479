"""Design checks of the sliding surface (3.49): conditions (3.52) and Hurwitz test (3.66).

On the surface ``S1 = 0`` (ideal disturbance compensation) the pitch/wheel motion obeys (3.59)
``q2'' + l1 q2' + l2 (q1' - q1d') + l3 q1'' = 0`` together with the sum of the first two rows
of (2.34), in which the input cancels (3.58)::

    z1 q1'' + z2 q2'' = m12 sin(q2) q2'^2 + Gb sin(q2) - 2 Dw q1' + tau*_1 + tau*_2
    z1 = m11 + m12 cos q2,   z2 = m22 + m12 cos q2

(the book's (3.58) omits the wheel damping ``-2 Dw q1'``; it is kept here when ``damping=True``).
With ``x = [q2, q2', q1' - q1d']`` (3.61) this is ``x' = Pi(x)`` (3.62)-(3.63) and, about the
equilibrium ``x* = [q2*, 0, 0]``, ``x' = A (x - x*)`` with (3.65)::

    A = [[0, 1, 0], [T1, T2, T3], [T4, T5, T6]],   Lam = 1 / (z1 - l3 z2)
    T4 = Lam Gb cos q2*,  T5 = Lam l1 z2,  T6 = Lam (l2 z2 - 2 Dw)
    T1 = -l3 T4,          T2 = -l1 - l3 T5, T3 = -l2 - l3 T6

The Routh-Hurwitz conditions for ``det(sI - A) = s^3 - (T2 + T6) s^2 + (T2 T6 - T3 T5 - T1) s
+ (T1 T6 - T3 T4)`` are (3.66): ``T2 + T6 < 0``, ``T3 T4 - T1 T6 < 0`` and
``(T2 + T6)(T3 T5 - T2 T6) + T1 T2 + T3 T4 > 0`` (the book prints ``- T3 T4`` in its
expanded form; the determinant gives ``+``, and the tests check the conditions against the
eigenvalues of ``A``). Without damping they reduce to (3.52).

Everything is evaluated over the operating range ``|q2| <= theta_max`` (worst case reported),
together with the sign of ``g2 + l3 g1`` of (3.50) (it must not vanish: it divides ``u_A``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mwip.params import NOMINAL, Params

__all__ = ["Condition", "SMCDesignReport", "check_smc_design", "sliding_matrix"]


@dataclass(frozen=True)
class Condition:
    """One inequality: its book label, the expression, worst value over the range, verdict."""

    name: str
    expression: str
    value: float
    holds: bool


@dataclass(frozen=True)
class SMCDesignReport:
    """Result of :func:`check_smc_design`."""

    lambdas: tuple[float, ...]
    theta_max: float
    damping: bool
    conditions: tuple[Condition, ...]
    eigenvalues: NDArray[np.complex128] = field(repr=False)

    @property
    def ok(self) -> bool:
        return all(c.holds for c in self.conditions)

    @property
    def failed(self) -> list[Condition]:
        return [c for c in self.conditions if not c.holds]

    def to_dict(self) -> dict[str, object]:
        return {
            "lambdas": list(self.lambdas),
            "theta_max": self.theta_max,
            "damping": self.damping,
            "ok": self.ok,
            "conditions": [c.__dict__ for c in self.conditions],
            "eigenvalues_at_upright": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
        }


def _z(p: Params, q2: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    c = np.cos(q2)
    return p.m11 + p.m12 * c, p.m22 + p.m12 * c


def sliding_matrix(
    lambdas: Sequence[float], p: Params = NOMINAL, q2_star: float = 0.0, damping: bool = True
) -> NDArray[np.float64]:
    """``A = dPi/dx`` at ``x* = [q2*, 0, 0]`` (3.65), shape (3, 3)."""
    return _thetas_matrix(_thetas(lambdas, p, np.array([q2_star]), damping))[0]


def _thetas(
    lambdas: Sequence[float], p: Params, q2: NDArray[np.float64], damping: bool
) -> tuple[NDArray[np.float64], ...]:
    l1, l2, l3 = (float(x) for x in lambdas[:3])
    z1, z2 = _z(p, q2)
    lam = 1.0 / (z1 - l3 * z2)
    dw = 2.0 * p.Dw if damping else 0.0
    t4 = lam * p.Gb * np.cos(q2)
    t5 = lam * l1 * z2
    t6 = lam * (l2 * z2 - dw)
    return -l3 * t4, -l1 - l3 * t5, -l2 - l3 * t6, t4, t5, t6


def _thetas_matrix(th: tuple[NDArray[np.float64], ...]) -> NDArray[np.float64]:
    t1, t2, t3, t4, t5, t6 = th
    A = np.zeros((t1.size, 3, 3))
    A[:, 0, 1] = 1.0
    A[:, 1, 0], A[:, 1, 1], A[:, 1, 2] = t1, t2, t3
    A[:, 2, 0], A[:, 2, 1], A[:, 2, 2] = t4, t5, t6
    return A


def check_smc_design(
    lambdas: Sequence[float],
    params: Params = NOMINAL,
    theta_max: float = 0.35,
    *,
    q1d_dot: float = 0.0,
    damping: bool = False,
    n_grid: int = 41,
) -> SMCDesignReport:
    """Check (3.52), (3.66) and ``g2 + l3 g1 != 0`` for surface coefficients ``lambdas``.

    ``lambdas`` = ``(l1, l2, l3[, l4])`` (``l4 > 0`` only sets the yaw rate of convergence).
    The pitch of the equilibrium ``q2*`` ranges over ``|q2| <= theta_max`` (disturbances and
    speed tracking move it, (3.60)); each condition reports its worst value over that range.
    ``damping=False`` is the book's analysis; ``damping=True`` adds the nominal wheel
    damping ``Dw`` that (3.58) omits (see module docstring).
    """
    if isinstance(lambdas, str | bytes) or not all(
        isinstance(x, int | float | np.integer | np.floating) and not isinstance(x, bool)
        for x in np.atleast_1d(np.asarray(lambdas, dtype=object))
    ):
        raise TypeError(f"lambdas must be 3 or 4 numbers, got {lambdas!r}")
    lam = tuple(float(x) for x in lambdas)
    if len(lam) not in (3, 4) or not all(np.isfinite(x) and x > 0 for x in lam):
        raise ValueError(f"lambdas must be 3 or 4 finite numbers in (0, inf), got {lambdas!r}")
    if not (np.isfinite(theta_max) and 0 <= theta_max < np.pi / 2):
        raise ValueError(f"theta_max must be in [0, pi/2), got {theta_max!r}")
    l1, l2, l3 = lam[:3]
    q2 = np.linspace(-theta_max, theta_max, n_grid) if theta_max > 0 else np.zeros(1)
    z1, z2 = _z(params, q2)
    d1 = params.m11 * params.m22 - params.m12**2 * np.cos(q2) ** 2
    g_sum = (l3 * z2 - z1) / d1  # g2 + l3 g1 of (2.36)
    t1, t2, t3, t4, t5, t6 = _thetas(lam, params, q2, damping)
    h1 = t2 + t6
    h2 = t3 * t4 - t1 * t6
    h3 = (t2 + t6) * (t3 * t5 - t2 * t6) + t1 * t2 + t3 * t4
    eig = np.linalg.eigvals(_thetas_matrix((t1, t2, t3, t4, t5, t6)))

    def cond(name: str, expr: str, vals: NDArray[np.float64], positive: bool) -> Condition:
        worst = float(np.min(vals) if positive else np.max(vals))
        return Condition(name, expr, worst, bool(worst > 0 if positive else worst < 0))

    conditions = (
        cond("(3.52a)", "l1 l3 - l2 > 0", np.array([l1 * l3 - l2]), True),
        cond("(3.52b)", "z1 - l3 z2 > 0", z1 - l3 * z2, True),
        cond("(3.52c)", "l2 z2 - l1 z1 < 0", l2 * z2 - l1 * z1, False),
        cond("(3.52d)", "l2 l3 z2 - l2 z1 < 0", l2 * l3 * z2 - l2 * z1, False),
        cond("(3.66a)", "T2 + T6 < 0", h1, False),
        cond("(3.66b)", "T3 T4 - T1 T6 < 0", h2, False),
        cond("(3.66c)", "(T2 + T6)(T3 T5 - T2 T6) + T1 T2 + T3 T4 > 0", h3, True),
        cond("(3.50)", "g2 + l3 g1 < 0 (never zero)", g_sum, False),
        cond("eig", "max Re eig(A) < 0", np.max(eig.real, axis=1), False),
    )
    mid = len(q2) // 2
    return SMCDesignReport(lam, float(theta_max), damping, conditions, eig[mid])
