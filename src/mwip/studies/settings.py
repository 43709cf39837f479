"""Study settings as data: each study's numbers (initial state, gains, durations, ...) live in
its study file ``mwip/studies/scenarios/<study>.toml``, table ``[settings]``.

A study reads them from its context, ``ctx.settings`` (:mod:`mwip.studies.study`): the
packaged defaults (:func:`defaults`) with the overrides of a run (a user's study file, a
campaign's draw), validated here (:func:`validate`). The file's ``[report]`` table holds the
texts of the HTML report (:func:`report_texts`). A user copies a study file
(``mwip scenario STUDY --out FILE.toml``), edits it and runs it with
``mwip run --scenario FILE.toml``. Overrides are validated against the defaults: unknown keys
and values of another type or length are one-line ``ValueError`` naming the field.

Open settings. Some settings are not printed by the book (a boundary layer, a first-order
observer gain, an initial adaptive gain, a noise level, the integration step). Each study file
declares them in a table ``[open]``, one entry per such setting, with the plausible range the
default was chosen from and why (from the book or physics)::

    [open]
    eps = { range = [0.001, 0.05], why = "boundary layer of (4.5): not printed; ..." }

A list-valued setting's range applies to each element. The default is never changed after a
verdict is seen (DEVELOPERS.md); the campaign tooling sweeps these ranges to measure how a
claim depends on them. :func:`open_settings` reads the table.

Ranges. Before anything runs, every overridden value is also checked against its allowed
range, from two sources (:func:`ranges`):

- generic physical rules by key name (:data:`RULES`): an initial pitch in (-pi/2, pi/2), a
  duration in (0, 3600] s, a sample period or step in [1e-5, 1] s, a seed in [0, 2^32),
  surface coefficients and input weights > 0, gains >= 0, ...;
- the study's own bounds: the table ``[ranges]`` of its study file, one interval per key in
  interval notation, e.g. ``D = "(0, 1)"`` (they replace the generic rule for that key).

Any other number must be finite with ``|x| <= 1e6``. Across keys: ``dt`` divides ``Ts`` and
``Ts_record``; a window ``[start, end]`` has ``start < end``; and the run must fit the work
budget of :mod:`mwip.budget` (``duration / dt`` integration steps per run).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from functools import cache
from importlib import resources
from typing import Any

__all__ = [
    "defaults", "open_settings", "packaged_text", "report_texts", "validate", "ranges",
    "RULES",
]  # fmt: skip

#: An allowed interval: (low, high, low included?, high included?).
Interval = tuple[float, float, bool, bool]

_PI2 = math.pi / 2
_GAINS = ("K", "rate", "Gamma_rate", "smc_K", "do1smc_K", "do4smc_K", "do1_gain", "do2_v",
          "do3_v", "do4_v", "Gamma", "gamma", "Gamma0", "Q_diag", "dbar_hodosmc", "dbar_smc",
          "dbar_smc_diagnostic")  # fmt: skip

#: Generic physical rules by key name (a list setting: each entry).
RULES: dict[str, Interval] = {
    "theta0": (-_PI2, _PI2, False, False),  # rad: the robot upright-ish, not lying down
    "alpha0": (-100.0, 100.0, True, True),  # rad
    "v0": (-20.0, 20.0, True, True),  # m/s
    "v_d": (-20.0, 20.0, True, True),  # m/s
    "v_feasible": (-20.0, 20.0, True, True),  # m/s
    "speed": (-1e3, 1e3, True, True),  # rad/s, wheel
    "stick_speed": (-1e3, 1e3, True, True),  # rad/s
    "psi_dot_d": (-1e3, 1e3, True, True),  # rad/s
    "alpha_dot_d": (-100.0, 100.0, True, True),  # rad/s
    "duration": (0.0, 3600.0, False, True),  # s
    "Tf": (0.0, 3600.0, False, True),  # s
    "Ts": (1e-5, 1.0, True, True),  # s
    "dt": (1e-5, 1.0, True, True),  # s
    "dt_continuous": (1e-5, 1.0, True, True),  # s
    "Ts_record": (1e-5, 1.0, True, True),  # s
    "rms_window": (0.0, 3600.0, True, True),  # s
    "rms_start": (0.0, 3600.0, True, True),  # s
    "stick_start": (0.0, 3600.0, True, True),  # s
    "seed": (0, 2**32 - 1, True, True),
    "record_every": (1, 10**6, True, True),
    "eps": (0.0, 1e3, False, True),  # boundary layers
    "phi": (0.0, 1e3, False, True),
    "epsilon": (0.0, 1e3, False, True),  # Lemma 5.2's ball (rad)
    "rho": (0.0, 1e4, False, True),  # N m
    "uncertainty": (0.0, 1.0, True, False),  # relative spread
    "theta_max": (0.0, _PI2, False, False),  # rad
    "lam": (0.0, 1e6, False, True),  # sliding-surface coefficients: > 0 (Hurwitz)
    "lambdas": (0.0, 1e6, False, True),
    "C": (0.0, 1e6, False, True),
    "R_diag": (0.0, 1e6, False, True),  # input weights: positive definite
    **{k: (0.0, 1e6, True, True) for k in _GAINS},  # gains, rates, bounds, state weights
}

#: Any number without a rule: finite and at most this in size.
MAGNITUDE = 1e6


def packaged_text(name: str) -> str:
    """The text of the study file shipped for study ``name``."""
    path = resources.files("mwip.studies").joinpath("scenarios", f"{name}.toml")
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"study {name!r} has no study file") from None


@cache
def _defaults(name: str) -> dict[str, Any]:
    data = tomllib.loads(packaged_text(name))
    return dict(data.get("settings", {}))


@cache
def _open(name: str) -> dict[str, dict[str, Any]]:
    data = tomllib.loads(packaged_text(name))
    table = data.get("open", {})
    base = data.get("settings", {})
    out: dict[str, dict[str, Any]] = {}
    for key, entry in table.items():
        where = f"study file of {name!r}: [open] {key}"
        if key not in base:
            raise ValueError(f"{where}: not a key of [settings]")
        if not isinstance(entry, dict) or set(entry) != {"range", "why"}:
            raise ValueError(f"{where} must be {{ range = [lo, hi], why = '...' }}")
        lo, hi = entry["range"]
        if not (isinstance(entry["why"], str) and entry["why"].strip()):
            raise ValueError(f"{where}: 'why' must be non-empty text")
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f"{where}: range must be finite with lo <= hi, got {entry['range']}")
        values = base[key] if isinstance(base[key], list) else [base[key]]
        if not all(lo <= v <= hi for v in values):
            raise ValueError(f"{where}: the default {base[key]!r} is outside {entry['range']}")
        out[key] = {"range": [float(lo), float(hi)], "why": entry["why"].strip()}
    return out


@cache
def _report(name: str) -> dict[str, str]:
    return dict(tomllib.loads(packaged_text(name)).get("report", {}))


def report_texts(name: str) -> dict[str, str]:
    """The ``[report]`` table of study ``name``'s file: the texts the HTML report shows
    (``title``, ``setup``, ``book``, ``gaps``, ``docs``, ``main_run``); {} when it has none."""
    return dict(_report(name))


def open_settings(name: str) -> dict[str, dict[str, Any]]:
    """The ``[open]`` table of study ``name``: setting -> ``{"range": [lo, hi], "why": str}``
    for each setting the book leaves open ({} when the study declares none)."""
    return {k: dict(v) for k, v in _open(name).items()}


def defaults(name: str) -> dict[str, Any]:
    """The packaged ``[settings]`` of study ``name`` (a copy)."""
    return {k: list(v) if isinstance(v, list) else v for k, v in _defaults(name).items()}


_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,]+?)\s*,\s*([^,]+?)\s*([\])])\s*$")


def _parse_interval(name: str, key: str, text: Any) -> Interval:
    m = _INTERVAL.match(text) if isinstance(text, str) else None
    try:
        if m is None:
            raise ValueError
        lo, hi = float(m.group(2)), float(m.group(3))
    except ValueError:
        raise ValueError(
            f'study file of {name!r}: [ranges] {key} must be an interval like "(0, 1]", '
            f"got {text!r}"
        ) from None
    return lo, hi, m.group(1) == "[", m.group(4) == "]"


@cache
def _ranges(name: str) -> dict[str, Interval]:
    data = tomllib.loads(packaged_text(name))
    keys = set(data.get("settings", {}))
    out = {k: v for k, v in RULES.items() if k in keys}
    for key, text in data.get("ranges", {}).items():
        if key not in keys:
            raise ValueError(f"study file of {name!r}: [ranges] {key} is not a setting")
        out[key] = _parse_interval(name, key, text)
    return out


def ranges(name: str) -> dict[str, Interval]:
    """The allowed interval of each setting of study ``name`` that has one (module docstring)."""
    return dict(_ranges(name))


def packaged_ranges_text(name: str) -> dict[str, str]:
    """The ``[ranges]`` table as written in study ``name``'s packaged file."""
    return dict(tomllib.loads(packaged_text(name)).get("ranges", {}))


