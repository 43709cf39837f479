"""The signal bus of one robot of the twin: the named signals its elements pass on.

Each sample the compiled twin loop (:mod:`mwip.hardware.loop`) runs the sensor chain (true
state -> measurement) and, after the law, the drive chain (commanded -> applied torque) of
:mod:`mwip.hardware.registry`; the elements of a chain talk through this vector, each reading
and writing its signals by name (``B.u`` is the offset of ``u``):

==========  =====  ==========================================================================
signal      width  meaning
==========  =====  ==========================================================================
u           2      wheel torques ``[u_r, u_l]`` (N m): the law's command on entry to the
                   drive chain, the torque held on the wheels on exit
duty        2      the firmware's duty command (before the driver's clipping), per wheel
acc         2      the accelerometer's body-axis readings ``(a_x, a_y)`` (m/s^2)
gyro        1      the gyro's rate reading (rad/s), bias and noise included
gyro_bias   1      the gyro's true zero-rate offset this sample (what power-on zeroing meets)
theta_acc   1      the accelerometer tilt (2.39) (rad)
theta_hat   1      the board's pitch estimate (rad); the true pitch without fusion
rate_hat    1      the board's pitch-rate estimate (rad/s); the true rate without fusion
ym          8      the measurement the law reads, ``[psi, theta, alpha, psi', theta', alpha',
                   x, y]``: the true state on entry to the sensor chain
==========  =====  ==========================================================================
"""

from __future__ import annotations

from mwip.layout import Field, Layout

__all__ = ["BUS", "B"]

BUS = Layout((
    Field("u", (2,), "wheel torques, commanded -> applied (N m)"),
    Field("duty", (2,), "the firmware's duty command"),
    Field("acc", (2,), "accelerometer (a_x, a_y) (m/s^2)"),
    Field("gyro", (), "gyro reading (rad/s)"),
    Field("gyro_bias", (), "the gyro's true offset (rad/s)"),
    Field("theta_acc", (), "accelerometer tilt (rad)"),
    Field("theta_hat", (), "pitch estimate (rad)"),
    Field("rate_hat", (), "pitch-rate estimate (rad/s)"),
    Field("ym", (8,), "the measurement"),
))  # fmt: skip

#: Offsets of the bus's signals (a constant named tuple the kernels read).
B = BUS.index()
