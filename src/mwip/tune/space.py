"""The search space of a controller's settings, from the registry's allowed ranges.

Each tuned number is one dimension: a scalar setting ``phi`` is the dimension ``phi``, a
vector setting ``K`` of size 2 the dimensions ``K[0]``, ``K[1]``. Which settings: by default
every numeric setting that is a gain, i.e. not a target (names ending ``_d``), not optional,
not a word, with a non-zero default; the objective's ``space.tune`` names them instead.

The range of a dimension with book default ``d``: ``[d / ratio, d x ratio]`` searched on a log
scale (gains are scale quantities), cut to the registry's range (:class:`Setting` ``lo, hi``,
open ends kept open); a default of 0 (e.g. ``Gamma0``) is searched linearly over the registry
range, which must then be finite unless the objective gives one. ``space.ranges`` narrows a
setting, ``K = { lo = [1, 1], hi = [30, 30], log = true }`` (a number for every component, or
one for all): every bound must lie inside the registry's allowed range, so a tuned setting
never leaves it. Every candidate is also checked by :meth:`ControllerSpec.resolve`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mwip.laws.registry import MAGNITUDE, ControllerSpec, Setting

__all__ = ["Dim", "Space", "build_space", "default_tuned"]


@dataclass(frozen=True)
class Dim:
    """One searched number: ``name`` (``K[0]``), its ``setting`` and component ``index``
    (``None`` for a scalar setting), the range ``lo .. hi`` and whether on a log scale."""

    name: str
    setting: str
    index: int | None
    lo: float
    hi: float
    log: bool
    default: float


@dataclass(frozen=True)
class Space:
    """The dimensions of a search, and the settings they make up."""

    controller: str
    dims: tuple[Dim, ...]

    def names(self) -> list[str]:
        return [d.name for d in self.dims]

    def settings(self, params: Mapping[str, float]) -> dict[str, Any]:
        """The settings of a point ``{dim name: value}`` (vector settings as tuples)."""
        out: dict[str, Any] = {}
        vectors: dict[str, dict[int, float]] = {}
        for d in self.dims:
            x = float(params[d.name])
            if d.index is None:
                out[d.setting] = x
            else:
                vectors.setdefault(d.setting, {})[d.index] = x
        for name, comps in vectors.items():
            out[name] = tuple(comps[i] for i in range(len(comps)))
        order = {d.setting: i for i, d in reversed(list(enumerate(self.dims)))}
        return dict(sorted(out.items(), key=lambda kv: order[kv[0]]))

    def defaults(self) -> dict[str, float]:
        """The book's point: every dimension at its default (clipped into its range)."""
        return {d.name: min(max(d.default, d.lo), d.hi) for d in self.dims}


def _is_gain(s: Setting) -> bool:
    if s.choices or s.optional or s.name.endswith("_d"):
        return False
    values = s.default if s.size else (s.default,)
    return all(isinstance(v, int | float) for v in values) and any(v != 0 for v in values)


def default_tuned(spec: ControllerSpec) -> list[str]:
    """The settings tuned by default (module docstring)."""
    return [s.name for s in spec.settings if _is_gain(s)]


def _inside(s: Setting, x: float) -> bool:
    if not math.isfinite(x) or abs(x) > MAGNITUDE:
        return False
    return (x > s.lo if s.lo_open else x >= s.lo) and (x < s.hi if s.hi_open else x <= s.hi)


def _edge(s: Setting, lo: float, hi: float) -> tuple[float, float]:
    """``lo, hi`` moved just inside the registry's open ends."""
    if s.lo_open and lo <= s.lo:
        lo = math.nextafter(s.lo, math.inf)
    if s.hi_open and hi >= s.hi:
        hi = math.nextafter(s.hi, -math.inf)
    return lo, hi


def _per_component(value: Any, n: int, where: str) -> list[float]:
    items = value if isinstance(value, list) else [value] * n
    if len(items) != n or not all(isinstance(v, int | float) and not isinstance(v, bool)
                                  for v in items):  # fmt: skip
        raise ValueError(f"{where} must be a number or a list of {n} numbers, got {value!r}")
    return [float(v) for v in items]


