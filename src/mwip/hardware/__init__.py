"""The robot's hardware (Sec. 2.5) and the digital twin of Chapter 6.

- :mod:`mwip.hardware.imu`: accelerometer tilt (2.37)/(2.39), gyro with zero drift (2.40),
  complementary and Kalman fusion;
- :mod:`mwip.hardware.encoder`: quadrature encoders on the motor shafts;
- :mod:`mwip.hardware.motor`: MAXON RE25 (Table 2.1), gearbox and PWM driver;
- :mod:`mwip.hardware.obstacle`: the Case 3 stick;
- :mod:`mwip.hardware.twin`: the composition and :func:`run_on_twin`.
"""

from mwip.hardware.encoder import EncoderSpec
from mwip.hardware.imu import FusionSpec, ImuNoise
from mwip.hardware.motor import RE25, DriveActuator, DriveSpec, MotorData
from mwip.hardware.obstacle import StickObstacle
from mwip.hardware.twin import CASES, Twin, TwinSensor, case_plant, run_on_twin

__all__ = [
    "EncoderSpec", "FusionSpec", "ImuNoise", "RE25", "MotorData", "DriveSpec", "DriveActuator",
    "StickObstacle", "Twin", "TwinSensor", "CASES", "case_plant", "run_on_twin",
]  # fmt: skip
