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

Driver (Sec. 2.5.2: a MOSFET H-bridge, "the PWM technique is used to realize speed
regulation"): ``mode="voltage"`` (default) maps the torque command to a duty open-loop,
``V* = R tau / (N eta k_t)``, so back-EMF acts on the motor as the physical damping
``eta N^2 k_t k_e / R`` per wheel (0.096 N m s/rad); ``mode="torque"`` is a current-mode
servo driver, ``V* = R i* + k_e omega_m`` (back-EMF feed-forward). Then, as the hardware does
it: duty clipped to [-1, 1] against the nominal 24 V, quantised to ``pwm_levels``, reduced by
the dead-band, times the (sagging) battery voltage, and the driver's current limit
``|V - k_e omega_m| <= R I_max`` (:class:`DriveActuator`).
The current is integrated exactly over the sample (``V``, ``omega_m`` held), and the torque
held over the sample is the one produced by the *mean* current.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.hardware.unknown import Unknown

__all__ = [
    "MotorData",
    "RE25",
    "DriveSpec",
    "current_step",
    "driver_voltage",
    "quantise_duty",
    "steady_speed",
    "simulate_motor",
    "apply_deadband",
    "DriveActuator",
    "UNKNOWNS",
]

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
    emf_compensation : voltage mode only: the fraction ``c`` in [0, 1] of the back-EMF of the
        wheel speed at the sample instant that the firmware adds, ``V* = R i* + c k_e omega_m``
        (default 0: the book's "the control signal modulates a pulse signal of a certain
        width", Sec. 6.1; 1: full feed-forward, as a current-mode driver). The plant's
        back-EMF damping stays whole whatever ``c``. ``mode="torque"`` means ``c = 1``.
    emf_feedforward : deprecated alias: ``True`` / ``False`` set ``emf_compensation`` to 1 / 0
        (then read back as ``None``).
    """

    gear_ratio: float = 23.0
    gear_efficiency: float = 0.75
    supply_voltage: float = 24.0
    current_limit: float = 4.0
    pwm_levels: int = 1000
    mode: Literal["torque", "voltage"] = "voltage"
    deadband: float = 0.01
    supply_resistance: float = 0.2
    emf_compensation: float = 0.0
    emf_feedforward: bool | None = None

    def __post_init__(self) -> None:
        if self.emf_feedforward is not None:
            if not isinstance(self.emf_feedforward, bool | np.bool_):
                raise ValueError(
                    f"'emf_feedforward' must be true or false, got {self.emf_feedforward!r}"
                )
            object.__setattr__(self, "emf_compensation", 1.0 if self.emf_feedforward else 0.0)
            object.__setattr__(self, "emf_feedforward", None)
        c = self.emf_compensation
        if isinstance(c, bool) or not (np.isfinite(c) and 0.0 <= c <= 1.0):
            raise ValueError(f"'emf_compensation' must be finite and in [0, 1], got {c!r}")
        object.__setattr__(self, "emf_compensation", float(c))
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

    @property
    def compensation(self) -> float:
        """The back-EMF fraction the driver adds: 1 for ``mode="torque"``, else
        ``emf_compensation``."""
        return 1.0 if self.mode == "torque" else self.emf_compensation

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


def apply_deadband(duty: ArrayLike, deadband: float) -> NDArray[np.float64]:
    """Duty after the driver's dead-band: ``sign(d) max(|d| - deadband, 0)``."""
    d = np.asarray(duty, dtype=float)
    return np.sign(d) * np.maximum(np.abs(d) - deadband, 0.0)


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
    the H-bridge PWM driver. ``ideal=True`` passes the commanded torques through.

    Per sample: the firmware turns the torque command into a duty against the nominal supply
    (``mode``, :class:`DriveSpec`), clipped to [-1, 1], quantised and reduced by the dead-band
    (``pwm``, per row); the bridge applies ``duty x V_s`` with the battery's sag
    ``V_s = V_0 - R_s I_bat`` (``sag``, per row; ``I_bat = sum duty i`` of the previous
    sample); the driver's current limit clips the voltage to ``|V - k_e omega_m| <= R I_max``
    within the supply ``|V| <= V_s``.
    The current is integrated exactly over the sample with ``V`` and ``omega_m`` held
    (:func:`current_step`); the wheel torque is ``eta N k_t`` times the mean current.

    ``emf_in_plant`` (voltage mode): the plant integrates the back-EMF's viscous torque
    ``-eta N^2 k_t k_e w / R`` itself (:mod:`mwip.hardware.drivetrain`), so the torque returned
    is the rest, ``eta N k_t (i_mean + k_e omega_m / R)``; ``last["torque"]`` is always the
    whole motor torque at the sample's start speed.

    ``plant_b_over_r`` is the plant's ``b / r``, to get each wheel's speed from the state.
    After each call ``last`` holds ``duty``, ``current`` (mean, A), ``voltage``, ``supply``,
    ``torque`` and ``limited`` for the logs.
    """

    def __init__(
        self,
        motor: MotorData = RE25,
        drive: DriveSpec = DriveSpec(),
        *,
        plant_b_over_r: float = 0.15 / 0.04,
        Ts: float = 0.005,
        ideal: bool = False,
        pwm: ArrayLike = True,
        sag: ArrayLike = True,
        emf_in_plant: bool = False,
    ) -> None:
        self.motor = motor
        self.drive = drive
        self.b_over_r = float(plant_b_over_r)
        self.Ts = float(Ts)
        self.ideal = ideal
        self.pwm = np.asarray(pwm, dtype=bool)
        self.sag = np.asarray(sag, dtype=bool)
        self.emf_in_plant = bool(emf_in_plant)
        # per-row values (scalars, or (N,) arrays set by the twin for a batch of twins)
        self.gear_ratio: Any = drive.gear_ratio
        self.compensation: Any = drive.compensation
        self.deadband: Any = drive.deadband
        self.current_limit: Any = drive.current_limit
        self.i = np.zeros((0, 2))
        self.i_bat = np.zeros(0)
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Currents to zero."""
        self.i = np.zeros((n, 2))
        self.i_bat = np.zeros(n)
        self.last = {}

    def motor_speed(self, state: NDArray[np.float64]) -> NDArray[np.float64]:
        """Motor shaft speeds ``N (psi_i' - theta')`` (N, 2), right then left."""
        pd, td, ad = state[:, 3], state[:, 4], state[:, 5]
        wr = pd + self.b_over_r * ad - td
        wl = pd - self.b_over_r * ad - td
        return _col(self.gear_ratio) * np.column_stack([wr, wl])

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        u_cmd = np.asarray(u_cmd, dtype=float)
        if self.ideal:
            self.last = {"limited": np.zeros_like(u_cmd)}
            return u_cmd
        n = u_cmd.shape[0]
        if self.i.shape != u_cmd.shape:
            self.reset(n)
        m, d = self.motor, self.drive
        R = m.resistance
        gain = _col(self.gear_ratio) * d.gear_efficiency * m.k_t
        om = self.motor_speed(state)
        emf = m.k_e * om
        c = self.compensation
        if np.ndim(c) == 0:
            ff: Any = emf if c == 1.0 else (0.0 if c == 0.0 else c * emf)
        else:
            ff = _col(c) * emf
        v_ref = R * np.nan_to_num(u_cmd) / gain + ff
        duty_ref = v_ref / d.supply_voltage
        duty = np.clip(duty_ref, -1.0, 1.0)
        shaped = duty
        if d.pwm_levels > 0:
            shaped = np.round(shaped * d.pwm_levels) / d.pwm_levels
        shaped = apply_deadband(shaped, _col(self.deadband))
        pwm = np.broadcast_to(self.pwm, (n,))[:, None]
        duty = np.where(pwm, shaped, duty)
        sag = np.broadcast_to(self.sag, (n,))
        vs = d.supply_voltage - np.where(sag, d.supply_resistance * self.i_bat, 0.0)
        vs = np.maximum(vs, 0.0)[:, None]
        v = duty * vs
        band = R * _col(self.current_limit)
        v_lim = np.clip(np.clip(v, emf - band, emf + band), -vs, vs)
        limited = (np.abs(duty_ref) > 1.0) | (np.abs(v_lim - v) > 1e-12)
        self.i, i_mean = current_step(self.i, v_lim, om, m, self.Ts)
        with np.errstate(divide="ignore", invalid="ignore"):
            duty_eff = np.where(vs > 0, v_lim / vs, 0.0)
        self.i_bat = np.sum(duty_eff * i_mean, axis=1)
        torque = gain * i_mean
        u = torque + gain * emf / R if (self.emf_in_plant and d.mode == "voltage") else torque
        self.last = {"duty": duty_eff, "current": i_mean, "voltage": v_lim,
                     "supply": vs[:, 0], "torque": torque,
                     "limited": limited.astype(float)}  # fmt: skip
        return u


def _col(x: Any) -> Any:
    """A per-row value as a column against (N, 2) wheel arrays (a scalar as it is)."""
    return x if np.ndim(x) == 0 else np.asarray(x, dtype=float)[:, None]


#: The drive's unknowns (docs/twin_model.md, "The prior"); Table 2.1's motor data, the 24 V
#: battery and the encoder lines are fixed by the data sheet.
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("drive.gear_ratio", 3.7, 51.0, "", "MAXON GP 32 A planetary ratios offered with "
            "the RE25, 1-3 stages; the book names no gearbox", "inertia", 23.0),
    Unknown("drive.emf_compensation", 0.0, 1.0, "", "fraction of k_e omega_m the firmware/"
            "driver adds: 0 = open-loop PWM as Sec. 6.1's words read, 1 = full feed-forward / "
            "current-mode driver", "motor", 0.0),
    Unknown("drive.deadband", 0.0, 0.05, "duty", "H-bridge dead time / minimum pulse, "
            "0-2.5 us at 20 kHz", "pwm", 0.01),
    Unknown("drive.current_limit", 1.0, 10.0, "A", "RE25 continuous current to its stall "
            "current at 24 V, Table 2.1", "motor", 4.0),
)  # fmt: skip
