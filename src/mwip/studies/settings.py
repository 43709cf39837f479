"""Study settings as data: each study's numbers (initial state, gains, durations, ...) live in
its study file ``mwip/studies/scenarios/<study>.toml``, table ``[settings]``.

A study reads them from its context, ``ctx.settings`` (:mod:`mwip.studies.study`): the
packaged defaults (:func:`defaults`) with the overrides of a run (a user's study file, a
campaign's draw), validated here (:func:`validate`). A user copies a study file
(``mwip scenario STUDY --out FILE.toml``), edits it and runs it with
``mwip run --scenario FILE.toml``. Overrides are validated against the defaults: unknown keys
and values of another type or length are one-line ``ValueError`` naming the field. The file's
``[report]`` table holds the texts of the HTML report (:func:`report_texts`).

Open settings. Some settings are not printed by the book (a boundary layer, a first-order
observer gain, an initial adaptive gain, a noise level, the integration step). Each study file
declares them in a table ``[open]``, one entry per such setting, with the plausible range the
default was chosen from and why (from the book or physics)::

    [open]
    eps = { range = [0.001, 0.05], why = "boundary layer of (4.5): not printed; ..." }

A list-valued setting's range applies to each element. The default is never changed after a
verdict is seen (DEVELOPERS.md); the campaign tooling sweeps these ranges to measure how a
claim depends on them. :func:`open_settings` reads the table.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from functools import cache
from importlib import resources
from typing import Any

__all__ = ["defaults", "open_settings", "packaged_text", "report_texts", "validate"]


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
    (``title``, ``setup``, ``book``, ``gaps``, ``docs``); {} when it has none."""
    return dict(_report(name))


def open_settings(name: str) -> dict[str, dict[str, Any]]:
    """The ``[open]`` table of study ``name``: setting -> ``{"range": [lo, hi], "why": str}``
    for each setting the book leaves open ({} when the study declares none)."""
    return {k: dict(v) for k, v in _open(name).items()}


def defaults(name: str) -> dict[str, Any]:
    """The packaged ``[settings]`` of study ``name`` (a copy)."""
    return {k: list(v) if isinstance(v, list) else v for k, v in _defaults(name).items()}


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
    return out
