"""Robot logs for ``mwip twin fit``: CSV or Parquet, one row per control sample, SI units.

Required columns: ``t`` (s), ``theta`` (rad, the board's pitch estimate), ``theta_rate``
(rad/s, gyro), ``enc_r``, ``enc_l`` (rad, wheel angle relative to the body) and either
``u_r``, ``u_l`` (N m, commanded wheel torque) or ``duty_r``, ``duty_l`` (-1..1). Optional:
``accel_x``, ``accel_y`` (m/s^2) and ``mode`` (``balancing``, the default,
``wheels-off-ground`` or ``static``).

Every problem is a :class:`LogError` (a ``ValueError``) whose message is one line naming the
file and the column.
"""

from __future__ import annotations

import csv
import difflib
import hashlib
import io
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["LogError", "Log", "read_log", "REQUIRED", "OPTIONAL", "MODES", "TORQUE_MAX",
           "window_starts"]

REQUIRED = ("t", "theta", "theta_rate", "enc_r", "enc_l")
INPUTS = (("u_r", "u_l"), ("duty_r", "duty_l"))
OPTIONAL = ("accel_x", "accel_y", "mode")
MODES = ("balancing", "wheels-off-ground", "static")
#: Largest plausible commanded wheel torque (N m): 51:1 gearbox, 10 A, 2x margin.
TORQUE_MAX = 20.0
_MAX_BYTES = 512 * 2**20


class LogError(ValueError):
    """A log that cannot be used; the message is one line naming the file and the column."""


@dataclass
class Log:
    """A validated log: ``columns`` are float arrays (``mode`` an array of strings)."""

    path: str
    sha256: str
    columns: dict[str, NDArray[np.float64]]
    mode: NDArray[np.str_]
    inputs: str = "torque"  # "torque" (u_r, u_l) or "duty" (duty_r, duty_l)
    extra: dict[str, str] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.columns["t"].shape[0])

    @property
    def Ts(self) -> float:
        return float(np.median(np.diff(self.columns["t"])))

    @property
    def command(self) -> NDArray[np.float64]:
        """(n, 2) command: torques (N m) or duties."""
        a, b = ("u_r", "u_l") if self.inputs == "torque" else ("duty_r", "duty_l")
        return np.column_stack([self.columns[a], self.columns[b]])

    @property
    def enc(self) -> NDArray[np.float64]:
        return np.column_stack([self.columns["enc_r"], self.columns["enc_l"]])

    def has(self, name: str) -> bool:
        return name in self.columns


def _err(path: str, column: str | None, text: str) -> LogError:
    where = f"log {path!r}" + (f", column {column!r}" if column else "")
    return LogError(" ".join(f"{where}: {text}".split()))


def _read_table(path: str, data: bytes) -> dict[str, list[str] | NDArray]:
    if path.lower().endswith((".parquet", ".pq")):
        try:
            import pyarrow.parquet as pq
        except ImportError:  # pragma: no cover - optional dependency
            raise _err(path, None, "reading Parquet needs pyarrow (pip install pyarrow)") from None
        try:
            table = pq.read_table(io.BytesIO(data))
        except Exception as exc:  # noqa: BLE001 - pyarrow raises many kinds
            raise _err(path, None, f"not a readable Parquet file ({type(exc).__name__})") from None
        out: dict[str, list[str] | NDArray] = {}
        for name in table.column_names:
            col = table.column(name).to_pylist()
            out[str(name)] = [("" if v is None else str(v)) for v in col]
        return out
    if b"\x00" in data[:4096]:
        raise _err(path, None, "is a binary file, not a CSV log")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _err(path, None, "is not UTF-8 text (a binary file?), not a CSV log") from None
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    rows = [r for r in rows if not r[0].lstrip().startswith("#")]
    if not rows:
        raise _err(path, None, "is empty (no header row)")
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise _err(path, dup, "appears twice in the header")
    cols: dict[str, list[str]] = {h: [] for h in header}
    for i, r in enumerate(rows[1:], start=2):
        if len(r) != len(header):
            raise _err(path, None, f"row {i} has {len(r)} fields, the header {len(header)}")
        for h, v in zip(header, r, strict=True):
            cols[h].append(v.strip())
    return dict(cols)


