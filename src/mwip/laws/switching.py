"""Switching functions of the sliding-mode laws.

The book's laws use the discontinuous ``sgn(s)`` (default, SPEC.md section 2); Chapter 4.4.2
and the robot use a saturation with a boundary layer ``phi``: ``sat(s / phi)``, which equals
``sgn(s)`` outside ``|s| > phi`` and is linear inside, trading the ideal sliding motion for a
band of width ~``phi`` and no chattering.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Switching", "sign", "saturation"]


def sign(s: ArrayLike) -> NDArray[np.float64]:
    """``sgn(s)`` with ``sgn(0) = 0``."""
    return np.sign(np.asarray(s, dtype=float))


def saturation(s: ArrayLike, phi: float) -> NDArray[np.float64]:
    """``sat(s / phi) = clip(s / phi, -1, 1)``, the boundary-layer approximation of ``sgn``."""
    return np.clip(np.asarray(s, dtype=float) / phi, -1.0, 1.0)


@dataclass(frozen=True)
class Switching:
    """A switching function: ``kind="sign"`` (book default) or ``"sat"`` with layer ``phi``.

    >>> Switching("sat", 0.1)([-1.0, 0.05, 0.0])
    array([-1. ,  0.5,  0. ])
    """

    kind: str = "sign"
    phi: float = 0.05

    def __post_init__(self) -> None:
        if self.kind not in ("sign", "sat"):
            raise ValueError(f"switching kind must be 'sign' or 'sat', got {self.kind!r}")
        if not (np.isfinite(self.phi) and self.phi > 0):
            raise ValueError(f"switching 'phi' must be finite and in (0, inf), got {self.phi!r}")

    def __call__(self, s: ArrayLike) -> NDArray[np.float64]:
        return sign(s) if self.kind == "sign" else saturation(s, self.phi)
