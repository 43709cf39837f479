"""The digital twin: plumbing, determinism, any controller unchanged, logs, Case 3 stick."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from mwip.hardware import StickObstacle, Twin, case_plant, run_on_twin
from mwip.hardware.elements import SENSOR_ELEMENTS
from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.motor import DriveSpec
from mwip.hardware.twin import stick_for
from mwip.laws.asta.controller import ASTA
from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.laws.smc.controller import make_smc
from mwip.params import NOMINAL, REAL
from mwip.sim import simulate

Q0 = (0.0, np.pi / 18, 0.0)


def _do4(q1d_dot: float = -7.0) -> object:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return make_smc("do4smc", (3, 0.01, 0.1, 3), K=(6.3, 4.0), Ts=0.005, q1d_dot=q1d_dot)


@pytest.mark.parametrize("case", [1, 3])
def test_ideal_twin_reproduces_plain_simulation_exactly(case: int) -> None:
    twin = run_on_twin(_do4(), case, twin=Twin.ideal(), q0=Q0, duration=6.5, record_every=2)
    plant = case_plant(case)
    dist = stick_for(plant) if case == 3 else None
    plain = simulate(_do4(), plant, q0=Q0, duration=6.5, Ts=0.005, dt=0.0005,
                     disturbance=dist, record_every=2)  # fmt: skip
    assert np.array_equal(twin.states, plain.states, equal_nan=True)
    assert np.array_equal(twin.inputs, plain.inputs, equal_nan=True)
    assert np.array_equal(twin.series()["u_applied"], twin.u, equal_nan=True)
    assert twin.status[0] == plain.status[0]


def test_twin_is_seeded_and_noisy() -> None:
    """Balancing (q1d' = 0; at -7 rad/s the accelerometer also reads the robot's own
    acceleration, test_experiments.py::test_speed_smc_fall_is_the_accelerometer)."""
    a = run_on_twin(_do4(0.0), 1, duration=1.0, seed=1)
    b = run_on_twin(_do4(0.0), 1, duration=1.0, seed=1)
    assert np.array_equal(a.states, b.states, equal_nan=True)
    # noise and bias only (the body's acceleration is another test's)
    sensors = Twin(elements=SENSOR_ELEMENTS - {"accel_motion"})
    a = run_on_twin(_do4(0.0), 1, twin=sensors, duration=1.0, seed=1)
    c = run_on_twin(_do4(0.0), 1, twin=sensors, duration=1.0, seed=2)
    assert not np.array_equal(a.states, c.states)
    meas = a.series()["y_meas"]
    err = meas[:, 1] - a.theta
    assert 0 < np.nanmax(np.abs(err[5:])) < 0.05  # measured pitch: close, not exact


def test_any_controller_runs_unchanged() -> None:
    ctrls = [
        ASTA(NOMINAL, lam=(10, 0.3, 3), K=(10, 10), rate=(5, 5), Ts=0.005),
        LQR(design_lqr(NOMINAL, Ts=0.005)),
        _do4(),
    ]
    for ctrl in ctrls:
        res = run_on_twin(ctrl, 1, twin=Twin(elements=SENSOR_ELEMENTS | {"delay"}),
                          q0=(0.0, 0.05, 0.0), duration=1.0)  # fmt: skip
        assert res.status[0] == "ok"
        assert np.all(np.isfinite(res.series()["u_applied"]))


class _Constant:
    Ts = 0.005
    static = True

    def __init__(self, u: float) -> None:
        self.u = u

    def reset(self, meas: object) -> None:
        pass

    def __call__(self, t: float, meas: object) -> np.ndarray:
        return np.full((1, 2), self.u)

    def log(self) -> dict:
        return {}


@pytest.mark.parametrize("mode", ["torque", "voltage"])
def test_torque_saturation_is_logged(mode: str) -> None:
    tw = Twin(drive=DriveSpec(mode=mode), elements={"inertia", "motor"})  # type: ignore[arg-type]
    res = run_on_twin(_Constant(20.0), 1, twin=tw, q0=(0.0, 0.0, 0.0), duration=0.05,
                      record_every=1)  # fmt: skip
    s = res.series()
    lim = tw.drive.wheel_torque_limit(tw.motor)
    assert np.all(s["drive_limited"] == 1.0)
    assert np.all(s["drive_torque"] <= lim + 1e-9)
    assert np.all(res.u == 20.0)
    # current limit until the back-EMF meets the supply, then full voltage
    vs = tw.drive.supply_voltage
    cur, volt = s["drive_current"][1:], s["drive_voltage"][1:]
    below = volt < vs - 1e-9
    assert below[0].all() and not below.all()  # both regimes are visited
    assert np.allclose(cur[below], tw.drive.current_limit, rtol=1e-9)
    assert np.all(volt[~below] == pytest.approx(vs))
    assert np.all(cur[~below] < tw.drive.current_limit)
    assert np.allclose(s["drive_torque"], tw.drive.gear_ratio * tw.drive.gear_efficiency
                       * tw.motor.k_t * s["drive_current"])  # fmt: skip


def test_stick_obstacle_does_the_lifting_work() -> None:
    s = stick_for(REAL.with_payload())
    t = np.arange(0.0, 10.0, 1e-4)
    tau = s(t)
    assert np.all(tau[:, 1:] == 0)
    climb = tau[:, 0] > 0  # resisting a motion at -7 rad/s
    assert climb.sum() * 1e-4 == pytest.approx(s.duration, abs=2e-4)
    # work of the climb = m g h (torque x wheel rotation)
    assert s.torque * s.climb_angle == pytest.approx(s.mass * 9.81 * s.height)
    assert np.sum(tau[:, 0]) * 1e-4 == pytest.approx(0.0, abs=1e-3)  # net impulse ~ 0
    assert t[climb][0] == pytest.approx(6.0, abs=1e-3)
    with pytest.raises(ValueError, match="height"):
        StickObstacle(height=0.05, r=0.04)


def test_twin_validation() -> None:
    # one gearbox: the encoder (on the motor shaft) has no gear ratio of its own, and a
    # legacy twin file giving it one that differs from the drive's is refused
    from mwip.robot import RobotFileError, robot_from_dict

    with pytest.raises(TypeError, match="gear_ratio"):
        EncoderSpec(gear_ratio=10.0)  # type: ignore[call-arg]
    with pytest.raises(RobotFileError, match="encoder.gear_ratio .* must equal .*gear_ratio"):
        robot_from_dict({"twin": {"drive": {"gear_ratio": 23.0},
                                  "encoder": {"gear_ratio": 10.0}}})  # fmt: skip
    with pytest.raises(ValueError, match="case"):
        case_plant(4)


def test_the_drive_sees_each_robots_wheel_geometry():
    """The twin's drive chain takes each robot's ``b / r`` from the plant it is built for
    (one row per robot, as a campaign block's plant): two robots in the same state and with
    the same command but different ``b / r`` get different torques while turning, each the
    torque of a drive built for its own robot alone."""
    from dataclasses import replace

    import numpy as np

    from mwip.hardware.identified import default_twin
    from mwip.params import REAL, stack_params

    rows = [replace(REAL, b=2.0 * REAL.r), replace(REAL, b=6.0 * REAL.r)]
    tw = default_twin()
    act = tw.actuator(stack_params(rows))
    act.reset(2, seed=0)
    state = np.zeros((2, 8))
    state[:, 5] = 3.0  # yaw rate: the wheels turn at +-(b/r) alpha'
    u = act(0.0, np.full((2, 2), 0.05), state)
    assert not np.allclose(u[0], u[1])
    for i, plant in enumerate(rows):
        one = tw.actuator(plant)
        one.reset(1, seed=0)
        assert np.array_equal(one(0.0, np.full((1, 2), 0.05), state[i : i + 1])[0], u[i])
