"""python-control interop (optional: ``pip install mwip[control]``).

- :func:`statespace`: the linearisation of Section 4.4 (:func:`mwip.models.linear.linearize`) as a
  ``control.StateSpace``, continuous or zero-order-hold sampled at ``Ts``.
- :func:`plant_system`: the nonlinear reduced model (2.33) as a ``control.NonlinearIOSystem``
  (state ``[psi, theta, alpha, psi', theta', alpha', x, y]``, inputs ``u_r, u_l``, outputs the
  LQR state ``[theta, alpha, theta', v, alpha']``), for ``control.input_output_response``.
- :func:`lqr_system`: a designed LQR (:class:`mwip.laws.lqr.controller.LQRDesign`) as the static
  gain
  ``u = -K x`` (a ``StateSpace`` with only ``D``, continuous or with the design's ``Ts``), so
  ``control.feedback`` / ``control.interconnect`` close the loop the python-control way.

Sampled dynamic controllers (observers, adaptive laws, fuzzy systems) keep their state in
mwip's stateful objects and run in :func:`mwip.sim.simulate`; their linear parts are not
exported here.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.models.linear import INPUT_NAMES, STATE_NAMES, statespace
from mwip.params import Params

__all__ = ["statespace", "plant_system", "lqr_system", "PLANT_STATES"]

PLANT_STATES = ("psi", "theta", "alpha", "psi_dot", "theta_dot", "alpha_dot", "x", "y")


def _control() -> Any:
    try:
        import control
    except ImportError as exc:
        raise ImportError(
            "python-control is needed for this: pip install 'mwip[control]' (or control)"
        ) from exc
    return control


def _one_robot(p: Params) -> None:
    if p.batch_shape != ():
        raise ValueError("python-control systems describe one robot: pass scalar Params")


def plant_system(p: Params, *, name: str = "mwip_plant") -> Any:
    """The nonlinear plant (2.33) with parameters ``p`` as a ``control.NonlinearIOSystem``.

    Its right-hand side is :func:`mwip.models.reduced.accelerations` plus the planar
    kinematics ``x' = r psi' cos(alpha)``, ``y' = r psi' sin(alpha)`` (2.28).
    """
    from mwip.models.reduced import accelerations

    ct = _control()
    _one_robot(p)

    def updfcn(t: float, x: NDArray[np.float64], u: NDArray[np.float64],
               params: Any = None) -> NDArray[np.float64]:  # fmt: skip
        q, qd = x[0:3], x[3:6]
        acc = accelerations(p, q, qd, np.asarray(u, dtype=float))
        v = p.r * qd[0]
        return np.concatenate([qd, acc, [v * np.cos(q[2]), v * np.sin(q[2])]])

    def outfcn(t: float, x: NDArray[np.float64], u: NDArray[np.float64],
               params: Any = None) -> NDArray[np.float64]:  # fmt: skip
        return np.array([x[1], x[2], x[4], p.r * x[3], x[5]])

    return ct.nlsys(updfcn, outfcn, states=list(PLANT_STATES), inputs=list(INPUT_NAMES),
                    outputs=list(STATE_NAMES), name=name)  # fmt: skip


def lqr_system(design: Any, *, name: str = "mwip_lqr") -> Any:
    """The static law ``u = -K x`` of an :class:`mwip.laws.lqr.controller.LQRDesign` as a
    ``control.StateSpace`` (inputs: the LQR state, outputs ``u_r, u_l``; ``dt`` = the
    design's ``Ts``, or continuous)."""
    ct = _control()
    K = np.asarray(design.K, dtype=float)
    dt = 0 if design.Ts is None else design.Ts
    return ct.ss(np.zeros((0, 0)), np.zeros((0, 5)), np.zeros((2, 0)), -K, dt=dt,
                 inputs=list(STATE_NAMES), outputs=list(INPUT_NAMES), name=name)  # fmt: skip