def _given_range(s: Setting, spec: ControllerSpec, value: Any) -> list[tuple[float, float, bool]]:
    where = f"objective space.ranges.{s.name}"
    if not isinstance(value, dict) or not {"lo", "hi"} <= set(value) <= {"lo", "hi", "log"}:
        raise ValueError(f"{where} must be {{ lo = ..., hi = ... [, log = true|false] }}, "
                         f"got {value!r}")  # fmt: skip
    n = max(s.size, 1)
    los = _per_component(value["lo"], n, f"{where}.lo")
    his = _per_component(value["hi"], n, f"{where}.hi")
    log = value.get("log")
    if log is not None and not isinstance(log, bool):
        raise ValueError(f"{where}.log must be true or false, got {log!r}")
    out = []
    for i, (lo, hi) in enumerate(zip(los, his, strict=True)):
        comp = f"{where}" + (f"[{i}]" if s.size else "")
        for x in (lo, hi):
            if not _inside(s, x):
                raise ValueError(f"{comp}: {x:g} is outside controller {spec.name!r}'s allowed "
                                 f"range for {s.name!r}: {s.allowed()}")  # fmt: skip
        if not lo < hi:
            raise ValueError(f"{comp}: lo must be < hi, got lo = {lo:g}, hi = {hi:g}")
        use_log = (lo > 0) if log is None else log
        if use_log and lo <= 0:
            raise ValueError(f"{comp}: a log scale needs lo > 0, got {lo:g}")
        out.append((lo, hi, use_log))
    return out


def _default_range(s: Setting, spec: ControllerSpec, d: float, ratio: float,
                   i: int | None) -> tuple[float, float, bool]:  # fmt: skip
    comp = s.name + (f"[{i}]" if i is not None else "")
    if d != 0:
        a, b = sorted((d / ratio, d * ratio))
        lo, hi = _edge(s, max(a, s.lo), min(b, s.hi))
        return lo, hi, lo > 0
    lo, hi = _edge(s, max(s.lo, -MAGNITUDE), min(s.hi, MAGNITUDE))
    if not (math.isfinite(s.lo) and math.isfinite(s.hi)):
        raise ValueError(f"objective space: {spec.name!r} setting {comp!r} has the default 0 "
                         f"and an open-ended range ({s.allowed()}); give "
                         f"space.ranges.{s.name}")  # fmt: skip
    return lo, hi, False


def build_space(
    spec: ControllerSpec,
    tune: Sequence[str] | None = None,
    ranges: Mapping[str, Any] | None = None,
    ratio: float = 4.0,
) -> Space:
    """The search space of ``spec`` (module docstring); one-line ``ValueError`` on bad input
    (``TypeError`` for an argument of the wrong kind, naming it)."""
    if not isinstance(spec, ControllerSpec):
        raise TypeError(f"'spec' must be a ControllerSpec (mwip.laws.registry.get(name)), got "
                        f"{type(spec).__name__}")  # fmt: skip
    if tune is not None and (isinstance(tune, str) or not isinstance(tune, Sequence)
                             or not all(isinstance(x, str) for x in tune)):  # fmt: skip
        raise TypeError(f"'tune' must be a list of setting names, got {tune!r}")
    if tune is not None and not tune:
        raise ValueError("'tune' is an empty list; give setting names, or None (the defaults)")
    if ranges is not None and not isinstance(ranges, Mapping):
        raise TypeError(f"'ranges' must be a mapping of setting name -> range, got {ranges!r}")
    if isinstance(ratio, bool) or not isinstance(ratio, int | float):
        raise TypeError(f"'ratio' must be a number > 1, got {ratio!r}")
    if not (math.isfinite(ratio) and 1.0 < ratio <= 1e6):
        raise ValueError(f"'ratio' must be in (1, 1e6], got {ratio!r}")
    ranges = dict(ranges or {})
    names = list(tune) if tune is not None else default_tuned(spec)
    for key in list(names) + list(ranges):
        try:
            s = spec.setting(key)
        except ValueError as exc:
            raise ValueError(f"objective space: {exc}") from None
        if s.choices or s.optional:
            raise ValueError(f"objective space: {spec.name!r} setting {key!r} is not a number "
                             f"to tune ({s.allowed()})")  # fmt: skip
    extra = sorted(set(ranges) - set(names))
    if extra:
        raise ValueError(f"objective space.ranges.{extra[0]}: not a tuned setting (space.tune: "
                         f"{', '.join(names)})")  # fmt: skip
    if not names:
        raise ValueError(f"objective space: controller {spec.name!r} has no setting to tune")
    names = [s.name for s in spec.settings if s.name in set(names)]  # the registry's order
    dims: list[Dim] = []
    for key in names:
        s = spec.setting(key)
        defaults = list(s.default) if s.size else [s.default]
        if key in ranges:
            bounds = _given_range(s, spec, ranges[key])
        else:
            bounds = [_default_range(s, spec, float(d), ratio, i if s.size else None)
                      for i, d in enumerate(defaults)]  # fmt: skip
        for i, ((lo, hi, log), d) in enumerate(zip(bounds, defaults, strict=True)):
            name = f"{key}[{i}]" if s.size else key
            dims.append(Dim(name, key, i if s.size else None, lo, hi, log, float(d)))
    return Space(spec.name, tuple(dims))
