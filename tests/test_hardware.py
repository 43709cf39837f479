"""Sensors and actuators of the twin (Sec. 2.5): IMU (2.37)-(2.40), fusion, encoders, RE25."""

from __future__ import annotations

import numpy as np
import pytest

from mwip.hardware import fusion
from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.firmware import FirmwareSpec
from mwip.hardware.fusion import FusionSpec
from mwip.hardware.imu import G, ImuNoise
from mwip.hardware.motor import RE25, RPM, DriveSpec
from mwip.hardware.twin import Twin, TwinActuator, TwinSensor
from mwip.params import REAL
from oracle_twin import current_step, simulate_motor, steady_speed

TS = 0.005


def _kalman() -> FirmwareSpec:
    return FirmwareSpec(fusion=FusionSpec(kind="kalman"))


def _sensor(twin: Twin, n: int, seed: int = 0) -> TwinSensor:
    """The twin's compiled sensor chain for ``n`` robots, reset."""
    sensor = TwinSensor(REAL, twin)
    sensor.reset(n, seed=seed)
    return sensor


def _actuator(twin: Twin, n: int) -> TwinActuator:
    """The twin's compiled drive chain for ``n`` robots, reset."""
    act = TwinActuator(REAL, twin)
    act.reset(n)
    return act


def _static_states(theta: np.ndarray) -> np.ndarray:
    y = np.zeros((theta.size, 8))
    y[:, 1] = theta
    return y


@pytest.mark.parametrize("kind", ["complementary", "kalman"])
def test_static_tilt_recovered_within_noise(kind: str) -> None:
    noise = ImuNoise()
    theta = np.linspace(-0.3, 0.3, 7)
    fw = FirmwareSpec(fusion=FusionSpec(kind=kind))
    sensor = _sensor(Twin(imu=noise, firmware=fw), theta.size, seed=3)
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
    """The compiled fusion element's Kalman filter: its gyro-offset state converges to the
    gyro's offset (the robot at rest, tilted)."""
    n = 4
    sensor = _sensor(Twin(imu=ImuNoise(gyro_bias_walk=0.0), firmware=_kalman()), n, seed=1)
    y = _static_states(np.full(n, 0.1))
    for k in range(4001):
        sensor(k * TS, y)
    j = sensor.chain.names().index("fusion")
    x0 = int(sensor.chain.plan[j, 3])  # the fusion element's state in the chain's
    assert np.allclose(sensor.X[:, x0 + fusion.S.bias], ImuNoise().gyro_bias, atol=2e-3)


def _integrated_gyro(noise: ImuNoise, n: int, steps: int, seed: int) -> np.ndarray:
    """The compiled IMU's gyro readings of ``n`` robots at rest, integrated by (2.40)."""
    sensor = _sensor(Twin(imu=noise), n, seed=seed)
    th = np.full(n, 0.05)
    y = _static_states(th)
    ang = th.copy()
    for k in range(steps):
        sensor(k * TS, y)
        ang = ang + sensor.last["imu_gyro"][:, 0] * TS  # (2.40)
    return ang - th


def test_gyro_only_integration_drifts_as_bias_predicts() -> None:
    b = 0.01
    n, steps = 16, 2000  # 10 s
    # noise-free gyro: (2.40) drifts exactly by b t
    drift = _integrated_gyro(ImuNoise(gyro_sigma=0.0, gyro_bias=b, gyro_bias_walk=0.0), n,
                             steps, seed=0)  # fmt: skip
    assert np.allclose(drift, b * steps * TS, rtol=1e-9)
    # with white noise the drift is b t within the random walk of the integrated noise
    sig = 0.002
    drift = _integrated_gyro(ImuNoise(gyro_sigma=sig, gyro_bias=b, gyro_bias_walk=0.0), n,
                             steps, seed=7)  # fmt: skip
    spread = sig * TS * np.sqrt(steps)
    assert np.all(np.abs(drift - b * steps * TS) < 4 * spread)
    assert abs(np.mean(drift) - b * steps * TS) < 4 * spread / np.sqrt(n)