def _floats(path: str, name: str, values: list[str] | NDArray) -> NDArray[np.float64]:
    out = np.empty(len(values))
    for i, v in enumerate(values):
        try:
            out[i] = float(v) if v != "" else math.nan
        except (TypeError, ValueError):
            raise _err(path, name, f"row {i + 2}: {str(v)[:20]!r} is not a number") from None
    return out


def _missing(path: str, name: str, header: list[str]) -> LogError:
    known = {*REQUIRED, *OPTIONAL, *INPUTS[0], *INPUTS[1]}
    close = difflib.get_close_matches(name, [h for h in header if h not in known], n=1,
                                      cutoff=0.6)  # fmt: skip
    hint = f" (found {close[0]!r}: rename it to {name!r}?)" if close else ""
    return _err(path, name, f"is missing{hint}; required: {', '.join(REQUIRED)} and "
                "u_r, u_l or duty_r, duty_l")  # fmt: skip


def read_log(path: str | Path) -> Log:
    """Read and validate one log (CSV or Parquet); every problem is a :class:`LogError`."""
    p = str(path)
    if not p.strip():
        raise _err(p, None, "the file name is empty")
    fp = Path(p)
    if p.endswith(("/", os.sep)) and not fp.is_dir():  # (Path drops the slash)
        raise _err(p, None, "ends in '/', which names a folder, but "
                   + ("is a file: drop the '/'" if fp.exists() else "does not exist"))
    if fp.is_dir():
        raise _err(p, None, "is a folder, not a log file")
    if not fp.exists():
        raise _err(p, None, "does not exist")
    if not fp.is_file():
        raise _err(p, None, "is not a regular file")
    try:
        with fp.open("rb") as fh:
            data = fh.read(_MAX_BYTES + 1)
    except OSError as exc:
        raise _err(p, None, f"cannot be read: {exc.strerror or exc}") from None
    if len(data) > _MAX_BYTES:
        raise _err(p, None, f"is larger than {_MAX_BYTES // 2**20} MiB")
    sha = hashlib.sha256(data).hexdigest()
    raw = _read_table(p, data)
    header = list(raw)
    for name in REQUIRED:
        if name not in raw:
            raise _missing(p, name, header)
    have = [pair for pair in INPUTS if pair[0] in raw or pair[1] in raw]
    if not have:
        close = difflib.get_close_matches("u_r", header, n=1, cutoff=0.6) or \
            difflib.get_close_matches("duty_r", header, n=1, cutoff=0.6)  # fmt: skip
        hint = f" (found {close[0]!r})" if close else ""
        raise _err(p, "u_r", f"is missing{hint}: give u_r, u_l (N m) or duty_r, duty_l")
    if len(have) > 1:
        raise _err(p, "duty_r", "both torque (u_r, u_l) and duty columns given; keep one pair")
    pair = have[0]
    for name in pair:
        if name not in raw:
            raise _missing(p, name, header)
    n = len(raw["t"])
    if n < 3:
        raise _err(p, "t", f"has {n} row{'s' if n != 1 else ''}; a log needs at least 3")
    cols: dict[str, NDArray[np.float64]] = {}
    for name in (*REQUIRED, *pair, "accel_x", "accel_y"):
        if name in raw:
            cols[name] = _floats(p, name, raw[name])
            bad = ~np.isfinite(cols[name])
            if bad.any():
                i = int(np.argmax(bad))
                raise _err(p, name, f"row {i + 2} is NaN or empty ({int(bad.sum())} such rows)")
    if ("accel_x" in raw) != ("accel_y" in raw):
        raise _missing(p, "accel_y" if "accel_x" in raw else "accel_x", header)
    t = cols["t"]
    dt = np.diff(t)
    if np.any(dt == 0):
        i = int(np.argmax(dt == 0))
        raise _err(p, "t", f"row {i + 3} repeats the time {t[i + 1]!r}")
    if np.any(dt < 0):
        raise _err(p, "t", f"is not increasing (row {int(np.argmax(dt < 0)) + 3} goes back)")
    med = float(np.median(dt))
    if np.any(np.abs(dt - med) > 0.25 * med):
        i = int(np.argmax(np.abs(dt - med) > 0.25 * med))
        raise _err(p, "t", f"row {i + 3}: the step {dt[i]:g} s is not the sample period "
                   f"{med:g} s (samples missing?)")  # fmt: skip
    if not (1e-4 <= med <= 0.1):
        raise _err(p, "t", f"sample period {med:g} s is outside 0.1-100 ms (t in ms?)")
    if "mode" in raw:
        mode = np.array([str(v).strip() or "balancing" for v in raw["mode"]])
        bad = ~np.isin(mode, MODES)
        if bad.any():
            raise _err(p, "mode", f"row {int(np.argmax(bad)) + 2}: {mode[bad][0]!r} is not one "
                       f"of {', '.join(MODES)}")  # fmt: skip
    else:
        mode = np.full(n, "balancing")
    th = cols["theta"]
    if np.mean(np.abs(th) > 1.6) > 0.05:
        raise _err(p, "theta", f"|theta| > 1.6 rad in {int(np.sum(np.abs(th) > 1.6))} rows: "
                   "degrees instead of rad?")  # fmt: skip
    if np.max(np.abs(cols["theta_rate"])) > 50.0:
        raise _err(p, "theta_rate", "above 50 rad/s: deg/s instead of rad/s?")
    inputs = "torque" if pair[0] == "u_r" else "duty"
    for name in pair:
        x = cols[name]
        if inputs == "duty" and np.max(np.abs(x)) > 1.0 + 1e-9:
            raise _err(p, name, f"duty {x[np.argmax(np.abs(x))]:g} outside [-1, 1] "
                       "(percent instead of a fraction?)")  # fmt: skip
        if inputs == "torque" and np.max(np.abs(x)) > TORQUE_MAX:
            raise _err(p, name, f"|u| up to {np.max(np.abs(x)):g} N m, far above any drive's "
                       f"limit ({TORQUE_MAX:g} N m): mN m instead of N m?")  # fmt: skip
    if "accel_x" in cols:
        g = np.hypot(cols["accel_x"], cols["accel_y"])
        if np.median(g) > 50.0:
            raise _err(p, "accel_x", "the specific force is far above g: mm/s^2 or mg?")
    moving = [c for c in pair if np.ptp(cols[c]) > 0]
    if not moving and not np.all(mode == "static"):
        raise _err(p, pair[0], "every input is constant: nothing to identify (use mode "
                   "'static' for a still hold)")  # fmt: skip
    if all(np.ptp(cols[c]) == 0 for c in cols if c != "t"):
        raise _err(p, "theta", "every signal is constant: nothing to identify")
    return Log(path=p, sha256=sha, columns=cols, mode=mode, inputs=inputs)


def window_starts(on: NDArray[np.bool_], length: int) -> list[int]:
    """Start indices of the consecutive, non-overlapping windows of ``length`` samples that fit
    inside each run of ``True`` in ``on`` (a log's rows of one mode); a run's tail shorter than
    ``length`` is left out."""
    out: list[int] = []
    k, n = 0, len(on)
    while k < n:
        if not on[k]:
            k += 1
            continue
        end = k
        while end < n and on[end]:
            end += 1
        out.extend(range(k, end - length + 1, length))
        k = end
    return out

