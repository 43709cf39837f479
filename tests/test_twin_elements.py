"""Each compiled twin element against its NumPy oracle (tests/oracle_twin.py), one at a time.

Every element of :mod:`mwip.hardware.registry` runs alone (its element switches on, every
other off, the ideal rest of the chain passing the signals through) on seeded random inputs:
random true states and commanded torques per sample, for a small batch of robots whose
unknowns are drawn from the prior. The compiled kernels run through the twin's own chains
(:class:`~mwip.hardware.twin.TwinSensor` / :class:`~mwip.hardware.twin.TwinActuator`, which
step the compiled element chain of :mod:`mwip.hardware.dispatch` for the batch); the oracles
through :class:`oracle_twin.OracleSensor` / :class:`oracle_twin.OracleActuator`, written apart
with NumPy. The whole-loop comparison is tests/test_twin_loop.py.

Tolerances (``rtol`` and ``atol`` the same number):

- ``EXACT`` = 1e-12 for the drive's elements (delay, firmware + motor, PWM and dead-band,
  battery sag, Coulomb friction, backlash): the kernels compute the same floating-point
  operations as the oracles, element by element, so they agree to an ulp or two of each
  intermediate; 1e-12 leaves room for a fused multiply-add or a reordered sum in the compiled
  code and is still six orders below anything physical. The states they carry (currents,
  battery current, delay line, backlash gap) are reset each run and stepped 60 times, each
  step contracting (the current's ``e^{-Ts/tau_e}``) or bounded (the gap), so the ulps do not
  accumulate.
- ``SENSOR`` = 1e-10 for the sensor's elements (IMU, fusion, encoders): the accelerometer tilt
  is ``arctan2``, whose NumPy (SIMD) and C-library forms may differ in the last bit for about
  0.1 % of arguments (tests/test_twin_loop.py); the fusion filter integrates it over the run
  (a complementary filter's state carries the ulp with weight ``tau / (tau + Ts)`` per
  sample, summing to at most ``(tau + Ts) / Ts`` ulps, about 400 for ``tau`` = 2 s), and the
  encoders floor the angle to counts and compute the same operations as their oracle (an ulp
  at a count boundary would be one count; none of these seeded states lands on one).

Each test can fail: :func:`test_a_perturbed_parameter_is_seen` runs every element again with
one of its parameters moved by 1e-6 relative on the oracle's side only and checks that the
comparison then fails.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from mwip.hardware.drivetrain import relative_mobility
from mwip.hardware.elements import ELEMENTS
from mwip.hardware.fusion import FusionSpec
from mwip.hardware.registry import DRIVE_CHAIN, SENSOR_CHAIN
from mwip.hardware.twin import Twin, TwinActuator, TwinSensor
from mwip.params import REAL
from oracle_twin import OracleActuator, OracleSensor

EXACT = 1e-12
SENSOR = 1e-10
N = 5
STEPS = 60

#: Each drive element and the element switches that run it alone (the firmware's map runs
#: with the motor: the switch ``motor`` is theirs).
DRIVE_CASES: dict[str, tuple[str, ...]] = {
    "delay": ("delay",),
    "firmware+motor": ("motor",),
    "pwm+deadband": ("motor", "pwm"),
    "sag": ("motor", "sag"),
    "friction": ("friction",),
    "backlash": ("backlash",),
}
#: Each sensor element and its switches (the IMU's readings reach the measurement through the
#: fusion; ``imu_noise``, ``imu_bias``, ``accel_motion`` are the IMU's own).
SENSOR_CASES: dict[str, tuple[str, ...]] = {
    "encoder": ("encoder",),
    "fusion": ("fusion",),
    "imu": ("fusion", "accel_motion", "imu_noise", "imu_bias"),
}
#: The parameter each case perturbs on the oracle's side (must make the comparison fail).
PERTURB = {
    "delay": "firmware.delay", "firmware+motor": "drive.gear_ratio",
    "pwm+deadband": "drive.deadband", "sag": "drive.current_limit",
    "friction": "gearbox.coulomb", "backlash": "gearbox.backlash",
    "encoder": "drive.gear_ratio", "fusion": "firmware.fusion.tau",
    "imu": "imu.gyro_bias", "kalman": "imu.accel_bias",
}  # fmt: skip


def test_every_element_of_the_registry_is_covered() -> None:
    """The cases cover every element of both chains (``command``, the optional command
    disturbances of ``mwip bench``, has its own tests with the bench) and every switch that
    runs one."""
    names = {e.name for e in SENSOR_CHAIN + DRIVE_CHAIN} - {"command"}
    covered = {"delay", "firmware", "motor", "friction", "backlash", "encoder", "fusion", "imu"}
    assert names == covered
    switches = {s for c in (*DRIVE_CASES.values(), *SENSOR_CASES.values()) for s in c}
    assert switches <= set(ELEMENTS)


def _values(twin: Twin, seed: int) -> dict[str, Any]:
    """The twin's unknowns, drawn per robot from the central 80 % of the prior (seeded)."""
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = dict(twin.values())
    for u in twin.prior:
        w = u.high - u.low
        out[u.name] = u.low + w * (0.1 + 0.8 * rng.random(N))
    out["firmware.torque_gain"] = np.linspace(0.8, 1.25, N)
    return out


