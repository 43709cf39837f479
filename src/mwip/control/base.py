"""The controller protocol shared by every control law.

A controller is a small stateful object (state only where it is real: observers, adaptive
gains, integrators) with the maths in pure functions beside it. The engine calls

- ``reset(meas)`` once with the first measurement (batch of N robots), then
- ``__call__(t, meas) -> u`` at every sample instant, ``u`` of shape (N, 2) = ``[u_r, u_l]``
  (N m), held constant until the next sample (zero-order hold);
- ``log()`` (optional) right after each call, returning named arrays (N, ...) to record.

``Ts`` is the sample period the controller was designed for (``None``: any). A controller
whose law is a static function of the measurement sets ``static = True``; only those can run
in the engine's ``"continuous"`` mode, where the law is evaluated inside the plant's
right-hand side as in the book's MATLAB studies (SPEC.md section 2).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from mwip.sim.sensors import Measurement

__all__ = ["Controller"]


@runtime_checkable
class Controller(Protocol):
    """Protocol of a discrete (sampled) or static controller; see module docstring."""

    Ts: float | None
    static: bool

    def reset(self, meas: Measurement) -> None: ...

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]: ...

    def log(self) -> Mapping[str, NDArray[np.float64]]: ...
