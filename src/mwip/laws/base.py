"""The controller protocol shared by every control law (defined in :mod:`mwip.core`).

A controller is a small stateful object (state only where it is real: observers, adaptive
gains, integrators) with the maths in pure functions or compiled kernels beside it. The engine
calls

- ``reset(meas)`` once with the first measurement (batch of N robots), then
- ``__call__(t, meas) -> u`` at every sample instant, ``u`` of shape (N, 2) = ``[u_r, u_l]``
  (N m), held constant until the next sample (zero-order hold);
- ``log()`` right after each call, returning named arrays (N, ...) to record.

``Ts`` is the sample period the controller was designed for (``None``: any). A controller
whose law is a static function of the measurement sets ``static = True``; only those can run
in the engine's ``"continuous"`` mode, where the law is evaluated inside the plant's
right-hand side as in the book's MATLAB studies (SPEC.md section 2).

Every controller is registered by name in :mod:`mwip.laws.registry` (``mwip controllers``).
"""

from __future__ import annotations

from mwip.core import Controller

__all__ = ["Controller"]
