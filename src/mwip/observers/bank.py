"""Run disturbance observers beside any controller and record their estimates.

:class:`ObservedController` wraps a controller: at every sample it first advances each
observer with the new measurement and the torque applied over the sample just ended, then
calls the wrapped controller. The estimates ``tau_hat`` (N, 3) of each observer are logged
under the observer's name. The observers do not act on the loop; this is how the book's
observer comparison (Fig. 3.2, Table 3.3) is run, and how a user monitors the lumped
disturbance (2.36) of a running robot.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from mwip.core import Controller, Measurement, Observer

__all__ = ["ObservedController", "SampledObserver"]


#: What :class:`ObservedController` needs of an observer: the :class:`mwip.core.Observer`
#: protocol (e.g. ``HighOrderDO``); the old name, kept.
SampledObserver = Observer


class ObservedController:
    """``controller`` plus passive ``observers`` sampled at the controller's period."""

    static = False

    def __init__(self, controller: Controller, observers: Mapping[str, Observer]) -> None:
        self.controller = controller
        self.observers = dict(observers)
        self.Ts: float | None = controller.Ts
        for name, obs in self.observers.items():
            if self.Ts is not None and abs(obs.Ts - self.Ts) > 1e-12:
                raise ValueError(
                    f"observer {name!r} has Ts={obs.Ts:g}, the controller Ts={self.Ts:g}"
                )
        if self.Ts is None and self.observers:
            self.Ts = next(iter(self.observers.values())).Ts
        self._u: NDArray[np.float64] | None = None

    def reset(self, meas: Measurement) -> None:
        for obs in self.observers.values():
            obs.reset(meas.qdot, q0=meas.q)
        self.controller.reset(meas)
        self._u = None

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        if self._u is not None:
            for obs in self.observers.values():
                obs.update(meas.q, meas.qdot, self._u)
        u = np.asarray(self.controller(t, meas), dtype=np.float64)
        self._u = u
        return u

    def log(self) -> dict[str, NDArray[np.float64]]:
        out = dict(self.controller.log())
        for name, obs in self.observers.items():
            out[name] = obs.tau_hat
        return out
