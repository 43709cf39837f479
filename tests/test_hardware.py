"""Sensors and actuators of the twin (Sec. 2.5): IMU (2.37)-(2.40), fusion, encoders, RE25."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.hardware.encoder import EncoderSpec, count, counts_to_angle
from mwip.hardware.imu import (
    FusionSpec,
    Imu,
    ImuNoise,
    TiltFilter,
    gyro_integrate,
    specific_force,
    tilt_arcsin,
    tilt_arctan,
)
from mwip.hardware.motor import (
    RE25,
    RPM,
    DriveActuator,
    DriveSpec,
    current_step,
    quantise_duty,
    simulate_motor,
    steady_speed,
)
from mwip.hardware.twin import Twin, TwinSensor
from mwip.params import REAL

TS = 0.005


def _static_states(theta: np.ndarray) -> np.ndarray:
    y = np.zeros((theta.size, 8))
    y[:, 1] = theta
    return y


@pytest.mark.parametrize("kind", ["complementary", "kalman"])
def test_static_tilt_recovered_within_noise(kind: str) -> None:
    noise = ImuNoise()
    theta = np.linspace(-0.3, 0.3, 7)
    sensor = TwinSensor(REAL, Twin(imu=noise, fusion=FusionSpec(kind=kind)))
    sensor.reset(theta.size, seed=3)
    y = _static_states(theta)
    est = []
    for k in range(1200):  # 6 s at 5 ms
        est.append(sensor(k * TS, y).y[:, 1])
    tail = np.array(est[-200:])
    sigma_tilt = noise.accel_sigma / 9.81  # per-sample accelerometer tilt noise
    # systematic parts: accelerometer bias (a_x offset) and, for the complementary filter,
    # the steady error b * tau of an uncompensated gyro bias
    systematic = abs(noise.accel_bias) / 9.81
    if kind == "complementary":
        systematic += abs(noise.gyro_bias) * FusionSpec().tau
    err = np.abs(tail.mean(axis=0) - theta)
    assert np.all(err < systematic + sigma_tilt), (kind, err)
    # the fusion filters the accelerometer noise: spread well below one sample's noise
    assert np.all(tail.std(axis=0) < sigma_tilt)


def test_kalman_estimates_gyro_bias() -> None:
    tf = TiltFilter(FusionSpec(kind="kalman"))
    imu = Imu(ImuNoise(gyro_bias_walk=0.0))
    n = 4
    imu.reset(n, seed=1)
    th = np.full(n, 0.1)
    z = np.zeros(n)
    ax, ay, _ = imu.read(th, z, z, z, 0.0)
    tf.reset(tilt_arctan(ax, ay))
    for _ in range(4000):
        ax, ay, om = imu.read(th, z, z, z, TS)
        tf.update(om, tilt_arctan(ax, ay), TS)
    assert np.allclose(tf.x[:, 1], ImuNoise().gyro_bias, atol=2e-3)


def test_gyro_only_integration_drifts_as_bias_predicts() -> None:
    b = 0.01
    n, steps = 16, 2000  # 10 s
    th = np.full(n, 0.05)
    z = np.zeros(n)
    # noise-free gyro: (2.40) drifts exactly by b t
    imu = Imu(ImuNoise(gyro_sigma=0.0, gyro_bias=b, gyro_bias_walk=0.0))
    imu.reset(n, seed=0)
    ang = th.copy()
    for _ in range(steps):
        ang = gyro_integrate(ang, imu.read(th, z, z, z, TS)[2], TS)
    assert np.allclose(ang - th, b * steps * TS, rtol=1e-9)
    # with white noise the drift is b t within the random walk of the integrated noise
    sig = 0.002
    imu = Imu(ImuNoise(gyro_sigma=sig, gyro_bias=b, gyro_bias_walk=0.0))
    imu.reset(n, seed=7)
    ang = th.copy()
    for _ in range(steps):
        ang = gyro_integrate(ang, imu.read(th, z, z, z, TS)[2], TS)
    spread = sig * TS * np.sqrt(steps)
    assert np.all(np.abs(ang - th - b * steps * TS) < 4 * spread)
    assert abs(np.mean(ang - th) - b * steps * TS) < 4 * spread / np.sqrt(n)


def test_accelerometer_tilt_formulas_and_motion_corruption() -> None:
    th = np.linspace(-1.0, 1.0, 11)
    z = np.zeros_like(th)
    ax, ay = specific_force(th, z, z, z, height=0.1)
    assert np.allclose(tilt_arcsin(ax), th)  # (2.37)
    assert np.allclose(tilt_arctan(ax, ay), th)  # (2.39)
    # a forward acceleration of the body reads as a backward tilt of atan(a / g)
    ax, ay = specific_force(0.0, 0.0, 0.0, 1.0, height=0.1)
    assert tilt_arctan(ax, ay) == pytest.approx(-np.arctan(1.0 / 9.81))


def test_encoder_quantisation_error_below_one_count(rng: np.random.Generator) -> None:
    spec = EncoderSpec()
    a = rng.uniform(-50.0, 50.0, 10_000)
    err = a - counts_to_angle(count(a, spec), spec)
    assert np.all((err >= 0) & (err < spec.resolution))
    # through the twin's sensor: psi, alpha and psi' of a robot rolling at constant speed
    tw = Twin(imu=ImuNoise.ideal())
    sensor = TwinSensor(REAL, tw)
    n = 5
    sensor.reset(n, seed=0)
    speeds = rng.uniform(-8.0, 8.0, n)
    yaw_rates = rng.uniform(-1.0, 1.0, n)
    res, bor = spec.resolution, REAL.b / REAL.r
    for k in range(400):
        t = k * TS
        y = np.zeros((n, 8))
        y[:, 0], y[:, 2] = speeds * t, yaw_rates * t
        y[:, 3], y[:, 5] = speeds, yaw_rates
        m = sensor(t, y).y
        assert np.all(np.abs(m[:, 0] - y[:, 0]) < res + 1e-12)
        assert np.all(np.abs(m[:, 2] - y[:, 2]) < res / bor + 1e-12)
        if k > 0:
            assert np.all(np.abs(m[:, 3] - y[:, 3]) < res / TS + 1e-9)


def test_motor_reproduces_table_2_1_at_24V() -> None:
    w0 = RE25.no_load_speed_rpm * RPM
    assert steady_speed(24.0, 0.0) == pytest.approx(w0)
    t, om, cur = simulate_motor(24.0, 0.0, duration=0.3)
    assert om[-1] == pytest.approx(w0, rel=1e-3)  # no-load speed 9560 rpm
    i_end, _ = current_step(0.0, 24.0, 0.0, RE25, 1.0)
    assert RE25.k_t * i_end == pytest.approx(0.243, rel=1e-9)  # stall torque 243 mN m
    # derived constants close to MAXON's catalogue RE25 24 V (23.4 mN m/A, 2.32 Ohm)
    assert RE25.k_t == pytest.approx(0.0234, rel=0.03)
    assert RE25.resistance == pytest.approx(2.32, rel=0.03)
    # the mechanical time constant is of the catalogue's order (a few ms)
    tau_m = RE25.resistance * RE25.rotor_inertia / RE25.k_t**2
    assert 1e-3 < tau_m < 1e-2
    assert np.interp(tau_m, t, om) == pytest.approx(w0 * (1 - np.exp(-1)), rel=0.05)


def test_drive_limits_and_pwm() -> None:
    drive = DriveSpec(mode="torque", deadband=0.0)
    act = DriveActuator(RE25, drive, plant_b_over_r=REAL.b / REAL.r, Ts=TS)
    act.reset(3)
    state = np.zeros((3, 8))
    u = act(0.0, np.array([[0.2, -0.2], [50.0, 50.0], [-50.0, 0.0]]), state)
    lim = drive.wheel_torque_limit()
    eta = drive.gear_efficiency
    assert lim == pytest.approx(drive.gear_ratio * eta * RE25.k_t * drive.current_limit)
    assert u[0] == pytest.approx([0.2, -0.2], abs=0.01)  # within a PWM step
    step = (drive.gear_ratio * eta * RE25.k_t * drive.supply_voltage / drive.pwm_levels
            / RE25.resistance)  # fmt: skip
    assert np.all(np.abs(u) <= lim + step)
    # the first sample starts from zero current (L/R = 0.1 ms): 2 % short of the limit
    assert u[1, 0] == pytest.approx(lim * (1 - RE25.tau_e / TS), abs=step)
    u = act(TS, np.array([[0.2, -0.2], [50.0, 50.0], [-50.0, 0.0]]), state)
    assert u[1, 0] == pytest.approx(lim, abs=step)
    assert act.last["limited"][1].all() and not act.last["limited"][0].any()
    duty = quantise_duty(np.array([1.2345, -30.0]), drive)
    assert np.allclose(duty * drive.pwm_levels, np.round(duty * drive.pwm_levels))
    assert duty[1] == -1.0
    # torque mode compensates back-EMF; voltage mode loses torque at speed
    state[:, 3] = 5.0
    act.reset(3)
    u_t = act(0.0, np.full((3, 2), 0.3), state)
    act_v = DriveActuator(RE25, DriveSpec(mode="voltage"), Ts=TS)
    act_v.reset(3)
    u_v = act_v(0.0, np.full((3, 2), 0.3), state)
    assert np.allclose(u_t, 0.3, atol=0.01)
    assert np.all(u_v < 0.3 - 0.1)


def test_parameter_validation_names_field() -> None:
    with pytest.raises(ValueError, match="accel_sigma"):
        ImuNoise(accel_sigma=-1.0)
    with pytest.raises(ValueError, match="cpr"):
        EncoderSpec(cpr=0)
    with pytest.raises(ValueError, match="current_limit"):
        DriveSpec(current_limit=0.0)
    with pytest.raises(ValueError, match="kind"):
        FusionSpec(kind="median")  # type: ignore[arg-type]
