"""The time left of a stage's loop (its progress lines: "about 3.5 min left")."""

from __future__ import annotations

import time

__all__ = ["StepClock"]


class StepClock:
    """The time left of a loop of ``n`` steps, from the steps computed in this run: steps
    read back from an earlier run's files cost nothing and are not counted (a resumed stage
    does not promise a few seconds for the rest).

    >>> clock = StepClock(10)
    >>> clock.left(0)
    ''
    """

    def __init__(self, n: int) -> None:
        self.n, self.count = n, 0
        self.first: float | None = None

    def ran(self, step: int) -> None:
        """Step ``step`` was computed now (not read back)."""
        if self.first is None:
            self.first = time.perf_counter()
        self.count += 1

    def left(self, step: int) -> str:
        """``", about 3.5 min left"`` after step ``step`` (``""`` until two steps were
        computed: the first one's time includes compiling and loading)."""
        if self.first is None or self.count < 2:
            return ""
        per = (time.perf_counter() - self.first) / (self.count - 1)
        rest = per * (self.n - 1 - step)
        text = (f"{rest:.0f} s" if rest < 100 else f"{rest / 60:.1f} min" if rest < 6000
                else f"{rest / 3600:.1f} h")  # fmt: skip
        return f", about {text} left"