def _interval_text(iv: Interval) -> str:
    lo, hi, lo_in, hi_in = iv
    a, b = (str(x) if isinstance(x, int) else f"{x:g}" for x in (lo, hi))
    return f"{'[' if lo_in else '('}{a}, {b}{']' if hi_in else ')'}"


def _in(iv: Interval, x: float) -> bool:
    lo, hi, lo_in, hi_in = iv
    return (x >= lo if lo_in else x > lo) and (x <= hi if hi_in else x < hi)


def _check_range(name: str, key: str, value: Any) -> None:
    iv = _ranges(name).get(key)
    items = value if isinstance(value, list) else [value]
    for i, x in enumerate(items):
        if isinstance(x, bool) or not isinstance(x, int | float):
            continue
        where = f"[settings] {key}" + (f"[{i}]" if isinstance(value, list) else "")
        if iv is not None and not _in(iv, x):
            raise ValueError(f"{where} must be in {_interval_text(iv)}, got {x!r}")
        if iv is None and abs(x) > MAGNITUDE:
            raise ValueError(f"{where} must be in [-{MAGNITUDE:g}, {MAGNITUDE:g}], got {x!r}")


def _check_together(name: str, cfg: Mapping[str, Any], changed: set[str]) -> None:
    """Rules across keys (module docstring), for the merged settings ``cfg``."""
    from mwip.budget import DEFAULT, estimate

    dt = cfg.get("dt")
    for period in ("Ts", "Ts_record"):
        Ts = cfg.get(period)
        if not ({"dt", period} & changed) or not isinstance(dt, int | float) or Ts is None:
            continue
        n = round(Ts / dt)
        if dt > Ts or abs(n * dt - Ts) > 1e-9 * Ts:
            raise ValueError(
                f"[settings] dt = {dt!r} must divide {period} = {Ts!r} into a whole number of steps"
            )
    for key in ("rms_window",):
        w = cfg.get(key)
        if key in changed and isinstance(w, list) and len(w) == 2 and not w[0] < w[1]:
            raise ValueError(f"[settings] {key} must be [start, end] with start < end, got {w!r}")
    duration = cfg.get("duration")
    steps = [cfg[k] for k in ("dt", "dt_continuous", "Ts") if isinstance(cfg.get(k), int | float)]
    if changed and isinstance(duration, int | float) and steps:
        step = min(steps)
        try:
            DEFAULT.check(estimate(duration, step, step), f"study {name!r} with these settings",
                          "shorten the duration or lengthen the step")  # fmt: skip
        except ValueError as exc:
            raise ValueError(f"[settings] {exc}") from None


