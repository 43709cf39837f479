"""Scenarios as data: a TOML file describes a closed-loop run.

Example (``examples/balance.toml``)::

    [scenario]
    controller = "lqr"       # the control law
    duration = 10.0          # s
    Ts = 0.005               # sample period (s)
    mode = "sampled"         # or "continuous"
    # dt = 0.0005            # integration step (s), optional

    [plant]                  # the simulated robot: a base set plus overrides
    base = "real"            # "real", "nominal", or a path to a parameter TOML
    mb = 2.7

    [design]                 # what the controller is designed with
    base = "nominal"

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

Unknown tables or keys are errors (a typo must not be silently ignored); every error is a
one-line ``ValueError`` naming the field.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mwip.io import read_toml
from mwip.params import NOMINAL, REAL, Params, load_params
from mwip.sim.disturbance import Disturbance, disturbance_from_dict

__all__ = ["Scenario", "load_scenario", "CONTROLLERS"]

CONTROLLERS = ("lqr",)
_INITIAL = ("theta", "alpha", "v", "theta_dot", "alpha_dot", "psi", "x", "y")


def _number(
    table: str, key: str, value: Any, lo: float, hi: float, *, lo_open: bool = True
) -> float:
    allowed = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"[{table}] {key} must be a number in {allowed}, got {value!r}")
    x = float(value)
    ok = math.isfinite(x) and (x > lo if lo_open else x >= lo) and x <= hi
    if not ok:
        raise ValueError(f"[{table}] {key} must be in {allowed}, got {value!r}")
    return x


def _params_table(name: str, data: Mapping[str, Any], default: Params, where: Path) -> Params:
    body = dict(data)
    base_value = body.pop("base", "")
    if not isinstance(base_value, str):
        raise ValueError(
            f"[{name}] base must be 'real', 'nominal' or a parameter file path, got {base_value!r}"
        )
    base_name = base_value.strip()
    if not base_name:
        base = default
    elif base_name.lower() in ("real", "nominal"):
        base = REAL if base_name.lower() == "real" else NOMINAL
    else:
        path = Path(base_name)
        if not path.is_absolute():
            path = where.parent / path
        base = load_params(path, base=default)
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
    duration: float = 10.0
    Ts: float = 0.005
    dt: float | None = None
    mode: str = "sampled"
    plant: Params = REAL
    design: Params = NOMINAL
    initial: Mapping[str, float] = field(default_factory=dict)
    disturbance: Disturbance | None = None

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ValueError(
                f"[scenario] controller must be one of {', '.join(CONTROLLERS)}, "
                f"got {self.controller!r}"
            )
        if self.mode not in ("sampled", "continuous"):
            raise ValueError(
                f"[scenario] mode must be 'sampled' or 'continuous', got {self.mode!r}"
            )
        _number("scenario", "duration", self.duration, 0.0, 3600.0)
        _number("scenario", "Ts", self.Ts, 0.0, 1.0)
        if self.dt is not None:
            _number("scenario", "dt", self.dt, 0.0, self.Ts)
        if not isinstance(self.plant, Params) or not isinstance(self.design, Params):
            raise ValueError("[plant] and [design] must be parameter sets (mwip.params.Params)")
        if not isinstance(self.initial, Mapping):
            raise ValueError(f"[initial] must be a table, got {self.initial!r}")
        for key, val in self.initial.items():
            if key not in _INITIAL:
                raise ValueError(f"[initial] unknown key {key!r}; allowed: {', '.join(_INITIAL)}")
            bound = math.pi / 2 if key == "theta" else 1e3
            _number("initial", key, val, -bound, bound)
            if abs(val) >= bound and key == "theta":
                raise ValueError(f"[initial] theta must be in (-1.5708, 1.5708), got {val!r}")

    def initial_state(self) -> dict[str, tuple[float, ...]]:
        """``q0, qdot0, pos0`` for :func:`mwip.sim.simulate` (``v`` via the plant's radius)."""
        g = {k: float(self.initial.get(k, 0.0)) for k in _INITIAL}
        return {
            "q0": (g["psi"], g["theta"], g["alpha"]),
            "qdot0": (g["v"] / float(self.plant.r), g["theta_dot"], g["alpha_dot"]),
            "pos0": (g["x"], g["y"]),
        }

    def build_controller(self) -> Any:
        """The controller, designed on :attr:`design` for this scenario's sampling."""
        from mwip.control.lqr import LQR, design_lqr

        return LQR(design_lqr(self.design, Ts=None if self.mode == "continuous" else self.Ts))

    def run(self, **kwargs: Any) -> Any:
        """Simulate the scenario; extra keyword arguments go to :func:`mwip.sim.simulate`."""
        from mwip.sim import simulate

        return simulate(
            self.build_controller(), self.plant, duration=self.duration, Ts=self.Ts, dt=self.dt,
            mode=self.mode, disturbance=self.disturbance,  # type: ignore[arg-type]
            **self.initial_state(), **kwargs,
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
    allowed = {"scenario", "plant", "design", "initial", "disturbance"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ValueError(f"unknown table [{unknown[0]}]; allowed: {sorted(allowed)}")
    for table in allowed:
        if table in data and not isinstance(data[table], dict):
            raise ValueError(f"[{table}] must be a table, got {data[table]!r}")
    sc = dict(data.get("scenario", {}))
    known = {"controller", "duration", "Ts", "dt", "mode"}
    extra = sorted(set(sc) - known)
    if extra:
        raise ValueError(f"[scenario] unknown key {extra[0]!r}; allowed: {sorted(known)}")
    for key in ("controller", "mode"):
        if key in sc and not isinstance(sc[key], str):
            raise ValueError(f"[scenario] {key} must be a string, got {sc[key]!r}")
    kwargs: dict[str, Any] = dict(sc)
    kwargs["plant"] = _params_table("plant", data.get("plant", {}), REAL, p)
    kwargs["design"] = _params_table("design", data.get("design", {}), NOMINAL, p)
    kwargs["initial"] = dict(data.get("initial", {}))
    if "disturbance" in data:
        try:
            kwargs["disturbance"] = disturbance_from_dict(data["disturbance"])
        except (ValueError, TypeError) as exc:
            raise ValueError(f"[disturbance] {exc}") from None
    return Scenario(**kwargs)