def _states(rng: np.random.Generator, n_steps: int) -> np.ndarray:
    """Random true states (n_steps, N, 8), a smooth walk (the fusion and the encoders see a
    moving robot, not white noise): pitch within +-0.3 rad, wheel speeds up to ~10 rad/s."""
    x = np.zeros((n_steps, N, 8))
    x[0, :, :6] = rng.uniform(-0.3, 0.3, (N, 6))
    for k in range(1, n_steps):
        x[k, :, 3:6] = np.clip(x[k - 1, :, 3:6] + rng.normal(0.0, 1.0, (N, 3)), -10, 10)
        x[k, :, :3] = x[k - 1, :, :3] + 0.005 * x[k, :, 3:6]
        x[k, :, 1] = np.clip(x[k, :, 1], -0.3, 0.3)
    x[..., 6:] = rng.uniform(-1.0, 1.0, (n_steps, N, 2))
    return x


def _masks(on: tuple[str, ...]) -> np.ndarray:
    return np.array([[e in on for e in ELEMENTS]] * N)


def _assert_close(a: np.ndarray, b: np.ndarray, tol: float, what: str) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.size == b.size:  # a log as (N, 1) on one side, (N,) on the other
        a = a.reshape(b.shape)
    np.testing.assert_allclose(a, b, rtol=tol, atol=tol, err_msg=what)


def _drive(case: str, twin: Twin, seed: int, perturb: float = 0.0) -> None:
    values = _values(twin, seed)
    masks = _masks(DRIVE_CASES[case])
    oracle_values = dict(values)
    if perturb:
        oracle_values[PERTURB[case]] = values[PERTURB[case]] * (1.0 + perturb)
    mob = relative_mobility(REAL)
    act = TwinActuator(REAL, twin, masks=masks, values=values, mobility=mob)
    orc = OracleActuator(twin, plant_b_over_r=float(REAL.b / REAL.r), masks=masks,
                         mobility=mob, values=oracle_values)  # fmt: skip
    act.reset(N)
    orc.reset(N)
    rng = np.random.default_rng(seed + 1)
    xs = _states(rng, STEPS)
    # torques up to ~2 N m: the current limit, the clipping and the backlash's free flight
    # all happen; some exactly zero (the dead-band's and the backlash's sign(0) branches)
    us = rng.normal(0.0, 0.7, (STEPS, N, 2))
    us[rng.random((STEPS, N, 2)) < 0.05] = 0.0
    for k in range(STEPS):
        t = k * twin.Ts
        a = act(t, us[k], xs[k])
        b = orc(t, us[k], xs[k])
        _assert_close(a, b, EXACT, f"{case}: applied torque, sample {k}")
        for key in set(act.last) & set(orc.last):
            _assert_close(np.asarray(act.last[key]), np.asarray(orc.last[key]), EXACT,
                          f"{case}: log {key}, sample {k}")  # fmt: skip


def _sensor(case: str, twin: Twin, seed: int, perturb: float = 0.0) -> None:
    values = _values(twin, seed)
    on = SENSOR_CASES.get(case, SENSOR_CASES["imu"])
    masks = _masks(on)
    oracle_values = dict(values)
    if perturb:
        oracle_values[PERTURB[case]] = values[PERTURB[case]] * (1.0 + perturb)
    sen = TwinSensor(REAL, twin, masks=masks, values=values)
    orc = OracleSensor(REAL, twin, masks=masks, values=oracle_values)
    sen.reset(N, seed)
    orc.reset(N, seed)
    rng = np.random.default_rng(seed + 2)
    xs = _states(rng, STEPS)
    for k in range(STEPS):
        t = k * twin.Ts
        a = sen(t, xs[k]).y
        b = orc(t, xs[k]).y
        _assert_close(a, b, SENSOR, f"{case}: measurement, sample {k}")
        for key in set(sen.last) & set(orc.last):
            _assert_close(np.asarray(sen.last[key]), np.asarray(orc.last[key]), SENSOR,
                          f"{case}: reading {key}, sample {k}")  # fmt: skip


def _kalman() -> Twin:
    tw = Twin()
    return replace(tw, firmware=replace(tw.firmware, fusion=FusionSpec(kind="kalman")))


@pytest.mark.parametrize("case", list(DRIVE_CASES))
def test_drive_element_matches_its_oracle(case: str) -> None:
    _drive(case, Twin(), seed=7)


@pytest.mark.parametrize("case", list(SENSOR_CASES))
def test_sensor_element_matches_its_oracle(case: str) -> None:
    _sensor(case, Twin(), seed=8)


def test_kalman_fusion_matches_its_oracle() -> None:
    """The fusion's other filter (``kind = "kalman"``), with the IMU's bias and noise."""
    _sensor("kalman", _kalman(), seed=9)


@pytest.mark.parametrize("case", [*DRIVE_CASES, *SENSOR_CASES, "kalman"])
def test_a_perturbed_parameter_is_seen(case: str) -> None:
    """The comparisons above can fail: one parameter of the oracle moved by 1e-6 relative."""
    with pytest.raises(AssertionError, match="Not equal to tolerance"):
        if case in DRIVE_CASES:
            _drive(case, Twin(), seed=7, perturb=1e-6)
        else:
            twin = _kalman() if case == "kalman" else Twin()
            _sensor(case, twin, seed=9 if case == "kalman" else 8, perturb=1e-6)
