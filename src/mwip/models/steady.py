"""Steady motion of the MWIP: the one place for the relation every study of speed uses.

In steady motion (``theta, psi', alpha'`` constant) the sum of the wheel and pitch rows of
(2.33) leaves gravity on the lean paying the wheel-ground damping::

    2 Dw psi' = sin(theta) (Gb + (m12 + Ibl cos theta) alpha'^2)          (steady rolling)

(``psi' = v / r``; without yaw ``2 Dw psi' = Gb sin(theta)``). From it:

- :func:`lean_for_speed`: the pitch that holds a speed (the internal dynamics (4.35)/(4.40));
- :func:`speed_cap`: the highest steady wheel speed, ``Gb / (2 Dw)`` (lying flat);
- :func:`balance_residual`: how far a (speed, pitch) pair is from the relation;
- :func:`speed_time_constant`: with ``theta`` held at 0, ``(m11 + m12) psi'' = -2 Dw psi'``,
  the decay of the speed under (4.38).

Which reading of the tables' damping ``Dw`` is used decides all four (SPEC.md section 2).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.params import Params, steady_speed_cap

__all__ = ["balance_residual", "lean_for_speed", "speed_cap", "speed_time_constant"]


def lean_for_speed(p: Params, v: float, alpha_dot: float = 0.0) -> float:
    """Pitch at which the internal dynamics (4.35)/(4.40) hold a constant speed ``v``.

    Steady motion (``theta, v, alpha'`` constant) of (2.33): adding the wheel and pitch rows,
    ``2 Dw v / r = sin(theta) (Gb + (m12 + Ibl cos theta) alpha'^2)``; solved with
    ``cos theta ~ 1`` in the small centrifugal term. Returns ``nan`` when no lean can hold the
    speed (``|sin theta| > 1``): the wheel-ground damping exceeds what gravity can supply.
    """
    s = 2.0 * p.Dw * v / p.r / (p.Gb + (p.m12 + p.Ibl) * alpha_dot**2)
    return float(np.arcsin(s)) if abs(s) <= 1.0 else float("nan")


def speed_cap(p: Params) -> Any:
    """Highest steady wheel speed (rad/s), ``Gb / (2 Dw)``: the steady relation with
    ``|sin theta| <= 1`` (:func:`mwip.params.steady_speed_cap`)."""
    return steady_speed_cap(p)


def balance_residual(p: Params, psi_dot: float, theta: float) -> float:
    """``(2 Dw psi' - Gb sin(theta)) / (Gb sin(theta))``: relative residual of the steady
    relation of (2.33) without yaw (0 when the speed is the one the lean carries); ``nan`` at
    ``theta = 0``."""
    g = p.Gb * np.sin(theta)
    return float((2.0 * p.Dw * psi_dot - g) / g) if g != 0 else float("nan")


def speed_time_constant(p: Params) -> float:
    """Time constant (s) of ``v`` under (4.38) with ``theta`` held at 0: ``(m11 + m12) /
    (2 Dw)`` (sum of the wheel and pitch rows of (2.33) with ``theta = theta' = 0``)."""
    return float((p.m11 + p.m12) / (2.0 * p.Dw))
