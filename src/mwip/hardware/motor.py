"""DC motor (MAXON RE25, Table 2.1) and PWM driver (Sec. 2.5.2) as the robot's actuator.

Motor, per wheel (armature circuit and shaft)::

    L i' = V - R i - k_e omega_m,      tau_m = k_t i,      J_r omega_m' = tau_m - tau_load

Table 2.1 prints no resistance or constants; they follow from its numbers so that the table
is reproduced exactly at the rated 24 V (tested): ``k_e = V / omega_0`` (no-load speed
9560 rpm), ``k_t = k_e`` (SI), ``R = k_t V / tau_stall`` (stall torque 243 mN m; SPEC.md
section 3: the table's "N m" are mN m). That gives ``k_t = 23.97 mN m/A`` and
``R = 2.37 Ohm``, within 3 % of MAXON's catalogue RE25 24 V (118752: 23.4 mN m/A,
2.32 Ohm). Inductance 0.238 mH (catalogue; Table 2.1 has none).

Gearbox: ratio ``N = 23`` (MAXON GP 32 A, 23:1, a standard pairing with the RE25); wheel
torque ``N eta k_t i``, motor speed ``N (psi_i' - theta')`` (the stator is on the body).
Why 23 (docs/twin.md): wheel stall torque 5.6 N m and continuous 0.60 N m per wheel cover the
0.1-0.5 N m the Chapter 6 controllers command (Figs. 6.4-6.16 plot |tau| <= 0.2 N m;
transients reach ~1 N m), while the wheel no-load speed 43.5 rad/s leaves ample headroom over
the 7 rad/s speed target.

Driver: the controller's torque command is turned into a PWM duty. ``mode="torque"``
(default) is a current-mode servo driver: ``V* = R i* + k_e omega_m`` with
``i* = tau_cmd / (N eta k_t)`` (back-EMF feed-forward), so the wheel gets the commanded torque
until a limit bites; ``mode="voltage"`` maps torque to duty open-loop
(``V* = R i*``), so back-EMF acts as extra damping. Then the limits, in this order: current
limit (``|i_ss| <= I_max``), supply (``|V| <= 24 V``), duty quantisation to ``pwm_levels``
(rounded, but never across the current limit).
The current is integrated exactly over the sample (``V``, ``omega_m`` held), and the torque
held over the sample is the one produced by the *mean* current.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MotorData",
    "RE25",
    "DriveSpec",
    "current_step",
    "driver_voltage",
    "quantise_duty",
    "steady_speed",
    "simulate_motor",
    "DriveActuator",
]

RPM = 2.0 * np.pi / 60.0


def _check(name: str, value: float, lo: float, hi: float) -> None:
    if not (np.isfinite(value) and lo < value <= hi):
        raise ValueError(f"{name!r} must be finite and in ({lo:g}, {hi:g}], got {value!r}")


@dataclass(frozen=True)
class MotorData:
    """Motor data sheet (Table 2.1 defaults, MAXON RE25 20 W 24 V), SI units."""

    rated_power: float = 20.0
    rated_voltage: float = 24.0
    rated_speed_rpm: float = 8330.0
    no_load_speed_rpm: float = 9560.0
    stall_torque: float = 0.243
    continuous_torque: float = 0.0263
    max_efficiency: float = 0.85
    rotor_inertia: float = 10.8e-7  # 10.8 g cm^2
    inductance: float = 0.238e-3

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

    @property
    def k_e(self) -> float:
        """Back-EMF constant (V s/rad) = rated voltage / no-load speed."""
        return self.rated_voltage / (self.no_load_speed_rpm * RPM)

    @property
    def k_t(self) -> float:
        """Torque constant (N m/A), equal to ``k_e`` in SI units."""
        return self.k_e

    @property
    def resistance(self) -> float:
        """Terminal resistance (Ohm) = ``k_t V / tau_stall``."""
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
    """Gearbox and PWM driver. ``current_limit`` is the driver's (A), ``pwm_levels`` the
    number of duty steps over [0, 1] (LM3S2965 PWM at 20 kHz: 1250 counts; 1000 default)."""

    gear_ratio: float = 23.0
    gear_efficiency: float = 1.0
    supply_voltage: float = 24.0
    current_limit: float = 4.0
    pwm_levels: int = 1000
    mode: Literal["torque", "voltage"] = "torque"

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

    def wheel_torque_limit(self, motor: MotorData = RE25) -> float:
        """Largest wheel torque at standstill (N m): current limit or supply, whichever binds."""
        i = min(self.current_limit, self.supply_voltage / motor.resistance)
        return self.gear_ratio * self.gear_efficiency * motor.k_t * i


def current_step(
    i0: ArrayLike, v: ArrayLike, omega_m: ArrayLike, motor: MotorData, Ts: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact solution of ``L i' = V - R i - k_e omega_m`` over ``Ts`` with ``V, omega_m`` held.

    Returns ``(i_end, i_mean)``: the current at the end of the sample and its mean over it.
    """
    R, tau = motor.resistance, motor.tau_e
    i_ss = (np.asarray(v, dtype=float) - motor.k_e * np.asarray(omega_m, dtype=float)) / R
    d = np.asarray(i0, dtype=float) - i_ss
    e = np.exp(-Ts / tau)
    return i_ss + d * e, i_ss + d * (tau / Ts) * (1.0 - e)


