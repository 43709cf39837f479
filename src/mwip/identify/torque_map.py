"""The firmware's torque-to-duty map from logs that hold both the commanded torques and the
duties (issue 37, item 1): the board's ``firmware.torque_gain``.

The firmware turns the law's torque ``u`` into the duty ``d = k R u / (N eta k_t V_0)``
before it adds the back-EMF compensation (:mod:`mwip.hardware.firmware`; the log schema's
duty is the one before it), with ``k`` the torque gain (delivered / commanded torque). A log
with both pairs gives the slope ``a`` of ``d = a u`` by least squares through the origin,
pooled over both wheels and every such log (rows where the torque is not zero and the duty
is not clipped at +-1); with the gear ratio ``N`` the stand fit identifies (the duty drives
its motor model) and the motor data of the robot file, ``k = a N eta k_t V_0 / R``, its
standard error from those of ``a`` and ``N`` (first order, independent).

A log whose duties follow no such map (the root-mean-square misfit above
:data:`MISFIT_MAX` of the duties' own, declared before any log was fitted: a duty logged
after the back-EMF compensation, or the columns of different samples) is a
:class:`~mwip.identify.logs.LogError` naming it, never fitted silently.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mwip.identify.logs import Log, LogError

__all__ = ["MISFIT_MAX", "TorqueMap", "torque_to_duty"]

#: Largest root-mean-square misfit of ``d - a u``, as a fraction of the duties' RMS.
MISFIT_MAX = 0.05


@dataclass(frozen=True)
class TorqueMap:
    """The slope ``a`` (duty per N m) of ``d = a u``, its standard error, the misfit (RMS of
    ``d - a u`` over the duties' RMS) and the rows used."""

    a: float
    se_a: float
    misfit: float
    rows: int

    def torque_gain(self, N: float, se_N: float | None, eta: float, kt: float, V0: float,
                    R: float) -> tuple[float, float]:  # fmt: skip
        """``(k, se_k)``: the torque gain (module docstring)."""
        k = self.a * N * eta * kt * V0 / R
        rel = (self.se_a / self.a) ** 2 + ((se_N or 0.0) / N) ** 2
        return k, abs(k) * math.sqrt(rel)

    def to_json(self) -> dict[str, float]:
        return {"a": self.a, "se_a": self.se_a, "misfit": self.misfit, "rows": self.rows}


def torque_to_duty(logs: Sequence[Log]) -> TorqueMap | None:
    """The map of the logs that hold both pairs (``None`` where none does); a log whose
    duties follow no map is a ``LogError`` naming it (module docstring)."""
    both = [lg for lg in logs if lg.both_inputs]
    if not both:
        return None
    us, ds = [], []
    for lg in both:
        u = np.column_stack([lg.columns["u_r"], lg.columns["u_l"]]).ravel()
        d = np.column_stack([lg.columns["duty_r"], lg.columns["duty_l"]]).ravel()
        keep = (np.abs(u) > 1e-9 * max(float(np.max(np.abs(u))), 1e-300)) & (np.abs(d) < 0.999)
        if keep.sum() < 3:
            raise LogError(f"log {lg.path!r}, column 'u_r': with both torque and duty columns, "
                           "fewer than 3 rows of a torque that is not zero: no torque-to-duty "
                           "map to read; give one pair")  # fmt: skip
        us.append(u[keep])
        ds.append(d[keep])
        _check_one(lg, u[keep], d[keep])
    u, d = np.concatenate(us), np.concatenate(ds)
    a, se, misfit = _slope(u, d)
    return TorqueMap(a=a, se_a=se, misfit=misfit, rows=int(u.size))


def _slope(u: np.ndarray, d: np.ndarray) -> tuple[float, float, float]:
    uu = float(u @ u)
    a = float(u @ d) / uu
    r = d - a * u
    sigma2 = float(r @ r) / max(u.size - 1, 1)
    misfit = math.sqrt(float(np.mean(r**2))) / max(math.sqrt(float(np.mean(d**2))), 1e-300)
    return a, math.sqrt(sigma2 / uu), misfit


def _check_one(lg: Log, u: np.ndarray, d: np.ndarray) -> None:
    a, _, misfit = _slope(u, d)
    if not (a > 0.0 and misfit <= MISFIT_MAX):
        what = (f"the duties fall as the torques rise (slope {a:.3g})" if a <= 0.0 else
                f"the misfit of the best map d = a u is {100 * misfit:.1f} % of the duties' "
                f"RMS, above {100 * MISFIT_MAX:g} %")  # fmt: skip
        raise LogError(f"log {lg.path!r}, column 'duty_r': the duty columns follow no "
                       f"torque-to-duty map of the torque columns ({what}): a duty logged "
                       "after the back-EMF compensation, or columns of different samples? "
                       "Give one pair")  # fmt: skip
