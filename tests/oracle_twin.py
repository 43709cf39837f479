"""NumPy oracles of the twin's elements: the forms the compiled kernels
(:mod:`mwip.hardware`) replaced, kept here, written apart, to test them against.

Each element's compiled kernel must equal its oracle on random inputs (tests/test_twin_elements.py),
and a whole twin run through :class:`OracleSensor` / :class:`OracleActuator` (the engine's
Python loop with these NumPy forms) must equal the compiled twin loop (tests/test_twin_loop.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mwip.core import Measurement
from mwip.hardware.elements import DRIVE_ELEMENTS, ELEMENTS, SENSOR_ELEMENTS
from mwip.hardware.fusion import FusionSpec
from mwip.hardware.imu import ImuNoise
from mwip.hardware.motor import RE25, DriveSpec, MotorData
from mwip.params import Params

G = 9.81

def specific_force(
    theta: ArrayLike,
    theta_dot: ArrayLike,
    theta_ddot: ArrayLike,
    x_ddot: ArrayLike,
    height: ArrayLike,
    g: float = G,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body-axis accelerometer readings ``(a_x, a_y)`` at ``height`` above the axle.

    The sensor point is at ``(x_w + h sin theta, h cos theta)``; with the axle's forward
    acceleration ``x'' = r psi''`` its acceleration is
    ``(x'' + h (theta'' cos - theta'^2 sin), -h (theta'' sin + theta'^2 cos))``; the specific
    force ``f = a + (0, g)`` projected on the body axes gives
    ``a_x = (f_z) sin theta - f_x cos theta``, ``a_y = f_z cos theta + f_x sin theta``, so
    that a static body reads ``(g sin theta, g cos theta)`` as assumed by (2.37)-(2.39).
    """
    th = np.asarray(theta, dtype=float)
    td = np.asarray(theta_dot, dtype=float)
    tdd = np.asarray(theta_ddot, dtype=float)
    s, c = np.sin(th), np.cos(th)
    fx = np.asarray(x_ddot, dtype=float) + height * (tdd * c - td**2 * s)
    fz = g - height * (tdd * s + td**2 * c)
    return fz * s - fx * c, fz * c + fx * s


def tilt_arcsin(a_x: ArrayLike, g: float = G) -> NDArray[np.float64]:
    """Single-axis tilt ``arcsin(a_x / g)`` (2.37) (argument clipped to [-1, 1])."""
    return np.arcsin(np.clip(np.asarray(a_x, dtype=float) / g, -1.0, 1.0))


def tilt_arctan(a_x: ArrayLike, a_y: ArrayLike) -> NDArray[np.float64]:
    """Two-axis tilt ``arctan(a_x / a_y)`` (2.39), quadrant-correct (``arctan2``)."""
    return np.arctan2(np.asarray(a_x, dtype=float), np.asarray(a_y, dtype=float))


def gyro_integrate(angle: ArrayLike, omega: ArrayLike, Ts: float) -> NDArray[np.float64]:
    """One step of gyro integration ``alpha_{k+1} = alpha_k + alpha'* Ts`` (2.40)."""
    return np.asarray(angle, dtype=float) + np.asarray(omega, dtype=float) * Ts


def complementary_step(
    angle: ArrayLike, omega: ArrayLike, angle_acc: ArrayLike, Ts: float, tau: ArrayLike
) -> NDArray[np.float64]:
    """Complementary filter: ``a (angle + omega Ts) + (1 - a) angle_acc``, ``a = tau/(tau+Ts)``.

    The gyro path is the integration (2.40); the accelerometer tilt (2.39) corrects its drift
    below ``1 / tau`` rad/s. A constant gyro bias ``b`` leaves a steady error ``b tau``.
    """
    t: Any = tau
    a = t / (t + Ts)
    return a * gyro_integrate(angle, omega, Ts) + (1.0 - a) * np.asarray(angle_acc, dtype=float)


