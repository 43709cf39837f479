"""The Fig. 5.3 fuzzy controller for a batch: PDC balance (5.10) + Mamdani position and
direction FLSs (Section 5.3.2, Tables 5.1-5.2), IT2 or type-1, one row per robot.

Per row ``i`` the law is :class:`~mwip.fuzzy.mamdani.FuzzyMWIPController` (designs ``G_i``,
``kind_i``, targets ``p_d,i``, ``alpha_d,i``), term by term::

    theta_off = FLS_p(r_nom psi - p_d, theta')      (0 without a position target)
    x         = [theta - theta_off, theta', psi (0 with a position target), psi']
    u_p       = (1/2) sum_j m_j(theta) G_j x        (5.10)
    u_alpha   = FLS_alpha(alpha - alpha_d, alpha')  (0 without a heading target)
    u         = [u_p + u_alpha, u_p - u_alpha]      (Fig. 5.3)

evaluated for all rows in one call of the compiled kernel
:func:`mwip.laws.fig53.kernel.fig53_law` (the law's one implementation), which the
compiled closed loop (:mod:`mwip.sim.loop`, through :meth:`Fig53Controller.packed_law`)
calls too. With a single row the same law drives every robot of the batch. Tested equal to
:class:`~mwip.fuzzy.mamdani.FuzzyMWIPController` row by row (tests/test_fig53.py) and to the
NumPy oracle (tests/test_kernels.py). The controller sees only measurements and the nominal
wheel radius.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from mwip.core import Measurement
from mwip.fuzzy.layout import ROW_WIDTH
from mwip.fuzzy.mamdani import FuzzyMWIPController
from mwip.fuzzy.pdc import PDCDesign
from mwip.laws.packing import PackedLaw
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
        self.G = np.stack([d.G for d in designs])
        self.pos_on = np.array([v is not None for v in p_d])
        self.dir_on = np.array([v is not None for v in alpha_d])
        self.p_d = np.array([0.0 if v is None else float(v) for v in p_d])
        self.alpha_d = np.array([0.0 if v is None else float(v) for v in alpha_d])
        self.r = float(params.r)
        self.Ts = Ts
        self._scale = {k: direction_as_position(c) for k, c in self._ref.items()}
        self._log: dict[str, NDArray[np.float64]] = {}
        # the kernel's data: one row per design, the FLS blocks [it2 pos, t1 pos, it2 dir,
        # t1 dir]; with a direction that is a scaled position FLS, its block is the position
        # FLS's with the scales (one FLS for both loops, as direction_as_position states)
        kind_code = {"it2": 0.0, "t1": 1.0}
        self._table = np.column_stack([
            [kind_code[k] for k in kinds], self.G.reshape(n, 8), self.p_d, self.alpha_d,
            self.pos_on.astype(float), self.dir_on.astype(float), np.full(n, self.r),
        ])  # fmt: skip
        assert self._table.shape == (n, ROW_WIDTH)
        blocks = {}
        for k, ref in self._ref.items():
            sc = self._scale[k]
            blocks[k] = (ref.position.block(), ref.direction.block() if sc is None
                         else ref.position.block(*sc))  # fmt: skip
        width = max(b.size for pair in blocks.values() for b in pair)
        self._fls = np.zeros((4, width))
        for k, pair in blocks.items():
            for j, b in enumerate(pair):
                self._fls[int(kind_code[k]) + 2 * j, : b.size] = b

    def reset(self, meas: Measurement) -> None:
        """Nothing to reset (static law); checks the batch matches the rows."""
        self._check_batch(meas.y.shape[0])

    def _check_batch(self, n: int) -> None:
        if self.rows not in (1, n):
            raise ValueError(f"the controller has {self.rows} rows, the batch {n} robots")

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        """Fig. 5.3 at a sample: (5.10) on ``theta - theta_off`` plus the direction FLS, in
        the compiled kernel :func:`mwip.laws.fig53.kernel.fig53_law` (the one
        implementation; the compiled closed loop calls it too)."""
        from mwip.laws.fig53.kernel import fig53_law  # Numba: loaded by the Python loop only

        y = np.ascontiguousarray(meas.y, dtype=float)
        n = y.shape[0]
        self._check_batch(n)
        u, theta_off, u_a = np.empty((n, 2)), np.empty(n), np.empty(n)
        fig53_law(y, self._table, self._fls, 0, u, theta_off, u_a)
        self._log = {"theta_off": theta_off, "u_alpha": u_a}
        return u

    def packed_law(self) -> PackedLaw:
        """The law packed (:mod:`mwip.laws.fig53.packing`) for the compiled closed loop
        (:mod:`mwip.sim.loop`) and the C export: the same kernel,
        :func:`~mwip.laws.fig53.kernel.fig53_law`, with this controller's row table (one
        parameter vector per row) and FLS blocks; logs ``theta_off`` and ``u_alpha``."""
        from mwip.laws.fig53.packing import pack

        return pack(self._table, self._fls, name=str(self._kinds[0]))

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
