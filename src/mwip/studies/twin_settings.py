"""The digital twin a Chapter 6 study runs on, built from the study's settings.

The book prints the robot's sample period (5 ms), its sensors and motor by name (Sec. 2.5,
Table 2.1) but not the numbers the twin needs: IMU noise and bias, the fusion constant, the
encoder's counts per turn, the gear ratio, the driver's current limit and PWM resolution, the
plant's integration step. They are settings of every twin study (``scenarios/exp-*.toml``,
declared in its ``[open]`` table with a range and the reason for the default; docs/twin.md,
"Open settings") and reach the twin only through :func:`twin_from`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.imu import FusionSpec, ImuNoise
from mwip.hardware.motor import DriveSpec
from mwip.hardware.twin import Twin
from mwip.params import Params

__all__ = ["TWIN_KEYS", "robot_label", "twin_doc", "twin_from"]

#: The settings every twin study carries (besides ``Ts``) and :func:`twin_from` reads.
TWIN_KEYS = (
    "dt",
    "fusion_tau",
    "accel_sigma",
    "accel_bias",
    "gyro_sigma",
    "gyro_bias",
    "gyro_bias_walk",
    "imu_height",
    "encoder_cpr",
    "gear_ratio",
    "current_limit",
    "pwm_levels",
)


def twin_from(cfg: Mapping[str, Any], *, ideal: bool = False) -> Twin:
    """The twin of the settings ``cfg`` (sampled every ``cfg["Ts"]``, plant step
    ``cfg["dt"]``); ``ideal=True``: the same sampling with ideal sensors and actuator (the
    plain simulation, :meth:`Twin.ideal`)."""
    if ideal:
        return Twin.ideal(Ts=cfg["Ts"], dt=cfg["dt"])
    imu = ImuNoise(accel_sigma=cfg["accel_sigma"], accel_bias=cfg["accel_bias"],
                   gyro_sigma=cfg["gyro_sigma"], gyro_bias=cfg["gyro_bias"],
                   gyro_bias_walk=cfg["gyro_bias_walk"], height=cfg["imu_height"])  # fmt: skip
    return Twin(
        imu=imu,
        fusion=FusionSpec(kind="complementary", tau=cfg["fusion_tau"]),
        encoder=EncoderSpec(cpr=cfg["encoder_cpr"], gear_ratio=cfg["gear_ratio"]),
        drive=DriveSpec(
            gear_ratio=cfg["gear_ratio"],
            current_limit=cfg["current_limit"],
            pwm_levels=cfg["pwm_levels"],
        ),  # fmt: skip
        Ts=cfg["Ts"],
        dt=cfg["dt"],
    )


def twin_doc(cfg: Mapping[str, Any]) -> str:
    """One line naming the twin of ``cfg`` (for the recorded settings)."""
    return (
        f"complementary fusion (tau {cfg['fusion_tau']:g} s), IMU at {cfg['imu_height']:g} m, "
        f"encoders {cfg['encoder_cpr']} cpr, RE25 + {cfg['gear_ratio']:g}:1, 24 V, "
        f"{cfg['current_limit']:g} A, {cfg['pwm_levels']} PWM levels, plant step "
        f"{cfg['dt'] * 1e3:g} ms"
    )


def robot_label(plant: Params) -> str:
    """The robot that ran, for figure titles: mass, wheel radius and the damping
    coefficients as the equations use them (whatever reading or file produced them)."""
    return (
        f"plant mb {float(plant.mb):g} kg, r {float(plant.r):g} m, "
        f"Db {float(plant.Db):.3g}, Dw {float(plant.Dw):.3g} N m s/rad"
    )
