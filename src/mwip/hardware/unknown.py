"""One unknown value of the twin: a dotted name of the twin file and a uniform range.

Each element module declares its unknowns in a module-level tuple ``UNKNOWNS`` of
:class:`Unknown`; :mod:`mwip.hardware.prior` collects them into the declared prior. Kept in a
module of its own so that the element modules can declare without importing the collector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Unknown"]


@dataclass(frozen=True)
class Unknown:
    """A value the book does not print: ``name`` (dotted path of the twin file, e.g.
    ``"drive.gear_ratio"``), a continuous uniform range ``[low, high]`` (``low == high``
    fixes it), its ``unit``, the ``source`` of the range, the twin ``element`` it acts
    through and the default twin's value ``default`` (informative; the declared prior has it
    inside, a narrowed one need not: a twin's own values are checked by :meth:`check`)."""

    name: str
    low: float
    high: float
    unit: str
    source: str
    element: str
    default: float

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

    def check(self, value: float) -> None:
        """A twin's ``value`` must lie in the range: else a one-line ``ValueError`` naming
        ``twin.prior.<name>``."""
        if not (np.isfinite(value) and self.low <= value <= self.high):
            raise ValueError(
                f"twin.prior.{self.name}: the twin's value {value!r} is outside "
                f"[{self.low:g}, {self.high:g}]"
            )

    @property
    def fixed(self) -> bool:
        """``low == high``: the value is fixed."""
        return self.low == self.high
