"""The excitation a user runs for ``mwip twin fit`` (``mwip twin excite``).

The schedule (one row per control sample, a ``mode`` column):

1. ``static``: the robot held level and still (motors off) for ``static`` seconds: the gyro's
   zero-rate offset (``imu.gyro_bias``) and, with a level body, the accelerometer offset
   (``imu.accel_bias``);
2. ``wheels-off-ground`` (robot on a stand, wheels free): duty steps of both signs and
   sizes (small ones near the dead-band, large ones into the current limit), then a chirp:
   ``drive.gear_ratio`` (the wheel's inertia ``N^2 J`` and gain), ``firmware.emf_compensation``
   (the speed damping), ``drive.deadband``, ``drive.current_limit``, ``gearbox.coulomb``,
   ``gearbox.viscous`` and ``delay`` (the chirp's phase). The wheels get different
   schedules (the right one's steps are the left one's delayed), so the battery sag is seen.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["schedule", "schedule_length", "read_schedule", "STEP_LEVELS", "MAX_SAMPLES"]

#: Rows of a schedule, at most (``max_samples``; ``mwip twin excite --max-samples``): 2
#: million rows are some 90 MB of CSV, 2.8 hours at 5 ms.
MAX_SAMPLES = 2_000_000

#: Duty levels of the steps (each held ``step`` seconds, then back to 0).
STEP_LEVELS = (0.03, -0.05, 0.08, -0.12, 0.2, -0.3, 0.5, -0.7, 0.9, -0.9, 0.015, -0.025)


def _number(name: str, v: object, lo: float, hi: float, lo_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
        raise TypeError(f"{name!r} must be a number, got {type(v).__name__} {v!r}")
    x = float(v)
    ok = np.isfinite(x) and (x > lo if lo_open else x >= lo) and x <= hi
    if not ok:
        raise ValueError(f"{name!r} must be in {'(' if lo_open else '['}{lo:g}, {hi:g}], "
                         f"got {v!r}")  # fmt: skip
    return x


def schedule_length(Ts: float = 0.005, static: float = 2.0, step: float = 0.25,
                    chirp: float = 4.0) -> int:  # fmt: skip
    """The rows :func:`schedule` makes (checked arguments; nothing is allocated)."""
    Ts = _number("Ts", Ts, 0.0, 0.1, lo_open=True)
    static, step, chirp = (_number(n, v, 0.0, 600.0) for n, v in
                           (("static", static), ("step", step), ("chirp", chirp)))  # fmt: skip
    nstep = max(int(round(step / Ts)), 1)
    return int(round(static / Ts)) + 2 * len(STEP_LEVELS) * nstep + int(round(chirp / Ts))


def schedule(
    Ts: float = 0.005, static: float = 2.0, step: float = 0.25, chirp: float = 4.0,
    amplitude: float = 0.35, f0: float = 0.5, f1: float = 15.0, *,
    max_samples: int = MAX_SAMPLES,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.str_]]:  # fmt: skip
    """``(t, duty (n, 2), mode (n,))`` of the excitation; at most ``max_samples`` rows (the
    size is checked before anything is allocated). Bad arguments: ``TypeError`` /
    ``ValueError`` naming them (``amplitude`` in (0, 1] duty, ``0 < f0 < f1 <= 1000`` Hz)."""
    if isinstance(max_samples, bool) or not isinstance(max_samples, int) or max_samples < 1:
        raise ValueError(f"'max_samples' must be an integer >= 1, got {max_samples!r}")
    n = schedule_length(Ts, static, step, chirp)
    amplitude = _number("amplitude", amplitude, 0.0, 1.0, lo_open=True)
    f1 = _number("f1", f1, 0.0, 1000.0, lo_open=True)
    f0 = _number("f0", f0, 0.0, f1, lo_open=True)
    if f0 >= f1:
        raise ValueError(f"'f0' must be below 'f1' = {f1:g} Hz, got {f0!r}")
    if n > max_samples:
        raise ValueError(f"the schedule would have {n} rows (Ts {Ts:g} s, {static:g} + "
                         f"{2 * len(STEP_LEVELS)} x {step:g} + {chirp:g} s), more than "
                         f"{max_samples} (--max-samples raises it; a longer Ts or shorter "
                         "parts make it shorter)")  # fmt: skip
    Ts, static, step, chirp = float(Ts), float(static), float(step), float(chirp)
    ns = int(round(static / Ts))
    parts: list[NDArray[np.float64]] = [np.zeros(ns)]
    nstep = max(int(round(step / Ts)), 1)
    for lvl in STEP_LEVELS:
        parts += [np.full(nstep, lvl), np.zeros(nstep)]
    nc = int(round(chirp / Ts))
    tc = np.arange(nc) * Ts
    k = (f1 - f0) / max(chirp, Ts)
    parts.append(amplitude * np.sin(2 * np.pi * (f0 * tc + 0.5 * k * tc * tc)))
    left = np.concatenate(parts)
    shift = nstep // 2
    right = np.concatenate([left[:ns], np.roll(left[ns:], shift)])
    mode = np.array(["static"] * ns + ["wheels-off-ground"] * (len(left) - ns))
    t = np.arange(len(left), dtype=float) * Ts
    duty = np.column_stack([right, left]).astype(float)
    return t, duty, mode.astype(np.str_)


def read_schedule(path: str | Path, Ts: float, max_samples: int = MAX_SAMPLES,
                  ) -> tuple[NDArray[np.float64], NDArray[np.str_]]:  # fmt: skip
    """The schedule file ``mwip twin excite`` writes (CSV: ``t, duty_r, duty_l, mode``) as
    ``(duty (n, 2), mode (n,))``, checked for a robot of sample period ``Ts``: one row per
    sample (``t`` steps of ``Ts``, to 1e-6 s), duties within +-1, modes ``static`` or
    ``wheels-off-ground``. A problem is a ``ValueError``, one line naming the file and the
    column."""
    import csv

    where = f"schedule {str(path)!r}"
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except UnicodeDecodeError:
        raise ValueError(f"{where}: not UTF-8 text (a binary file?), not a schedule CSV") from None
    except OSError as exc:
        raise ValueError(f"{where}: {exc.strerror or exc}") from None
    if not rows:
        raise ValueError(f"{where}: empty (want the header t,duty_r,duty_l,mode)")
    header = [h.strip() for h in rows[0]]
    want = ("t", "duty_r", "duty_l", "mode")
    missing = [c for c in want if c not in header]
    if missing:
        raise ValueError(f"{where}: no column {missing[0]!r} (want t,duty_r,duty_l,mode, as "
                         "'mwip twin excite' writes)")  # fmt: skip
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if not body:
        raise ValueError(f"{where}: no rows")
    if len(body) > max_samples:
        raise ValueError(f"{where}: {len(body)} rows, more than {max_samples}")
    idx = {c: header.index(c) for c in want}
    cols: dict[str, NDArray[np.float64]] = {}
    for c in want[:3]:
        vals = np.empty(len(body))
        for i, r in enumerate(body):
            try:
                vals[i] = float(r[idx[c]])
            except (ValueError, IndexError):
                raise ValueError(f"{where}, column {c!r}: row {i + 2} is not a number") from None
        if not np.all(np.isfinite(vals)):
            raise ValueError(f"{where}, column {c!r}: not finite (NaN or inf)")
        cols[c] = vals
    for c in ("duty_r", "duty_l"):
        if np.any(np.abs(cols[c]) > 1.0):
            raise ValueError(f"{where}, column {c!r}: duties are within -1..1 "
                             f"(max |duty| {np.max(np.abs(cols[c])):.3g})")  # fmt: skip
    t = cols["t"]
    if t.size > 1 and np.max(np.abs(np.diff(t) - Ts)) > 1e-6:
        step = float(np.median(np.diff(t)))
        raise ValueError(f"{where}, column 't': steps of {step:g} s, the robot samples every "
                         f"{Ts:g} s (write the schedule with 'mwip twin excite --ts {Ts:g}')")
    mode = np.array([(r[idx["mode"]] if len(r) > idx["mode"] else "").strip() for r in body])
    bad = ~np.isin(mode, ("static", "wheels-off-ground"))
    if np.any(bad):
        first = int(np.argmax(bad))
        raise ValueError(f"{where}, column 'mode': row {first + 2} is {str(mode[first])!r}; a "
                         "schedule's rows are 'static' or 'wheels-off-ground'")  # fmt: skip
    return np.column_stack([cols["duty_r"], cols["duty_l"]]), mode
