"""The parameters ``mwip twin fit`` identifies: dotted twin-file paths, bounds, prior centre.

The table is this package's until the twin's declared prior (``mwip.hardware.prior.PRIOR``)
lands; the fit reads it only through :data:`BOUNDS`, :func:`centre` and :data:`UNITS`.
``drive.emf_compensation`` is the fraction of the back-EMF ``k_e omega_m`` the firmware adds
to the voltage (0: open-loop PWM); today's twin file has the boolean
``drive.emf_feedforward`` instead (written as ``c >= 0.5``).
"""

from __future__ import annotations

__all__ = ["BOUNDS", "UNITS", "NAMES", "centre"]

#: name -> (lower, upper) bound
BOUNDS: dict[str, tuple[float, float]] = {
    "drive.gear_ratio": (3.7, 51.0),
    "drive.emf_compensation": (0.0, 1.0),
    "drive.deadband": (0.0, 0.05),
    "drive.current_limit": (1.0, 10.0),
    "gearbox.coulomb": (0.0, 0.06),
    "gearbox.viscous": (0.0, 0.005),
    "delay": (0.0, 1.0),
    "imu.gyro_bias": (-0.02, 0.02),
    "imu.accel_bias": (-0.05, 0.05),
    "imu.height": (0.0, 0.13),
    "fusion.tau": (0.1, 2.0),
}

UNITS: dict[str, str] = {
    "drive.gear_ratio": "motor turns per wheel turn",
    "drive.emf_compensation": "fraction of k_e omega_m added by the firmware",
    "drive.deadband": "duty",
    "drive.current_limit": "A",
    "gearbox.coulomb": "N m per wheel",
    "gearbox.viscous": "N m s/rad per wheel",
    "delay": "fraction of Ts",
    "imu.gyro_bias": "rad/s",
    "imu.accel_bias": "m/s^2",
    "imu.height": "m",
    "fusion.tau": "s",
}

NAMES: tuple[str, ...] = tuple(BOUNDS)


def centre(name: str) -> float:
    """The prior centre of ``name``: the middle of its bounds."""
    lo, hi = BOUNDS[name]
    return 0.5 * (lo + hi)
