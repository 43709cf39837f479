"""Scenarios as data: a TOML file describes a closed-loop run.

Example (``examples/balance.toml``)::

    [scenario]
    controller = "lqr"       # the control law: any name of `mwip controllers`
    duration = 10.0          # s
    Ts = 0.005               # sample period (s)
    mode = "sampled"         # or "continuous"
    # dt = 0.0005            # integration step (s), optional
    # robot = "my_robot.toml" # the robot (a robot file, relative to this file; `mwip robot
    #                        # show`); default the book's. [plant] and [design] override it
    # twin = true            # run on the robot's digital twin (Chapter 6: IMU, encoders,
    #                        # drives, firmware)
    # case = 2               # with twin: 1 robot, 2 with payload, 3 payload + stick at ~6 s
    # seed = 0               # sensor-noise seed (twin)

    [controller]             # optional: the controller's settings (`mwip controllers NAME`)
    Q_diag = [1000.0, 100.0, 100.0, 100.0, 1000.0]

    [plant]                  # the simulated body: the robot's, plus overrides (book symbols)
    base = "real"            # optional: "real" or "nominal" (the book's tables) instead
    mb = 2.7

    [design]                 # what the controller is designed with: the robot's design model
    base = "nominal"         # (or a book table), plus overrides

    [initial]                # initial state; unset entries are zero
    theta = 0.1745           # rad
    alpha = 0.0              # rad
    v = 0.0                  # m/s
    theta_dot = 0.0          # rad/s
    alpha_dot = 0.0          # rad/s

    [disturbance]            # optional: external generalised forces (N m)
    kind = "sinusoid"        # "book", "sinusoid" or "pulse"
    amplitude = [0.05, 0.05, 0.05]
    omega = [2.0, 1.0, 1.0]
    phase = [1.5708, 0.0, 0.0]

Without a ``[controller]`` table the controller runs with the book's settings
(:mod:`mwip.laws.registry`). Unknown tables or keys are errors (a typo must not be
silently ignored); every error is a one-line ``ValueError`` naming the field.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from mwip.core import Controller
from mwip.io import read_toml
from mwip.laws.registry import CONTROLLERS as _REGISTRY
from mwip.laws.registry import get as _get_controller
from mwip.params import NOMINAL, REAL, Params
from mwip.sim.disturbance import Disturbance, disturbance_from_dict
from mwip.sim.result import SimResult

__all__ = ["Scenario", "ScenarioError", "load_scenario", "CONTROLLERS"]

#: The controller names a scenario may use (the registry's).
CONTROLLERS = tuple(_REGISTRY)
_INITIAL = ("theta", "alpha", "v", "theta_dot", "alpha_dot", "psi", "x", "y")


class ScenarioError(ValueError):
    """A refused scenario field. The message names the table and key (``[scenario] duration
    must be in (0, 3600], got 0.0``); ``field`` says which field (``"duration"``,
    ``"initial.theta"``, ``"controller"``, ``"settings"``, ...) and ``reason`` what is wrong
    with it, without the name (``"must be in (0, 3600], got 0.0"``), so that a front end can
    name its own option instead (``mwip simulate --duration``)."""

    def __init__(self, message: str, field: str, reason: str) -> None:
        super().__init__(message)
        self.field = field
        self.reason = reason


def _refuse(table: str, key: str, reason: str) -> ScenarioError:
    field = key if table == "scenario" else f"{table}.{key}"
    return ScenarioError(f"[{table}] {key} {reason}", field, reason)


def _number(
    table: str, key: str, value: Any, lo: float, hi: float, *, lo_open: bool = True,
    hi_open: bool = False, unit: str = "",
) -> float:  # fmt: skip
    allowed = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}{unit}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _refuse(table, key, f"must be a number in {allowed}, got {value!r}")
    x = float(value)
    ok = (math.isfinite(x) and (x > lo if lo_open else x >= lo)
          and (x < hi if hi_open else x <= hi))  # fmt: skip
    if not ok:
        raise _refuse(table, key, f"must be in {allowed}, got {value!r}")
    return x


def _params_table(name: str, data: Mapping[str, Any], default: Params) -> Params:
    body = dict(data)
    base_value = body.pop("base", "")
    if not isinstance(base_value, str) or base_value.strip().lower() not in ("", "real",
                                                                              "nominal"):
        raise ValueError(
            f"[{name}] base must be 'real' or 'nominal' (a robot file is [scenario] robot), "
            f"got {base_value!r}"
        )
    base_name = base_value.strip()
    if not base_name:
        base = default
    else:
        base = REAL if base_name.lower() == "real" else NOMINAL
    for key, value in body.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"[{name}] {key} must be a number (one robot), got {value!r}")
    try:
        return Params.from_dict(body, base=base)
    except ValueError as exc:
        raise ValueError(f"[{name}] {exc}") from None


@dataclass(frozen=True)
class Scenario:
    """A closed-loop run described as data (see module docstring)."""

    controller: str = "lqr"
    settings: Mapping[str, Any] = field(default_factory=dict)
    duration: float = 10.0
    Ts: float = 0.005
    dt: float | None = None
    mode: Literal["sampled", "continuous"] = "sampled"
    plant: Params = REAL
    design: Params = NOMINAL
    initial: Mapping[str, float] = field(default_factory=dict)
    disturbance: Disturbance | None = None
    twin: bool = False
    case: int = 1
    seed: int = 0
    #: the robot (:class:`mwip.robot.Robot`, a robot file); ``None``: the default robot. Its
    #: body and design model are :attr:`plant` and :attr:`design` (where the scenario does
    #: not override them) and its twin runs with ``twin``, its ``Ts``/``dt`` the scenario's.
    robot: Any = None

    def __post_init__(self) -> None:
        try:
            spec = _get_controller(self.controller)
        except ValueError as exc:
            raise ScenarioError(f"[scenario] {exc}", "controller", str(exc)) from None
        try:
            spec.resolve(self.settings)
        except ValueError as exc:
            raise ScenarioError(f"[controller] {exc}", "settings", str(exc)) from None
        if not isinstance(self.twin, bool):
            raise _refuse("scenario", "twin", f"must be true or false, got {self.twin!r}")
        if self.case not in (1, 2, 3) or isinstance(self.case, bool):
            raise _refuse("scenario", "case", f"must be 1, 2 or 3, got {self.case!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise _refuse("scenario", "seed", f"must be an integer >= 0, got {self.seed!r}")
        if self.case != 1 and not self.twin:
            raise ScenarioError(f"[scenario] case = {self.case} runs on the digital twin: it "
                                "needs twin = true (CLI: --twin)", "case",
                                "runs on the digital twin: it needs --twin")  # fmt: skip
        if self.twin and self.mode != "sampled":
            raise _refuse("scenario", "mode", "must be 'sampled' on the twin (twin = true)")
        if self.mode not in ("sampled", "continuous"):
            raise _refuse("scenario", "mode",
                          f"must be 'sampled' or 'continuous', got {self.mode!r}")  # fmt: skip
        _number("scenario", "duration", self.duration, 0.0, 3600.0)
        _number("scenario", "Ts", self.Ts, 0.0, 1.0)
        if self.dt is not None:
            _number("scenario", "dt", self.dt, 0.0, self.Ts)
        if not isinstance(self.plant, Params) or not isinstance(self.design, Params):
            raise ScenarioError(
                "[plant] and [design] must be parameter sets (mwip.params.Params)",
                "plant",
                "must be a parameter set",
            )
        if not isinstance(self.initial, Mapping):
            raise ScenarioError(f"[initial] must be a table, got {self.initial!r}", "initial",
                                f"must be a table, got {self.initial!r}")  # fmt: skip
        for key, val in self.initial.items():
            if key not in _INITIAL:
                raise ScenarioError(f"[initial] unknown key {key!r}; allowed: "
                                    f"{', '.join(_INITIAL)}", "initial",
                                    f"unknown key {key!r}")  # fmt: skip
            if key == "theta":  # upright within a quarter turn, both ends open
                _number("initial", key, val, -math.pi / 2, math.pi / 2, hi_open=True,
                        unit=" rad")  # fmt: skip
            else:
                _number("initial", key, val, -1e3, 1e3)

    def initial_state(self) -> dict[str, tuple[float, ...]]:
        """``q0, qdot0, pos0`` for :func:`mwip.sim.simulate` (``v`` via the plant's radius)."""
        g = {k: float(self.initial.get(k, 0.0)) for k in _INITIAL}
        return {
            "q0": (g["psi"], g["theta"], g["alpha"]),
            "qdot0": (g["v"] / float(self.plant.r), g["theta_dot"], g["alpha_dot"]),
            "pos0": (g["x"], g["y"]),
        }

    def build_controller(self) -> Controller:
        """The controller (registry name and settings), designed on :attr:`design` for this
        scenario's sampling (continuous mode: ``Ts = None``)."""
        Ts = None if self.mode == "continuous" else self.Ts
        return _get_controller(self.controller).build(self.design, self.settings, Ts)

    def run(self, **kwargs: Any) -> SimResult:
        """Simulate the scenario; extra keyword arguments go to :func:`mwip.sim.simulate`
        (plain runs) or :func:`mwip.hardware.twin.run_on_twin` (``twin``)."""
        init = self.initial_state()
        if self.twin:
            from mwip.hardware.twin import run_on_twin
            from mwip.robot import robot_or_default

            base = robot_or_default(self.robot).twin
            tw = replace(base, firmware=replace(base.firmware, Ts=self.Ts),
                         dt=base.dt if self.dt is None else self.dt)
            kwargs.pop("budget", None)  # the twin's fixed Ts, dt: the default budget applies
            return run_on_twin(
                self.build_controller(), self.case, twin=tw,
                base=self.plant, q0=init["q0"],
                qdot0=init["qdot0"], duration=self.duration, record_every=1, seed=self.seed,
                disturbance=self.disturbance, **kwargs,
            )  # fmt: skip
        from mwip.sim import simulate

        return simulate(
            self.build_controller(), self.plant, duration=self.duration, Ts=self.Ts, dt=self.dt,
            mode=self.mode, disturbance=self.disturbance, q0=init["q0"], qdot0=init["qdot0"],
            pos0=init["pos0"], seed=self.seed, **kwargs,
        )  # fmt: skip

    def with_overrides(self, **changes: Any) -> Scenario:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario TOML file; errors name the file, the table and the key."""
    p = Path(path)
    data = read_toml(p, "scenario file")
    try:
        return _scenario_from_data(data, p)
    except ValueError as exc:
        raise ValueError(f"scenario file {str(p)!r}: {exc}") from None


def _scenario_from_data(data: dict[str, Any], p: Path) -> Scenario:
    allowed = {"scenario", "controller", "plant", "design", "initial", "disturbance"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ValueError(f"unknown table [{unknown[0]}]; allowed: {sorted(allowed)}")
    for table in allowed:
        if table in data and not isinstance(data[table], dict):
            raise ValueError(f"[{table}] must be a table, got {data[table]!r}")
    sc = dict(data.get("scenario", {}))
    known = {"controller", "duration", "Ts", "dt", "mode", "twin", "case", "seed", "robot"}
    extra = sorted(set(sc) - known)
    if extra:
        raise ValueError(f"[scenario] unknown key {extra[0]!r}; allowed: {sorted(known)}")
    for key in ("controller", "mode"):
        if key in sc and not isinstance(sc[key], str):
            raise ValueError(f"[scenario] {key} must be a string, got {sc[key]!r}")
    kwargs: dict[str, Any] = dict(sc)
    body, design = REAL, NOMINAL
    if "robot" in sc:
        from mwip.robot import load_named_robot

        kwargs["robot"] = load_named_robot(sc["robot"], "[scenario] robot", p.parent)
        body, design = kwargs["robot"].body, kwargs["robot"].design
    if isinstance(kwargs.get("twin"), str):
        raise ValueError("[scenario] twin must be true or false (a twin file is now a robot "
                         "file: [scenario] robot)")  # fmt: skip
    kwargs["settings"] = dict(data.get("controller", {}))
    from mwip.laws.settings_file import check_file_types  # K = "7,3": text, not a list

    check_file_types(str(sc.get("controller", "lqr")), kwargs["settings"], "[controller]")
    kwargs["plant"] = _params_table("plant", data.get("plant", {}), body)
    kwargs["design"] = _params_table("design", data.get("design", {}), design)
    kwargs["initial"] = dict(data.get("initial", {}))
    if "disturbance" in data:
        try:
            kwargs["disturbance"] = disturbance_from_dict(data["disturbance"])
        except (ValueError, TypeError) as exc:
            raise ValueError(f"[disturbance] {exc}") from None
    return Scenario(**kwargs)
