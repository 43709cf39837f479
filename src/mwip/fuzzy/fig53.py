"""The Fig. 5.3 fuzzy controller for a batch: PDC balance (5.10) + Mamdani position and
direction FLSs (Section 5.3.2, Tables 5.1-5.2), IT2 or type-1, one row per robot.

Per row ``i`` the law is :class:`~mwip.fuzzy.mamdani.FuzzyMWIPController` (designs ``G_i``,
``kind_i``, targets ``p_d,i``, ``alpha_d,i``), term by term::

    theta_off = FLS_p(r_nom psi - p_d, theta')      (0 without a position target)
    x         = [theta - theta_off, theta', psi (0 with a position target), psi']
    u_p       = (1/2) sum_j m_j(theta) G_j x        (5.10)
    u_alpha   = FLS_alpha(alpha - alpha_d, alpha')  (0 without a heading target)
    u         = [u_p + u_alpha, u_p - u_alpha]      (Fig. 5.3)

evaluated for all rows at once: one call of each FLS per kind and sample instead of one per
robot (the FLS cost dominates a twin run). With a single row the same law drives every robot
of the batch. Tested equal to :class:`~mwip.fuzzy.mamdani.FuzzyMWIPController` row by row
(tests/test_fig53.py). The controller sees only measurements and the nominal wheel radius.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from mwip.core import Measurement
from mwip.fuzzy.mamdani import FuzzyMWIPController
from mwip.fuzzy.pdc import PDCDesign
from mwip.fuzzy.ts_model import nie_tan_weights, type1_weights
from mwip.params import NOMINAL, Params

__all__ = ["Fig53Controller", "direction_as_position"]


class Fig53Controller:
    """Fig. 5.3 for a batch; see the module docstring.

    Parameters
    ----------
    designs, kinds, p_d, alpha_d : sequences of the same length (rows)
        PDC gains (Lemma 5.1/5.2), ``"it2"`` or ``"t1"``, position target (m) or ``None``,
        heading target (rad) or ``None``, per row; one row applies to every robot.
    params : Params
        Nominal parameters (the wheel radius ``r_nom`` of ``p = r_nom psi``).
    Ts : float or None
        Sample period (the law is static; ``None``: any).
    """

    static = True

    def __init__(
        self,
        designs: Sequence[PDCDesign],
        kinds: Sequence[str],
        p_d: Sequence[float | None],
        alpha_d: Sequence[float | None],
        *,
        params: Params = NOMINAL,
        Ts: float | None = 0.005,
    ) -> None:
        n = len(designs)
        if not (len(kinds) == len(p_d) == len(alpha_d) == n) or n == 0:
            raise ValueError("designs, kinds, p_d and alpha_d must have the same length > 0")
        bad = sorted(set(kinds) - {"it2", "t1"})
        if bad:
            raise ValueError(f"kind must be 'it2' or 't1', got {bad[0]!r}")
        self.rows = n
        # the FLSs are built by FuzzyMWIPController itself (Table 5.1 ranges, footprints)
        self._ref = {k: FuzzyMWIPController(designs[0], kind=k, params=params) for k in
                     sorted(set(kinds))}  # fmt: skip
        self._kinds = np.array(list(kinds))
        self._groups = {k: np.array([i for i in range(n) if kinds[i] == k]) for k in self._ref}
        self.G = np.stack([d.G for d in designs])
        self.pos_on = np.array([v is not None for v in p_d])
        self.dir_on = np.array([v is not None for v in alpha_d])
        self.p_d = np.array([0.0 if v is None else float(v) for v in p_d])
        self.alpha_d = np.array([0.0 if v is None else float(v) for v in alpha_d])
        self.r = float(params.r)
        self.Ts = Ts
        self._scale = {k: direction_as_position(c) for k, c in self._ref.items()}
        self._log: dict[str, NDArray[np.float64]] = {}

    def reset(self, meas: Measurement) -> None:
        """Nothing to reset (static law)."""

    def _rowwise(
        self, n: int
    ) -> tuple[dict[str, NDArray[np.int64]], NDArray[np.float64], NDArray[np.float64],
               NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:  # fmt: skip
        """Groups and per-row arrays for ``n`` robots (one row: broadcast to all)."""
        if n == self.rows:
            return (self._groups, self.G, self.p_d, self.alpha_d, self.pos_on, self.dir_on)
        if self.rows != 1:
            raise ValueError(f"the controller has {self.rows} rows, the batch {n} robots")
        groups = {str(self._kinds[0]): np.arange(n)}
        return (groups, np.broadcast_to(self.G, (n, 2, 4)), np.repeat(self.p_d, n),
                np.repeat(self.alpha_d, n), np.repeat(self.pos_on, n),
                np.repeat(self.dir_on, n))  # fmt: skip

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        """Fig. 5.3 at a sample: (5.10) on ``theta - theta_off`` plus the direction FLS."""
        y = meas.y
        n = y.shape[0]
        groups, G, p_d, alpha_d, pos_on, dir_on = self._rowwise(n)
        theta_off, u_a, m = np.zeros(n), np.zeros(n), np.zeros((n, 2))
        for kind, rows in groups.items():
            ref, yr, sc = self._ref[kind], y[rows], self._scale[kind]
            pe, thd = self.r * yr[:, 0] - p_d[rows], yr[:, 4]
            ae, ad = yr[:, 2] - alpha_d[rows], yr[:, 5]
            if sc is None:
                theta_off[rows] = ref.position(pe, thd)
                u_a[rows] = ref.direction(ae, ad)
            else:  # one FLS call for both loops (the FLS cost dominates a twin run)
                both = ref.position(np.concatenate([pe, sc[0] * ae]),
                                    np.concatenate([thd, sc[1] * ad]))  # fmt: skip
                theta_off[rows], u_a[rows] = both[: rows.size], sc[2] * both[rows.size :]
            m[rows] = (nie_tan_weights if kind == "it2" else type1_weights)(yr[:, 1])
        theta_off = np.where(pos_on, theta_off, 0.0)
        u_a = np.where(dir_on, u_a, 0.0)
        x = np.stack([y[:, 1] - theta_off, y[:, 4], np.where(pos_on, 0.0, y[:, 0]),
                      y[:, 3]], -1)  # fmt: skip
        u_p = 0.5 * np.einsum("ni,nij,nj->n", m, G, x)
        self._log = {"theta_off": theta_off, "u_alpha": u_a}
        return np.stack([u_p + u_a, u_p - u_a], -1)

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        """``theta_off`` (the position FLS's lean) and ``u_alpha`` (N,)."""
        return self._log


def direction_as_position(c: FuzzyMWIPController) -> tuple[float, float, float] | None:
    """``(a1, a2, b)`` with ``direction(x1, x2) = b * position(a1 x1, a2 x2)``, or ``None``.

    Both FLSs are uniform partitions with the same number of sets, footprint, rules, kind and
    reducer, only the ranges differ (Table 5.1); memberships of uniform triangular partitions
    scale with the range and the outputs are linear in the consequent centroids, so the
    direction FLS is the position FLS with scaled inputs and output (exact up to rounding;
    tested).
    """
    p, d = c.position, c.direction
    same = (p.rules == d.rules and p.kind == d.kind and (p.m, p.n) == (d.m, d.n)
            and all((a.n, a.fou) == (b.n, b.fou) for a, b in
                    ((p.in1, d.in1), (p.in2, d.in2), (p.out, d.out))))  # fmt: skip
    if not same:
        return None
    return (p.in1.half_range / d.in1.half_range, p.in2.half_range / d.in2.half_range,
            d.out.half_range / p.out.half_range)  # fmt: skip
