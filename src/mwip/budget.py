"""Bounded work: the cost of a simulation is estimated before it starts and a run above the
budget is refused with one line saying what it would need.

A run of ``n`` plants over ``n_samples = duration / Ts`` sample periods with ``n_sub = Ts / dt``
integration steps per period costs

- ``steps = n * n_samples * n_sub`` plant integration steps (the time: the compiled kernel
  does some 10^7 of them a second on one core, and each sample period also costs a call of
  the controller in Python);
- ``bytes = n * n_rec * 8 * 10 * 3`` of records (``n_rec = n_samples / record_every + 1``
  rows of 8 states and 2 inputs, float64; the factor 3 covers the controller's logs and the
  copies made by :class:`~mwip.sim.SimResult` and its writers).

A step of the continuous mode (``mode="continuous"``: the law inside the right-hand side, a
ROS2 step with NumPy per step, :func:`mwip.sim.engine.simulate`) costs some 300 times a
compiled one (~3e4 steps a second): it is counted with that weight (:attr:`Cost.weight`), so
the same budget bounds the same wall time in both modes.

The defaults (:data:`DEFAULT`) allow every study of the book with room to spare; raise them
with ``Budget(max_steps=..., max_bytes=...)`` (``simulate(..., budget=...)``) or on the CLI
with ``--max-steps`` and ``--max-memory``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Budget", "BudgetError", "DEFAULT", "Cost", "estimate"]

#: bytes per recorded row and plant: 10 float64 values, times 3 for logs and copies
ROW_BYTES = 8 * 10 * 3


#: rough speeds for :meth:`Cost.seconds`: kernel steps per second, Python time per sample
STEPS_PER_S = 1e7
SAMPLE_S = 2e-5
#: continuous-mode steps per second (one core, one plant; measured ~3.5e4)
STEPS_PER_S_CONTINUOUS = 3e4


class BudgetError(ValueError):
    """A run would exceed its budget (a ``ValueError``: the input asks for too much)."""


@dataclass(frozen=True)
class Cost:
    """Estimated cost of a run: integration steps, sample periods, bytes of records; ``weight``:
    what one step costs in compiled-kernel steps (1, or ~333 in continuous mode)."""

    steps: float
    samples: float
    bytes: float
    weight: float = 1.0

    def seconds(self) -> float:
        """A rough wall time on one core: ``weight steps / 1e7 + samples * 2e-5`` s (the
        compiled kernel's rate and the per-sample Python work of a simple controller)."""
        return self.weight * self.steps / STEPS_PER_S + self.samples * SAMPLE_S

    def text(self) -> str:
        return (
            f"{self.steps:.3g} integration steps, {self.samples:.3g} sample periods, "
            f"{self.bytes / 2**30:.3g} GiB of records"
        )


@dataclass(frozen=True)
class Budget:
    """Upper bounds on one run: integration steps (all plants together), sample periods
    (each one a Python call of the controller) and bytes of records."""

    max_steps: float = 2e9
    max_samples: float = 2e7
    max_bytes: float = 4 * 2**30

    def __post_init__(self) -> None:
        for name in ("max_steps", "max_samples", "max_bytes"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
                raise ValueError(f"Budget {name} must be a number > 0, got {v!r}")

    def check(self, cost: Cost, what: str = "this run", hint: str | None = None) -> None:
        """Raise :class:`BudgetError` when ``cost`` exceeds a bound (``hint``: what to do)."""
        over = []
        if cost.weight * cost.steps > self.max_steps:
            mode = "" if cost.weight == 1.0 else " in continuous mode"
            over.append(f"{cost.steps:.3g} integration steps (budget "
                        f"{self.max_steps / cost.weight:.3g}{mode})")  # fmt: skip
        if cost.samples > self.max_samples:
            over.append(f"{cost.samples:.3g} sample periods (budget {self.max_samples:.3g})")
        if cost.bytes > self.max_bytes:
            over.append(
                f"{cost.bytes / 2**30:.3g} GiB of memory (budget {self.max_bytes / 2**30:.3g} GiB)"
            )
        if over:
            hint = hint or (
                "shorten the duration, lengthen Ts or dt, or raise the budget "
                "(CLI: --max-steps, --max-memory; API: budget=Budget(...))"
            )
            raise BudgetError(f"{what} would need {' and '.join(over)}; {hint}")


DEFAULT = Budget()


def estimate(duration: float, Ts: float, dt: float, n: int = 1, record_every: int = 1,
             mode: str = "sampled") -> Cost:  # fmt: skip
    """The :class:`Cost` of ``n`` plants over ``duration`` (see the module docstring)."""

    def whole(x: float) -> float:  # round(), but inf for a ratio that overflows (Ts = 1e-320)
        return float(max(round(x), 1)) if math.isfinite(x) else math.inf

    samples = whole(duration / Ts)
    n_sub = whole(Ts / dt)
    rows = whole(samples / max(record_every, 1)) + 1
    weight = STEPS_PER_S / STEPS_PER_S_CONTINUOUS if mode == "continuous" else 1.0
    return Cost(steps=float(n) * samples * n_sub, samples=float(samples),
                bytes=float(n) * rows * ROW_BYTES, weight=weight)  # fmt: skip
