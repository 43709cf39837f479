"""IT2 Mamdani position and direction controllers (Section 5.3.2, Tables 5.1-5.2, Fig. 5.3).

Two-input Mamdani FLSs, seven triangular IT2 sets per variable (NB .. PB,
:class:`~mwip.fuzzy.sets.UniformPartition`, footprint documented there), the diagonal rule
base of Table 5.2, minimum t-norm, Begian-Melek-Mendel type reduction with the centroids of
the (symmetric) consequent sets as rule outputs. The type-1 counterpart uses the same rules
with the sets at the middle of each footprint and the weighted-average defuzzifier.

- position: ``(p_e, theta') -> theta_off`` with ``p_e = p - p_d``, ``p = r_nom psi`` (m);
- direction: ``(alpha_e, alpha_e') -> u_alpha`` with ``alpha_e = alpha - alpha_d``;

(errors are measured minus desired: with Table 5.2's diagonal ``out = -(i + j)`` a positive
position error gives a backward lean, a positive heading error a negative ``u_alpha``, i.e.
more torque on the left wheel, turning back; the physically consistent reading).
Table 5.1 ranges: p_e [-3, 3] m, theta_e' [-4, 4] rad/s, alpha_e [-1, 1] rad,
alpha_e' [-1, 1] rad/s, theta_off [-pi/40, pi/40] rad (SPEC.md erratum), u_alpha [-200, 200]
in the book's units (PWM counts); in N m we scale it by ``u_alpha_max`` (default 1.1 N m:
200/1000 of the 5.6 N m wheel stall torque, documented in docs/fuzzy.md).

:class:`FuzzyMWIPController` combines them as in Fig. 5.3: the PDC balance law acts on
``theta - theta_off`` and gives ``u_p`` per wheel; ``u_l = u_p - u_alpha``,
``u_r = u_p + u_alpha``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.fuzzy.layout import HEAD
from mwip.fuzzy.pdc import PDCBalance, PDCDesign
from mwip.fuzzy.sets import LABELS7, UniformPartition
from mwip.params import NOMINAL, Params

__all__ = [
    "RuleBase",
    "TABLE_5_2",
    "Ranges",
    "TABLE_5_1",
    "MamdaniFLS",
    "position_controller",
    "direction_controller",
    "FuzzyMWIPController",
]

_ROWS_5_2 = (  # rows: theta_e' (alpha_e'), NB..PB; columns: p_e (alpha_e), NB..PB
    "PB PB PB PB PM PS ZO",
    "PB PB PB PM PS ZO NS",
    "PB PB PM PS ZO NS NM",
    "PB PM PS ZO NS NM NB",
    "PM PS ZO NS NM NB NB",
    "PS ZO NS NM NB NB NB",
    "ZO NS NM NB NB NB NB",
)


@dataclass(frozen=True)
class RuleBase:
    """Complete two-input rule grid: ``table[i][j]`` = output label for (x1 = i, x2 = j)."""

    table: tuple[tuple[str, ...], ...]
    labels: tuple[str, ...] = LABELS7

    def __post_init__(self) -> None:
        n = len(self.labels)
        if len(self.table) != n or any(len(r) != n for r in self.table):
            raise ValueError(f"rule table must be {n}x{n}")
        bad = {lab for r in self.table for lab in r} - set(self.labels)
        if bad:
            raise ValueError(f"unknown labels in rule table: {sorted(bad)}")

    @property
    def index(self) -> NDArray[np.int64]:
        """Output set index per rule, (n, n)."""
        pos = {lab: k for k, lab in enumerate(self.labels)}
        return np.array([[pos[lab] for lab in r] for r in self.table])


#: Table 5.2, indexed ``[p_e][theta_e']`` (the printed table is symmetric: ``-(i + j)``).
TABLE_5_2 = RuleBase(tuple(tuple(r.split()) for r in _ROWS_5_2))


@dataclass(frozen=True)
class Ranges:
    """Table 5.1: half-ranges of the inputs and outputs (symmetric ranges)."""

    p_e: float = 3.0
    theta_rate: float = 4.0
    alpha_e: float = 1.0
    alpha_rate: float = 1.0
    theta_off: float = math.pi / 40  # printed [pi/40, pi/40]: read [-pi/40, pi/40] (SPEC 3)
    u_alpha_book: float = 200.0  # book units (PWM)

    def __post_init__(self) -> None:
        for k, v in self.__dict__.items():
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"range {k} must be finite and > 0, got {v!r}")


TABLE_5_1 = Ranges()


@dataclass(frozen=True)
class MamdaniFLS:
    """Two-input IT2 (or type-1) Mamdani FLS with min t-norm and BMM type reduction."""

    in1: UniformPartition
    in2: UniformPartition
    out: UniformPartition
    rules: RuleBase = TABLE_5_2
    kind: str = "it2"
    m: float = 0.5
    n: float = 0.5
    _y: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _block: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.kind not in ("it2", "t1"):
            raise ValueError(f"kind must be 'it2' or 't1', got {self.kind!r}")
        if not (self.in1.n == self.in2.n == self.out.n == len(self.rules.labels)):
            raise ValueError("partitions and rule base must have the same number of sets")
        # consequent centroids (symmetric sets: the apex) per rule, flattened
        object.__setattr__(self, "_y", self.out.centers[self.rules.index].ravel())
        object.__setattr__(self, "_block", self.block())

    def type1(self) -> MamdaniFLS:
        """Type-1 counterpart: same rules, type-1 sets at the middle of each footprint."""
        return MamdaniFLS(self.in1.type1(), self.in2.type1(), self.out.type1(), self.rules,
                          "t1", self.m, self.n)  # fmt: skip

    def block(self, a1: float = 1.0, a2: float = 1.0, b: float = 1.0) -> NDArray[np.float64]:
        """This FLS as the flat array of the compiled kernel (:mod:`mwip.laws.fig53.kernel`),
        evaluating ``b * FLS(a1 x1, a2 x2)``: the sets' apexes and lower / upper feet
        (``c -+ (1 -+ fou) h`` of :meth:`UniformPartition.memberships`; the type-1 sets for a
        type-1 FLS) and the rule outputs ``_y``."""
        parts = [p if self.kind == "it2" else p.type1() for p in (self.in1, self.in2)]
        n = self.in1.n
        out = np.empty(HEAD + 10 * n + n * n)
        out[:HEAD] = [n, float(self.kind == "t1"), self.m, self.n, parts[0].half_range,
                      parts[1].half_range, a1, a2, b]  # fmt: skip
        for k, p in enumerate(parts):
            c, h = p.centers, p.spacing
            wl, wu = (1.0 - p.fou) * h, (1.0 + p.fou) * h
            out[HEAD + 5 * n * k : HEAD + 5 * n * (k + 1)] = np.concatenate(
                [c, c - wl, c + wl, c - wu, c + wu]
            )
        out[HEAD + 10 * n :] = self._y
        return out

    def __call__(self, x1: ArrayLike, x2: ArrayLike) -> NDArray[np.float64]:
        """Crisp output for inputs broadcast together (vectorised): saturated inputs, lower
        and upper memberships, firing intervals by the minimum t-norm (``firing_grid``), BMM
        (IT2) or the weighted average (type 1) over the rules, in the compiled kernel
        :func:`mwip.fuzzy._kernel.fls_eval` (the one implementation; the NumPy oracle
        composed of :mod:`mwip.fuzzy.sets` and :mod:`mwip.fuzzy.reducers` is in
        tests/oracle_laws.py)."""
        from mwip.fuzzy._kernel import fls_batch  # Numba: loaded when evaluated

        a, b = np.broadcast_arrays(np.asarray(x1, dtype=float), np.asarray(x2, dtype=float))
        out = np.empty(a.shape)
        fls_batch(np.ascontiguousarray(a).reshape(-1), np.ascontiguousarray(b).reshape(-1),
                  self._block, out.reshape(-1))  # fmt: skip
        return out if out.ndim else out[()]


def position_controller(
    kind: str = "it2", ranges: Ranges = TABLE_5_1, fou: float = 0.25
) -> MamdaniFLS:
    """Position FLS ``(p_e, theta') -> theta_off`` (Section 5.3.2)."""
    fls = MamdaniFLS(UniformPartition(ranges.p_e, fou=fou),
                     UniformPartition(ranges.theta_rate, fou=fou),
                     UniformPartition(ranges.theta_off, fou=fou))  # fmt: skip
    return fls if kind == "it2" else fls.type1()


def direction_controller(
    kind: str = "it2", ranges: Ranges = TABLE_5_1, fou: float = 0.25, u_alpha_max: float = 1.1
) -> MamdaniFLS:
    """Direction FLS ``(alpha_e, alpha_e') -> u_alpha`` (N m; book range 200 -> u_alpha_max)."""
    fls = MamdaniFLS(UniformPartition(ranges.alpha_e, fou=fou),
                     UniformPartition(ranges.alpha_rate, fou=fou),
                     UniformPartition(u_alpha_max, fou=fou))  # fmt: skip
    return fls if kind == "it2" else fls.type1()


class FuzzyMWIPController:
    """Balance (PDC) + position + direction fuzzy control (Fig. 5.3); static law.

    ``p_d`` (m) and ``alpha_d`` (rad) are the targets; ``None`` disables that loop. With the
    position loop on, the PDC's wheel-angle feedback is dropped (the position FLS closes that
    loop through ``theta_off``); without it the PDC regulates ``psi`` to 0 as in Section 5.4.
    ``kind`` selects IT2 (Nie-Tan PDC, BMM Mamdani) or the type-1 counterparts.
    """

    static = True

    def __init__(
        self,
        design: PDCDesign | ArrayLike,
        *,
        kind: str = "it2",
        p_d: float | None = None,
        alpha_d: float | None = None,
        params: Params = NOMINAL,
        ranges: Ranges = TABLE_5_1,
        fou: float = 0.25,
        u_alpha_max: float = 1.1,
        Ts: float | None = None,
    ) -> None:
        self.balance = PDCBalance(design, kind=kind, psi_ref=None if p_d is not None else 0.0)
        self.position = position_controller(kind, ranges, fou)
        self.direction = direction_controller(kind, ranges, fou, u_alpha_max)
        self.p_d, self.alpha_d = p_d, alpha_d
        self.r = float(params.r)
        self.Ts = Ts
        self._log: dict[str, NDArray[np.float64]] = {}

    def reset(self, meas: Measurement) -> None:
        """Nothing to reset (static law)."""

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        y = meas.y
        n = y.shape[0]
        theta_off = np.zeros(n)
        if self.p_d is not None:
            theta_off = self.position(self.r * y[:, 0] - self.p_d, y[:, 4])
        u_p = 0.5 * self.balance.total_torque(meas, theta_off)
        u_a = np.zeros(n)
        if self.alpha_d is not None:
            u_a = self.direction(y[:, 2] - self.alpha_d, y[:, 5])
        self._log = {"theta_off": theta_off, "u_alpha": u_a}
        return np.stack([u_p + u_a, u_p - u_a], -1)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return self._log
