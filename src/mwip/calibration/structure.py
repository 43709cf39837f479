"""The twin structure the book calibration's revisions 1-5 declared (S0).

The declaration (``book-evidence.toml``) takes its prior from the twin file of its time: the
17 unknowns of :data:`mwip.hardware.prior.ORDER`, in that order (a prior draw is a row of
uniform numbers in it, so the order fixes the draws), with the firmware agreeing with its
hardware (``firmware.torque_gain = 1``, not an unknown of it) and no power-on gyro zeroing.
Unknowns the robot file added later (:mod:`mwip.hardware.firmware`) are not part of it.
"""

from __future__ import annotations

from mwip.hardware.prior import ORDER, PRIOR, Prior

__all__ = ["BOOK_PRIOR"]

#: The prior of the book calibration's declared structure S0 (module docstring).
BOOK_PRIOR: Prior = PRIOR.subset(ORDER)
