"""What a tuning run optimises, as data: the objective file (TOML), validated into
:class:`Objective`.

::

    [objective]
    title = "..."
    mode = "scalar"          # "scalar": one cost, success first; "pareto": one objective per
                             # term and the success rate (NSGA-II, the Pareto front)
    success_theta = 0.2      # success: never fell and |theta| < this (rad) in the last second
    torque_limit = "drive"   # ... and peak torque <= a limit: "drive" (the robot's drive
                             # at its current limit or supply; on robots with the twin's drive the
                             # drive itself bounds the torque, so no further check), a number
                             # (N m, checked on any robot) or "none"

    [[objective.terms]]      # after the success rate, in this order; means over the
    metric = "rms_theta"     # successful robots (mwip.campaign.metrics)
    scale = 0.02             # the value that counts half (see below)
    weight = 1.0

    [robots]                 # the robots the tuner evaluates every candidate on
    robot = "my_robot.toml"  # optional: a robot file (relative to this file; docs/robot.md):
                             # the campaign's robot (its body, design model and twin); default
                             # the campaign's; `mwip tune --robot FILE` overrides it
    campaign = "robustness"  # a campaign (built-in name or file): its [robot] distribution,
                             # [initial], [disturbances], duration (its controllers unused)
    plant = "twin"           # "twin" (the robot's twin's sensors and drive), "plain" (ideal
                             # sensors, the commanded torque applied) or "campaign" (as it says)
    samples = 256            # robots; evaluated in chunks of `chunk` (the pruning steps)
    chunk = 64
    seed = 2026              # the robots and their noise derive from (seed, robot index)
    duration = 10.0          # s (default: the campaign's)

    [validation]             # robots and seeds the tuner never sees
    samples = 256
    seed = 1

    [space]                  # optional: which settings, narrower ranges (never wider)
    tune = ["lambdas", "K"]
    ratio = 4.0              # default range: [default / ratio, default x ratio], log scale
    [space.ranges]
    K = { lo = [1.0, 1.0], hi = [30.0, 30.0] }

The scalar cost of a candidate on ``N`` robots, ``f`` of which fail, is

    J = f / N + g / N,   g = sum_i w_i m_i / (m_i + c_i) / sum_i w_i  in [0, 1),

with ``m_i`` the mean of term ``i`` over the successful robots (``g = 1`` when none
succeeds): the success rate is strictly first (one robot more that succeeds always lowers
``J``), the terms order candidates of equal success. ``m / (m + c)`` maps ``[0, inf)`` onto
``[0, 1)`` and is monotone, so ``c`` only weighs the terms against each other. Pareto mode:
the objectives ``(f / N, m_1, m_2, ...)``, all minimised.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Term", "Objective", "TERM_METRICS", "builtin_objectives", "load_objective",
           "parse_objective", "scalar_cost", "pareto_values", "successes"]  # fmt: skip

#: The metrics a term may name (per robot, :mod:`mwip.campaign.metrics`), with their default
#: scales (the value that counts half).
TERM_METRICS: dict[str, float] = {
    "rms_theta": 0.02,  # rad
    "rms_speed_error": 0.1,  # m/s
    "control_tv": 20.0,  # N m/s
    "peak_torque": 0.5,  # N m
    "energy": 1.0,  # J
}

_TOP = {"objective", "robots", "validation", "space"}
_OBJECTIVE = {"title", "mode", "success_theta", "torque_limit", "terms"}
_ROBOTS = {"robot", "campaign", "plant", "samples", "chunk", "seed", "duration"}
_VALIDATION = {"samples", "seed"}
_SPACE = {"tune", "ratio", "ranges"}
#: Largest robot sets (a trial is samples x duration of simulated time).
MAX_ROBOTS = 100_000


@dataclass(frozen=True)
class Term:
    """A secondary term: ``metric`` (:data:`TERM_METRICS`), ``scale`` c > 0, ``weight`` >= 0."""

    metric: str
    scale: float
    weight: float = 1.0


@dataclass(frozen=True)
class Objective:
    """A validated objective file (see the module docstring)."""

    name: str
    title: str = ""
    mode: str = "scalar"
    success_theta: float = 0.2
    torque_limit: float | None = None  # N m; None: no limit
    limit_is_drive: bool = False  # the limit is the drive's: checked only without its model
    terms: tuple[Term, ...] = ()
    campaign: str = "robustness"
    plant: str = "twin"
    samples: int = 256
    chunk: int = 64
    seed: int = 2026
    duration: float | None = None
    validation_samples: int = 256
    validation_seed: int = 1
    tune: tuple[str, ...] | None = None
    ratio: float = 4.0
    ranges: tuple[tuple[str, Any], ...] = ()
    #: the robot (:class:`mwip.robot.Robot`) the campaign runs; ``None``: the campaign's own
    robot: Any = field(default=None, repr=False, compare=False)
    source: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def limit_for(self, drive: str) -> float | None:
        """The torque limit checked on robots with ``drive`` (``twin`` or ``ideal``)."""
        return None if self.limit_is_drive and drive == "twin" else self.torque_limit

    @property
    def n_objectives(self) -> int:
        return 1 if self.mode == "scalar" else 1 + len(self.terms)

    def identity(self) -> str:
        """A hash of the file's content (not its name) and of the robot as loaded."""
        src = dict(self.source)
        if self.robot is not None:
            from mwip.robot import robot_to_toml

            src["robot_loaded"] = hashlib.sha256(robot_to_toml(self.robot).encode()).hexdigest()
        text = json.dumps(src, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:12]


