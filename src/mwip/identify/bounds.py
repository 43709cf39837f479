"""The parameters ``mwip twin fit`` identifies: dotted twin-file paths, bounds, prior centre.

The bounds are the twin's declared prior (``mwip.hardware.prior.PRIOR``); the fit reads them
only through :data:`BOUNDS`, :func:`centre` and :data:`UNITS`. ``firmware.emf_compensation`` is
the fraction of the back-EMF ``k_e omega_m`` the firmware adds to the voltage (0: open-loop
PWM).
"""

from __future__ import annotations

__all__ = ["BOUNDS", "UNITS", "NAMES", "centre"]

def _bounds() -> dict[str, tuple[float, float]]:
    from mwip.hardware.prior import PRIOR

    return {n: (float(lo), float(hi)) for n, (lo, hi) in zip(PRIOR.names, PRIOR.bounds, strict=True)
            if n in _FITTED}  # fmt: skip


#: what the fit can identify, in this order
_FITTED = (
    "drive.gear_ratio", "firmware.emf_compensation", "drive.deadband", "drive.current_limit",
    "gearbox.coulomb", "gearbox.viscous", "firmware.delay", "imu.gyro_bias", "imu.accel_bias",
    "imu.height", "firmware.fusion.tau",
)  # fmt: skip

#: name -> (lower, upper) bound: the twin's declared prior (mwip.hardware.prior.PRIOR)
BOUNDS: dict[str, tuple[float, float]] = {n: _bounds()[n] for n in _FITTED}

UNITS: dict[str, str] = {
    "drive.gear_ratio": "motor turns per wheel turn",
    "firmware.emf_compensation": "fraction of k_e omega_m added by the firmware",
    "drive.deadband": "duty",
    "drive.current_limit": "A",
    "gearbox.coulomb": "N m per wheel",
    "gearbox.viscous": "N m s/rad per wheel",
    "firmware.delay": "fraction of Ts",
    "imu.gyro_bias": "rad/s",
    "imu.accel_bias": "m/s^2",
    "imu.height": "m",
    "firmware.fusion.tau": "s",
}

NAMES: tuple[str, ...] = tuple(BOUNDS)


def centre(name: str) -> float:
    """The prior centre of ``name``: the middle of its bounds."""
    lo, hi = BOUNDS[name]
    return 0.5 * (lo + hi)
