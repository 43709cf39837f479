"""The robot's hardware (Sec. 2.5) and the digital twin of Chapter 6 (docs/twin_model.md).

- :mod:`mwip.hardware.imu`: accelerometer tilt (2.37)/(2.39), gyro with zero drift (2.40),
  complementary and Kalman fusion;
- :mod:`mwip.hardware.encoder`: quadrature encoders on the motor shafts;
- :mod:`mwip.hardware.motor`: MAXON RE25 (Table 2.1) and the H-bridge PWM driver;
- :mod:`mwip.hardware.drivetrain`: reflected rotor inertia, gearbox friction and backlash;
- :mod:`mwip.hardware.obstacle`: the Case 3 stick; :mod:`mwip.hardware.payload`: the Case 2 pan;
- :mod:`mwip.hardware.prior`: the unknown values and their prior (each module's ``UNKNOWNS``);
- :mod:`mwip.hardware.elements`: the switchable physical elements (one registry);
- :mod:`mwip.hardware.twin`: the composition and :func:`run_on_twin`;
- :mod:`mwip.hardware.twin_config`: the twin as ``[twin]`` TOML tables (``mwip twin show``);
- :mod:`mwip.hardware.ablation`: the ideal robot, then each element added in turn;
- :mod:`mwip.hardware.sensitivity`: payload, stick and gear-ratio sensitivities.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = [
    "EncoderSpec", "FusionSpec", "ImuNoise", "RE25", "MotorData", "DriveSpec", "DriveActuator",
    "GearboxSpec", "TwinPlant", "ELEMENTS", "StickObstacle", "Twin", "TwinSensor",
    "TwinActuator", "CASES", "case_plant", "run_on_twin", "PayloadSpec", "StickSpec", "Unknown",
    "Prior", "PRIOR",
]  # fmt: skip

__getattr__, __dir__ = exports(
    __name__,
    {
        "GearboxSpec": "mwip.hardware.drivetrain",
        "TwinPlant": "mwip.hardware.drivetrain",
        "ELEMENTS": "mwip.hardware.elements",
        "EncoderSpec": "mwip.hardware.encoder",
        "FusionSpec": "mwip.hardware.imu",
        "ImuNoise": "mwip.hardware.imu",
        "RE25": "mwip.hardware.motor",
        "DriveActuator": "mwip.hardware.motor",
        "DriveSpec": "mwip.hardware.motor",
        "MotorData": "mwip.hardware.motor",
        "StickObstacle": "mwip.hardware.obstacle",
        "StickSpec": "mwip.hardware.obstacle",
        "PayloadSpec": "mwip.hardware.payload",
        "Unknown": "mwip.hardware.prior",
        "Prior": "mwip.hardware.prior",
        "PRIOR": "mwip.hardware.prior",
        "CASES": "mwip.hardware.twin",
        "Twin": "mwip.hardware.twin",
        "TwinActuator": "mwip.hardware.twin",
        "TwinSensor": "mwip.hardware.twin",
        "case_plant": "mwip.hardware.twin",
        "run_on_twin": "mwip.hardware.twin",
    },
)  # fmt: skip

if TYPE_CHECKING:
    from mwip.hardware.drivetrain import GearboxSpec, TwinPlant
    from mwip.hardware.elements import ELEMENTS
    from mwip.hardware.encoder import EncoderSpec
    from mwip.hardware.imu import FusionSpec, ImuNoise
    from mwip.hardware.motor import RE25, DriveActuator, DriveSpec, MotorData
    from mwip.hardware.obstacle import StickObstacle, StickSpec
    from mwip.hardware.payload import PayloadSpec
    from mwip.hardware.prior import PRIOR, Prior, Unknown
    from mwip.hardware.twin import CASES, Twin, TwinActuator, TwinSensor, case_plant, run_on_twin
