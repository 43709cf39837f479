"""The progress of a set of studies: runs done / total within each study, and the share of
the work done across studies with an estimate of the time left (``mwip run``, ``mwip
reproduce``).

A study's total is the number of simulation runs it made the last time it ran here
(:func:`mwip.studies.runner.expected_runs`; unknown the first time). The share of the work
weighs each study by its declared cost (``Study.cost``, seconds on one core) and counts a
running study by its runs done over its total; the time left is the time so far scaled by
the share left (``elapsed * (1 - f) / f``).

Without a terminal the display is lines (deterministic in the number of runs, not in time):
a study's runs at every tenth of its total (or at 1, 2, 5, 10, 20, 50, ... runs when the
total is unknown), and one line per finished study with the share done and the time left.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

__all__ = ["StudyProgress", "duration_text"]


def duration_text(seconds: float) -> str:
    """``"42 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def _steps(n: int) -> bool:
    """1, 2, 5, 10, 20, 50, ...: where a study of unknown total reports its runs."""
    while n >= 10 and n % 10 == 0:
        n //= 10
    return n in (1, 2, 5)


class StudyProgress:
    """Counts runs and finished studies; :meth:`run` and :meth:`done` return the line to
    print without a terminal (or ``None``), :meth:`fraction` and :meth:`status` feed a bar."""

    def __init__(
        self,
        names: list[str],
        costs: Mapping[str, float],
        totals: Mapping[str, int | None],
        clock: Callable[[], float] = time.monotonic,
        label: str = "studies",
    ) -> None:
        self.label = label
        self.names = list(names)
        self.costs = {n: max(float(costs.get(n, 1.0)), 1e-9) for n in self.names}
        self.totals = dict(totals)
        self.runs = dict.fromkeys(self.names, 0)
        self.finished: set[str] = set()
        self.last = ""
        self._clock = clock
        self._t0 = clock()

    def fraction(self) -> float:
        """Share of the work done, in [0, 1]."""
        done = 0.0
        for n in self.names:
            if n in self.finished:
                done += self.costs[n]
            elif self.totals.get(n):
                done += self.costs[n] * min(self.runs[n] / self.totals[n], 0.99)  # type: ignore[operator]
        return done / sum(self.costs.values()) if self.names else 1.0

    def left(self) -> float | None:
        """Estimated seconds left (``None`` before any work is done)."""
        f = self.fraction()
        if f <= 0:
            return None
        return (self._clock() - self._t0) * (1 - f) / f

    def _runs_text(self, study: str) -> str:
        total = self.totals.get(study)
        k = self.runs[study]
        if total:
            return f"{k}/{max(total, k)} runs"
        return "1 run" if k == 1 else f"{k} runs"

    def run(self, study: str) -> str | None:
        """One simulation run of ``study`` ended."""
        self.runs[study] = self.runs.get(study, 0) + 1
        self.last = study
        k, total = self.runs[study], self.totals.get(study)
        if total:
            if k > total or 10 * k // total == 10 * (k - 1) // total:
                return None
            return f"{study}: {self._runs_text(study)} ({100 * min(k, total) // total}%)"
        if not _steps(k):
            return None
        return (
            f"{study}: {self._runs_text(study)} done (its total is known after it has run "
            "once here)"
        )

    def done(self, study: str, wall: float, error: str | None = None) -> str:
        """``study`` finished (``error``: it failed)."""
        self.finished.add(study)
        self.last = study
        left = self.left()
        eta = "" if left is None or len(self.finished) == len(self.names) else (
            f", about {duration_text(left)} left")  # fmt: skip
        what = "FAILED" if error is not None else "done"
        share = f"{100 * self.fraction():.0f}%"
        return (f"{self.label} {len(self.finished)}/{len(self.names)} ({share} of the work, "
                f"{duration_text(self._clock() - self._t0)} so far{eta}): "
                f"{study} {what} in {wall:.1f} s, {self._runs_text(study)}")  # fmt: skip

    def status(self) -> str:
        """A short status for a progress bar: studies done and the last study's runs."""
        text = f"{len(self.finished)}/{len(self.names)} studies"
        if self.last:
            text += f"; {self.last} {self._runs_text(self.last)}"
        return text
