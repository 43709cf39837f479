"""The twin's configuration as data: ``[twin]`` TOML tables, every default with its source.

A twin file (``mwip twin show`` prints the default one)::

    [twin]            Ts, dt, delay (fraction of Ts), elements (the switched-on effects)
    [twin.motor]      MAXON RE25 data (Table 2.1; inductance from the catalogue)
    [twin.drive]      gear ratio and efficiency, battery, H-bridge PWM driver
    [twin.gearbox]    Coulomb/viscous friction, backlash
    [twin.imu]        accelerometer/gyro noise, bias, drift, mounting height
    [twin.fusion]     complementary or Kalman filter
    [twin.encoder]    counts per motor turn (the gear ratio is the drive's)
    [twin.payload]    the Case 2/3 pan: mass, height above the body's top, radius
    [twin.stick]      the Case 3 stick's height
    [twin.prior]      the unknowns' ranges, one inline table each (mwip.hardware.prior):
                      "drive.gear_ratio" = { low = 3.7, high = 51.0, unit = "", source = "..." }

Values printed by the book or a data sheet are marked "fixed: data sheet"; the unknowns
"unknown" with their range in ``[twin.prior]`` (a user may narrow a range, or fix an unknown
with ``low = high``; the twin's value must lie inside). ``drive.emf_feedforward = true/false``
is read as the deprecated alias of ``drive.emf_compensation = 1/0``.

Missing keys keep their defaults; an unknown key or a value out of range is a one-line
``ValueError`` naming ``twin.<table>.<key>``. The ``[twin]`` tables may sit in a larger TOML
file (a study's settings); :func:`load_twin` reads only them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any

from mwip.hardware.drivetrain import GearboxSpec
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.imu import FusionSpec, ImuNoise
from mwip.hardware.motor import DriveSpec, MotorData
from mwip.hardware.obstacle import StickSpec
from mwip.hardware.payload import PayloadSpec
from mwip.hardware.prior import PRIOR, Prior
from mwip.hardware.twin import Twin
from mwip.io import read_toml, write_text_atomic

__all__ = ["SOURCES", "twin_from_dict", "load_twin", "twin_to_toml", "save_twin"]

#: table -> dataclass of :class:`Twin` field
_TABLES: dict[str, tuple[str, type]] = {
    "motor": ("motor", MotorData),
    "drive": ("drive", DriveSpec),
    "gearbox": ("gearbox", GearboxSpec),
    "imu": ("imu", ImuNoise),
    "fusion": ("fusion", FusionSpec),
    "encoder": ("encoder", EncoderSpec),
    "payload": ("payload", PayloadSpec),
    "stick": ("stick", StickSpec),
}
_TOP = ("Ts", "dt", "delay", "elements")

#: Where each default comes from (printed beside it by ``mwip twin show``).
SOURCES: dict[str, str] = {
    "Ts": "s; sampling period, Sec. 6.1 (5 ms)",
    "dt": "s; plant integration step (engine default, docs/engine.md)",
    "delay": "fraction of Ts; ASSUMED 1 ms of computation on the 50 MHz Cortex-M3 (no FPU)",
    "elements": "switched-on effects, all by default (mwip.hardware.elements)",
    "motor.rated_power": "W; Table 2.1",
    "motor.rated_voltage": "V; Table 2.1",
    "motor.rated_speed_rpm": "Table 2.1",
    "motor.no_load_speed_rpm": "Table 2.1; gives k_e = V / omega_0",
    "motor.stall_torque": "N m; Table 2.1 (mN m, SPEC.md section 3); gives R = k_t V / tau_s",
    "motor.continuous_torque": "N m; Table 2.1",
    "motor.max_efficiency": "Table 2.1; gives the no-load current (gearbox.coulomb)",
    "motor.rotor_inertia": "kg m^2; Table 2.1 (10.8 g cm^2)",
    "motor.inductance": "H; MAXON catalogue RE25 24 V (Table 2.1 has none)",
    "motor.torque_constant": "N m/A = V s/rad; 0: V / no-load speed (23.97e-3)",
    "motor.terminal_resistance": "Ohm; 0: k_t V / stall torque (2.368)",
    "drive.gear_ratio": "ASSUMED MAXON GP 32 A 23:1 (the book names no gearbox; docs/twin.md)",
    "drive.gear_efficiency": "MAXON GP 32 A catalogue, 2 stages (75 %)",
    "drive.supply_voltage": "V; battery, Sec. 2.5",
    "drive.current_limit": "A; ASSUMED driver limit (4x the RE25's continuous current)",
    "drive.pwm_levels": "duty steps (0: not quantised); ASSUMED (LM3S2965 PWM counter at ~20 kHz)",
    "drive.mode": "'voltage': PWM duty from the control signal (Sec. 6.1), or 'torque'",
    "drive.deadband": "duty; ASSUMED 0.5 us dead time / minimum pulse at 20 kHz",
    "drive.supply_resistance": "Ohm; ASSUMED battery + wiring resistance (voltage sag)",
    "drive.emf_compensation": "fraction of k_e omega_m the firmware adds: 0 open-loop PWM "
    "(Sec. 6.1's words), 1 full feed-forward",
    "gearbox.coulomb": "N m per wheel; N k_t I_0, I_0 from Table 2.1's 85 % efficiency",
    "gearbox.viscous": "N m s/rad per wheel beyond the book's Db (which is the drive's)",
    "gearbox.backlash": "rad at the wheel; MAXON GP 32 A catalogue (0.7 deg)",
    "imu.accel_sigma": "m/s^2 per sample; MEMS class (docs/twin.md); book names no part",
    "imu.accel_bias": "m/s^2; 2 mg residual offset, ASSUMED",
    "imu.gyro_sigma": "rad/s per sample; MEMS class, ASSUMED",
    "imu.gyro_bias": "rad/s; uncalibrated zero-rate offset, ASSUMED ('zero drift', Sec. 2.5.1)",
    "imu.gyro_bias_walk": "rad/s/sqrt(s); thermal drift, ASSUMED",
    "imu.height": "m; accelerometer above the axle, ASSUMED",
    "fusion.kind": "'complementary' or 'kalman' (Sec. 2.5.1 names both)",
    "fusion.tau": "s; complementary time constant, ASSUMED",
    "fusion.q_angle": "Kalman process noise of the angle",
    "fusion.q_bias": "Kalman process noise of the gyro bias",
    "fusion.r_angle": "Kalman variance of the accelerometer tilt",
    "encoder.cpr": "counts per motor turn; HEDS-5540 code C = 100 lines, x4 quadrature",
    "encoder.gear_ratio": "must equal drive.gear_ratio (the encoder is on the motor shaft)",
    "payload.mass": "kg; fixed: Sec. 6.2.2 (0.5 kg)",
    "payload.height": "m, pan centre above the body's top (2l, fixed)",
    "payload.radius": "m, pan radius (inertia m R^2/4)",
    "stick.height": "m, Case 3 stick ('a small stick', below r)",
}
#: Values a data sheet (or the book) prints: marked "fixed: data sheet"; the prior's unknowns
#: are marked "unknown" (their range in [twin.prior]).
_FIXED = (
    "Ts",
    "motor.rated_power",
    "motor.rated_voltage",
    "motor.rated_speed_rpm",
    "motor.no_load_speed_rpm",
    "motor.stall_torque",
    "motor.continuous_torque",
    "motor.max_efficiency",
    "motor.rotor_inertia",
    "drive.supply_voltage",
    "encoder.cpr",
)
SOURCES.update({k: "fixed: data sheet; " + SOURCES[k] for k in _FIXED})
SOURCES.update({k: "unknown (twin.prior); " + SOURCES[k] for k in PRIOR.names})


def _build(cls: type, data: Mapping[str, Any], table: str, base: Any) -> Any:
    names = [f.name for f in fields(cls)]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ValueError(f"twin.{table}: unknown key {unknown[0]!r}; allowed: {', '.join(names)}")
    for key, value in data.items():  # the type of the default (a word for a number is no number)
        old = getattr(base, key)
        kinds = ((bool, "true or false") if isinstance(old, bool) else
                 ((int, float), "a number") if isinstance(old, int | float) else
                 (str, "text") if isinstance(old, str) else (None, ""))  # fmt: skip
        if kinds[0] is not None and (not isinstance(value, kinds[0])
                                     or (kinds[0] is not bool and isinstance(value, bool))):
            shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
            raise ValueError(f"twin.{table}.{key} must be {kinds[1]}, got {shown}")
    try:
        return replace(base, **dict(data))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"twin.{table}: {exc}") from None


def twin_from_dict(data: Mapping[str, Any], base: Twin | None = None) -> Twin:
    """A :class:`Twin` from the contents of a ``[twin]`` table (missing keys from ``base``,
    default the default twin). ``encoder.gear_ratio`` follows ``drive.gear_ratio`` unless
    given."""
    if base is None:
        from mwip.hardware.identified import default_twin

        tw = default_twin()
    else:
        tw = base
    allowed = set(_TOP) | set(_TABLES) | {"prior"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ValueError(f"twin: unknown key {unknown[0]!r}; allowed: {', '.join(sorted(allowed))}")
    kw: dict[str, Any] = {}
    for table, (attr, cls) in _TABLES.items():
        sub = data.get(table, {})
        if not isinstance(sub, Mapping):
            raise ValueError(f"twin.{table} must be a table, got {sub!r}")
        kw[attr] = _build(cls, sub, table, getattr(tw, attr))
    if "gear_ratio" not in data.get("encoder", {}):
        kw["encoder"] = replace(kw["encoder"], gear_ratio=kw["drive"].gear_ratio)
    for key in _TOP:
        if key in data:
            kw[key] = data[key]
    if "elements" in kw and not isinstance(kw["elements"], list | tuple):
        raise ValueError(f"twin.elements must be a list of names, got {kw['elements']!r}")
    try:
        out = replace(tw, **kw)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"twin: {exc}") from None
    prior = Prior.from_dict(data.get("prior", {}), base=tw.prior)
    prior.check(out.values())
    return replace(out, prior=prior)


def load_twin(path: str | os.PathLike[str], base: Twin | None = None) -> Twin:
    """Read the ``[twin]`` tables of a TOML file (one-line errors naming the key)."""
    data = read_toml(path, "twin file")
    if "twin" not in data:
        raise ValueError(f"twin file {str(path)!r} has no [twin] table")
    extra = sorted(set(data) - {"twin"})
    if extra:
        raise ValueError(f"twin file {str(path)!r}: unknown table or key {extra[0]!r}; a twin "
                         "file holds only [twin] and its sub-tables")  # fmt: skip
    return twin_from_dict(data["twin"], base)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        from mwip.io import toml_str

        return toml_str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, list | tuple | frozenset):
        items = [x for x in ELEMENTS if x in v] if isinstance(v, frozenset) else list(v)
        return "[" + ", ".join(_value(x) for x in items) + "]"
    raise TypeError(f"cannot write {v!r}")


def twin_to_toml(twin: Twin | None = None, identified: str | None = None) -> str:
    """The ``[twin]`` tables of ``twin`` (default: the default twin), each value commented
    with its source (:data:`SOURCES`); ``identified`` (e.g. "most probable twin of the book
    calibration") replaces the data-sheet guess in the comment of every unknown's value."""
    if twin is None:
        from mwip.hardware.identified import default_twin

        tw = default_twin()
    else:
        tw = twin
    lines = ["# mwip digital twin (docs/twin_model.md). Units SI.", "[twin]"]

    def put(key: str, value: Any, src_key: str) -> None:
        text = f"{key} = {_value(value)}"
        src = SOURCES.get(src_key)
        if identified is not None and src_key in PRIOR.names:
            src = f"unknown (twin.prior); identified: {identified}"
        lines.append(f"{text:<34} # {src}" if src else text)

    for key in _TOP:
        put(key, tw.active if key == "elements" else getattr(tw, key), key)
    for table, (attr, cls) in _TABLES.items():
        lines += ["", f"[twin.{table}]"]
        obj = getattr(tw, attr)
        for f in fields(cls):
            if getattr(obj, f.name) is None:  # a deprecated alias, read back as None
                continue
            put(f.name, getattr(obj, f.name), f"{table}.{f.name}")
    lines += ["", "# the unknowns: uniform ranges (low = high fixes one); the values above "
              "lie inside", "[twin.prior]"]  # fmt: skip
    for name, e in tw.prior.to_dict().items():
        body = ", ".join(f"{k} = {_value(e[k])}" for k in ("low", "high", "unit", "source"))
        lines.append(f'"{name}" = {{ {body} }}')
    return "\n".join(lines) + "\n"


def save_twin(twin: Twin, path: str | os.PathLike[str]) -> None:
    """Write :func:`twin_to_toml` atomically."""
    write_text_atomic(path, twin_to_toml(twin))
