"""A known excitation added to a balancing controller's command: closed-loop identification
of the body (``mwip twin log --controller NAME --dither AMP``; :mod:`mwip.identify.body`).

Under its controller alone a balancing robot's command is a function of its measured state,
so the regressors of (2.32) move together and the sensors' noise, entering them as errors in
variables, biases the inertial coefficients (``m12``, ``m22``: reported not identified on
such logs). The remedy of closed-loop identification (Ljung 1999, System Identification,
Sec. 13.4: an external signal uncorrelated with the noise) is a known signal added to the
command: the firmware adds ``d_k`` to the torque its controller asks for and logs the sum,
the command the motors got. Here ``d_k`` is the same on both wheels (it excites the
forward/pitch plane of (2.32)), a random binary sequence of amplitude ``amplitude`` (N m per
wheel) held for ``hold`` seconds (its power spread up to ``1 / (2 hold)`` Hz), seeded: a
deterministic function of ``(seed, k)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Dithered", "sequence"]


def sequence(n: int, Ts: float, amplitude: float, hold: float = 0.05,
             seed: int = 0) -> NDArray[np.float64]:  # fmt: skip
    """The dither ``d_k`` (n,) of the module docstring."""
    if not (amplitude >= 0.0 and np.isfinite(amplitude)):
        raise ValueError(f"'amplitude' must be a finite number >= 0, got {amplitude!r}")
    per = max(1, int(round(hold / Ts)))
    rng = np.random.default_rng([seed, 7_411])
    levels = rng.choice((-1.0, 1.0), size=n // per + 1)
    return amplitude * np.repeat(levels, per)[:n]


class Dithered:
    """``ctrl``'s command plus the dither of :func:`sequence` at the sample ``round(t / Ts)``,
    both wheels. A controller of the :class:`mwip.core.Controller` protocol; it runs in the
    engine's loop (its sum is not a packed law)."""

    static = False

    def __init__(self, ctrl: Any, amplitude: float, Ts: float, duration: float,
                 seed: int = 0, hold: float = 0.05) -> None:  # fmt: skip
        self.ctrl = ctrl
        self.Ts = Ts
        self.d = sequence(int(np.ceil(duration / Ts)) + 2, Ts, amplitude, hold, seed)

    def reset(self, meas: Any) -> None:
        self.ctrl.reset(meas)

    def __call__(self, t: float, meas: Any) -> NDArray[np.float64]:
        u = np.asarray(self.ctrl(t, meas), dtype=float)
        return u + self.d[min(int(round(t / self.Ts)), self.d.size - 1)]

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return dict(self.ctrl.log())
