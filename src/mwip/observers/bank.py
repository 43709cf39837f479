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
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from mwip.sim.sensors import Measurement

__all__ = ["ObservedController", "SampledObserver"]


class SampledObserver(Protocol):
    """What :class:`ObservedController` needs of an observer (e.g. ``HighOrderDO``)."""

    Ts: float

    def reset(
        self,
        qdot0: NDArray[np.float64],
        estimates0: None = None,
        q0: NDArray[np.float64] | None = None,
    ) -> None: ...

    def update(
        self, q: NDArray[np.float64], qdot: NDArray[np.float64], u: NDArray[np.float64]
    ) -> NDArray[np.float64]: ...

    @property
    def tau_hat(self) -> NDArray[np.float64]: ...


class ObservedController:
    """``controller`` plus passive ``observers`` sampled at the controller's period."""

    static = False

    def __init__(self, controller: object, observers: Mapping[str, SampledObserver]) -> None:
        self.controller = controller
        self.observers = dict(observers)
        self.Ts = getattr(controller, "Ts", None)
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
        self.controller.reset(meas)  # type: ignore[attr-defined]
        self._u = None

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        if self._u is not None:
            for obs in self.observers.values():
                obs.update(meas.q, meas.qdot, self._u)
        u = np.asarray(self.controller(t, meas), dtype=float)  # type: ignore[operator]
        self._u = u
        return u

    def log(self) -> dict[str, NDArray[np.float64]]:
        out = dict(getattr(self.controller, "log", dict)())
        for name, obs in self.observers.items():
            out[name] = obs.tau_hat
        return out
