"""Running the benchmark: its runs as blocks of the campaign engine (:mod:`mwip.campaign.execute`).

The runs. Level ``L`` (of all axes' levels, in file order) and replicate ``i`` make run
``u = L n + i`` (``n`` = ``bench.samples``); the engine's *sample* index is ``u``. Block ``b``
holds runs ``b B .. (b + 1) B - 1`` (``B`` = ``bench.block``, the last block padded with runs
that are simulated and dropped) and is one engine batch per entrant on the robot's twin
(default: the identified one), every run with its own robot, twin unknowns, delay, actuator
and push (all per row).

Randomness, from the bench seed ``s`` alone (never from the block, the chunk or the worker):

- replicate ``i``'s initial pitch ``U(-theta0, theta0)``: ``SeedSequence(s, spawn_key=(0, i))``;
- its IMU noise (every normal variate the twin's IMU draws, per row):
  ``SeedSequence(s, spawn_key=(1, i))``; its torque noise: ``(2, i)``;
- the level's own draws (parameters, twin unknowns, posterior member):
  ``SeedSequence(s, spawn_key=(3, crc32(axis/label), i))``.

So replicate ``i`` of every level starts alike and sees the same noise streams (common random
numbers), a level without effects repeats the nominal runs, and a row depends only on (seed,
level, replicate) and the block it is computed in (its batch size: fixed by ``B``): the table
is the same for any ``--jobs``, chunk size or interruption (:mod:`mwip.campaign.execute`).
"""

from __future__ import annotations

import copy
import hashlib
import json
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.bench.spec import CASE_ONLY, Bench, Level
from mwip.params import NOMINAL, PARAM_FIELDS, Params

__all__ = ["Entrant", "BenchRun", "run_rows", "posterior_members"]


@dataclass(frozen=True)
class Entrant:
    """A controller in the benchmark: registry ``name``, ``settings`` (validated), the model it
    is designed on and where it comes from (``origin``: registry, a settings file, a scenario)."""

    label: str
    name: str
    settings: tuple[tuple[str, Any], ...] = ()
    design: Params = NOMINAL
    origin: str = "registry"

    def settings_dict(self) -> dict[str, Any]:
        return dict(self.settings)

    def record(self) -> dict[str, Any]:
        return {"label": self.label, "name": self.name, "origin": self.origin,
                "settings": {k: list(v) if isinstance(v, tuple) else v
                             for k, v in self.settings},
                "design": {f: float(getattr(self.design, f)) for f in PARAM_FIELDS}}  # fmt: skip


@dataclass(frozen=True)
class BenchRun:
    """A benchmark of ``entrants`` as work for :func:`mwip.campaign.execute.run_campaign`: it
    has the campaign's ``kind``, ``samples`` (runs per entrant), ``block``, ``source`` and
    ``identity()``, and brings its own block runner (``compute_chunk``) and row order."""

    bench: Bench
    entrants: tuple[Entrant, ...]
    #: the robot (:class:`mwip.robot.Robot`): its body is every run's real robot, its twin the
    #: hardware; ``None``: the default robot (:func:`mwip.robot.default_robot`)
    robot: Any = field(default=None, compare=False)
    kind: str = field(default="bench", init=False)

    @property
    def the_robot(self) -> Any:
        """:attr:`robot`, or the default robot."""
        from mwip.robot import robot_or_default

        return robot_or_default(self.robot)

    @property
    def samples(self) -> int:
        return len(self.bench.levels) * self.bench.samples

    @property
    def block(self) -> int:
        return self.bench.block

    @property
    def source(self) -> dict[str, Any]:
        b = self.bench
        robot = self.the_robot
        extra: dict[str, Any] = {}
        if self.robot is not None:  # the robot as loaded (the default's values are above)
            from mwip.robot import robot_to_toml

            extra["robot_loaded"] = hashlib.sha256(robot_to_toml(robot).encode()).hexdigest()
        return {"bench": b.source, "quick": b.quick, "twin": robot.twin.values(), **extra,
                "posterior_members": len(posterior_members(self.robot)),
                "sizes": {k: getattr(b, k) for k in ("seed", "samples", "duration", "block",
                                                     "success_theta", "theta0", "push_at",
                                                     "push_width", "payload_height",
                                                     "payload_radius")},
                "entrants": [e.record() for e in self.entrants]}  # fmt: skip

    def identity(self) -> str:
        """A hash of everything that defines the rows (the definition, the sizes, the entrants,
        the robot's twin values, the robot as loaded)."""
        text = json.dumps(self.source, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def order_key(self) -> tuple[str, list[str]]:
        return "controller", [e.label for e in self.entrants]

    def compute_chunk(self, blocks: list[int]) -> Any:
        """The rows of ``blocks`` (a pandas DataFrame; runs on a worker)."""
        import pandas as pd

        ctrls = _controllers(self)
        frames = [pd.DataFrame(cols) for b in blocks for cols in run_rows(self, b, ctrls)]
        return pd.concat(frames, ignore_index=True)


_CACHE: dict[str, dict[str, Any]] = {}


def _controllers(work: BenchRun) -> dict[str, Any]:
    """Every entrant designed on its design model, once per process."""
    from mwip.laws.registry import build

    key = work.identity()
    if key not in _CACHE:
        _CACHE.clear()
        _CACHE[key] = {e.label: build(e.name, e.design, e.settings_dict())
                       for e in work.entrants}  # fmt: skip
    return _CACHE[key]


def posterior_members(robot: Any = None) -> list[dict[str, float]]:
    """The twin's posterior members as unknown values. For the default robot (``robot`` is
    ``None``): ``members`` of ``book-twin.json`` (resampled from the book calibration's
    weighted posterior, or a thinned set of its Markov chain states where the chains were its
    sampler; names as the robot file has them now, :func:`mwip.hardware.prior.current_name`),
    else (a posterior of stages 1-2 alone lists none) the default twin's values alone. For
    another robot, its own twin's values alone (its file carries no posterior)."""
    from mwip.hardware.identified import STATUS_FILE, default_twin
    from mwip.hardware.prior import current_name

    if robot is not None:
        from mwip.robot import robot_or_default

        return [robot_or_default(robot).twin.values()]
    try:
        doc = json.loads(STATUS_FILE.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        doc = {}
    members = doc.get("members") if isinstance(doc, dict) else None
    if isinstance(members, list) and members:
        known = default_twin().values()
        out = []
        for m in members:
            row = dict(known)  # a member names the unknowns it varies
            row.update({current_name(k): float(v) for k, v in m.items()})
            out.append({k: row[k] for k in known})
        return out
    return [default_twin().values()]


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=tuple(int(k) for k in key)))