def _unknown(table: dict[str, Any], allowed: set[str], where: str) -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        name = f"{where}.{extra[0]}" if where else extra[0]
        raise ValueError(f"objective {name}: unknown key; allowed: {', '.join(sorted(allowed))}")


def _num(value: Any, where: str, lo: float, hi: float, lo_open: bool = False) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        ok = (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        raise ValueError(f"objective {where} must be a number in {'(' if lo_open else '['}"
                         f"{lo:g}, {hi:g}], got {value!r}")  # fmt: skip
    return float(value)


def _int(value: Any, where: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"objective {where} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _table(data: dict[str, Any], key: str) -> dict[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise ValueError(f"objective {key} must be a table")
    return value


def _robot_file(rob: dict[str, Any], folder: Path | None) -> Any:
    """The robot of ``[robots] robot`` (a file relative to ``folder``), or ``None``."""
    if "robot" not in rob:
        return None
    from mwip.robot import load_named_robot

    return load_named_robot(rob["robot"], "objective robots.robot", folder)


def parse_objective(data: dict[str, Any], name: str = "file", *, robot: Any = None,
                    folder: Path | None = None) -> Objective:  # fmt: skip
    """Validate a parsed objective file; one-line ``ValueError`` naming the field."""
    _unknown(data, _TOP, "")
    obj, rob, val, spc = (_table(data, k) for k in ("objective", "robots", "validation", "space"))
    _unknown(obj, _OBJECTIVE, "objective")
    _unknown(rob, _ROBOTS, "robots")
    _unknown(val, _VALIDATION, "validation")
    _unknown(spc, _SPACE, "space")
    title = obj.get("title", "")
    if not isinstance(title, str):
        raise ValueError("objective objective.title must be text")
    mode = obj.get("mode", "scalar")
    if mode not in ("scalar", "pareto"):
        raise ValueError(f"objective objective.mode must be one of scalar, pareto; got {mode!r}")
    success_theta = _num(obj.get("success_theta", 0.2), "objective.success_theta", 0.0, 1.5,
                         lo_open=True)  # fmt: skip
    limit_raw = obj.get("torque_limit", "drive")
    limit: float | None
    if robot is not None:
        from mwip.robot import robot_or_default

        robot = robot_or_default(robot)
    else:
        robot = _robot_file(rob, folder)
    if limit_raw == "drive" and robot is not None:
        limit = robot.wheel_torque_limit
    elif limit_raw == "drive":
        from mwip.hardware.identified import wheel_torque_limit

        limit = float(wheel_torque_limit())
    elif limit_raw == "none":
        limit = None
    else:
        try:
            limit = _num(limit_raw, "objective.torque_limit", 0.0, 1e4, lo_open=True)
        except ValueError:
            raise ValueError(
                'objective objective.torque_limit must be "drive", "none" or a '
                f"number in (0, 10000] N m, got {limit_raw!r}"
            ) from None
    raw_terms = obj.get("terms", [])
    if not isinstance(raw_terms, list):
        raise ValueError("objective objective.terms must be a list of [[objective.terms]] tables")
    if "terms" in obj and not raw_terms:
        raise ValueError("objective objective.terms is an empty list; give [[objective.terms]] "
                         "tables, or leave it out (success alone)")  # fmt: skip
    terms: list[Term] = []
    for i, t in enumerate(raw_terms):
        where = f"objective.terms[{i}]"
        if not isinstance(t, dict):
            raise ValueError(f"objective {where} must be a table")
        _unknown(t, {"metric", "scale", "weight"}, where)
        metric = t.get("metric")
        if metric not in TERM_METRICS:
            raise ValueError(f"objective {where}.metric: unknown metric {metric!r}; choose from: "
                             f"{', '.join(TERM_METRICS)}")  # fmt: skip
        scale = _num(t.get("scale", TERM_METRICS[metric]), f"{where}.scale", 0.0, 1e9, True)
        weight = _num(t.get("weight", 1.0), f"{where}.weight", 0.0, 1e9)
        terms.append(Term(metric, scale, weight))
    if len({t.metric for t in terms}) != len(terms):
        raise ValueError("objective objective.terms: a metric is named twice")
    if mode == "pareto" and not terms:
        raise ValueError("objective objective.terms: pareto mode needs at least one term")
    if mode == "scalar" and terms and sum(t.weight for t in terms) == 0:
        raise ValueError("objective objective.terms: the weights sum to 0; give one > 0")

    campaign = rob.get("campaign", "robustness")
    if not isinstance(campaign, str) or not campaign.strip():
        raise ValueError("objective robots.campaign must be a built-in campaign name or a file")
    plant = rob.get("plant", "twin")
    if plant not in ("twin", "plain", "campaign"):
        raise ValueError(f"objective robots.plant must be one of twin, plain, campaign; "
                         f"got {plant!r}")  # fmt: skip
    samples = _int(rob.get("samples", 256), "robots.samples", 1, MAX_ROBOTS)
    chunk = _int(rob.get("chunk", min(samples, 64)), "robots.chunk", 1, samples)
    if samples % chunk:
        raise ValueError(f"objective robots.chunk must divide robots.samples = {samples}, "
                         f"got {chunk}")  # fmt: skip
    seed = _int(rob.get("seed", 2026), "robots.seed", 0, 2**63 - 1)
    duration = rob.get("duration")
    if duration is not None:
        duration = _num(duration, "robots.duration", 0.0, 3600.0, lo_open=True)
    v_samples = _int(val.get("samples", samples), "validation.samples", 1, MAX_ROBOTS)
    if v_samples % chunk:
        raise ValueError(f"objective validation.samples must be a multiple of robots.chunk = "
                         f"{chunk}, got {v_samples}")  # fmt: skip
    v_seed = _int(val.get("seed", seed + 1), "validation.seed", 0, 2**63 - 1)
    if v_seed == seed:
        raise ValueError(f"objective validation.seed must differ from robots.seed = {seed} "
                         "(validation robots the tuner never saw)")  # fmt: skip

    tune = spc.get("tune")
    if tune is not None and not (isinstance(tune, list) and tune
                                 and all(isinstance(x, str) for x in tune)):  # fmt: skip
        raise ValueError("objective space.tune must be a non-empty list of setting names")
    ratio = _num(spc.get("ratio", 4.0), "space.ratio", 1.0, 1e6, lo_open=True)
    ranges = spc.get("ranges", {})
    if not isinstance(ranges, dict):
        raise ValueError("objective space.ranges must be a table")
    if "ranges" in spc and not ranges:
        raise ValueError("objective space.ranges is an empty table; give a setting's range or "
                         "leave it out")  # fmt: skip
    return Objective(
        name, title, mode, success_theta, limit, limit_raw == "drive", tuple(terms), campaign,
        plant, samples, chunk, seed, duration, v_samples, v_seed,
        None if tune is None else tuple(tune), ratio, tuple(sorted(ranges.items())),
        robot=robot, source=data,
    )  # fmt: skip


def builtin_objectives() -> list[str]:
    """The objectives shipped with mwip (``--objective NAME``)."""
    folder = resources.files("mwip.tune").joinpath("objectives")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_objective(name_or_path: str, robot: Any = None) -> Objective:
    """A built-in objective by name, or an objective file; ``robot`` (a
    :class:`mwip.robot.Robot` or a robot file) replaces its ``[robots] robot``."""
    import tomllib

    from mwip.io import read_toml

    if name_or_path in builtin_objectives():
        path = resources.files("mwip.tune").joinpath("objectives", f"{name_or_path}.toml")
        return parse_objective(tomllib.loads(path.read_text(encoding="utf-8")), name_or_path,
                               robot=robot)  # fmt: skip
    if not Path(name_or_path).is_file():
        raise ValueError(f"--objective: {name_or_path!r} is neither a built-in objective "
                         f"({', '.join(builtin_objectives())}) nor a file")  # fmt: skip
    data = read_toml(name_or_path, "objective file")
    if not data:
        raise ValueError(f"objective file {name_or_path!r} is empty; give at least its "
                         "[objective] and [robots] tables (docs/tune.md; a built-in one: "
                         f"{', '.join(builtin_objectives())})")  # fmt: skip
    return parse_objective(data, Path(name_or_path).stem, robot=robot,
                           folder=Path(name_or_path).parent)  # fmt: skip


def successes(obj: Objective, met: dict[str, NDArray], drive: str = "ideal") -> NDArray[np.bool_]:
    """Per robot: balanced (``met["success"]``) and within the torque limit checked on robots
    with ``drive`` (:meth:`Objective.limit_for`)."""
    ok = np.asarray(met["success"], dtype=bool)
    limit = obj.limit_for(drive)
    if limit is not None:
        with np.errstate(invalid="ignore"):
            ok = ok & (np.asarray(met["peak_torque"], dtype=float) <= limit)
    return ok


def term_means(obj: Objective, met: dict[str, NDArray], drive: str = "ideal") -> list[float]:
    """Each term's mean over the successful robots (``inf`` when none succeeds)."""
    ok = successes(obj, met, drive)
    out = []
    for t in obj.terms:
        x = np.asarray(met[t.metric], dtype=float)[ok]
        out.append(float(np.mean(x)) if x.size else math.inf)
    return out


def scalar_cost(obj: Objective, met: dict[str, NDArray], drive: str = "ideal") -> float:
    """``J = f / N + g / N`` (module docstring); ``drive``: the robots' (``twin``, ``ideal``)."""
    ok = successes(obj, met, drive)
    n = ok.size
    fails = int(n - ok.sum())
    weights = sum(t.weight for t in obj.terms)
    if not obj.terms or weights == 0:
        g = 0.0
    elif fails == n:
        g = 1.0
    else:
        means = term_means(obj, met, drive)
        g = sum(t.weight * (m / (m + t.scale) if math.isfinite(m) else 1.0)
                for t, m in zip(obj.terms, means, strict=True))  # fmt: skip
        g = min(g / weights, math.nextafter(1.0, 0.0))
    return (fails + g) / n


def pareto_values(obj: Objective, met: dict[str, NDArray],
                  drive: str = "ideal") -> tuple[float, ...]:  # fmt: skip
    """``(f / N, m_1, m_2, ...)``, a large finite number for a term when none succeeds."""
    ok = successes(obj, met, drive)
    means = [m if math.isfinite(m) else 1e12 for m in term_means(obj, met, drive)]
    return (float(1.0 - ok.mean()), *means)
