"""The robot's hardware (Sec. 2.5) and the digital twin of Chapter 6 (docs/twin_model.md).

The twin's elements, one module each with its one compiled kernel
(:mod:`mwip.hardware.element`, in the order of :mod:`mwip.hardware.registry`):

- :mod:`mwip.hardware.imu`: accelerometer tilt (2.37)/(2.39), gyro with zero drift (2.40);
- :mod:`mwip.hardware.fusion`: the firmware's gyro zeroing and complementary or Kalman fusion;
- :mod:`mwip.hardware.encoder`: quadrature encoders on the motor shafts, odometry;
- :mod:`mwip.hardware.command`: the command disturbances of ``mwip bench`` (optional);
- :mod:`mwip.hardware.delay`: the firmware's computation delay;
- :mod:`mwip.hardware.firmware`: what the board believes (torque gain, back-EMF
  compensation) and its torque-to-duty map;
- :mod:`mwip.hardware.motor`: MAXON RE25 (Table 2.1) and the H-bridge PWM driver (its data
  sheet and the drive's specification: :mod:`mwip.hardware.motor_data`, no kernel);
- :mod:`mwip.hardware.friction`, :mod:`mwip.hardware.backlash`: the gearbox's Coulomb
  friction and backlash;

and around them:

- :mod:`mwip.hardware.bus`, :mod:`mwip.hardware.pack`, :mod:`mwip.hardware.dispatch`,
  :mod:`mwip.hardware.loop`: the signal bus, the packing, the dispatcher, the compiled loop;
- :mod:`mwip.hardware.drivetrain`: the plant's reflected rotor inertia and extra damping;
- :mod:`mwip.hardware.obstacle`: the Case 3 stick; :mod:`mwip.hardware.payload`: the Case 2 pan;
- :mod:`mwip.hardware.prior`: the unknown values and their prior (each module's ``UNKNOWNS``);
- :mod:`mwip.hardware.elements`: the switchable physical elements (one registry);
- :mod:`mwip.hardware.twin`: the composition and :func:`run_on_twin`;
- :mod:`mwip.hardware.ablation`: the ideal robot, then each element added in turn;
- :mod:`mwip.hardware.sensitivity`: payload, stick and gear-ratio sensitivities.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = [
    "EncoderSpec", "FusionSpec", "ImuNoise", "RE25", "MotorData", "DriveSpec", "FirmwareSpec",
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
        "FusionSpec": "mwip.hardware.fusion",
        "FirmwareSpec": "mwip.hardware.firmware",
        "ImuNoise": "mwip.hardware.imu",
        "RE25": "mwip.hardware.motor_data",
        "DriveSpec": "mwip.hardware.motor_data",
        "MotorData": "mwip.hardware.motor_data",
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
    from mwip.hardware.firmware import FirmwareSpec
    from mwip.hardware.fusion import FusionSpec
    from mwip.hardware.imu import ImuNoise
    from mwip.hardware.motor_data import RE25, DriveSpec, MotorData
    from mwip.hardware.obstacle import StickObstacle, StickSpec
    from mwip.hardware.payload import PayloadSpec
    from mwip.hardware.prior import PRIOR, Prior, Unknown
    from mwip.hardware.twin import CASES, Twin, TwinActuator, TwinSensor, case_plant, run_on_twin