def _check(name: str, key: str, default: Any, value: Any) -> Any:
    where = f"[settings] {key}"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{where} must be true or false, got {value!r}")
        return value
    if isinstance(default, int | float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{where} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{where} must be finite, got {value!r}")
        if isinstance(default, int) and not isinstance(value, int):
            raise ValueError(f"{where} must be an integer, got {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ValueError(f"{where} must be a string, got {value!r}")
        return value
    if isinstance(default, list):
        if not isinstance(value, list) or len(value) != len(default):
            raise ValueError(f"{where} must be a list of {len(default)} values, got {value!r}")
        pairs = enumerate(zip(default, value, strict=True))
        return [_check(name, f"{key}[{i}]", d, v) for i, (d, v) in pairs]
    raise ValueError(f"{where}: unsupported default type in the study file of {name!r}")


def validate(name: str, overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Check ``overrides`` against the defaults of study ``name``; returns them cleaned."""
    if not overrides:
        return {}
    base = _defaults(name)
    out = {}
    for key, value in overrides.items():
        if key not in base:
            allowed = ", ".join(sorted(base)) or "none"
            raise ValueError(f"[settings] {key}: unknown for study {name!r}; allowed: {allowed}")
        out[key] = _check(name, key, base[key], value)
        _check_range(name, key, out[key])
    _check_together(name, {**base, **out}, set(out))
    return out