def test_accelerometer_tilt_formulas_and_motion_corruption() -> None:
    th = np.linspace(-1.0, 1.0, 11)
    sensor = _sensor(Twin(imu=ImuNoise.ideal(height=0.1)), th.size)
    sensor(0.0, _static_states(th))
    ax = sensor.last["imu_accel"][:, 0]
    assert np.allclose(np.arcsin(np.clip(ax / G, -1.0, 1.0)), th)  # (2.37)
    assert np.allclose(sensor.last["imu_theta_acc"][:, 0], th)  # (2.39)
    # a forward acceleration of the body reads as a backward tilt of atan(a / g): the axle's
    # speed rises by 1 m/s^2 x Ts over a sample (the IMU's acceleration: the sample's mean)
    sensor = _sensor(Twin(imu=ImuNoise.ideal(height=0.1)), 1)
    y = np.zeros((1, 8))
    sensor(0.0, y)
    y[0, 3] = 1.0 * TS / REAL.r  # psi' = x' / r
    sensor(TS, y)
    assert sensor.last["imu_theta_acc"][0, 0] == pytest.approx(-np.arctan(1.0 / 9.81))


def test_encoder_quantisation_error_below_one_count(rng: np.random.Generator) -> None:
    spec = EncoderSpec()
    tw = Twin(imu=ImuNoise.ideal())
    res = spec.resolution(tw.drive.gear_ratio)  # the encoder is on the motor shaft
    # the compiled encoder's wheel angles (relative to the body, from power-on at 0)
    a = rng.uniform(-50.0, 50.0, 10_000)
    sensor = _sensor(tw, a.size)
    sensor(0.0, np.zeros((a.size, 8)))
    y = np.zeros((a.size, 8))
    y[:, 0] = a
    sensor(TS, y)
    err = a[:, None] - sensor.last["encoder_angles"]
    assert np.all((err >= 0) & (err < res))
    # through the twin's sensor: psi, alpha and psi' of a robot rolling at constant speed
    n = 5
    sensor = _sensor(tw, n)
    speeds = rng.uniform(-8.0, 8.0, n)
    yaw_rates = rng.uniform(-1.0, 1.0, n)
    bor = REAL.b / REAL.r
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
    # the compiled drive chain: the firmware's torque-to-duty map, the driver and the motors
    tw = Twin(drive=drive, elements={"motor", "pwm", "sag"})
    act = _actuator(tw, 3)
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
    limited = act.last["drive_limited"]
    assert limited[1].all() and not limited[0].any()
    # the duty the bridge applied: on the PWM grid where nothing limits it, within [-1, 1]
    duty = act.last["drive_duty"]
    assert np.allclose(duty[0] * drive.pwm_levels, np.round(duty[0] * drive.pwm_levels))
    assert np.all(np.abs(duty) <= 1.0)
    # torque mode compensates back-EMF; voltage mode loses torque at speed (the whole motor
    # torque: the plant holds a voltage drive's back-EMF damping in its Db)
    state[:, 3] = 5.0
    act.reset(3)
    u_t = act(0.0, np.full((3, 2), 0.3), state)
    act_v = _actuator(Twin(drive=DriveSpec(mode="voltage"), elements={"motor", "pwm", "sag"}),
                      3)  # fmt: skip
    act_v(0.0, np.full((3, 2), 0.3), state)
    assert np.allclose(u_t, 0.3, atol=0.01)
    assert np.allclose(act.last["drive_torque"], 0.3, atol=0.01)
    assert np.all(act_v.last["drive_torque"] < 0.3 - 0.1)


def test_parameter_validation_names_field() -> None:
    with pytest.raises(ValueError, match="accel_sigma"):
        ImuNoise(accel_sigma=-1.0)
    with pytest.raises(ValueError, match="cpr"):
        EncoderSpec(cpr=0)
    with pytest.raises(ValueError, match="current_limit"):
        DriveSpec(current_limit=0.0)
    with pytest.raises(ValueError, match="kind"):
        FusionSpec(kind="median")  # type: ignore[arg-type]
