"""The robot file's tables and fields: each value's unit, status and source.

A value is **known** (printed by the book or a data sheet: its source says where), **assumed**
(a guess, with its reasoning) or **unknown** (the book prints nothing and the value has a
declared prior range in ``[prior]``, with its source; the file's value is the robot's current
one, inside the range). A file may override a value's source in ``[provenance]`` (a fitted
or measured value says so: ``mwip twin fit`` writes it).

==============  =============================================================================
table           what
==============  =============================================================================
[robot]         name, notes (where the robot comes from), elements (the twin's switched-on
                effects), dt (the twin's plant integration step)
[body]          the real robot, the plant: masses, the body's three principal inertias about
                its centre of mass, the wheels, damping (Table 6.1)
[design]        the nominal model the controllers and observers are designed on (Table 6.2)
[motor]         the motors' data sheet (Table 2.1)
[drive]         gearbox ratio and efficiency, battery, H-bridge PWM driver
[gearbox]       Coulomb and viscous friction, backlash
[firmware]      what the board believes and does: sample period, computation delay, torque
                gain, back-EMF compensation, power-on gyro zeroing
[firmware.fusion]  the pitch estimate's filter
[imu]           accelerometer and gyro noise, offsets, drift, mounting height
[encoder]       counts per motor turn
[payload]       the Chapter 6 Case 2/3 pan
[stick]         the Case 3 stick
[prior]         the unknowns' ranges: ``"drive.gear_ratio" = { low = .., high = .., unit = ..,
                source = .., scale = "linear" | "log" }``
[provenance]    sources that replace the built-in ones: ``"drive.gear_ratio" = "fitted: ..."``
==============  =============================================================================
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FieldInfo", "TABLES", "BODY_TO_PARAMS", "info", "STATUS_WORDS"]

STATUS_WORDS = ("known", "assumed", "unknown")


@dataclass(frozen=True)
class FieldInfo:
    """One field of a table: ``unit`` (SI; ``""`` dimensionless), ``status`` (one of
    :data:`STATUS_WORDS`; an unknown's is set by the prior), ``source`` and, for the body,
    the ``plausible`` size of the value for a robot of this class (a value outside it is a
    unit mistake: the file is SI)."""

    unit: str
    status: str
    source: str
    plausible: tuple[float, float] | None = None


_T61 = "Table 6.1 (= Table 3.1)"
_T62 = "Table 6.2 (= Table 3.2)"
_DAMP = "the table's N s/m at the rim read as D r^2 (SPEC.md section 2, 'units')"

#: The body's fields in the file (physical names) and the book's symbols they set in
#: :class:`mwip.params.Params`.
BODY_TO_PARAMS: dict[str, str] = {
    "mb": "mb", "mw": "mw", "Ixx": "Ibz", "Iyy": "Iby", "Izz": "Iyaw", "Iwa": "Iwa",
    "Iwd": "Iwd", "l": "l", "b": "b", "r": "r", "Db": "Db", "Dw": "Dw", "g": "g",
}  # fmt: skip


def _body(table: str) -> dict[str, FieldInfo]:
    t = _T61 if table == "body" else _T62
    return {
        "mb": FieldInfo("kg", "known", f"body mass, {t}", (0.01, 500.0)),
        "mw": FieldInfo("kg", "known", f"mass of one wheel, {t}", (0.001, 100.0)),
        "Ixx": FieldInfo("kg m^2", "known", f"body's roll inertia about its forward axis "
                         f"through its centre of mass; {t}'s Ibz, which (2.32) multiplies with "
                         "sin^2 theta (docs/models.md)", (1e-7, 100.0)),
        "Iyy": FieldInfo("kg m^2", "known", f"body's pitch inertia about the axle-parallel axis "
                         f"through its centre of mass (not the axle); {t}'s Iby", (1e-7, 100.0)),
        "Izz": FieldInfo("kg m^2", "known", "body's yaw inertia about its own vertical axis "
                         "through its centre of mass; 0 in the book's (2.32), which has none "
                         "(docs/models.md)", (0.0, 100.0)),
        "Iwa": FieldInfo("kg m^2", "known", f"wheel inertia about the axle, {t}", (1e-8, 10.0)),
        "Iwd": FieldInfo("kg m^2", "known", f"wheel inertia about a diameter, {t}",
                         (0.0, 10.0)),
        "l": FieldInfo("m", "known", f"axle to the body's centre of mass, {t}", (0.005, 2.0)),
        "b": FieldInfo("m", "known", f"half the distance between the wheels, {t}",
                       (0.01, 2.0)),
        "r": FieldInfo("m", "known", f"wheel radius, {t}", (0.005, 1.0)),
        "Db": FieldInfo("N m s/rad", "known", f"body-wheel rotational damping; {_DAMP}",
                        (0.0, 10.0)),
        "Dw": FieldInfo("N m s/rad", "known", f"wheel-ground rotational damping; {_DAMP}",
                        (0.0, 10.0)),
        "g": FieldInfo("m/s^2", "known", "gravity (SPEC.md section 2)", (9.7, 9.9)),
    }  # fmt: skip


_DS = "known"
TABLES: dict[str, dict[str, FieldInfo]] = {
    "robot": {
        "name": FieldInfo("", "known", "the robot's name"),
        "notes": FieldInfo("", "known", "where this robot comes from"),
        "elements": FieldInfo("", "known", "the twin's switched-on physical effects "
                              "(mwip.hardware.elements; all by default)"),
        "dt": FieldInfo("s", "assumed", "the twin's plant integration step (docs/engine.md); "
                        "divides firmware.Ts"),
    },
    "body": _body("body"),
    "design": _body("design"),
    "motor": {
        "rated_power": FieldInfo("W", _DS, "Table 2.1"),
        "rated_voltage": FieldInfo("V", _DS, "Table 2.1"),
        "rated_speed_rpm": FieldInfo("rpm", _DS, "Table 2.1"),
        "no_load_speed_rpm": FieldInfo("rpm", _DS, "Table 2.1; gives k_e = V / omega_0"),
        "stall_torque": FieldInfo("N m", _DS, "Table 2.1 (mN m, SPEC.md section 3); gives "
                                  "R = k_t V / tau_s"),
        "continuous_torque": FieldInfo("N m", _DS, "Table 2.1"),
        "max_efficiency": FieldInfo("", _DS, "Table 2.1; gives the no-load current "
                                    "(gearbox.coulomb)"),
        "rotor_inertia": FieldInfo("kg m^2", _DS, "Table 2.1 (10.8 g cm^2)"),
        "inductance": FieldInfo("H", _DS, "MAXON catalogue RE25 24 V (Table 2.1 has none)"),
        "torque_constant": FieldInfo("N m/A", "known", "0: V / no-load speed (23.97e-3)"),
        "terminal_resistance": FieldInfo("Ohm", "known", "0: k_t V / stall torque (2.368)"),
    },
    "drive": {
        "gear_ratio": FieldInfo("", "assumed", "MAXON GP 32 A 23:1 (the book names no "
                                "gearbox; docs/twin.md)"),
        "gear_efficiency": FieldInfo("", "assumed", "MAXON GP 32 A catalogue, 2 stages (75 %)"),
        "supply_voltage": FieldInfo("V", "known", "battery, Sec. 2.5"),
        "current_limit": FieldInfo("A", "assumed", "driver limit, 4x the RE25's continuous "
                                   "current"),
        "pwm_levels": FieldInfo("", "assumed", "duty steps (0: not quantised); LM3S2965 PWM "
                                "counter at ~20 kHz"),
        "mode": FieldInfo("", "known", "'voltage': PWM duty from the control signal "
                          "(Sec. 6.1), or 'torque' (a current-mode driver)"),
        "deadband": FieldInfo("duty", "assumed", "0.5 us dead time / minimum pulse at 20 kHz"),
        "supply_resistance": FieldInfo("Ohm", "assumed", "battery + wiring resistance "
                                       "(voltage sag)"),
    },
    "gearbox": {
        "coulomb": FieldInfo("N m", "assumed", "per wheel; N k_t I_0, I_0 from Table 2.1's "
                             "85 % efficiency"),
        "viscous": FieldInfo("N m s/rad", "assumed", "per wheel, beyond the book's Db"),
        "backlash": FieldInfo("rad", "assumed", "at the wheel; MAXON GP 32 A catalogue "
                              "(0.7 deg)"),
    },
    "firmware": {
        "Ts": FieldInfo("s", "known", "sampling period, Sec. 6.1 (5 ms)"),
        "delay": FieldInfo("Ts", "assumed", "fraction of Ts; 1 ms of computation on the "
                           "50 MHz Cortex-M3 (no FPU); `mwip export c --pil` measures a law's"),
        "torque_gain": FieldInfo("", "assumed", "delivered / commanded torque: 1 = the "
                                 "firmware's torque-to-duty constants are the drive's"),
        "emf_compensation": FieldInfo("", "assumed", "fraction of k_e omega_m the firmware "
                                      "adds: 0 open-loop PWM (Sec. 6.1's words), 1 full "
                                      "feed-forward"),
        "gyro_zeroing": FieldInfo("", "assumed", "the gyro averaged at rest at power-on and "
                                  "subtracted (the book does not say)"),
    },
    "firmware.fusion": {
        "kind": FieldInfo("", "known", "'complementary' or 'kalman' (Sec. 2.5.1 names both)"),
        "tau": FieldInfo("s", "assumed", "complementary time constant"),
        "q_angle": FieldInfo("rad^2/s", "assumed", "Kalman process noise of the angle"),
        "q_bias": FieldInfo("rad^2/s^3", "assumed", "Kalman process noise of the gyro offset"),
        "r_angle": FieldInfo("rad^2", "assumed", "Kalman variance of the accelerometer tilt"),
    },
    "imu": {
        "accel_sigma": FieldInfo("m/s^2", "assumed", "per sample; MEMS class (docs/twin.md); "
                                 "the book names no part"),
        "accel_bias": FieldInfo("m/s^2", "assumed", "2 mg residual offset"),
        "gyro_sigma": FieldInfo("rad/s", "assumed", "per sample; MEMS class"),
        "gyro_bias": FieldInfo("rad/s", "assumed", "uncalibrated zero-rate offset ('zero "
                               "drift', Sec. 2.5.1)"),
        "gyro_bias_walk": FieldInfo("rad/s/sqrt(s)", "assumed", "thermal drift"),
        "height": FieldInfo("m", "assumed", "accelerometer above the axle"),
    },
    "encoder": {
        "cpr": FieldInfo("", "known", "counts per motor turn; HEDS-5540 code C = 100 lines, "
                         "x4 quadrature (Fig. 2.6)"),
    },
    "payload": {
        "mass": FieldInfo("kg", "known", "Sec. 6.2.2 (0.5 kg)"),
        "height": FieldInfo("m", "assumed", "pan centre above the body's top (2l)"),
        "radius": FieldInfo("m", "assumed", "pan radius (a thin disc)"),
    },
    "stick": {
        "height": FieldInfo("m", "assumed", "Case 3 stick ('a small stick', below r)"),
    },
}  # fmt: skip


def info(path: str) -> FieldInfo | None:
    """The :class:`FieldInfo` of a dotted path (``"drive.gear_ratio"``,
    ``"firmware.fusion.tau"``), or ``None``."""
    table, _, key = path.rpartition(".")
    return TABLES.get(table, {}).get(key)
