"""One sample of any twin element: the one place that dispatches on the element code.

Every element (:mod:`mwip.hardware.element`) has a kernel ``step(k, p, s, bus, yi, z, lg)``;
:func:`element_step` picks it by code. The compiled twin loop and the Python loop's batch
steps (:mod:`mwip.hardware.loop`) both call it. A new element adds one import and its branch
here, and that is its whole registration: :mod:`mwip.hardware.registry` builds the chains from
the element modules imported here (each element declares its stage and its place).
"""

from __future__ import annotations

from mwip.hardware import backlash, command, delay, encoder, firmware, friction, fusion, imu, motor
from mwip.jit_cache import njit

__all__ = ["element_step"]


@njit
def element_step(code, k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201, PLR0911 - compiled kernel
    """One sample of element ``code`` for one robot (module docstring)."""
    if code == imu.CODE:
        imu.step(k, p, s, bus, yi, z, lg)
    elif code == fusion.CODE:
        fusion.step(k, p, s, bus, yi, z, lg)
    elif code == encoder.CODE:
        encoder.step(k, p, s, bus, yi, z, lg)
    elif code == command.CODE:
        command.step(k, p, s, bus, yi, z, lg)
    elif code == delay.CODE:
        delay.step(k, p, s, bus, yi, z, lg)
    elif code == firmware.CODE:
        firmware.step(k, p, s, bus, yi, z, lg)
    elif code == motor.CODE:
        motor.step(k, p, s, bus, yi, z, lg)
    elif code == friction.CODE:
        friction.step(k, p, s, bus, yi, z, lg)
    elif code == backlash.CODE:
        backlash.step(k, p, s, bus, yi, z, lg)
