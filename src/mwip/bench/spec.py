"""The benchmark as data: ``bench.toml`` (beside this module) validated into a frozen
:class:`Bench` of axes and their levels.

Format::

    [bench]
    title = "..."
    seed = 2027             # every run's randomness derives from (seed, level, replicate)
    samples = 64            # runs per level (n of each success fraction)
    duration = 5.0          # s per run
    block = 128             # runs per engine batch: the numerical unit (< 256)
    success_theta = 0.2     # success: never fell, |theta| < this throughout the last second
    theta0 = 0.1745         # initial pitch uniform in +-theta0 (rad); the other states 0
    push_at = 1.0           # s: the push axis's impulse starts here ...
    push_width = 0.1        # ... and lasts this long (s)
    payload_height = 0.1    # optional: the payload axis's pan above the body's top (m) and
    payload_radius = 0.08   # its radius (m); default: the identified twin's (payload.*)

    [quick]                 # --quick: any of the [bench] sizes replaced
    samples = 4

    [[axis]]                # an axis: a name, a title, the source of its levels
    name = "delay"
    title = "..."
    source = "..."
    [[axis.level]]          # a level: a label and its effects (none: the nominal run)
    label = "1.5"
    delay = 1.5

A level's effects (any combination; an unset one stays at the identified twin's value):

- ``params = { mb = 0.2, ... }``: each listed field of the real robot (Table 6.1) drawn
  uniformly in ``centre (1 +- a)``, independently per run;
- ``twin = "posterior"``: each run takes a member of the identified twin's posterior
  (``book-twin.json``'s ``members``: the book calibration's posterior, resampled);
  ``twin = "prior"``: every unknown of the declared prior (:mod:`mwip.hardware.prior`) that
  acts on the robot drawn uniformly over its range; ``twin = ["drive.gear_ratio", ...]``:
  those unknowns only;
- ``noise = s``: the IMU's white noise (accelerometer and gyro sigmas) ``s`` times the twin's;
- ``torque_noise = sigma``: white noise (N m) added to each commanded wheel torque per sample;
- ``deadband = d``: the drive's dead-band (duty, ``drive.deadband``);
- ``responsiveness = rho``: ``applied += rho (commanded - applied)`` every sample, in (0, 1];
- ``delay = D``: samples between the measurement and the torque (the twin's fractional delay
  plus whole samples), in [0, 10];
- ``payload = m``: a pan of ``m`` kg on the body (:meth:`mwip.params.Params.with_payload`) at
  ``payload_height`` above the body's top with ``payload_radius`` (default: the identified
  twin's ``payload.height`` and ``payload.radius``);
- ``push = J``: a horizontal impulse of ``J`` N s on the body's centre of mass from
  ``push_at`` over ``push_width``: generalised forces ``(J / width) (r, l, 0)`` on
  ``(psi, theta, alpha)`` (the body's centre is at ``x = r psi + l sin theta``).

Any unknown key, a value out of range or a duplicate name is a one-line ``ValueError``
naming the field and the allowed range.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from typing import Any

from mwip.params import PARAM_FIELDS

__all__ = ["Level", "Axis", "Bench", "parse_bench", "load_bench", "builtin_text",
           "MAX_SAMPLES", "MAX_BLOCK"]  # fmt: skip

MAX_SAMPLES = 100_000
MAX_BLOCK = 255
#: unknowns of the declared prior that act only in the Chapter 6 cases 2 and 3
CASE_ONLY = ("payload.", "stick.")

_BENCH_KEYS = {"title", "seed", "samples", "duration", "block", "success_theta", "theta0",
               "push_at", "push_width", "payload_height", "payload_radius"}  # fmt: skip
_SIZES = _BENCH_KEYS - {"title"}
_EFFECTS = ("params", "twin", "noise", "torque_noise", "deadband", "responsiveness", "delay",
            "payload", "push")  # fmt: skip


@dataclass(frozen=True)
class Level:
    """One level of an axis (see the module docstring for the effects; ``None``: the twin's)."""

    axis: str
    label: str
    params: tuple[tuple[str, float], ...] = ()
    twin: str | tuple[str, ...] | None = None
    noise: float = 1.0
    torque_noise: float = 0.0
    deadband: float | None = None
    responsiveness: float = 1.0
    delay: float | None = None
    payload: float = 0.0
    push: float = 0.0

    @property
    def key(self) -> str:
        return f"{self.axis}/{self.label}"


@dataclass(frozen=True)
class Axis:
    name: str
    title: str
    source: str
    levels: tuple[Level, ...]


@dataclass(frozen=True)
class Bench:
    """The validated benchmark (sizes as given, or the ``[quick]`` ones)."""

    title: str
    seed: int
    samples: int
    duration: float
    block: int
    success_theta: float
    theta0: float
    push_at: float
    push_width: float
    axes: tuple[Axis, ...]
    payload_height: float | None = None
    payload_radius: float | None = None
    quick: bool = False
    source: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def levels(self) -> tuple[Level, ...]:
        """Every level, axis by axis, in file order."""
        return tuple(lv for ax in self.axes for lv in ax.levels)

    def with_samples(self, n: int) -> Bench:
        return replace(self, samples=_integer(n, "--samples", 1, MAX_SAMPLES))


def _integer(value: Any, where: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{where} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _number(value: Any, where: str, lo: float, hi: float, lo_open: bool = False) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        raise ValueError(f"{where} must be a number in {'(' if lo_open else '['}{lo:g}, {hi:g}], "
                         f"got {value!r}")  # fmt: skip
    return float(value)


def _text(value: Any, where: str) -> str:
    if not (isinstance(value, str) and value.strip()):
        raise ValueError(f"{where} must be non-empty text, got {value!r}")
    return value.strip()


def _unknown(table: dict[str, Any], allowed: set[str] | tuple[str, ...], where: str) -> None:
    extra = sorted(set(table) - set(allowed))
    if extra:
        raise ValueError(f"{where}.{extra[0]}: unknown key; allowed: {', '.join(sorted(allowed))}")


def _sizes(table: dict[str, Any], where: str, out: dict[str, Any]) -> None:
    checks = {
        "seed": lambda v, w: _integer(v, w, 0, 2**63 - 1),
        "samples": lambda v, w: _integer(v, w, 1, MAX_SAMPLES),
        "duration": lambda v, w: _number(v, w, 0.0, 600.0, lo_open=True),
        "block": lambda v, w: _integer(v, w, 1, MAX_BLOCK),
        "success_theta": lambda v, w: _number(v, w, 0.0, 1.5, lo_open=True),
        "theta0": lambda v, w: _number(v, w, 0.0, 1.0),
        "push_at": lambda v, w: _number(v, w, 0.0, 600.0),
        "push_width": lambda v, w: _number(v, w, 0.0, 10.0, lo_open=True),
        "payload_height": lambda v, w: _number(v, w, 0.0, 1.0),
        "payload_radius": lambda v, w: _number(v, w, 0.0, 1.0),
    }
    for key, value in table.items():
        if key in checks:
            out[key] = checks[key](value, f"{where}.{key}")


def _level(item: Any, axis: str, where: str) -> Level:
    from mwip.hardware.prior import PRIOR

    if not isinstance(item, dict):
        raise ValueError(f"{where} must be a table")
    _unknown(item, {"label", *_EFFECTS}, where)
    kw: dict[str, Any] = {"axis": axis, "label": _text(item.get("label"), f"{where}.label")}
    if "params" in item:
        p = item["params"]
        if not (isinstance(p, dict) and p):
            raise ValueError(f"{where}.params must be a table {{ field = relative half-width }}")
        _unknown(p, set(PARAM_FIELDS) - {"g"}, f"{where}.params")
        kw["params"] = tuple((k, _number(v, f"{where}.params.{k}", 0.0, 0.9))
                             for k, v in p.items())  # fmt: skip
    if "twin" in item:
        t = item["twin"]
        if isinstance(t, str):
            if t not in ("posterior", "prior"):
                raise ValueError(f"{where}.twin must be 'posterior', 'prior' or a list of the "
                                 f"prior's names, got {t!r}")  # fmt: skip
            kw["twin"] = t
        elif isinstance(t, list) and t and all(isinstance(x, str) for x in t):
            for name in t:
                if name not in PRIOR.names or name.startswith(CASE_ONLY):
                    allowed = [n for n in PRIOR.names if not n.startswith(CASE_ONLY)]
                    raise ValueError(f"{where}.twin: {name!r} is not an unknown acting on the "
                                     f"robot; allowed: {', '.join(allowed)}")  # fmt: skip
            kw["twin"] = tuple(t)
        else:
            raise ValueError(f"{where}.twin must be 'posterior', 'prior' or a list of names")
    ranges = {"noise": (0.0, 100.0, False), "torque_noise": (0.0, 10.0, False),
              "deadband": (0.0, 0.5, False), "responsiveness": (0.0, 1.0, True),
              "delay": (0.0, 10.0, False), "payload": (0.0, 10.0, False),
              "push": (0.0, 100.0, False)}  # fmt: skip
    for key, (lo, hi, lo_open) in ranges.items():
        if key in item:
            kw[key] = _number(item[key], f"{where}.{key}", lo, hi, lo_open)
    return Level(**kw)


def parse_bench(data: dict[str, Any], quick: bool = False) -> Bench:
    """Validate a parsed benchmark file (module docstring); ``quick``: the ``[quick]`` sizes."""
    _unknown(data, {"bench", "quick", "axis"}, "bench file")
    head = data.get("bench")
    if not isinstance(head, dict):
        raise ValueError("bench: missing [bench] table")
    _unknown(head, _BENCH_KEYS, "bench")
    sizes: dict[str, Any] = {"seed": 0, "samples": 64, "duration": 5.0, "block": 128,
                             "success_theta": 0.2, "theta0": 0.1745, "push_at": 1.0,
                             "push_width": 0.1}  # fmt: skip
    _sizes(head, "bench", sizes)
    q = data.get("quick", {})
    if not isinstance(q, dict):
        raise ValueError("quick must be a table of [bench] sizes")
    _unknown(q, _SIZES, "quick")
    if quick:
        _sizes(q, "quick", sizes)
    items = data.get("axis")
    if not (isinstance(items, list) and items):
        raise ValueError("axis: give at least one [[axis]] with its [[axis.level]] tables")
    axes: list[Axis] = []
    for i, ax in enumerate(items):
        where = f"axis[{i}]"
        if not isinstance(ax, dict):
            raise ValueError(f"{where} must be a table")
        _unknown(ax, {"name", "title", "source", "level"}, where)
        name = _text(ax.get("name"), f"{where}.name")
        if "/" in name:
            raise ValueError(f"{where}.name must not contain '/', got {name!r}")
        title = _text(ax.get("title", name), f"{where}.title")
        source = _text(ax.get("source", "ours"), f"{where}.source")
        lv = ax.get("level")
        if not (isinstance(lv, list) and lv):
            raise ValueError(f"{where}.level: give at least one [[axis.level]]")
        levels = tuple(_level(x, name, f"{where}.level[{j}]") for j, x in enumerate(lv))
        labels = [x.label for x in levels]
        dup = sorted({x for x in labels if labels.count(x) > 1})
        if dup:
            raise ValueError(f"{where}.level: label {dup[0]!r} is used twice")
        axes.append(Axis(name, title, source, levels))
    names = [a.name for a in axes]
    dup = sorted({x for x in names if names.count(x) > 1})
    if dup:
        raise ValueError(f"axis: name {dup[0]!r} is used twice")
    if sizes["push_at"] + sizes["push_width"] > sizes["duration"] and any(
            lv.push > 0 for a in axes for lv in a.levels):  # fmt: skip
        raise ValueError(f"bench.push_at + push_width ({sizes['push_at'] + sizes['push_width']:g}"
                         f" s) must lie within the duration ({sizes['duration']:g} s)")
    from mwip.budget import DEFAULT, estimate

    DEFAULT.check(estimate(sizes["duration"], 0.005, 0.0005, n=sizes["block"]),
                  "one block of the benchmark", "lower bench.block or bench.duration")
    title = _text(head.get("title", "mwip bench"), "bench.title")
    return Bench(title=title, axes=tuple(axes), quick=quick, source=data, **sizes)


def builtin_text() -> str:
    """The text of the built-in benchmark (``bench.toml``)."""
    return resources.files("mwip.bench").joinpath("bench.toml").read_text(encoding="utf-8")


def load_bench(path: str | None = None, quick: bool = False) -> Bench:
    """The built-in benchmark, or the benchmark file ``path``."""
    if path is None:
        text, what = builtin_text(), "the built-in bench.toml"
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:  # pragma: no cover - a packaging error
            raise ValueError(f"{what} is not valid TOML: {exc}") from None
    else:
        from mwip.io import read_toml

        data = read_toml(path, "bench file")
    return parse_bench(data, quick)