def driver_voltage(
    tau_cmd: ArrayLike, omega_m: ArrayLike, motor: MotorData, drive: DriveSpec
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Terminal voltage asked by the driver for a wheel torque command, after the current
    limit and the supply limit. Returns ``(V, limited)``."""
    gain = drive.gear_ratio * drive.gear_efficiency * motor.k_t
    i_ref = np.asarray(tau_cmd, dtype=float) / gain
    R = motor.resistance
    emf = motor.k_e * np.asarray(omega_m, dtype=float)
    v = R * i_ref + (emf if drive.mode == "torque" else 0.0)
    # current limit: the steady current (V - emf)/R stays within +-I_max
    lo = emf - R * drive.current_limit
    hi = emf + R * drive.current_limit
    v_lim = np.clip(v, lo, hi)
    v_lim = np.clip(v_lim, -drive.supply_voltage, drive.supply_voltage)
    return v_lim, np.abs(v_lim - v) > 1e-12


def quantise_duty(v: ArrayLike, drive: DriveSpec) -> NDArray[np.float64]:
    """PWM: duty ``V / V_supply`` rounded to ``1 / pwm_levels`` (0 levels: no quantisation)."""
    duty = np.clip(np.asarray(v, dtype=float) / drive.supply_voltage, -1.0, 1.0)
    if drive.pwm_levels > 0:
        duty = np.round(duty * drive.pwm_levels) / drive.pwm_levels
    return duty


def steady_speed(v: ArrayLike, load_torque: ArrayLike, motor: MotorData = RE25) -> NDArray:
    """Steady shaft speed (rad/s) at voltage ``v`` and load torque (N m): the speed-torque line
    ``omega = (V - R tau / k_t) / k_e``."""
    return (
        np.asarray(v, dtype=float)
        - motor.resistance * np.asarray(load_torque, dtype=float) / motor.k_t
    ) / motor.k_e


def simulate_motor(
    v: float,
    load_torque: float = 0.0,
    duration: float = 0.5,
    motor: MotorData = RE25,
    dt: float = 1e-5,
) -> tuple[NDArray[np.floating], NDArray[np.float64], NDArray[np.float64]]:
    """Free motor run from rest (electrical and mechanical model): ``(t, omega, i)``.

    Semi-implicit Euler on ``L i' = V - R i - k_e omega``, ``J omega' = k_t i - tau_load``
    (the electrical pole is integrated exactly per step).
    """
    n = int(round(duration / dt))
    t = np.arange(n + 1) * dt
    om = np.zeros(n + 1)
    cur = np.zeros(n + 1)
    for k in range(n):
        i_end, i_mean = current_step(cur[k], v, om[k], motor, dt)
        cur[k + 1] = i_end
        om[k + 1] = om[k] + dt * (motor.k_t * i_mean - load_torque) / motor.rotor_inertia
    return t, om, cur


class DriveActuator:
    """Actuator protocol (:mod:`mwip.sim.sensors`): two RE25 motors through the gearbox and
    the PWM driver. ``ideal=True`` passes the commanded torques through (plumbing checks).

    ``plant_b_over_r`` is the plant's ``b / r``, to get each wheel's speed from the state.
    After each call ``last`` holds ``duty``, ``current`` (mean, A), ``voltage`` and
    ``limited`` (N, 2) for the logs.
    """

    def __init__(
        self,
        motor: MotorData = RE25,
        drive: DriveSpec = DriveSpec(),
        *,
        plant_b_over_r: float = 0.15 / 0.04,
        Ts: float = 0.005,
        ideal: bool = False,
    ) -> None:
        self.motor = motor
        self.drive = drive
        self.b_over_r = float(plant_b_over_r)
        self.Ts = float(Ts)
        self.ideal = ideal
        self.i = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Currents to zero."""
        self.i = np.zeros((n, 2))
        self.last = {}

    def motor_speed(self, state: NDArray[np.float64]) -> NDArray[np.float64]:
        """Motor shaft speeds ``N (psi_i' - theta')`` (N, 2), right then left."""
        pd, td, ad = state[:, 3], state[:, 4], state[:, 5]
        wr = pd + self.b_over_r * ad - td
        wl = pd - self.b_over_r * ad - td
        return self.drive.gear_ratio * np.column_stack([wr, wl])

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        u_cmd = np.asarray(u_cmd, dtype=float)
        if self.ideal:
            self.last = {"limited": np.zeros_like(u_cmd)}
            return u_cmd
        if self.i.shape != u_cmd.shape:
            self.reset(u_cmd.shape[0])
        om = self.motor_speed(state)
        v, limited = driver_voltage(np.nan_to_num(u_cmd), om, self.motor, self.drive)
        duty = quantise_duty(v, self.drive)
        if self.drive.pwm_levels > 0:  # rounding must not step over the current limit
            lv, vs = self.drive.pwm_levels, self.drive.supply_voltage
            emf = self.motor.k_e * om
            band = self.motor.resistance * self.drive.current_limit
            lo = np.ceil(np.clip((emf - band) / vs, -1.0, 1.0) * lv) / lv
            hi = np.floor(np.clip((emf + band) / vs, -1.0, 1.0) * lv) / lv
            duty = np.clip(duty, lo, np.maximum(hi, lo))
        v_q = duty * self.drive.supply_voltage
        self.i, i_mean = current_step(self.i, v_q, om, self.motor, self.Ts)
        gain = self.drive.gear_ratio * self.drive.gear_efficiency * self.motor.k_t
        u = gain * i_mean
        self.last = {"duty": duty, "current": i_mean, "voltage": v_q,
                     "limited": limited.astype(float)}  # fmt: skip
        return u