def kalman_step(
    x: NDArray[np.float64],
    P: NDArray[np.float64],
    omega: ArrayLike,
    angle_acc: ArrayLike,
    Ts: float,
    spec: FusionSpec,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One predict/update step of the angle-bias Kalman filter, batch-first.

    State ``x = [angle, bias]`` (N, 2); prediction by the gyro integration (2.40) with the
    bias removed, ``angle += (omega - bias) Ts``; measurement the accelerometer tilt (2.39).
    ``P`` (2, 2) is shared by the batch (its recursion does not depend on the data).
    """
    A = np.array([[1.0, -Ts], [0.0, 1.0]])
    Q = np.diag([spec.q_angle * Ts, spec.q_bias * Ts])
    xp = np.empty_like(x)
    xp[:, 0] = x[:, 0] + (np.asarray(omega, dtype=float) - x[:, 1]) * Ts
    xp[:, 1] = x[:, 1]
    Pp = A @ P @ A.T + Q
    S = Pp[0, 0] + spec.r_angle
    K = Pp[:, 0] / S
    innov = np.asarray(angle_acc, dtype=float) - xp[:, 0]
    xn = xp + innov[:, None] * K[None, :]
    Pn = Pp - np.outer(K, Pp[0, :])
    return xn, 0.5 * (Pn + Pn.T)


class Imu:
    """Stateful IMU of N robots: the gyro's zero drift is a random walk (seeded).

    Every call draws the same normal variates whatever is switched on (bias walk, accel x,
    accel y, gyro: ``n`` each, or one each broadcast to all rows when ``common``), so switching
    an element on or off leaves the others' noise unchanged, and with ``common`` every row of
    a batch sees the noise of a single run with the same seed.
    """

    def __init__(self, noise: ImuNoise = ImuNoise(), *, common: bool = False) -> None:  # noqa: B008
        self.noise = noise
        self.common = common
        # per-row values (floats, or (N,) arrays set by the twin for a batch of twins)
        self.accel_sigma: Any = noise.accel_sigma
        self.accel_bias: Any = noise.accel_bias
        self.gyro_sigma: Any = noise.gyro_sigma
        self.gyro_bias: Any = noise.gyro_bias
        self.height: Any = noise.height
        self.bias = np.zeros(0)
        self._rng = np.random.default_rng(0)

    def reset(self, n: int, seed: int | None = None) -> None:
        """New noise stream; the zero drift starts at ``gyro_bias``."""
        self._rng = np.random.default_rng(seed)
        if np.ndim(self.gyro_bias) == 0:
            self.bias = np.full(n, self.gyro_bias)
        else:
            self.bias = np.broadcast_to(np.asarray(self.gyro_bias, dtype=float), (n,)).copy()

    def _normal(self, n: int) -> NDArray[np.float64]:
        if self.common:
            return np.broadcast_to(self._rng.standard_normal(1), (n,))
        return self._rng.standard_normal(n)

    def read(
        self,
        theta: NDArray[np.float64],
        theta_dot: NDArray[np.float64],
        theta_ddot: NDArray[np.float64],
        x_ddot: NDArray[np.float64],
        dt: float,
        *,
        noise: ArrayLike = True,
        bias: ArrayLike = True,
        motion: ArrayLike = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(a_x, a_y, omega*)`` for true motion; advances the drift by ``dt`` first.

        ``noise``, ``bias``, ``motion`` (bool, per row) switch the white noise, the offsets
        and drift, and the body-acceleration terms of :func:`specific_force`."""
        nz = self.noise
        n = theta.shape[0]
        on_n = np.broadcast_to(np.asarray(noise, dtype=float), (n,))
        on_b = np.broadcast_to(np.asarray(bias, dtype=float), (n,))
        on_m = np.broadcast_to(np.asarray(motion, dtype=float), (n,))
        walk = self._normal(n)
        if dt > 0:
            self.bias = self.bias + nz.gyro_bias_walk * np.sqrt(dt) * walk
        ax, ay = specific_force(theta, on_m * theta_dot, on_m * theta_ddot, on_m * x_ddot,
                                self.height)  # fmt: skip
        ax = ax + on_n * self.accel_sigma * self._normal(n)
        ay = ay + on_n * self.accel_sigma * self._normal(n)
        ax = ax + on_b * self.accel_bias
        omega = theta_dot + on_b * self.bias + on_n * self.gyro_sigma * self._normal(n)
        return ax, ay, omega


class TiltFilter:
    """Fusion of accelerometer tilt (2.39) and gyro rate (2.40) into ``theta, theta'``."""

    def __init__(self, spec: FusionSpec = FusionSpec()) -> None:  # noqa: B008
        self.spec = spec
        self.tau: Any = spec.tau  # a float, or (N,) per row (a batch of twins)
        self.x = np.zeros((0, 2))
        self.P = np.eye(2)

    def reset(self, angle_acc: NDArray[np.float64]) -> None:
        """Start from the accelerometer tilt (the robot is at rest at power-on)."""
        self.x = np.column_stack([angle_acc, np.zeros_like(angle_acc)])
        self.P = np.diag([self.spec.r_angle, 0.02**2])

    def update(
        self, omega: NDArray[np.float64], angle_acc: NDArray[np.float64], Ts: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Advance one sample; returns ``(theta, theta')`` estimates."""
        if self.spec.kind == "complementary":
            self.x[:, 0] = complementary_step(self.x[:, 0], omega, angle_acc, Ts, self.tau)
            return self.x[:, 0].copy(), np.asarray(omega, dtype=float).copy()
        self.x, self.P = kalman_step(self.x, self.P, omega, angle_acc, Ts, self.spec)
        return self.x[:, 0].copy(), np.asarray(omega, dtype=float) - self.x[:, 1]



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
        drive: DriveSpec = DriveSpec(),  # noqa: B008
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
        self.compensation: Any = 0.0
        self.torque_gain: Any = 1.0
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
        v_ref = R * np.nan_to_num(u_cmd) / (gain / _col(self.torque_gain)) + ff
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



def coulomb_torque(
    w: NDArray[np.float64],
    drive: NDArray[np.float64],
    f_c: ArrayLike,
    mobility: ArrayLike,
    Ts: float,
) -> NDArray[np.float64]:
    """Coulomb friction torque on each wheel (N m), held over a sample, in the discrete
    stick-slip form (Karnopp): the torque that would stop the relative wheel speed ``w``
    within the sample, ``f* = -w / (Ts m) - drive`` (``m`` the relative mobility,
    :func:`relative_mobility`), is applied when ``|f*| <= F_c`` (sticking), else
    ``-F_c sign(w + Ts m drive)`` (sliding). A held ``-F_c sign(w)`` would instead reverse a
    slow wheel within the sample and chatter at the sample rate."""
    fc = np.asarray(f_c, dtype=float)
    m = np.asarray(mobility, dtype=float)
    need = -w / (Ts * m) - drive
    slide = -fc * np.sign(w + Ts * m * drive)
    return np.where(np.abs(need) <= fc, need, slide)


class Backlash:
    """Gearbox play of ``width`` rad at the wheel, per wheel of N robots.

    State: the gap ``g`` (motor side minus wheel side, in ``[-width/2, width/2]``) and its
    rate ``v``. In contact (``g`` at the wall the torque pushes towards) the torque passes.
    Otherwise the motor side, inertia ``J_m = N^2 J`` at the wheel, moves freely,
    ``g'' = tau / J_m`` (the wheel's own motion and the impact are neglected), and the torque
    passes from the instant it closes the gap: the held torque is ``tau (Ts - t_c) / Ts``.
    """

    def __init__(self, width: ArrayLike, inertia: ArrayLike, Ts: float) -> None:
        self.width = np.asarray(width, dtype=float)
        # a float, or (N,) per row (the twins' own N^2 J)
        self.inertia: Any = (float(inertia) if np.ndim(inertia) == 0  # type: ignore[arg-type]
                             else np.asarray(inertia, dtype=float))  # fmt: skip
        self.Ts = float(Ts)
        self.g = np.zeros((0, 2))
        self.v = np.zeros((0, 2))

    def reset(self, n: int) -> None:
        """Start in contact on the positive side with the play at rest."""
        half = np.broadcast_to(self.width, (n,))[:, None] / 2.0
        self.g = np.broadcast_to(half, (n, 2)).copy()
        self.v = np.zeros((n, 2))

    def __call__(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        n = tau.shape[0]
        if self.g.shape != tau.shape:
            self.reset(n)
        half = np.broadcast_to(self.width, (n,))[:, None] / 2.0 * np.ones((1, 2))
        Ts, g, v = self.Ts, self.g, self.v
        s = np.sign(tau)
        wall = np.where(s != 0, s * half, np.where(v >= 0, half, -half))
        contact = (half <= 0) | ((s != 0) & (np.abs(g - wall) <= 1e-15))
        inertia = self.inertia
        if np.ndim(inertia) != 0:
            inertia = np.broadcast_to(inertia, (n,))[:, None]
        a = tau / inertia
        # time to the wall: g + v t + a t^2 / 2 = wall (first root in [0, Ts])
        d = wall - g
        t_c = np.full_like(g, np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            disc = v * v + 2.0 * a * d
            quad = np.abs(a) > 0
            root = np.where(quad, (-v + np.sign(a) * np.sqrt(np.maximum(disc, 0.0))) / a, 0.0)
            root = np.where(quad & (disc >= 0), root, np.inf)
            lin = np.where((~quad) & (v != 0), d / v, np.inf)
        t_c = np.where(quad, root, lin)
        t_c = np.where(np.isfinite(t_c) & (t_c >= 0), t_c, np.inf)
        closes = ~contact & (t_c <= Ts)
        free = ~contact & ~closes
        out = np.where(contact, tau, np.where(closes, tau * (Ts - np.minimum(t_c, Ts)) / Ts, 0.0))
        g_new = np.where(free, np.clip(g + v * Ts + 0.5 * a * Ts * Ts, -half, half), wall)
        v_new = np.where(free, v + a * Ts, 0.0)
        self.g = np.where(contact | closes, wall, g_new)
        self.v = np.where(contact | closes, 0.0, v_new)
        return out



def count(rel_angle: ArrayLike, resolution: ArrayLike) -> NDArray[np.int64]:
    """Counter value for a wheel-relative-to-body angle (rad): ``floor(angle / resolution)``."""
    res = resolution
    return np.floor(np.asarray(rel_angle, dtype=float) / res).astype(np.int64)


def counts_to_angle(counts: ArrayLike, resolution: ArrayLike) -> NDArray[np.float64]:
    """Wheel-relative angle of a counter value (rad); error in ``[0, resolution)``."""
    res: Any = resolution
    return np.asarray(counts, dtype=float) * res


def difference_rate(angle_now: ArrayLike, angle_prev: ArrayLike, Ts: float) -> NDArray[np.float64]:
    """Rate by the difference over one sample, ``(a_k - a_{k-1}) / Ts``."""
    return (np.asarray(angle_now, dtype=float) - np.asarray(angle_prev, dtype=float)) / Ts


class OracleActuator:
    """Actuator protocol: delay, motor + driver, gearbox friction and backlash, per row.

    Per sample ``k`` and wheel, with the commanded ``u_k``:

    1. ``delay`` (fraction ``d`` of ``Ts``): the board writes the new duty ``d Ts`` after the
       sample instant, so the torque command held over the sample is
       ``d u_{k-1} + (1 - d) u_k`` (exact for ``d = 0`` and ``d = 1``, a one-sample shift;
       for a fraction the sample's mean);
    2. ``motor`` (:class:`DriveActuator`, with ``pwm`` and ``sag``): the
       torque the motor delivers (the back-EMF term of a voltage drive is in the plant's
       ``Db``); without it the command is applied as a torque;
    3. ``friction``: Coulomb friction held over the sample
       (:func:`coulomb_torque`; compiled: :mod:`mwip.hardware.friction`);
    4. ``backlash`` (:class:`Backlash`; compiled: :mod:`mwip.hardware.backlash`).

    ``last`` holds the drive's logs (``duty``, ``current``, ``voltage``, ``supply``,
    ``torque``, ``limited``) and ``friction``.
    """

    def __init__(
        self,
        twin: Any,
        *,
        plant_b_over_r: float,
        masks: NDArray[np.bool_] | None = None,
        mobility: ArrayLike = 1.0 / 2e-3,
        values: Mapping[str, Any] | None = None,
    ) -> None:
        self.twin = twin
        v = twin.values() if values is None else values
        self.values = v
        self.mobility = np.asarray(mobility, dtype=float)
        self.masks = twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        m = self.masks
        self.drive = DriveActuator(
            twin.motor, twin.drive, plant_b_over_r=float(plant_b_over_r), Ts=twin.Ts,
            pwm=_cl(m, "pwm"), sag=_cl(m, "sag"), emf_in_plant=True,
        )  # fmt: skip
        gr = v["drive.gear_ratio"]
        self.drive.gear_ratio = gr
        self.drive.compensation = (1.0 if twin.drive.mode == "torque"
                                   else v["firmware.emf_compensation"])  # fmt: skip
        self.drive.torque_gain = v["firmware.torque_gain"]
        self.drive.deadband = v["drive.deadband"]
        self.drive.current_limit = v["drive.current_limit"]
        self.gear_ratio = gr
        self.delay = _col(v["firmware.delay"])
        self.coulomb = _col(v["gearbox.coulomb"])
        n2j = gr * gr * twin.motor.rotor_inertia
        self.backlash = Backlash(_cl(m, "backlash") * v["gearbox.backlash"], n2j, twin.Ts)
        idx = [_IDX[e] for e in sorted(DRIVE_ELEMENTS)]
        self.any = bool(np.any(m[:, idx]))
        self.u_prev = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}


    @property
    def b_over_r(self) -> Any:
        """The plant's ``b / r`` (a number, or one per robot), from which the drive gets each
        wheel's speed: the inner :class:`DriveActuator`'s (one value, so
        setting it here reaches the motor model)."""
        return self.drive.b_over_r

    @b_over_r.setter
    def b_over_r(self, value: Any) -> None:
        self.drive.b_over_r = value

    def reset(self, n: int, seed: int | None = None) -> None:
        """Currents, the delay line and the backlash to rest."""
        self.drive.reset(n, seed)
        self.backlash.reset(n)
        self.u_prev = np.zeros((n, 2))
        self.last = {}

    def _rows(self, name: str, n: int) -> NDArray[np.bool_]:
        return np.broadcast_to(_cl(self.masks, name), (n,))[:, None]

    def __call__(
        self, t: float, u_cmd: NDArray[np.float64], state: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        u_cmd = np.asarray(u_cmd, dtype=float)
        if not self.any:
            self.last = {"limited": np.zeros_like(u_cmd)}
            return u_cmd
        n = u_cmd.shape[0]
        if self.u_prev.shape != u_cmd.shape:
            self.reset(n)
        d = self.delay * self._rows("delay", n)
        u = d * self.u_prev + (1.0 - d) * u_cmd
        self.u_prev = u_cmd.copy()
        motor = self._rows("motor", n)
        if motor.any():
            u = np.where(motor, self.drive(t, u, state), u)
            last = dict(self.drive.last)
        else:
            last = {"limited": np.zeros_like(u)}
        fric = np.zeros_like(u)
        if self._rows("friction", n).any():
            w = self.drive.motor_speed(state) / _col(self.gear_ratio)
            fc = self.coulomb * self._rows("friction", n)
            mob = np.broadcast_to(self.mobility, (n,))[:, None]
            fric = coulomb_torque(w, u, fc, mob, self.twin.Ts)
            u = u + fric
        if self._rows("backlash", n).any():
            u = self.backlash(u)
        last["friction"] = fric
        self.last = {f"drive_{k}": val for k, val in last.items()}
        return u


class OracleSensor:
    """Sensor protocol: IMU fusion for ``theta, theta'``, encoders for ``psi, alpha`` and
    rates, odometry for ``x, y``, per row as the elements say (``encoder``, ``fusion``,
    ``accel_motion``, ``imu_noise``, ``imu_bias``); a row without ``encoder`` gets the true
    ``psi, alpha``, rates and position, one without ``fusion`` the true ``theta, theta'``.
    ``last`` holds the raw readings of the last call. ``record_measurement``: the compiled
    twin loop also records the measurement as the log ``y_meas`` (set by :func:`run_on_twin`
    with ``drive_logs=False``)."""

    record_measurement: bool = False

    def __init__(
        self, plant: Params, twin: Any, *,
        masks: NDArray[np.bool_] | None = None, common_noise: bool = False,
        values: Mapping[str, Any] | None = None,
    ) -> None:  # fmt: skip
        self.twin = twin
        v = self.twin.values() if values is None else values
        self.masks = self.twin.masks() if masks is None else np.asarray(masks, dtype=bool)
        self.r = float(np.mean(plant.r))
        self.b_over_r = float(np.mean(plant.b / plant.r))
        self.imu = Imu(self.twin.imu, common=common_noise)
        for key in ("accel_sigma", "accel_bias", "gyro_sigma", "gyro_bias", "height"):
            setattr(self.imu, key, v[f"imu.{key}"])
        self.filter = TiltFilter(self.twin.firmware.fusion)
        self.filter.tau = v["firmware.fusion.tau"]
        self.zeroing = bool(self.twin.firmware.gyro_zeroing)
        self._offset = np.zeros(0)
        gr = v["drive.gear_ratio"]
        # encoder resolution per row (None: the spec's, the same arithmetic)
        self._res: Any = None
        if np.ndim(gr) != 0:
            self._res = 2.0 * np.pi / (self.twin.encoder.cpr * np.asarray(gr)[:, None])
        else:
            self._res = 2.0 * np.pi / (self.twin.encoder.cpr * gr)
        idx = [_IDX[e] for e in sorted(SENSOR_ELEMENTS)]
        self.any = bool(self.masks[:, idx].any())
        self._prev: NDArray[np.float64] | None = None
        self._theta0 = np.zeros(0)
        self._c0 = np.zeros((0, 2), dtype=np.int64)
        self._rel_prev = np.zeros((0, 2))
        self._origin = np.zeros((0, 4))
        self._pos = np.zeros((0, 2))
        self.last: dict[str, NDArray[np.float64]] = {}

    def reset(self, n: int, seed: int | None = None) -> None:
        """Seed the noise; filters and counters start at the first call."""
        self.imu.reset(n, seed)
        self._prev = None
        self.last = {}

    def _relative(self, state: NDArray[np.float64]) -> NDArray[np.float64]:
        psi, th, al = state[:, 0], state[:, 1], state[:, 2]
        return np.column_stack([psi + self.b_over_r * al - th, psi - self.b_over_r * al - th])

    def _on(self, name: str, n: int) -> NDArray[np.bool_]:
        return np.broadcast_to(_cl(self.masks, name), (n,))

    def __call__(self, t: float, state: NDArray[np.float64]) -> Measurement:
        if not self.any:
            return Measurement(t=t, y=state.copy())
        Ts = self.twin.Ts
        n = state.shape[0]
        first = self._prev is None
        if first:
            acc = np.zeros((n, 3))
        else:
            acc = (state[:, 3:6] - self._prev[:, 3:6]) / Ts  # type: ignore[index]
        ax, ay, omega = self.imu.read(
            state[:, 1], state[:, 4], acc[:, 1], self.r * acc[:, 0], 0.0 if first else Ts,
            noise=self._on("imu_noise", n), bias=self._on("imu_bias", n),
            motion=self._on("accel_motion", n),
        )  # fmt: skip
        th_acc = tilt_arctan(ax, ay)  # (2.39)
        if self.zeroing:  # the firmware subtracts the gyro's offset at power-on
            if first:
                self._offset = self._on("imu_bias", n) * self.imu.bias
            omega = omega - self._offset
        fusion = self._on("fusion", n)
        if first:
            self.filter.reset(th_acc)
            th_hat, thd_hat = th_acc.copy(), omega.copy()
        else:
            th_hat, thd_hat = self.filter.update(omega, th_acc, Ts)
        th_hat = np.where(fusion, th_hat, state[:, 1])
        thd_hat = np.where(fusion, thd_hat, state[:, 4])
        if first:
            self._theta0 = th_hat.copy()
            self._c0 = count(self._relative(state), self._res)
            self._rel_prev = np.zeros((n, 2))
            self._origin = state[:, [0, 2, 6, 7]].copy()
            self._pos = state[:, 6:8].copy()
        rel = counts_to_angle(count(self._relative(state), self._res) - self._c0,
                              self._res)  # fmt: skip
        rel_rate = (rel - self._rel_prev) / Ts if not first else np.zeros((n, 2))
        self._rel_prev = rel
        psi = self._origin[:, 0] + rel.mean(axis=1) + th_hat - self._theta0
        alpha = self._origin[:, 1] + (rel[:, 0] - rel[:, 1]) / (2.0 * self.b_over_r)
        psi_dot = rel_rate.mean(axis=1) + thd_hat
        alpha_dot = (rel_rate[:, 0] - rel_rate[:, 1]) / (2.0 * self.b_over_r)
        if not first:
            v = self.r * psi_dot
            self._pos = self._pos + Ts * np.column_stack([v * np.cos(alpha), v * np.sin(alpha)])
        self._prev = state.copy()
        y = np.column_stack([psi, th_hat, alpha, psi_dot, thd_hat, alpha_dot, self._pos])
        enc = self._on("encoder", n)[:, None]
        y[:, [0, 2, 3, 5, 6, 7]] = np.where(enc, y[:, [0, 2, 3, 5, 6, 7]],
                                            state[:, [0, 2, 3, 5, 6, 7]])  # fmt: skip
        y[:, 1] = th_hat
        y[:, 4] = thd_hat
        self.last = {"imu_theta_acc": th_acc, "imu_gyro": omega + (self._offset if self.zeroing
                                                                    else 0.0),
                     "imu_gyro_bias": self.imu.bias.copy()}
        return Measurement(t=t, y=y)


_IDX = {e: i for i, e in enumerate(ELEMENTS)}


def _cl(masks: NDArray[np.bool_], name: str) -> NDArray[np.bool_]:
    return masks[:, _IDX[name]]


class _OracleLogged:
    """Forwards a controller, adding the oracle chains' logs (no packed law: the engine's
    Python loop)."""

    def __init__(self, controller: Any, sensor: Any, actuator: Any) -> None:
        self._c, self._s, self._a = controller, sensor, actuator
        self.Ts = getattr(controller, "Ts", None)
        self.static = False
        self._meas: Any = None

    def reset(self, meas: Measurement) -> None:
        self._meas = meas.y
        self._c.reset(meas)

    def __call__(self, t: float, meas: Measurement) -> NDArray[np.float64]:
        self._meas = meas.y
        return self._c(t, meas)

    def log(self) -> Mapping[str, Any]:
        get = getattr(self._c, "log", None)
        out = dict(get()) if get is not None else {}
        out["y_meas"] = self._meas
        out.update(self._a.last)
        out.update(self._s.last)
        return out


def oracle_run(controller: Any, twin: Any, plant: Params, *, rows: Any = None,
               values: Mapping[str, Any] | None = None, common_noise: bool = False,
               **kw: Any) -> Any:
    """A twin run with the NumPy oracles in the engine's Python loop: ``plant`` the plant the
    twin integrates (``twin.plant(...)``), ``values`` per-row unknowns (``twin.row_values``)."""
    from mwip.hardware.drivetrain import relative_mobility
    from mwip.sim import simulate

    masks = twin.masks(rows)
    sensor = OracleSensor(plant, twin, masks=masks, common_noise=common_noise, values=values)
    act = OracleActuator(twin, plant_b_over_r=float(np.mean(plant.b / plant.r)), masks=masks,
                         mobility=relative_mobility(plant), values=values)
    return simulate(_OracleLogged(controller, sensor, act), plant, Ts=twin.Ts, dt=twin.dt,
                    sensor=sensor, actuator=act, **kw)
