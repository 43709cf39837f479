"""The twin's elements in the order they act: one registry (:mod:`mwip.hardware.element`).

Each sample the compiled twin loop runs the sensor chain on the true state (the IMU reads,
the firmware fuses the pitch, the encoders count), the law on the measurement, then the drive
chain on the command (the firmware's delay and torque-to-duty map, the driver and motors, the
gearbox's Coulomb friction and backlash). An element runs when some robot of the batch has
one of its switches on (:attr:`~mwip.hardware.element.Element.switches`), or, for an
``optional`` one, when the run asks for it. A new element: one entry here, one import and
branch in :mod:`mwip.hardware.dispatch` (docs/extending.md).
"""

from __future__ import annotations

from mwip.hardware import backlash, command, delay, encoder, firmware, friction, fusion, imu, motor
from mwip.hardware.element import Element

__all__ = ["SENSOR_CHAIN", "DRIVE_CHAIN", "ELEMENTS_BY_NAME"]

SENSOR_CHAIN: tuple[Element, ...] = (imu.ELEMENT, fusion.ELEMENT, encoder.ELEMENT)
DRIVE_CHAIN: tuple[Element, ...] = (
    command.ELEMENT, delay.ELEMENT, firmware.ELEMENT, motor.ELEMENT, friction.ELEMENT,
    backlash.ELEMENT,
)  # fmt: skip

ELEMENTS_BY_NAME: dict[str, Element] = {e.name: e for e in SENSOR_CHAIN + DRIVE_CHAIN}
