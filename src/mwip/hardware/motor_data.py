"""The motor's data sheet and the drive's specification (:class:`MotorData`, :data:`RE25`,
:class:`DriveSpec`): plain values of :mod:`mwip.hardware.motor` (its module docstring says what
they model), kept apart from its compiled kernel so that a command that only needs a value
(``mwip simulate``'s drive torque limit, :func:`mwip.hardware.identified.wheel_torque_limit`)
imports no compiler. :mod:`mwip.hardware.motor` re-exports them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

__all__ = ["RPM", "MotorData", "RE25", "DriveSpec"]

RPM = 2.0 * np.pi / 60.0


def _check(name: str, value: float, lo: float, hi: float) -> None:
    if not (np.isfinite(value) and lo < value <= hi):
        raise ValueError(f"{name!r} must be finite and in ({lo:g}, {hi:g}], got {value!r}")


@dataclass(frozen=True)
class MotorData:
    """Motor data sheet (Table 2.1 defaults, MAXON RE25 20 W 24 V), SI units.

    ``torque_constant`` and ``terminal_resistance`` are derived from Table 2.1 when 0 (the
    default): ``k_t = k_e = V / omega_0``, ``R = k_t V / tau_stall``; a positive value sets
    them directly (e.g. from a catalogue or a measurement).
    """

    rated_power: float = 20.0
    rated_voltage: float = 24.0
    rated_speed_rpm: float = 8330.0
    no_load_speed_rpm: float = 9560.0
    stall_torque: float = 0.243
    continuous_torque: float = 0.0263
    max_efficiency: float = 0.85
    rotor_inertia: float = 10.8e-7  # 10.8 g cm^2
    inductance: float = 0.238e-3
    torque_constant: float = 0.0
    terminal_resistance: float = 0.0

    def __post_init__(self) -> None:
        _check("rated_power", self.rated_power, 0.0, 1e4)
        _check("rated_voltage", self.rated_voltage, 0.0, 1e3)
        _check("rated_speed_rpm", self.rated_speed_rpm, 0.0, 1e6)
        _check("no_load_speed_rpm", self.no_load_speed_rpm, 0.0, 1e6)
        _check("stall_torque", self.stall_torque, 0.0, 1e3)
        _check("continuous_torque", self.continuous_torque, 0.0, 1e3)
        _check("max_efficiency", self.max_efficiency, 0.0, 1.0)
        _check("rotor_inertia", self.rotor_inertia, 0.0, 1.0)
        _check("inductance", self.inductance, 0.0, 1.0)
        for name in ("torque_constant", "terminal_resistance"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v <= 1e3):
                raise ValueError(
                    f"{name!r} must be finite and in [0, 1000] (0: from Table 2.1), got {v!r}"
                )

    @property
    def k_e(self) -> float:
        """Back-EMF constant (V s/rad) = rated voltage / no-load speed (or
        ``torque_constant``)."""
        if self.torque_constant > 0:
            return self.torque_constant
        return self.rated_voltage / (self.no_load_speed_rpm * RPM)

    @property
    def k_t(self) -> float:
        """Torque constant (N m/A), equal to ``k_e`` in SI units."""
        return self.k_e

    @property
    def resistance(self) -> float:
        """Terminal resistance (Ohm) = ``k_t V / tau_stall`` (or ``terminal_resistance``)."""
        if self.terminal_resistance > 0:
            return self.terminal_resistance
        return self.k_t * self.rated_voltage / self.stall_torque

    @property
    def stall_current(self) -> float:
        """Stall current (A) at the rated voltage."""
        return self.rated_voltage / self.resistance

    @property
    def tau_e(self) -> float:
        """Electrical time constant ``L / R`` (s)."""
        return self.inductance / self.resistance


RE25 = MotorData()


@dataclass(frozen=True)
class DriveSpec:
    """Gearbox ratio and efficiency, battery and H-bridge PWM driver (docs/twin_model.md).

    gear_ratio : motor turns per wheel turn (23: MAXON GP 32 A 23:1; the book names none).
    gear_efficiency : torque efficiency of the gearbox (0.75: GP 32 A, 2 stages, catalogue).
    supply_voltage : battery voltage (24 V, Sec. 2.5).
    supply_resistance : battery + wiring resistance (Ohm) for the sag ``V = V_0 - R_s I_bat``
        (assumed 0.2 Ohm; the book gives none).
    current_limit : driver's current limit (A), steady current ``|V - e| / R <= I_max``.
    pwm_levels : duty steps over [0, 1] (0: not quantised).
    deadband : duty lost to the H-bridge's dead time / minimum pulse, ``d -> sign(d)
        max(|d| - deadband, 0)`` (assumed 0.01: 0.5 us at 20 kHz).
    mode : ``"voltage"`` (default, the book's PWM speed regulation: duty proportional to the
        commanded torque, ``V* = R tau / (N eta k_t)``, back-EMF acting on the motor) or
        ``"torque"`` (a current-controlled driver: ``V* = R i* + k_e omega_m``).
    The firmware's back-EMF compensation is the firmware's
    (:class:`mwip.hardware.firmware.FirmwareSpec`); the plant's back-EMF damping stays whole
    whatever it is.
    """

    gear_ratio: float = 23.0
    gear_efficiency: float = 0.75
    supply_voltage: float = 24.0
    current_limit: float = 4.0
    pwm_levels: int = 1000
    mode: Literal["torque", "voltage"] = "voltage"
    deadband: float = 0.01
    supply_resistance: float = 0.2

    def __post_init__(self) -> None:
        _check("gear_ratio", self.gear_ratio, 0.0, 1000.0)
        _check("gear_efficiency", self.gear_efficiency, 0.0, 1.0)
        _check("supply_voltage", self.supply_voltage, 0.0, 1000.0)
        _check("current_limit", self.current_limit, 0.0, 1000.0)
        if int(self.pwm_levels) != self.pwm_levels or not (0 <= self.pwm_levels <= 10**7):
            raise ValueError(
                f"'pwm_levels' must be an integer in [0, 1e7], got {self.pwm_levels!r}"
            )
        if self.mode not in ("torque", "voltage"):
            raise ValueError(f"'mode' must be 'torque' or 'voltage', got {self.mode!r}")
        if not (np.isfinite(self.deadband) and 0.0 <= self.deadband < 1.0):
            raise ValueError(f"'deadband' must be finite and in [0, 1), got {self.deadband!r}")
        if not (np.isfinite(self.supply_resistance) and 0.0 <= self.supply_resistance <= 100.0):
            raise ValueError(
                f"'supply_resistance' must be finite and in [0, 100], "
                f"got {self.supply_resistance!r}"
            )

    def wheel_torque_limit(self, motor: MotorData = RE25) -> float:
        """Largest wheel torque at standstill (N m): current limit or supply, whichever binds."""
        i = min(self.current_limit, self.supply_voltage / motor.resistance)
        return self.gear_ratio * self.gear_efficiency * motor.k_t * i

    def emf_damping(self, motor: MotorData = RE25, gear_ratio: Any = None) -> Any:
        """Back-EMF damping of a voltage drive at the wheel, ``eta N^2 k_t k_e / R``
        (N m s/rad per wheel, on the wheel speed relative to the body); ``gear_ratio``
        replaces ``N`` (a float or one per row of a batch of twins)."""
        n = self.gear_ratio if gear_ratio is None else gear_ratio
        return self.gear_efficiency * n * n * motor.k_t * motor.k_e / motor.resistance
