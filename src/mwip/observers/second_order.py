"""Second-order disturbance observer (3.7): the n = 2 case of the HODO.

.. math::

    \\hat\\tau_d &= z_1 + p_1(q), &
    \\dot z_1 &= -L_1 (F + G u + \\hat\\tau_d) + \\dot{\\hat\\tau}_d, \\\\
    \\dot{\\hat\\tau}_d &= z_2 + p_2(q), &
    \\dot z_2 &= -L_2 (F + G u + \\hat\\tau_d) \\qquad (3.7)

with ``L_i = dp_i/dq`` (3.8). This is (3.20)-(3.23) with n = 2 once ``p_i(q)`` is read as the
linear function ``L_i q'`` of the velocity (the book's ``z_i`` are the HODO's ``p_i``; its
``p_i(q)`` are ``L_i q'``): then ``z_1' = -L_1(F + G u + tau^) + tau^'`` is (3.21) and
``z_2' = -L_2(F + G u + tau^)`` is (3.23), and the error matrix ``A_1 = [[-L_1, I], [-L_2, 0]]``
of Theorem 3.1 is ``D_2`` of (3.32).

Differences in the printed text (not in the observer): (3.9) writes ``L_i`` as 2x4 matrices
``[k_{2i-1,1..4}; k_{2i,1..4}]`` and Theorem 3.1 uses 2x2 identities, which belong to a
two-channel model, not to the three-channel (2.36); here ``L_i`` are 3x3 as in (3.24). The
book calls ``A_1`` "negative definite" where Hurwitz is meant (as in Section 3.4).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.observers.hodo import Discretization, FGFunction, HighOrderDO, ModelHold
from mwip.params import Params

__all__ = ["SecondOrderDO"]


class SecondOrderDO(HighOrderDO):
    """Second-order DO (3.7) with gains ``L1, L2`` (3x3 arrays or scalars times ``I3``).

    Same runtime as :class:`~mwip.observers.hodo.HighOrderDO` with ``gains = [L1, L2]``;
    :attr:`tau_hat_dot` is the estimate of ``tau_d'``.
    """

    def __init__(
        self,
        params: Params,
        L1: ArrayLike,
        L2: ArrayLike,
        Ts: float,
        discretization: Discretization = "exact",
        *,
        substeps: int = 1,
        model_hold: ModelHold = "end",
        f_g: FGFunction | None = None,
    ) -> None:
        super().__init__(
            params,
            [L1, L2],
            Ts,
            discretization,
            substeps=substeps,
            model_hold=model_hold,
            f_g=f_g,
        )

    @property
    def tau_hat_dot(self) -> NDArray[np.float64]:
        """Current estimate of ``tau_d'``, shape (N, 3)."""
        return self.estimates[:, 1, :]
