"""One law, one setting per robot: a batch in which every robot (or every group of robots)
runs its own gains, in one engine call.

A tuner evaluates many candidate settings at once (a CMA-ES population, a grid), each over
the same set of robots: :func:`batch` builds the registered controller once per candidate,
packs each (:mod:`mwip.laws.packing`) and stacks the parameter vectors, one per robot, robot
``i`` taking candidate ``i // repeat``. The result is a :class:`PackedController`:

- on the plain loop (ideal sensors, no actuator model) the engine runs it in the compiled
  closed loop (:mod:`mwip.sim.loop`), one parameter vector per robot;
- anywhere else (the digital twin's sensors and drive) its ``__call__`` runs the same kernels
  through :func:`mwip.laws.dispatch.step_batch`, so both paths compute the same law.

Each candidate's controller sees only the nominal parameters and its robots' measurements,
as every controller does. Packing happens at :meth:`PackedController.reset`: a law fitted to
the initial state (TSMC's cubics (4.43)) is packed per robot from its own first measurement.

>>> from mwip.params import NOMINAL
>>> ctrl = batch("lqr", [{"R_diag": (0.01, 0.01)}, {"R_diag": (0.1, 0.1)}], NOMINAL, Ts=0.005)
>>> ctrl.rows, ctrl.repeat
(2, 1)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.core import Controller, Measurement
from mwip.laws.packing import PackedLaw
from mwip.params import NOMINAL, Params

__all__ = ["PackedController", "batch"]


class PackedController:
    """Controllers of one law, one per group of ``repeat`` consecutive robots, run as one
    packed law with a parameter vector per robot (module docstring)."""

    static = False

    def __init__(self, controllers: Sequence[Controller], repeat: int = 1) -> None:
        if not controllers:
            raise ValueError("batch: no settings given")
        if int(repeat) < 1:
            raise ValueError(f"batch: repeat must be >= 1, got {repeat!r}")
        periods = {getattr(c, "Ts", None) for c in controllers}
        if len(periods) != 1:
            raise ValueError("batch: the controllers run at different sample periods")
        self._ctrls = list(controllers)
        self.repeat = int(repeat)
        self.Ts: float | None = periods.pop()
        self._law: PackedLaw | None = None
        self._P = np.zeros((1, 0))
        self._X = np.zeros((1, 1))
        self._k = 0
        self._logs: dict[str, NDArray[np.float64]] = {}

    @property
    def rows(self) -> int:
        """The number of settings (candidates)."""
        return len(self._ctrls)

    def reset(self, meas: Measurement) -> None:
        """Reset every candidate's controller on its robots' first measurement and pack."""
        n = meas.y.shape[0]
        if n != self.rows * self.repeat:
            raise ValueError(f"batch: {self.rows} settings x repeat {self.repeat} = "
                             f"{self.rows * self.repeat} robots, the run has {n}")  # fmt: skip
        laws = []
        for j, c in enumerate(self._ctrls):
            sl = slice(j * self.repeat, (j + 1) * self.repeat)
            c.reset(Measurement(meas.t, np.ascontiguousarray(meas.y[sl])))
            law = c.packed_law() if hasattr(c, "packed_law") else None
            if law is None:
                raise ValueError(f"batch: {type(c).__name__} has no packed law (its observer or "
                                 "model is not one the compiled kernels run)")  # fmt: skip
            laws.append(law)
        first = laws[0]
        for law in laws[1:]:
            if (law.code, law.param_layout, law.state_layout) != (
                first.code, first.param_layout, first.state_layout
            ):  # fmt: skip
                raise ValueError("batch: the settings give laws of different layouts (e.g. "
                                 "observer orders); one batch runs one layout")  # fmt: skip

        def rows(a: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.broadcast_to(a, (self.repeat, a.shape[1]))

        P = np.concatenate([rows(law.params) for law in laws])
        X = np.concatenate([rows(law.state) for law in laws])
        self._law = PackedLaw(first.code, P, X, first.param_layout, first.state_layout,
                              first.log_names, first.name)  # fmt: skip
        self._P, self._X = self._law.arrays(n)
        self._k = 0

    def packed_law(self) -> PackedLaw | None:
        """The stacked law (after :meth:`reset`), one parameter vector per robot."""
        return self._law

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        from mwip.laws.dispatch import step_batch  # Numba: the Python loop only

        if self._law is None:
            raise RuntimeError("batch: call reset(meas) before the first sample")
        y = np.ascontiguousarray(meas.y, dtype=float)
        n = y.shape[0]
        u = np.empty((n, 2))
        lg = np.zeros((n, self._law.log_width))
        step_batch(np.int64(self._law.code), self._P, self._X, np.int64(self._k), float(t), y,
                   u, lg)  # fmt: skip
        self._k += 1
        self._logs = {name: (v[:, 0] if v.shape[1] == 1 else v).copy()
                      for name, v in self._law.split_logs(lg).items()}  # fmt: skip
        return u

    def log(self) -> Mapping[str, NDArray[np.float64]]:
        return self._logs


def batch(
    name: str,
    settings: Sequence[Mapping[str, Any]],
    nominal: Params = NOMINAL,
    Ts: float | None = 0.005,
    repeat: int = 1,
) -> PackedController:
    """The registered controller ``name`` with one setting per candidate (each validated by
    the registry, within its allowed ranges), robot ``i`` running candidate ``i // repeat``;
    all designed on the same ``nominal`` parameters and sample period ``Ts``."""
    from mwip.laws.registry import get

    spec = get(name)
    return PackedController([spec.build(nominal, s, Ts) for s in settings], repeat)
