"""First-order disturbance observer (3.2): the n = 1 case of the HODO.

.. math::

    \\hat\\tau_d = p + L \\dot q, \\qquad
    \\dot p = -L \\left(F + G \\begin{bmatrix} u_A \\\\ u_B \\end{bmatrix} + \\hat\\tau_d\\right)
    \\qquad (3.2)

This is (3.20)-(3.23) with n = 1 (``p_1 = p``, ``L_1 = L``; (3.23) alone), so the error obeys
``tau~' = -L tau~ + tau_d'`` (3.3) and ``||tau~|| <= mu_1 / lambda_min(L)`` (3.6). The class is
a named form of :class:`~mwip.observers.hodo.HighOrderDO` with one gain; see there for the
sampled implementation.
"""

from __future__ import annotations

from numpy.typing import ArrayLike

from mwip.observers.hodo import Discretization, FGFunction, HighOrderDO, ModelHold
from mwip.params import Params

__all__ = ["FirstOrderDO"]


class FirstOrderDO(HighOrderDO):
    """First-order DO (3.2) with gain ``L`` (3x3 array, or a scalar meaning ``L I3``).

    Same runtime as :class:`~mwip.observers.hodo.HighOrderDO` with ``gains = [L]``.
    """

    def __init__(
        self,
        params: Params,
        L: ArrayLike,
        Ts: float,
        discretization: Discretization = "exact",
        *,
        substeps: int = 1,
        model_hold: ModelHold = "end",
        f_g: FGFunction | None = None,
    ) -> None:
        super().__init__(
            params, [L], Ts, discretization, substeps=substeps, model_hold=model_hold, f_g=f_g
        )
