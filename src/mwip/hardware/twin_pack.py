"""Packing the digital twin's sensor and drive for the compiled twin loop
(:mod:`mwip.sim.twin_loop`): per-robot parameter and state vectors read from the Python
:class:`~mwip.hardware.twin.TwinSensor` and :class:`~mwip.hardware.twin.TwinActuator` after
the engine's first measurement, with the constants NumPy computes once (``exp(-Ts/tau_e)``,
``tau/(tau+Ts)``, ``sqrt(Ts)``, the encoder resolution) computed by the same NumPy
expressions, and the IMU's normal variates drawn ahead from the sensor's own generator in the
order the Python sensor draws them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.sim import twin_loop as tl

__all__ = ["prepare", "TwinRun"]


# ---------------------------------------------------------------------------------------------
def _rows(x: Any, n: int) -> NDArray[np.float64]:
    """A float, an (N,) or an (N, 1) per-row value as (n,) floats."""
    return np.broadcast_to(np.asarray(x, dtype=float).reshape(-1), (n,)).astype(float)


def _pack_sensor(sensor: Any, n: int) -> tuple[NDArray, NDArray, NDArray]:
    from mwip.hardware.imu import G

    tw = sensor.twin
    Ts = tw.Ts
    imu = sensor.imu
    on = {e: _rows(sensor._on(e, n), n) for e in
          ("imu_noise", "imu_bias", "accel_motion", "fusion", "encoder")}  # fmt: skip
    tau = sensor.filter.tau
    a = tau / (tau + Ts)  # complementary_step, the same NumPy expression
    res = tw.encoder.resolution if sensor._res is None else sensor._res
    SP = np.zeros((n, tl.N_SP))
    SP[:, tl.S_TS] = Ts
    SP[:, tl.S_R] = _rows(sensor.r, n)
    SP[:, tl.S_BOR] = _rows(sensor.b_over_r, n)
    SP[:, tl.S_GBW] = imu.noise.gyro_bias_walk * np.sqrt(Ts)
    SP[:, tl.S_ON_N] = on["imu_noise"]
    SP[:, tl.S_ON_B] = on["imu_bias"]
    SP[:, tl.S_ON_M] = on["accel_motion"]
    SP[:, tl.S_ASIG] = _rows(imu.accel_sigma, n)
    SP[:, tl.S_ABIAS] = _rows(imu.accel_bias, n)
    SP[:, tl.S_GSIG] = _rows(imu.gyro_sigma, n)
    SP[:, tl.S_HEIGHT] = _rows(imu.height, n)
    SP[:, tl.S_FUSION] = on["fusion"]
    SP[:, tl.S_A] = _rows(a, n)
    SP[:, tl.S_1MA] = _rows(1.0 - a, n)
    SP[:, tl.S_ENC] = on["encoder"]
    SP[:, tl.S_RES] = _rows(res, n)
    SP[:, tl.S_ANY] = float(sensor.any)
    SP[:, tl.S_G] = G
    SS = np.zeros((n, tl.N_SS))
    C0 = np.zeros((n, 2), dtype=np.int64)
    if sensor.any:
        SS[:, tl.SS_PREV : tl.SS_PREV + 8] = sensor._prev
        SS[:, tl.SS_X0] = sensor.filter.x[:, 0]
        SS[:, tl.SS_BIAS] = sensor.imu.bias
        SS[:, tl.SS_TH0] = sensor._theta0
        SS[:, tl.SS_REL : tl.SS_REL + 2] = sensor._rel_prev
        SS[:, tl.SS_ORIG : tl.SS_ORIG + 4] = sensor._origin
        SS[:, tl.SS_POS : tl.SS_POS + 2] = sensor._pos
        C0[:] = sensor._c0
    return SP, SS, C0


def _pack_drive(act: Any, n: int) -> tuple[NDArray, NDArray]:
    tw = act.twin
    drv = act.drive
    m, d = drv.motor, drv.drive
    R = m.resistance
    gr = drv.gear_ratio
    c = drv.compensation
    DP = np.zeros((n, tl.N_DP))
    DP[:, tl.D_ANY] = float(act.any)
    DP[:, tl.D_DELAY] = _rows(act.delay * act._rows("delay", n), n)
    DP[:, tl.D_MOTOR_ANY] = float(act._rows("motor", n).any())
    DP[:, tl.D_MOTOR] = _rows(act._rows("motor", n), n)
    DP[:, tl.D_R] = R
    DP[:, tl.D_GAIN] = _rows(np.asarray(gr, dtype=float) * d.gear_efficiency * m.k_t, n)
    DP[:, tl.D_GR] = _rows(gr, n)
    DP[:, tl.D_BOR] = _rows(drv.b_over_r, n)
    DP[:, tl.D_KE] = m.k_e
    if np.ndim(c) == 0:
        DP[:, tl.D_CMODE] = 0.0 if c == 1.0 else (1.0 if c == 0.0 else 2.0)
    else:
        DP[:, tl.D_CMODE] = 2.0
    DP[:, tl.D_C] = _rows(c, n)
    DP[:, tl.D_VNOM] = d.supply_voltage
    DP[:, tl.D_LEVELS] = float(d.pwm_levels)
    DP[:, tl.D_DEADBAND] = _rows(drv.deadband, n)
    DP[:, tl.D_PWM] = _rows(np.broadcast_to(drv.pwm, (n,)), n)
    DP[:, tl.D_SAG] = _rows(np.broadcast_to(drv.sag, (n,)), n)
    DP[:, tl.D_RS] = d.supply_resistance
    DP[:, tl.D_BAND] = _rows(R * np.asarray(drv.current_limit, dtype=float), n)
    DP[:, tl.D_EXP] = np.exp(-drv.Ts / m.tau_e)  # current_step's NumPy exp
    DP[:, tl.D_TAU_TS] = m.tau_e / drv.Ts
    DP[:, tl.D_EMF_PLANT] = float(drv.emf_in_plant and d.mode == "voltage")
    DP[:, tl.D_FRIC_ANY] = float(act._rows("friction", n).any())
    DP[:, tl.D_FC] = _rows(act.coulomb * act._rows("friction", n), n)
    DP[:, tl.D_MOB] = _rows(np.broadcast_to(act.mobility, (n,)), n)
    DP[:, tl.D_TS] = tw.Ts
    DP[:, tl.D_BL_ANY] = float(act._rows("backlash", n).any())
    bl = act.backlash
    DP[:, tl.D_HALF] = _rows(np.broadcast_to(bl.width, (n,)) / 2.0, n)
    DP[:, tl.D_INERTIA] = _rows(bl.inertia, n)
    DP[:, tl.D_BL_TS] = bl.Ts
    DS = np.zeros((n, tl.N_DS))
    if act.any:
        DS[:, tl.DS_UPREV : tl.DS_UPREV + 2] = act.u_prev
        DS[:, tl.DS_I : tl.DS_I + 2] = drv.i
        DS[:, tl.DS_IBAT] = drv.i_bat
        if bl.g.shape != (n, 2):
            bl.reset(n)
        DS[:, tl.DS_G : tl.DS_G + 2] = bl.g
        DS[:, tl.DS_V : tl.DS_V + 2] = bl.v
    return DP, DS


def prepare(sensor: Any, actuator: Any, n: int, n_samples: int) -> TwinRun | None:
    """The compiled run of ``sensor`` (a :class:`~mwip.hardware.twin.TwinSensor`, already
    reset and called once at ``t = 0``) and ``actuator`` (a
    :class:`~mwip.hardware.twin.TwinActuator`, reset, not yet called) for ``n`` robots, or
    ``None`` where the Python loop stays (a Kalman fusion filter, a noise generator that is
    not NumPy's). Nothing is drawn until :meth:`TwinRun.__call__`."""
    if sensor.twin.fusion.kind != "complementary":
        return None
    if sensor.any and not isinstance(sensor.imu._rng, np.random.Generator):
        return None
    if actuator.u_prev.shape != (n, 2) or actuator.drive.i.shape != (n, 2):
        return None
    return TwinRun(sensor, actuator, n, n_samples)


class TwinRun:
    """A prepared compiled twin run (:func:`prepare`): called by the engine with the packed law,
    the disturbance by chunks of samples and the run's arrays, it fills them and returns the
    extra log ``u_applied``, and ``y_meas`` (the measurement the law read) when the sensor's
    ``record_measurement`` is set."""

    def __init__(self, sensor: Any, actuator: Any, n: int, n_samples: int) -> None:
        self.sensor, self.actuator, self.n, self.n_samples = sensor, actuator, n, n_samples

    def function(self) -> Any:
        """The compiled loop this run calls: threaded for batches of ``PARALLEL_MIN`` or more."""
        from mwip.sim.codes import PARALLEL_MIN

        return tl.run_parallel if self.n >= PARALLEL_MIN else tl.run

    def __call__(self, first: NDArray[np.float64], y: NDArray[np.float64], coef: NDArray,
                 tau: Callable[[int, int], NDArray], column: NDArray[np.int64], method: int,
                 dt: float, n_sub: int,
                 Ts: float, rec_idx: NDArray[np.int64], code: int, P: NDArray, X: NDArray,
                 states: NDArray, us: NDArray, log_arr: NDArray, status: NDArray,
                 t_end: NDArray) -> dict[str, NDArray[np.float64]]:  # fmt: skip
        n, n_samples = self.n, self.n_samples
        sensor = self.sensor
        SP, SS, C0 = _pack_sensor(sensor, n)
        DP, DS = _pack_drive(self.actuator, n)
        m = 1 if sensor.imu.common else n
        per_sample = tau(0, 1).size + (4 * m if sensor.any else 0)
        chunk = max(16, tl.CHUNK_NUMBERS // per_sample)
        measured = bool(getattr(sensor, "record_measurement", False))
        u_app = np.full((n, rec_idx.size, 10 if measured else 2), np.nan)
        M0 = np.ascontiguousarray(first, dtype=float)
        RUN = np.zeros((n, 3), dtype=np.int64)  # next record row, left, disturbance column
        RUN[:, 2] = column
        fn = self.function()
        no_noise = np.zeros((1, 4, 1))
        for k0 in range(0, n_samples + 1, chunk):
            k1 = min(k0 + chunk, n_samples + 1)
            tk = tau(k0, min(k1, n_samples)) if k0 < n_samples else tau(0, 1)
            z = k1 - max(k0, 1)
            # the Python sensor's draws for samples max(k0, 1) .. k1 - 1, in its order
            Z = (np.ascontiguousarray(sensor.imu._rng.standard_normal((z, 4, m)))
                 if sensor.any and z > 0 else no_noise)  # fmt: skip
            fn(y, coef, tk, method, dt, n_sub, n_samples, Ts, rec_idx, np.int64(code), P, X,
               M0, Z, SP, SS, C0, DP, DS, states, us, log_arr, u_app, status, t_end,
               np.int64(k0), np.int64(k1), RUN)  # fmt: skip
            if bool(RUN[:, 1].all()):
                break
        if measured:  # the log run_on_twin's wrapper keeps in the Python loop
            return {"u_applied": u_app[:, :, :2].copy(), "y_meas": u_app[:, :, 2:].copy()}
        return {"u_applied": u_app}
