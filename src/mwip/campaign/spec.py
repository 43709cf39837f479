"""The campaign file: what to run, as data (TOML), validated into a frozen :class:`Campaign`.

Three kinds (the third, ``calibration``, holds the book calibration's prior draws,
:mod:`mwip.calibration.sample`). ``kind = "robustness"`` (default)::

    [campaign]
    title = "..."
    samples = 1000          # N, >= 1 (mwip campaign run --samples overrides it)
    seed = 0                # every sample's randomness derives from (seed, sample index)
    duration = 10.0         # s of simulated time per sample
    block = 100             # samples per engine batch: the numerical unit (see execute.py);
                            # below 256 the engine steps the plants on one thread
    sensors = "twin"        # "twin" (the Chapter 6 digital twin's IMU and encoders)
                            # or "ideal" (the controller sees the true state)
    drive = "twin"          # "twin" (the twin's motors: supply and current limits) or
                            # "ideal" (the commanded torque is applied); default: = sensors
    success_theta = 0.2     # success: the robot did not fall and |theta| < this (rad)
                            # throughout the last second

    [[controllers]]         # one entry per controller (registry name, settings, label)
    name = "hodosmc"
    settings = { K = [6.3, 4.0] }

    [robot]
    file = "my_robot.toml"  # optional: a robot file (relative to this file; `mwip robot show`,
                            # docs/robot.md): its body, design model and hardware (the twin);
                            # default the book's robot; `campaign run --robot FILE` overrides it
    centre = "real"         # the plant's centre: "real" (the robot's body), "nominal" (its
                            # design model) or a parameter file (missing fields: the body's)
    design = "nominal"      # the model every controller is designed on (stays fixed): as centre
    damping = "units"       # reading of the book's Db, Dw (SPEC.md section 2; the book's robot)
    [robot.uncertainty]     # per parameter; unlisted parameters stay at the centre
    mb = { uniform = 0.2 }          # centre x (1 + U(-0.2, 0.2))
    l = { normal = 0.1 }            # centre x (1 + 0.1 Z), Z standard normal cut at +-3
    r = { values = [0.04, 0.042] }  # one of the listed values (equally likely)
    Iby = { grid = [1e-3, 3e-3, 11] }  # 11 equally spaced values (a grid axis)

    [initial]               # psi, theta, alpha, psi_dot, theta_dot, alpha_dot (rad, rad/s)
    theta = { uniform = [-0.2, 0.2] }   # or a number, { values = [...] }, { grid = [lo, hi, n] }

    [[disturbances]]        # each sample takes one of them, equally likely (default: none)
    kind = "book"           # none, book, sinusoid, pulse (mwip.sim.disturbance)

Grid axes are enumerated in the order they are written, the last fastest: sample ``i`` takes
grid point ``i mod G`` (G = the number of grid points), so ``samples = G`` covers the grid once.

``kind = "claims"``: the studies' book claims over their open settings
(:mod:`mwip.campaign.claims`)::

    [campaign]
    kind = "claims"
    studies = ["all"]       # or study names; each study's [open] table gives the ranges
    samples = 20            # settings drawn per study
    quick = true            # the studies' quick variants

Any unknown key, a value of the wrong type, a distribution reaching outside a parameter's
valid range, or zero samples is a one-line ``ValueError`` naming the field.

Sizes are bounded before anything starts (the same one-line error, naming the field and the
allowed range): ``samples`` in [1, :data:`MAX_SAMPLES`], ``block`` in [1, :data:`MAX_BLOCK`]
(and one robustness block within the run budget of :mod:`mwip.budget`), a grid axis and the
whole grid at most :data:`MAX_GRID` points; the blocks of a run at most
:data:`MAX_BLOCKS` (:func:`mwip.campaign.execute.n_blocks`).
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from mwip.params import PARAM_FIELDS, Params, book_params, load_params

__all__ = [
    "Dist",
    "ControllerEntry",
    "Campaign",
    "INITIAL_KEYS",
    "parse_campaign",
    "load_campaign",
    "builtin_names",
    "builtin_text",
]

#: The initial-state coordinates a campaign may set, in the engine's state order.
INITIAL_KEYS: tuple[str, ...] = ("psi", "theta", "alpha", "psi_dot", "theta_dot", "alpha_dot")

_CAMPAIGN_KEYS = {
    "robustness": {
        "kind",
        "title",
        "samples",
        "seed",
        "duration",
        "block",
        "sensors",
        "drive",
        "success_theta",
    },
    "claims": {"kind", "title", "samples", "seed", "block", "studies", "quick"},
    "calibration": {"kind", "title", "samples", "seed", "block", "duration"},
}
_TOP_KEYS = {
    "robustness": {"campaign", "controllers", "robot", "initial", "disturbances"},
    "claims": {"campaign"},
    "calibration": {"campaign"},
}


@dataclass(frozen=True)
class Dist:
    """One uncertain quantity. ``kind``:

    - ``fixed``: ``value``;
    - ``uniform``: parameters ``centre (1 + U(-a, a))`` (``a`` = ``args[0]``); initial states
      ``U(lo, hi)``;
    - ``normal``: parameters ``centre (1 + s Z)``, ``Z`` standard normal cut at +-3
      (inverse-CDF draw of a uniform on the cut range);
    - ``values``: one of ``args``, equally likely;
    - ``grid``: ``n`` equally spaced values from ``lo`` to ``hi`` (a grid axis).
    """

    kind: str
    args: tuple[float, ...] = ()

    @property
    def is_grid(self) -> bool:
        return self.kind == "grid"

    def grid_values(self) -> np.ndarray:
        lo, hi, n = self.args
        return np.linspace(lo, hi, int(n))

    def support(self, centre: float, relative: bool) -> tuple[float, float]:
        """The smallest and largest value this distribution can give."""
        if self.kind == "fixed":
            return self.args[0], self.args[0]
        if self.kind in ("values", "grid"):
            vals = self.grid_values() if self.kind == "grid" else np.asarray(self.args)
            return float(np.min(vals)), float(np.max(vals))
        if self.kind == "uniform" and not relative:
            return self.args[0], self.args[1]
        width = self.args[0] * (3.0 if self.kind == "normal" else 1.0)
        return centre * (1.0 - width), centre * (1.0 + width)


@dataclass(frozen=True)
class ControllerEntry:
    """A controller of the campaign: registry ``name``, ``settings`` (validated), ``label``."""

    name: str
    label: str
    settings: tuple[tuple[str, Any], ...] = ()

    def settings_dict(self) -> dict[str, Any]:
        return dict(self.settings)


@dataclass(frozen=True)
class Campaign:
    """A validated campaign (see the module docstring for the file format)."""

    kind: str
    title: str
    samples: int
    seed: int
    block: int
    duration: float = 10.0
    sensors: str = "twin"
    drive: str = "twin"
    success_theta: float = 0.2
    controllers: tuple[ControllerEntry, ...] = ()
    centre: Params = field(default_factory=lambda: book_params("real"))
    design: Params = field(default_factory=lambda: book_params("nominal"))
    uncertainty: tuple[tuple[str, Dist], ...] = ()
    initial: tuple[tuple[str, Dist], ...] = ()
    disturbances: tuple[tuple[str, dict[str, Any]], ...] = (("none", {"kind": "none"}),)
    studies: tuple[str, ...] = ()
    quick: bool = True
    #: the robot (:class:`mwip.robot.Robot`) whose hardware the twin runs; ``None``: the
    #: default robot (:func:`mwip.robot.default_robot`)
    robot: Any = field(default=None, compare=False)
    #: the parsed file, for the identity check of a resumed run
    source: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def with_samples(self, n: int) -> Campaign:
        return replace(self, samples=_integer(n, "samples", 1, MAX_SAMPLES))

    @property
    def grid_axes(self) -> list[tuple[str, Dist]]:
        """Grid axes in file order: (column name, distribution)."""
        return [(k, d) for k, d in self.uncertainty + self.initial_named() if d.is_grid]

    def initial_named(self) -> tuple[tuple[str, Dist], ...]:
        return tuple((f"{k}0", d) for k, d in self.initial)

    @property
    def grid_size(self) -> int:
        return int(np.prod([int(d.args[2]) for _, d in self.grid_axes])) if self.grid_axes else 1

    def identity(self) -> str:
        """A hash of everything that defines the results except N (a longer or shorter run of
        the same campaign shares its samples, since sample i depends on (seed, i) alone)."""
        src = {k: v for k, v in self.source.items()}
        camp = dict(src.get("campaign", {}))
        camp.pop("samples", None)
        camp.pop("title", None)
        src["campaign"] = camp
        if self.robot is not None:  # the robot as loaded (its file's text may be anywhere)
            from mwip.robot import robot_to_toml

            src["robot_loaded"] = hashlib.sha256(robot_to_toml(self.robot).encode()).hexdigest()
        text = json.dumps(src, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


#: Upper bounds of a campaign's sizes (module docstring).
MAX_SAMPLES = 10_000_000
MAX_BLOCK = 10_000
MAX_GRID = 1_000_000
MAX_BLOCKS = 1_000_000


def _where(*parts: str) -> str:
    return ".".join(parts)


def _unknown(table: dict[str, Any], allowed: set[str], where: str) -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        name = f"{where}.{extra[0]}" if where else extra[0]
        raise ValueError(f"{name}: unknown key; allowed: {', '.join(sorted(allowed))}")


def _number(
    value: Any, where: str, lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False
) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        left = "(" if lo_open or math.isinf(lo) else "["
        raise ValueError(f"{where} must be a number in {left}{lo:g}, {hi:g}], got {value!r}")
    return float(value)


def _integer(value: Any, where: str, lo: int, hi: int | None = None) -> int:
    if (isinstance(value, bool) or not isinstance(value, int) or value < lo
            or (hi is not None and value > hi)):  # fmt: skip
        allowed = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
        raise ValueError(f"{where} must be an integer {allowed}, got {shown}")
    return int(value)


def _dist(value: Any, where: str, relative: bool) -> Dist:
    """Parse ``value`` (a number or a one-key table) into a :class:`Dist`."""
    if not isinstance(value, dict):
        return Dist("fixed", (_number(value, where),))
    kinds = ("uniform", "normal", "values", "grid")
    if len(value) != 1 or next(iter(value)) not in kinds:
        raise ValueError(
            f"{where} must be a number or one of {{ {' | '.join(kinds)} = ... }}, got {value!r}"
        )
    kind, arg = next(iter(value.items()))
    sub = f"{where}.{kind}"
    if kind in ("uniform", "normal") and relative:
        return Dist(kind, (_number(arg, sub, 0.0),))
    if kind == "normal":
        raise ValueError(f"{sub}: initial states take uniform = [lo, hi], values or grid")
    if kind == "uniform":
        if not (isinstance(arg, list) and len(arg) == 2):
            raise ValueError(f"{sub} must be [lo, hi], got {arg!r}")
        lo, hi = (_number(a, sub) for a in arg)
        if lo > hi:
            raise ValueError(f"{sub} must have lo <= hi, got {arg!r}")
        return Dist(kind, (lo, hi))
    if kind == "values":
        if not (isinstance(arg, list) and arg):
            raise ValueError(f"{sub} must be a non-empty list of numbers, got {arg!r}")
        return Dist(kind, tuple(_number(a, sub) for a in arg))
    if not (isinstance(arg, list) and len(arg) == 3):
        raise ValueError(f"{sub} must be [lo, hi, n], got {arg!r}")
    lo, hi = _number(arg[0], sub), _number(arg[1], sub)
    n = _integer(arg[2], f"{sub}[2]", 1, MAX_GRID)
    if lo > hi:
        raise ValueError(f"{sub} must have lo <= hi, got {arg!r}")
    return Dist(kind, (lo, hi, float(n)))


def _params(value: Any, where: str, damping: str, base: str, robot: Any = None) -> Params:
    """``real`` (the robot's body), ``nominal`` (its design model) or a parameter file
    (missing fields from ``base`` of the two); without a robot the book's sets under
    ``damping``."""
    if not isinstance(value, str):
        raise ValueError(f"{where} must be 'real', 'nominal' or a parameter file, got {value!r}")

    def book(name: str) -> Params:
        if robot is None:
            return book_params(name, damping)
        return robot.body if name == "real" else robot.design

    if value.lower() in ("real", "nominal"):
        return book(value.lower())
    path = Path(value)
    if not path.exists():
        raise ValueError(f"{where} must be 'real', 'nominal' or an existing file, got {value!r}")
    return load_params(path, base=book(base))


def _robot(table: dict[str, Any], folder: Path | None, robot: Any) -> Any:
    """The campaign's robot: ``robot`` (given by the caller, e.g. ``--robot``) over the file's
    ``[robot] file`` (relative to the campaign file's folder); ``None`` for neither."""
    if robot is not None:
        from mwip.robot import robot_or_default

        return robot_or_default(robot)
    if "file" not in table:
        return None
    from mwip.robot import load_named_robot

    return load_named_robot(table["file"], "robot.file", folder)


def _controllers(items: Any) -> tuple[ControllerEntry, ...]:
    from mwip.laws.registry import get

    if not (isinstance(items, list) and items):
        raise ValueError("controllers must be a non-empty list of [[controllers]] tables")
    out: list[ControllerEntry] = []
    for i, item in enumerate(items):
        where = f"controllers[{i}]"
        if not isinstance(item, dict):
            raise ValueError(f"{where} must be a table")
        _unknown(item, {"name", "label", "settings"}, where)
        name = item.get("name")
        if not isinstance(name, str):
            raise ValueError(f"{where}.name must be a registered controller name")
        try:
            spec = get(name)
        except ValueError as exc:
            raise ValueError(f"{where}.name: {exc}") from None
        given = item.get("settings", {})
        if not isinstance(given, dict):
            raise ValueError(f"{where}.settings must be a table")
        try:
            spec.resolve(given)
        except ValueError as exc:
            raise ValueError(f"{where}.settings: {exc}") from None
        label = item.get("label", name)
        if not (isinstance(label, str) and label):
            raise ValueError(f"{where}.label must be non-empty text")
        out.append(ControllerEntry(name, label, tuple(sorted(given.items()))))
    labels = [c.label for c in out]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise ValueError(f"controllers: label {dup[0]!r} is used twice; give each a 'label'")
    return tuple(out)


def _disturbances(items: Any) -> tuple[tuple[str, dict[str, Any]], ...]:
    from mwip.sim.disturbance import disturbance_from_dict

    if items is None:
        return (("none", {"kind": "none"}),)
    if not (isinstance(items, list) and items):
        raise ValueError("disturbances must be a non-empty list of [[disturbances]] tables")
    out = []
    for i, item in enumerate(items):
        where = f"disturbances[{i}]"
        if not isinstance(item, dict):
            raise ValueError(f"{where} must be a table")
        d = dict(item)
        label = d.pop("label", d.get("kind", ""))
        if d.get("kind") != "none":
            try:
                disturbance_from_dict(d)
            except (ValueError, TypeError) as exc:
                raise ValueError(f"{where}: {exc}") from None
        elif set(d) != {"kind"}:
            raise ValueError(f"{where}: kind 'none' takes no other keys")
        out.append((str(label), d))
    labels = [x for x, _ in out]
    if len(set(labels)) != len(labels):
        raise ValueError("disturbances: two entries share a label; give each a 'label'")
    return tuple(out)


def parse_campaign(data: dict[str, Any], *, robot: Any = None,
                   folder: Path | None = None) -> Campaign:  # fmt: skip
    """Validate a parsed campaign file (see the module docstring). ``robot`` (a
    :class:`mwip.robot.Robot` or a robot file) replaces the file's ``[robot] file``;
    ``folder`` is where that path is relative to (the campaign file's folder)."""
    camp = data.get("campaign")
    if not isinstance(camp, dict):
        raise ValueError("campaign: missing [campaign] table")
    kind = camp.get("kind", "robustness")
    if kind not in _CAMPAIGN_KEYS:
        raise ValueError(
            f"campaign.kind must be one of robustness, claims, calibration; got {kind!r}"
        )
    _unknown(data, _TOP_KEYS[kind], "")
    _unknown(camp, _CAMPAIGN_KEYS[kind], "campaign")
    title = camp.get("title", "")
    if not isinstance(title, str):
        raise ValueError("campaign.title must be text")
    samples = _integer(camp.get("samples", 100), "campaign.samples", 1, MAX_SAMPLES)
    seed = _integer(camp.get("seed", 0), "campaign.seed", 0, 2**63 - 1)
    block = _integer(camp.get("block", 100 if kind == "robustness" else 1), "campaign.block", 1,
                     MAX_BLOCK)  # fmt: skip
    if robot is not None and kind != "robustness":
        raise ValueError(f"a robot (--robot) applies to robustness campaigns; a {kind} campaign "
                         "runs the book's studies on their own robots")
    if kind == "calibration":
        cap = _number(camp.get("duration", 0.0), "campaign.duration", 0.0, 3600.0)
        return Campaign("calibration", title, samples, seed, block, duration=cap, source=data)
    if kind == "claims":
        from mwip.studies import study_names

        studies = camp.get("studies", ["all"])
        if not (isinstance(studies, list) and studies and all(isinstance(s, str) for s in studies)):
            raise ValueError("campaign.studies must be a list of study names or ['all']")
        if studies == ["all"]:
            studies = study_names()
        for s in studies:
            if s not in study_names():
                raise ValueError(
                    f"campaign.studies: unknown study {s!r}; choose from: "
                    f"{', '.join(study_names())}"
                )
        quick = camp.get("quick", True)
        if not isinstance(quick, bool):
            raise ValueError(f"campaign.quick must be true or false, got {quick!r}")
        return Campaign(
            "claims", title, samples, seed, block, studies=tuple(studies), quick=quick, source=data
        )

    duration = _number(camp.get("duration", 10.0), "campaign.duration", 0.0, 3600.0, True)
    sensors = camp.get("sensors", "twin")
    if sensors not in ("twin", "ideal"):
        raise ValueError(f"campaign.sensors must be one of twin, ideal; got {sensors!r}")
    drive = camp.get("drive", sensors)
    if drive not in ("twin", "ideal"):
        raise ValueError(f"campaign.drive must be one of twin, ideal; got {drive!r}")
    success = _number(camp.get("success_theta", 0.2), "campaign.success_theta", 0.0, 1.6, True)
    controllers = _controllers(data.get("controllers"))

    given_robot = robot
    robot = data.get("robot", {})
    if not isinstance(robot, dict):
        raise ValueError("robot must be a table")
    _unknown(robot, {"file", "centre", "design", "damping", "uncertainty"}, "robot")
    damping = robot.get("damping", "units")
    if damping not in ("units", "literal"):
        raise ValueError(f"robot.damping must be one of units, literal; got {damping!r}")
    the_robot = _robot(robot, folder, given_robot)
    if the_robot is not None and damping != "units":
        raise ValueError("robot.damping reads the book's tables; a robot file gives its body's "
                         "Db, Dw as the rotational coefficients of (2.32): drop one of the two")
    centre = _params(robot.get("centre", "real"), "robot.centre", damping, "real", the_robot)
    design = _params(robot.get("design", "nominal"), "robot.design", damping, "nominal",
                     the_robot)  # fmt: skip
    unc_table = robot.get("uncertainty", {})
    if not isinstance(unc_table, dict):
        raise ValueError("robot.uncertainty must be a table")
    _unknown(unc_table, set(PARAM_FIELDS), "robot.uncertainty")
    uncertainty = []
    for key, value in unc_table.items():
        where = f"robot.uncertainty.{key}"
        d = _dist(value, where, relative=True)
        c = float(getattr(centre, key))
        for v in d.support(c, relative=True):
            try:
                replace(centre, **{key: v})
            except ValueError:
                raise ValueError(
                    f"{where} reaches {v:g}, outside the parameter's valid range (centre {c:g})"
                ) from None
        uncertainty.append((key, d))

    init_table = data.get("initial", {})
    if not isinstance(init_table, dict):
        raise ValueError("initial must be a table")
    _unknown(init_table, set(INITIAL_KEYS), "initial")
    initial = []
    for key in init_table:
        d = _dist(init_table[key], f"initial.{key}", relative=False)
        lo, hi = d.support(0.0, relative=False)
        limit = 1.5 if key in ("theta",) else 1e3
        if lo < -limit or hi > limit:
            raise ValueError(
                f"initial.{key} must lie in [-{limit:g}, {limit:g}], "
                f"got values from {lo:g} to {hi:g}"
            )
        initial.append((key, d))
    n_grid = math.prod(int(d.args[2]) for _, d in [*uncertainty, *initial] if d.is_grid)
    if n_grid > MAX_GRID:
        raise ValueError(f"robot.uncertainty/initial: the grid has {n_grid:.3g} points; at most "
                         f"{MAX_GRID} (fewer points per grid axis)")  # fmt: skip
    from mwip.budget import DEFAULT, estimate

    DEFAULT.check(estimate(duration, 0.005, 0.005, n=block), "one block of the campaign",
                  f"lower campaign.block (in [1, {MAX_BLOCK}]) or campaign.duration")  # fmt: skip
    return Campaign(
        "robustness",
        title,
        samples,
        seed,
        block,
        duration,
        sensors,
        drive,
        success,
        controllers,
        centre,
        design,
        tuple(uncertainty),
        tuple(initial),
        _disturbances(data.get("disturbances")),
        robot=the_robot,
        source=data,
    )


def builtin_names() -> list[str]:
    """The campaigns shipped with mwip (``mwip campaign show NAME``)."""
    folder = resources.files("mwip.campaign").joinpath("builtin")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_text(name: str) -> str:
    """The text of built-in campaign ``name``."""
    if name not in builtin_names():
        raise ValueError(f"unknown campaign {name!r}; built-in: {', '.join(builtin_names())}")
    path = resources.files("mwip.campaign").joinpath("builtin", f"{name}.toml")
    return path.read_text(encoding="utf-8")


def load_campaign(name_or_path: str, robot: Any = None) -> Campaign:
    """A built-in campaign by name, or a campaign file; ``robot`` (a :class:`mwip.robot.Robot`
    or a robot file) replaces the file's ``[robot] file`` (see :func:`parse_campaign`)."""
    if name_or_path in builtin_names():
        text = builtin_text(name_or_path)
    else:
        path = Path(name_or_path)
        if not path.is_file():
            raise ValueError(
                f"campaign {name_or_path!r} is neither a built-in campaign "
                f"({', '.join(builtin_names())}) nor a file"
            )
        from mwip.io import read_toml  # size, encoding, BOM and syntax: one line each

        return parse_campaign(read_toml(path, "campaign"), robot=robot, folder=path.parent)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:  # pragma: no cover - a packaging error
        raise ValueError(f"campaign {name_or_path!r} is not valid TOML: {exc}") from None
    return parse_campaign(data, robot=robot)
