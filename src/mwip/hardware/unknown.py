"""One unknown value of the twin: a dotted name of the robot file and a uniform (or log-uniform)
range.

Each element module declares its unknowns in a module-level tuple ``UNKNOWNS`` of
:class:`Unknown`; :mod:`mwip.hardware.prior` collects them into the declared prior. Kept in a
module of its own so that the element modules can declare without importing the collector;
the names of unknowns before the robot file (:data:`LEGACY_NAMES`) are here too, so that reading
a record (:mod:`mwip.hardware.identified`) imports no element.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["Unknown", "LEGACY_NAMES", "current_name"]

#: Names of unknowns before the robot file (``[twin]`` files, records of earlier runs) and
#: their names now.
LEGACY_NAMES: dict[str, str] = {
    "delay": "firmware.delay",
    "drive.emf_compensation": "firmware.emf_compensation",
    "fusion.tau": "firmware.fusion.tau",
}


def current_name(name: str) -> str:
    """``name``, or its name now if it is a :data:`LEGACY_NAMES` one."""
    return LEGACY_NAMES.get(name, name)


@dataclass(frozen=True)
class Unknown:
    """A value the book does not print: ``name`` (dotted path of the robot file, e.g.
    ``"drive.gear_ratio"``), a continuous range ``[low, high]`` (``low == high`` fixes it),
    uniform in the value (``scale = "linear"``) or in its logarithm (``"log"``, ``low > 0``:
    a ratio known only to a factor), its ``unit``, the ``source`` of the range, the twin
    ``element`` it acts through and the default twin's value ``default`` (informative; the
    declared prior has it inside, a narrowed one need not: a twin's own values are checked by
    :meth:`check`)."""

    name: str
    low: float
    high: float
    unit: str
    source: str
    element: str
    default: float
    scale: Literal["linear", "log"] = "linear"

    def __post_init__(self) -> None:
        for key in ("unit", "source", "element"):
            if not isinstance(getattr(self, key), str):
                raise ValueError(
                    f"twin.prior.{self.name}: {key!r} must be a string, got {getattr(self, key)!r}"
                )
        for key in ("low", "high", "default"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, int | float | np.floating):
                raise ValueError(f"twin.prior.{self.name}: {key!r} must be a number, got {v!r}")
            if not np.isfinite(v):
                raise ValueError(f"twin.prior.{self.name}: {key!r} must be finite, got {v!r}")
            object.__setattr__(self, key, float(v))
        if self.low > self.high:
            raise ValueError(
                f"twin.prior.{self.name}: low ({self.low:g}) must be <= high ({self.high:g})"
            )
        if self.scale not in ("linear", "log"):
            raise ValueError(f"twin.prior.{self.name}: 'scale' must be 'linear' or 'log', got "
                             f"{self.scale!r}")  # fmt: skip
        if self.scale == "log" and self.low <= 0:
            raise ValueError(f"twin.prior.{self.name}: a log-uniform range needs low > 0, got "
                             f"{self.low:g}")  # fmt: skip

    def check(self, value: float) -> None:
        """A twin's ``value`` must lie in the range: else a one-line ``ValueError`` naming
        ``twin.prior.<name>``."""
        if not (np.isfinite(value) and self.low <= value <= self.high):
            raise ValueError(
                f"twin.prior.{self.name}: the twin's value {value!r} is outside "
                f"[{self.low:g}, {self.high:g}]"
            )

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """The quantiles in [0, 1] of the values ``x`` (the inverse of :meth:`from_unit`; a
        fixed unknown: 0)."""
        x = np.asarray(x, dtype=float)
        if self.fixed:
            return np.zeros_like(x)
        if self.scale == "log":
            lo, hi = np.log(self.low), np.log(self.high)
            return (np.log(x) - lo) / (hi - lo)
        return (x - self.low) / (self.high - self.low)

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Values at the quantiles ``u`` in [0, 1] of the range (uniform or log-uniform)."""
        if self.scale == "log":
            lo, hi = np.log(self.low), np.log(self.high)
            return np.exp(lo + u * (hi - lo))
        return self.low + u * (self.high - self.low)

    @property
    def fixed(self) -> bool:
        """``low == high``: the value is fixed."""
        return self.low == self.high