def _level_key(lv: Level) -> int:
    return zlib.crc32(lv.key.encode("utf-8"))


class _Push:
    """Per-row rectangular pulses ``(J / width) (r, l, 0)`` from ``at`` over ``width``."""

    def __init__(self, J: NDArray[np.float64], r: NDArray[np.float64], l: NDArray[np.float64],
                 at: float, width: float) -> None:  # fmt: skip
        f = J / width
        self.forces = np.column_stack([f * r, f * l, np.zeros_like(f)])  # (N, 3)
        self.at, self.width = at, width

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float)
        on = ((tt >= self.at) & (tt < self.at + self.width)).astype(float)
        return on[:, None, None] * self.forces[None, :, :]


def _v_ref(entry: Entrant) -> float:
    """The entrant's speed target (``v_d``, or ``r psi_dot_d`` of its design model; else 0)."""
    from mwip.laws.registry import get

    s = get(entry.name).resolve(entry.settings_dict())
    if s.get("v_d") is not None:
        return float(s["v_d"])
    if s.get("psi_dot_d") is not None:
        return float(entry.design.r) * float(s["psi_dot_d"])
    return 0.0


def _inputs(bench: Bench, units: NDArray[np.int64], robot: Any = None) -> dict[str, Any]:
    """Per-row inputs of runs ``units``: levels, replicates, initial pitch, the real robot per
    row (``robot``'s body, varied by the level), the twin's unknowns per row, whole-sample
    delay, responsiveness, torque noise, push; ``robot`` ``None``: the default robot."""
    from mwip.robot import robot_or_default

    levels = bench.levels
    n = units.size
    li = (units // bench.samples) % len(levels)
    rep = units % bench.samples
    the_robot = robot_or_default(robot)
    twin = the_robot.twin
    base = twin.values()
    acting = [u.name for u in twin.prior if not u.name.startswith(CASE_ONLY)]
    real = the_robot.body
    fields = {f: np.full(n, float(getattr(real, f))) for f in PARAM_FIELDS}
    vals = {k: np.full(n, v) for k, v in base.items()}
    theta0 = np.empty(n)
    whole = np.zeros(n, dtype=np.int64)
    rho, sigma, push, pay = np.ones(n), np.zeros(n), np.zeros(n), np.zeros(n)
    members = posterior_members(robot)
    for j in range(n):
        lv, i = levels[int(li[j])], int(rep[j])
        theta0[j] = bench.theta0 * (2.0 * _rng(bench.seed, 0, i).random() - 1.0)
        g = _rng(bench.seed, 3, _level_key(lv), i)
        for f, a in lv.params:
            fields[f][j] = float(getattr(real, f)) * (1.0 + a * (2.0 * g.random() - 1.0))
        if lv.twin == "posterior":
            m = members[int(g.integers(len(members)))]
            for k, v in m.items():
                vals[k][j] = v
        elif lv.twin is not None:
            names = acting if lv.twin == "prior" else list(lv.twin)
            for name in names:
                u = twin.prior[name]
                vals[name][j] = u.low + g.random() * (u.high - u.low)
        if lv.noise != 1.0:
            vals["imu.accel_sigma"][j] = lv.noise * base["imu.accel_sigma"]
            vals["imu.gyro_sigma"][j] = lv.noise * base["imu.gyro_sigma"]
        if lv.deadband is not None:
            vals["drive.deadband"][j] = lv.deadband
        if lv.delay is not None:
            shift = 0 if lv.delay == 0.0 else int(np.ceil(lv.delay)) - 1
            whole[j] = shift
            vals["firmware.delay"][j] = lv.delay - shift
        rho[j], sigma[j], push[j], pay[j] = lv.responsiveness, lv.torque_noise, lv.push, lv.payload
    plant = replace(real, **fields)
    if np.any(pay > 0):
        h = base["payload.height"] if bench.payload_height is None else bench.payload_height
        rad = base["payload.radius"] if bench.payload_radius is None else bench.payload_radius
        loaded = plant.with_payload(pay, h, pan_radius=rad)  # type: ignore[arg-type]  # (N,)
        on = pay > 0
        plant = replace(plant, **{f: np.where(on, getattr(loaded, f), getattr(plant, f))
                                  for f in ("mb", "l", "Iby", "Ibz", "Iyaw")})  # fmt: skip
    return {"level": li, "replicate": rep, "theta0": theta0, "plant": plant, "values": vals,
            "whole": whole, "rho": rho, "sigma": sigma, "push": push}  # fmt: skip


def _twin_for(values: Mapping[str, NDArray[np.float64]], robot: Any = None) -> Any:
    """The robot's twin (``None``: the default robot's) with its prior widened to hold
    ``values`` (the stress levels go past the declared ranges; the prior only validates, it
    changes no value)."""
    from mwip.hardware.prior import Prior
    from mwip.robot import robot_or_default

    twin = robot_or_default(robot).twin
    wide = {u.name: {"low": min(u.low, float(np.min(values[u.name]))),
                     "high": max(u.high, float(np.max(values[u.name])))}
            for u in twin.prior}  # fmt: skip
    return replace(twin, prior=Prior.from_dict(wide, base=twin.prior))


def run_rows(work: BenchRun, block: int, controllers: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The rows of ``block``, one table (column -> (B,) array) per entrant: ``controller``,
    ``sample`` (the run), ``axis``, ``level``, ``replicate``, ``theta0`` and the metrics of
    :mod:`mwip.campaign.metrics`."""
    from mwip.campaign.metrics import sample_metrics
    from mwip.hardware.twin import NoiseTable
    from mwip.sim.engine import simulate

    bench = work.bench
    B = bench.block
    units = np.arange(block * B, (block + 1) * B, dtype=np.int64)
    inp = _inputs(bench, units, work.robot)
    twin = _twin_for(inp["values"], work.robot)
    vals, n = twin.row_values(inp["values"])
    plant: Params = inp["plant"]
    p = twin.plant(plant, None, vals)
    S = max(int(round(bench.duration / twin.Ts)), 1) + 1  # sample instants of a run
    rep = inp["replicate"]
    imu = np.stack([_rng(bench.seed, 1, int(i)).standard_normal(4 * S) for i in rep])
    tq = np.stack([_rng(bench.seed, 2, int(i)).standard_normal((S, 2)) for i in rep])
    dist = None
    if np.any(inp["push"] > 0):
        r_arr = np.asarray(plant.r, dtype=float)
        l_arr = np.asarray(plant.l, dtype=float)
        dist = _Push(inp["push"], r_arr, l_arr, bench.push_at, bench.push_width)
    levels = bench.levels
    axis = np.array([levels[int(k)].axis for k in inp["level"]], dtype=object)
    label = np.array([levels[int(k)].label for k in inp["level"]], dtype=object)
    b = np.broadcast_to(np.asarray(plant.b, dtype=float), (n,))
    q0 = np.column_stack([np.zeros(n), inp["theta0"], np.zeros(n)])
    rows: list[dict[str, Any]] = []
    sensor_noise = NoiseTable(imu.reshape(n, S, 4))
    command = {"sigma": inp["sigma"], "whole": inp["whole"], "rho": inp["rho"]}
    for entry in work.entrants:
        ctrl = copy.deepcopy(controllers[entry.label])
        sensor = twin.sensor(p, values=vals, noise=sensor_noise)
        drive = twin.actuator(p, values=vals, command=command, noise=NoiseTable(tq))
        res = simulate(ctrl, p, q0=q0, duration=bench.duration, Ts=twin.Ts, dt=twin.dt,
                       disturbance=dist, sensor=sensor, actuator=drive, seed=0)  # fmt: skip
        met = sample_metrics(res, b, _v_ref(entry), bench.success_theta)
        cols: dict[str, Any] = {"controller": np.full(n, entry.label, dtype=object),
                                "sample": units, "axis": axis, "level": label,
                                "replicate": rep.astype(np.int64), "theta0": inp["theta0"]}
        cols.update(met)
        rows.append(cols)
    return rows
