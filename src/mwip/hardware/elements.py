"""The twin's physical elements, each switchable: one registry (docs/twin_model.md).

The ideal robot is the plant of Table 6.1 with exact measurements and the commanded wheel
torques applied; each element below adds one physical effect of the real robot. The order is
the ablation's (:mod:`mwip.hardware.ablation`): the drive train first, then timing, then the
sensors. Where an element needs another (``pwm`` and ``sag`` act in the motor driver, the IMU
elements act through the fusion filter) it has no effect without it.

==============  ======  ======================================================================
element         where   physical effect
==============  ======  ======================================================================
inertia         plant   rotor inertia reflected through the gearbox (``N^2 J`` per wheel)
motor           drive   DC motor + H-bridge: voltage (PWM) drive with back-EMF, current
                        limit, supply limit, gearbox efficiency (or a current-mode driver)
pwm             drive   duty quantisation and driver dead-band
sag             drive   battery voltage sag under the drawn current
delay           drive   computation and actuation delay (a fraction of or a whole sample)
friction        drive   gearbox + brush Coulomb friction and extra viscous friction
backlash        drive   gearbox backlash (torque reversal waits for the play to close)
encoder         sensor  encoder counts: quantised angles, rates by differences, odometry
fusion          sensor  pitch and pitch rate from the IMU through the fusion filter
accel_motion    sensor  the accelerometer also reads the body's own acceleration
imu_noise       sensor  white noise on the accelerometer and gyro
imu_bias        sensor  accelerometer offset, gyro zero drift and its random walk
==============  ======  ======================================================================
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "ELEMENTS",
    "DESCRIPTIONS",
    "REQUIRES",
    "PLANT_ELEMENTS",
    "DRIVE_ELEMENTS",
    "SENSOR_ELEMENTS",
    "check_elements",
    "element_mask",
]

#: All elements, in the ablation's order.
ELEMENTS: tuple[str, ...] = (
    "inertia", "motor", "pwm", "sag", "delay", "friction", "backlash",
    "encoder", "fusion", "accel_motion", "imu_noise", "imu_bias",
)  # fmt: skip

DESCRIPTIONS: dict[str, str] = {
    "inertia": "rotor inertia reflected through the gearbox",
    "motor": "motor + driver: voltage drive, back-EMF, current/supply limits, efficiency",
    "pwm": "PWM duty quantisation and dead-band",
    "sag": "battery voltage sag",
    "delay": "computation and actuation delay",
    "friction": "gearbox Coulomb and viscous friction",
    "backlash": "gearbox backlash",
    "encoder": "encoder quantisation, difference rates, odometry",
    "fusion": "IMU pitch through the fusion filter",
    "accel_motion": "accelerometer reads the body's acceleration",
    "imu_noise": "IMU white noise",
    "imu_bias": "IMU bias and gyro drift",
}

#: Elements that act only through another one (an ablation of one element alone adds these).
REQUIRES: dict[str, frozenset[str]] = {
    "pwm": frozenset({"motor"}),
    "sag": frozenset({"motor"}),
    "accel_motion": frozenset({"fusion"}),
    "imu_noise": frozenset({"fusion"}),
    "imu_bias": frozenset({"fusion"}),
}

PLANT_ELEMENTS = frozenset({"inertia"})
DRIVE_ELEMENTS = frozenset({"motor", "pwm", "sag", "delay", "friction", "backlash"})
SENSOR_ELEMENTS = frozenset({"encoder", "fusion", "accel_motion", "imu_noise", "imu_bias"})


def check_elements(elements: Iterable[str], what: str = "elements") -> frozenset[str]:
    """The set of ``elements``; an unknown name is a one-line ``ValueError`` naming it."""
    if isinstance(elements, str):
        raise ValueError(f"{what!r} must be a list of element names, got the string {elements!r}")
    out = frozenset(str(e) for e in elements)
    unknown = sorted(out - set(ELEMENTS))
    if unknown:
        raise ValueError(
            f"{what!r}: unknown element {unknown[0]!r}; allowed: {', '.join(ELEMENTS)}"
        )
    return out


def element_mask(rows: Iterable[Iterable[str]]) -> NDArray[np.bool_]:
    """(N, E) mask: row ``i`` has element ``ELEMENTS[j]`` switched on."""
    sets = [check_elements(r) for r in rows]
    return np.array([[e in s for e in ELEMENTS] for s in sets], dtype=bool).reshape(
        -1, len(ELEMENTS)
    )
