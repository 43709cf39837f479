"""Robot logs for ``mwip twin fit``: CSV or Parquet, one row per control sample, SI units.

Required columns: ``t`` (s), ``theta`` (rad, the board's pitch estimate), ``theta_rate``
(rad/s, gyro), ``enc_r``, ``enc_l`` (rad, wheel angle relative to the body) and either
``u_r``, ``u_l`` (N m, commanded wheel torque) or ``duty_r``, ``duty_l`` (-1..1), or both as a
board logs them (the duty then drives the motor model and the pair gives the firmware's
torque-to-duty map, :mod:`mwip.identify.torque_map`). A column with no value in any row is an
absent column. Optional: ``accel_x``, ``accel_y`` (m/s^2) and ``mode`` (``balancing``, the
default, ``wheels-off-ground`` or ``static``).

Every problem is a :class:`LogError` (a ``ValueError``) whose message is one line naming the
file and the column.

Checks before any fit (:func:`read_log`): numbers in every numeric column (a Parquet column
of text is refused, not parsed), time steady and in seconds, and the physics of each column,
each with the unit mistake it most likely is:

- ``theta``: mostly within +-1.6 rad (degrees?);
- ``theta_rate``: within +-50 rad/s, and, where the body pitches (balancing rows), its
  integral over 0.1 s windows follows the change of ``theta`` (slope in [1/3, 3]: a gyro in
  deg/s is 57 times too fast, a pitch in degrees 57 times too slow); on the stand
  (``wheels-off-ground`` rows, the body held) it must not follow the wheels;
- ``enc_r``, ``enc_l``: the wheel speed between samples (relative to the body) within
  :data:`WHEEL_RATE_MAX` (degrees, mrad or encoder counts are 57, 1000 or ~1000 times more);
- ``accel_x``, ``accel_y``: the specific force at rest (static rows, else all) near 1 g
  (in g? in mg or mm/s^2?);
- the inputs: duties within +-1, torques within :data:`TORQUE_MAX`.

Sizes are checked while reading: at most :data:`MAX_ROWS` rows (``max_rows``; ``mwip twin fit
--max-rows`` raises it: the fit takes some 3 kB and 0.7 ms per row), counted as they are read
(a Parquet file's rows after decompression, from its metadata and then batch by batch), and
files of at most 512 MiB.
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
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["LogError", "Log", "read_log", "REQUIRED", "OPTIONAL", "MODES", "TORQUE_MAX",
           "MAX_ROWS", "WHEEL_RATE_MAX", "window_starts"]

REQUIRED = ("t", "theta", "theta_rate", "enc_r", "enc_l")
INPUTS = (("u_r", "u_l"), ("duty_r", "duty_l"))
OPTIONAL = ("accel_x", "accel_y", "mode")
MODES = ("balancing", "wheels-off-ground", "static")
#: Largest plausible commanded wheel torque (N m): 51:1 gearbox, 10 A, 2x margin.
TORQUE_MAX = 20.0
#: Largest plausible wheel speed relative to the body (rad/s): the RE25's no-load speed
#: (9560 rpm, 1001 rad/s) through the smallest gear ratio of the twin's prior (3.7), with room.
WHEEL_RATE_MAX = 300.0
#: Rows of one fit's logs together (``max_rows``): 500,000 is 42 minutes at 5 ms, a fit of some
#: 1.5 GB and 6 minutes.
MAX_ROWS = 500_000
_MAX_BYTES = 512 * 2**20
_G = 9.81


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
    def both_inputs(self) -> bool:
        """Both the commanded torques and the duties were logged (``inputs`` is ``duty``)."""
        return self.inputs == "duty" and "u_r" in self.columns

    @property
    def enc(self) -> NDArray[np.float64]:
        return np.column_stack([self.columns["enc_r"], self.columns["enc_l"]])

    def has(self, name: str) -> bool:
        return name in self.columns


def _err(path: str, column: str | None, text: str) -> LogError:
    where = f"log {path!r}" + (f", column {column!r}" if column else "")
    return LogError(" ".join(f"{where}: {text}".split()))


def _read_table(path: str, data: bytes, max_rows: int) -> dict[str, list[str] | NDArray]:
    if path.lower().endswith((".parquet", ".pq")):
        return _read_parquet(path, data, max_rows)
    if b"\x00" in data[:4096]:
        raise _err(path, None, "is a binary file, not a CSV log")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _err(path, None, "is not UTF-8 text (a binary file?), not a CSV log") from None
    header: list[str] | None = None
    cols: dict[str, list[str]] = {}
    reader = csv.reader(io.StringIO(text))
    try:
        for r in reader:
            if not r or not any(c.strip() for c in r) or r[0].lstrip().startswith("#"):
                continue
            if header is None:
                header = [h.strip() for h in r]
                if len(set(header)) != len(header):
                    dup = next(h for h in header if header.count(h) > 1)
                    raise _err(path, dup, "appears twice in the header")
                cols = {h: [] for h in header}
                continue
            i = reader.line_num
            if len(r) != len(header):
                raise _err(path, None, f"row {i} has {len(r)} fields, the header {len(header)}")
            if len(cols[header[0]]) >= max_rows:
                raise _too_many(path, max_rows)
            for h, v in zip(header, r, strict=True):
                cols[h].append(v.strip())
    except csv.Error as exc:
        raise _err(path, None, f"row {reader.line_num}: not a CSV log ({exc})") from None
    if header is None:
        raise _err(path, None, "is empty (no header row)")
    return dict(cols)


def _too_many(path: str, max_rows: int) -> LogError:
    return _err(path, None, f"has more than {max_rows} rows (the rows of one fit's logs "
                "together; --max-rows raises it: the fit takes some 3 kB and 0.7 ms per row), "
                "or cut the log")  # fmt: skip


def _read_parquet(path: str, data: bytes, max_rows: int) -> dict[str, list[str] | NDArray]:
    """The columns of a Parquet log: numbers as float arrays (a column of another type is
    refused, naming it), ``mode`` as text; the rows counted from the metadata, then while the
    batches are read."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - optional dependency
        raise _err(path, None, "reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        pf = pq.ParquetFile(io.BytesIO(data))
        rows = pf.metadata.num_rows
        schema = pf.schema_arrow
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many kinds
        raise _err(path, None, f"not a readable Parquet file ({type(exc).__name__})") from None
    if rows > max_rows:
        raise _too_many(path, max_rows)
    numeric = {*REQUIRED, *INPUTS[0], *INPUTS[1], "accel_x", "accel_y"}
    for fld in schema:
        t = fld.type
        if fld.name in numeric and not (pa.types.is_floating(t) or pa.types.is_integer(t)
                                          or pa.types.is_decimal(t)):  # fmt: skip
            raise _err(path, fld.name, f"is stored as {t} in the Parquet file; expected "
                       "numbers (float or integer), not text: write the numbers as numbers")
    parts: dict[str, list[Any]] = {str(n): [] for n in schema.names}
    seen = 0
    try:
        for batch in pf.iter_batches(batch_size=65536):
            seen += batch.num_rows
            if seen > max_rows:
                raise _too_many(path, max_rows)
            for name, col in zip(batch.schema.names, batch.columns, strict=True):
                if name in numeric:
                    parts[str(name)].append(col.cast(pa.float64()).to_numpy(zero_copy_only=False))
                else:
                    parts[str(name)].append(np.array(["" if v is None else str(v)
                                                      for v in col.to_pylist()], dtype=object))
    except LogError:
        raise
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many kinds
        raise _err(path, None, f"not a readable Parquet file ({type(exc).__name__})") from None
    return {n: (np.concatenate(v) if v else np.empty(0)) for n, v in parts.items()}


def _all_empty(values: list[str] | NDArray) -> bool:
    """A column with no value in any row (blank text, or nulls / NaN of a Parquet column)."""
    if isinstance(values, list):
        return all(not str(v).strip() for v in values)
    arr = np.asarray(values)
    if arr.dtype.kind in "fc":
        return bool(np.all(np.isnan(arr)))
    return all(v is None or (isinstance(v, float) and math.isnan(v)) or not str(v).strip()
               for v in arr.tolist())  # fmt: skip


def _floats(path: str, name: str, values: list[str] | NDArray) -> NDArray[np.float64]:
    if isinstance(values, np.ndarray) and values.dtype.kind == "f":
        return values.astype(np.float64, copy=False)  # (Parquet: None is NaN)
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


def read_log(path: str | Path, max_rows: int = MAX_ROWS) -> Log:
    """Read and validate one log (CSV or Parquet) of at most ``max_rows`` rows (module
    docstring); every problem is a :class:`LogError`."""
    if isinstance(max_rows, bool) or not isinstance(max_rows, int) or max_rows < 3:
        raise ValueError(f"'max_rows' must be an integer >= 3, got {max_rows!r}")
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
    raw = _read_table(p, data, max_rows)
    raw = {k: v for k, v in raw.items() if not _all_empty(v)}  # an empty column is absent
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
    # both pairs, as a board logs them: the duty drives the motor model, and the pair gives
    # the firmware's torque-to-duty map (mwip.identify.torque_map)
    pair = have[-1]
    given = [n for pr in have for n in pr]  # every input column, of one pair or both
    for name in given:
        if name not in raw:
            raise _missing(p, name, header)
    n = len(raw["t"])
    if n < 3:
        raise _err(p, "t", f"has {n} row{'s' if n != 1 else ''}; a log needs at least 3")
    cols: dict[str, NDArray[np.float64]] = {}
    for name in (*REQUIRED, *given, "accel_x", "accel_y"):
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
    _check_gyro(p, cols, mode, med)  # (names the unit by the pitch it should follow)
    top = float(np.max(np.abs(cols["theta_rate"])))
    if top > 50.0:
        hint = "deg/s instead of rad/s?" if top < 50 * 57.3 else "mrad/s or deg/s instead of rad/s?"
        raise _err(p, "theta_rate", f"up to {top:.4g}, above 50 rad/s: {hint}")
    inputs = "torque" if pair[0] == "u_r" else "duty"
    for name in given:
        x = cols[name]
        if name.startswith("duty") and np.max(np.abs(x)) > 1.0 + 1e-9:
            raise _err(p, name, f"duty {x[np.argmax(np.abs(x))]:g} outside [-1, 1] "
                       "(percent instead of a fraction?)")  # fmt: skip
        if name.startswith("u_") and np.max(np.abs(x)) > TORQUE_MAX:
            raise _err(p, name, f"|u| up to {np.max(np.abs(x)):g} N m, far above any drive's "
                       f"limit ({TORQUE_MAX:g} N m): mN m instead of N m?")  # fmt: skip
    if "accel_x" in cols:
        _check_accel(p, cols, mode)
    _check_wheels(p, cols, med)
    moving = [c for c in pair if np.ptp(cols[c]) > 0]
    if not moving and not np.all(mode == "static"):
        raise _err(p, pair[0], "every input is constant: nothing to identify (use mode "
                   "'static' for a still hold)")  # fmt: skip
    if all(np.ptp(cols[c]) == 0 for c in cols if c != "t"):
        raise _err(p, "theta", "every signal is constant: nothing to identify")
    return Log(path=p, sha256=sha, columns=cols, mode=mode, inputs=inputs)


def _check_accel(p: str, cols: dict[str, NDArray[np.float64]], mode: NDArray[np.str_]) -> None:
    """The specific force at rest (static rows, else every row) is about 1 g."""
    rest = mode == "static"
    rows = rest if rest.sum() >= 3 else np.ones(mode.shape, dtype=bool)
    g = float(np.median(np.hypot(cols["accel_x"][rows], cols["accel_y"][rows])))
    if 0.7 * _G <= g <= 1.3 * _G:
        return
    if 0.7 <= g <= 1.3:
        hint = "in g instead of m/s^2?"
    elif 0.7 * _G * 1000 <= g <= 1.3 * _G * 1000:
        hint = "in mm/s^2 instead of m/s^2?"
    elif 700 <= g <= 1300:
        hint = "in mg instead of m/s^2?"
    else:
        hint = "another unit, or the vertical axis missing (accel_x, accel_y: the pitch plane)?"
    where = "static rows" if rows is rest else "all rows: the body is on average at rest"
    raise _err(p, "accel_x", f"|(accel_x, accel_y)| is {g:.3g} at rest (median over {where}); "
               f"expected about {_G} m/s^2 (1 g): {hint}")  # fmt: skip


def _check_wheels(p: str, cols: dict[str, NDArray[np.float64]], Ts: float) -> None:
    """The wheel speed between samples (relative to the body) is one a drive can reach."""
    for name in ("enc_r", "enc_l"):
        rate = np.abs(np.diff(cols[name])) / Ts
        top = float(np.max(rate)) if rate.size else 0.0
        if top <= WHEEL_RATE_MAX:
            continue
        typical = float(np.percentile(rate, 99))
        if typical / 57.3 <= WHEEL_RATE_MAX:
            hint = "degrees instead of rad (x57.3)?"
        elif typical / 1000 <= WHEEL_RATE_MAX:
            hint = "mrad (x1000) or encoder counts instead of rad?"
        else:
            hint = "encoder counts instead of rad (angle = 2 pi counts / (counts per turn))?"
        i = int(np.argmax(rate))
        raise _err(p, name, f"row {i + 3}: the wheel turns {top:.4g} rad/s between two samples, "
                   f"above any drive's no-load speed ({WHEEL_RATE_MAX:g} rad/s): {hint}")


def _windows(on: NDArray[np.bool_], w: int) -> list[int]:
    return window_starts(on, w + 1)


def _check_gyro(p: str, cols: dict[str, NDArray[np.float64]], mode: NDArray[np.str_],
                Ts: float) -> None:  # fmt: skip
    """The gyro against the pitch (balancing rows) and against the wheels (on the stand)."""
    w = max(2, int(round(0.1 / Ts)))
    th, gyro = cols["theta"], cols["theta_rate"]
    starts = _windows(mode == "balancing", w)
    if len(starts) >= 20:
        idx = np.asarray(starts)
        csum = np.concatenate([[0.0], np.cumsum(0.5 * (gyro[1:] + gyro[:-1]) * Ts)])
        dth = th[idx + w] - th[idx]
        dint = csum[idx + w] - csum[idx]
        moving = float(np.std(dth)) > 2e-3 and float(np.std(dint)) > 1e-9
        corr = float(np.corrcoef(dth, dint)[0, 1]) if moving else 0.0
        if moving and corr > 0.6:
            k = float(np.dot(dth, dint) / np.dot(dth, dth))  # gyro integral per pitch change
            if k > 3.0:
                hint = ("deg/s instead of rad/s (x57.3)?" if 20 <= k <= 170 else
                        "mrad/s instead of rad/s (x1000)?" if 300 <= k <= 3000 else
                        "another unit than rad/s?")  # fmt: skip
                raise _err(p, "theta_rate", f"its integral over {w * Ts:g} s windows is {k:.3g} "
                           f"times the change of theta (balancing rows); expected 1: {hint}")
            if k < 1.0 / 3.0:
                hint = ("theta in degrees instead of rad (x57.3)?" if 20 <= 1 / k <= 170 else
                        "theta in mrad instead of rad (x1000)?" if 300 <= 1 / k <= 3000 else
                        "theta in another unit than rad?")  # fmt: skip
                raise _err(p, "theta", f"it changes {1 / k:.3g} times as much as the gyro "
                           f"(theta_rate) turns over {w * Ts:g} s windows (balancing rows); "
                           f"expected 1: {hint}")  # fmt: skip
    stand = mode == "wheels-off-ground"
    on = stand[1:] & stand[:-1]
    if on.sum() < 20:
        return
    g = np.abs(gyro[1:][on])
    for name in ("enc_r", "enc_l"):
        wheel = np.abs(np.diff(cols[name]))[on] / Ts
        if float(np.std(wheel)) <= 1.0 or float(np.std(g)) <= 0.5 * float(np.std(wheel)):
            continue
        if float(np.corrcoef(g, wheel)[0, 1]) > 0.9:
            raise _err(p, "theta_rate", "on the stand (wheels-off-ground rows, the body held) "
                       f"it follows {name}'s speed: a wheel speed instead of the body's pitch "
                       "rate (gyro)?")  # fmt: skip


def runs(on: NDArray[np.bool_], min_len: int = 1) -> list[tuple[int, int]]:
    """``(start, end)`` of each run of ``True`` in ``on`` (a log's rows of one mode) of at
    least ``min_len`` samples."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(on, dtype=np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)
            if b - a >= min_len]  # fmt: skip


def window_starts(on: NDArray[np.bool_], length: int) -> list[int]:
    """Start indices of the consecutive, non-overlapping windows of ``length`` samples that fit
    inside each run of ``True`` in ``on`` (a log's rows of one mode); a run's tail shorter than
    ``length`` is left out."""
    return [k for a, b in runs(on) for k in range(a, b - length + 1, length)]

