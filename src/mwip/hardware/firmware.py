"""The board's firmware (Sec. 6.1): what it believes about its drive and does each sample.

A real board converts the law's torque command into a PWM duty with the constants its
programmer believed (gear ratio, torque constant, winding resistance, gear efficiency, supply
voltage), not with the drive's true ones; it adds some fraction of the back-EMF of the speed
it measures; it runs the law some time after the sample instant (the computation delay); it
zeroes its gyro at power-on or not and fuses its IMU one way or another
(:mod:`mwip.hardware.fusion`). :class:`FirmwareSpec` holds all of it, and is part of the robot
file (``[firmware]``).

Torque to duty (element :data:`ELEMENT`, kernel :func:`step`)
    Per wheel, with the motor speed ``omega_m = N (psi_i' - theta')`` the board reads on the
    encoder (on the motor shaft), ``V* = R tau / G_fw + c k_e omega_m`` and the duty command
    ``V* / V_0``, ``G_fw = N eta k_t / k``: the firmware's torque-to-current gain is the
    drive's true one divided by the **torque gain** ``k`` (``firmware.torque_gain``), so that
    at standstill and inside the limits the drive delivers ``k`` times the commanded torque.
    ``k = 1`` is a firmware that agrees with its hardware (the default robot until the
    calibration decides otherwise: SPEC.md "Twin structure"). ``c`` is the back-EMF
    compensation (``firmware.emf_compensation``; a current-mode driver, ``drive.mode =
    "torque"``, compensates fully). The driver (:mod:`mwip.hardware.motor`) then clips,
    quantises and applies the duty.

The computation delay (``firmware.delay``, a fraction of ``Ts``) is its own element,
:mod:`mwip.hardware.delay`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mwip.hardware.bus import B
from mwip.hardware.element import Element, PackContext
from mwip.hardware.fusion import FusionSpec
from mwip.hardware.numerics import nan_to_num
from mwip.hardware.unknown import Unknown
from mwip.jit_cache import njit
from mwip.layout import Field, Layout

__all__ = ["FirmwareSpec", "ELEMENT", "step", "UNKNOWNS", "CODE"]


@dataclass(frozen=True)
class FirmwareSpec:
    """What the board's firmware believes and does (module docstring).

    Ts : sample period (s; Sec. 6.1: 5 ms).
    delay : computation and actuation delay as a fraction of ``Ts`` in [0, 1]: the board
        writes the new duty ``delay Ts`` after the sample instant.
    torque_gain : delivered / commanded torque at standstill, inside the limits: the drive's
        true torque-to-current gain over the one the firmware uses (1: they agree).
    emf_compensation : the fraction ``c`` in [0, 1] of the back-EMF ``k_e omega_m`` of the
        measured motor speed that the firmware adds to its voltage command (0: open-loop
        PWM, "the control signal modulates a pulse signal of a certain width", Sec. 6.1).
    gyro_zeroing : the firmware averages the gyro at rest at power-on and subtracts it.
    fusion : the pitch estimate's filter (:class:`~mwip.hardware.fusion.FusionSpec`).
    """

    Ts: float = 0.005
    delay: float = 0.2
    torque_gain: float = 1.0
    emf_compensation: float = 0.0
    gyro_zeroing: bool = False
    fusion: FusionSpec = field(default_factory=FusionSpec)

    def __post_init__(self) -> None:
        for name, lo, hi, closed in (("Ts", 0.0, 1.0, False), ("delay", 0.0, 1.0, True),
                                     ("torque_gain", 0.0, 100.0, False),
                                     ("emf_compensation", 0.0, 1.0, True)):  # fmt: skip
            v = getattr(self, name)
            ok_lo = v >= lo if closed else v > lo
            if isinstance(v, bool) or not (np.isfinite(v) and ok_lo and v <= hi):
                left = "[" if closed else "("
                raise ValueError(f"{name!r} must be finite and in {left}{lo:g}, {hi:g}], "
                                 f"got {v!r}")  # fmt: skip
            object.__setattr__(self, name, float(v))
        if not isinstance(self.gyro_zeroing, bool | np.bool_):
            raise ValueError(f"'gyro_zeroing' must be true or false, got {self.gyro_zeroing!r}")
        if not isinstance(self.fusion, FusionSpec):
            raise ValueError(f"'fusion' must be a FusionSpec, got {self.fusion!r}")


#: The element's code (its branch in :mod:`mwip.hardware.dispatch`).
CODE = 5

PARAMS = Layout((
    Field("R", (), "the winding resistance the firmware uses (Ohm)"),
    Field("gain", (), "its torque-to-current gain N eta k_t / k (N m/A)"),
    Field("k_e", (), "its back-EMF constant (V s/rad)"),
    Field("gear_ratio", (), "motor turns per wheel turn (the encoder reads the motor)"),
    Field("b_over_r", (), "b / r"),
    Field("c_mode", (), "0: full back-EMF compensation, 1: none, 2: the fraction c"),
    Field("c", (), "back-EMF compensation fraction"),
    Field("V", (), "the supply voltage the duty is taken against (V)"),
))  # fmt: skip
P = PARAMS.index()


def _pack(ctx: PackContext) -> dict[str, Any]:
    m, d = ctx.twin.motor, ctx.twin.drive
    gr: Any = ctx.value("drive.gear_ratio")
    gain = np.asarray(gr, dtype=float) * d.gear_efficiency * m.k_t
    k: Any = ctx.value("firmware.torque_gain")
    c: Any = 1.0 if d.mode == "torque" else ctx.value("firmware.emf_compensation")
    if np.ndim(c) == 0:
        mode = 0.0 if c == 1.0 else (1.0 if c == 0.0 else 2.0)
    else:
        mode = 2.0
    return {"R": m.resistance, "gain": gain / k, "k_e": m.k_e, "gear_ratio": gr,
            "b_over_r": np.asarray(ctx.plant.b / ctx.plant.r, dtype=float), "c_mode": mode,
            "c": c, "V": d.supply_voltage}  # fmt: skip



@njit(inline="always")
def step(k, p, s, bus, yi, z, lg):  # noqa: ANN001, ANN201 - compiled kernel
    """The duty command of each wheel for the torque on the bus (module docstring)."""
    pd, td, ad = yi[3], yi[4], yi[5]
    bor = p[P.b_over_r]
    for w in range(2):
        wheel = pd + bor * ad - td if w == 0 else pd - bor * ad - td
        emf = p[P.k_e] * (p[P.gear_ratio] * wheel)
        mode = p[P.c_mode]
        ff = emf if mode == 0.0 else (0.0 if mode == 1.0 else p[P.c] * emf)
        v_ref = p[P.R] * nan_to_num(bus[B.u + w]) / p[P.gain] + ff
        bus[B.duty + w] = v_ref / p[P.V]


ELEMENT = Element(
    name="firmware", code=CODE, stage="drive", place=30, params=PARAMS, state=Layout(), pack=_pack,
    switches=("motor",), doc="the board's torque-to-duty map: torque gain, back-EMF compensation",
)  # fmt: skip

#: The firmware's unknowns (docs/twin_model.md, "The prior").
UNKNOWNS: tuple[Unknown, ...] = (
    Unknown("firmware.emf_compensation", 0.0, 1.0, "", "fraction of k_e omega_m the "
            "firmware/driver adds: 0 = open-loop PWM as Sec. 6.1's words read, 1 = full "
            "feed-forward / current-mode driver", "motor", 0.0),
    Unknown("firmware.delay", 0.0, 1.0, "Ts", "fraction of Ts: 0-5 ms of computation on the "
            "50 MHz Cortex-M3", "delay", 0.2),
    Unknown("firmware.fusion.tau", 0.1, 2.0, "s", "complementary filter time constant, not "
            "printed", "fusion", 0.5),
    Unknown("firmware.torque_gain", 0.25, 4.0, "", "delivered / commanded torque at standstill "
            "(the drive's true torque-to-current gain over the firmware's): log-uniform, a "
            "factor up to 4 either way, e.g. a catalogue k_t without the gear efficiency "
            "(0.6-0.9: 1.1-1.7), another stage's gear ratio of the GP 32 A series (3.7-66:1), "
            "a supply taken at 12 instead of 24 V (2); the book prints none of these "
            "constants", "motor", 1.0, scale="log"),
)  # fmt: skip
