"""The Chapter 6 runs of the book's robot, for a batch of twins (one twin per row).

Every experiment of Sec. 6.2 that the studies ``exp-hodosmc-*``, ``exp-asta`` and ``exp-it2``
emulate, with the studies' own controllers, settings and cases (their study files), run as one
batched :func:`mwip.hardware.twin.run_on_twin` call per run over ``N`` twins that differ in the
unknowns of the twin's prior (``values``: name -> (N,) array, :mod:`mwip.hardware.prior`):

========================================  ==========================================  =======
run                                       what                                         book
========================================  ==========================================  =======
``exp-hodosmc-balance/{k}.case{1,2}``     SMC, DO1SMC, DO4SMC, ``q1d' = 0``              T. 6.4
``exp-hodosmc-speed/{k}.case{1,2}``       the same at ``q1d' = -7 rad/s``                T. 6.5
``exp-hodosmc-obstacle/{k}.case3``        payload + stick at 6 s, ``-7 rad/s``           T. 6.6
``exp-asta/{k}.case{1,2}``                ASMC, ASTA (6.1)-(6.2)                         T. 6.7-8
``exp-it2/{k}.exp{1,2,3}``                IT2, T1 (Fig. 5.3), balance/position/heading   F. 6.17-19
========================================  ==========================================  =======

The book's numbers are what the robot's board recorded, so the metrics are computed from the
twin's measured signals ``y_meas`` (the fused pitch estimate, the encoder wheel speed, the
odometry), each with the study's window: ``rms_theta`` and ``rms_speed_err`` (6.3),
``final_speed`` (mean ``psi'`` over the last 2 s), ``settling_time`` (Table 6.6's band),
``rms_s1`` (ASTA/ASMC: the sliding variable the controller computed), ``osc_amp``,
``final_abs_theta``, ``final_pos_err``, ``final_alpha_err`` (IT2/T1, as
:func:`mwip.studies.exp_it2.run_metrics` but measured). ``stands`` is 1 where the run stayed
up for its whole duration, ``t_end`` when it stopped.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.hardware.twin import Twin, run_on_twin
from mwip.params import Params
from mwip.sim.result import SimResult

__all__ = ["Run", "RUNS", "run_names", "PUBLISHED", "run_batch"]

HODO = ("smc", "do1smc", "do4smc")
ASTA = ("asmc", "asta")
FUZZY = ("it2", "t1")
TRACK_WINDOW = 2.0


@dataclass(frozen=True)
class Run:
    """One Chapter 6 run: ``study`` (its settings), controller ``kind``, ``case`` (1, 2, 3)
    and, for the fuzzy experiments, experiment ``exp``."""

    study: str
    kind: str
    case: int
    exp: int = 0

    @property
    def name(self) -> str:
        tail = f"exp{self.exp}" if self.exp else f"case{self.case}"
        return f"{self.study}/{self.kind}.{tail}"


def _runs() -> tuple[Run, ...]:
    out: list[Run] = []
    for study in ("exp-hodosmc-balance", "exp-hodosmc-speed"):
        out += [Run(study, k, c) for c in (1, 2) for k in HODO]
    out += [Run("exp-hodosmc-obstacle", k, 3) for k in HODO]
    out += [Run("exp-asta", k, c) for c in (1, 2) for k in ASTA]
    out += [Run("exp-it2", k, 1, e) for e in (1, 2, 3) for k in FUZZY]
    return tuple(out)


#: Every Chapter 6 run, in a fixed order.
RUNS: tuple[Run, ...] = _runs()


def run_names() -> list[str]:
    """The names of :data:`RUNS`."""
    return [r.name for r in RUNS]


def _published() -> dict[str, float]:
    from mwip.studies import exp_asta, exp_hodosmc

    out: dict[str, float] = {}
    for study, table in (("exp-hodosmc-balance", exp_hodosmc.PUBLISHED_BALANCE),
                         ("exp-hodosmc-speed", exp_hodosmc.PUBLISHED_SPEED),
                         ("exp-asta", exp_asta.PUBLISHED)):  # fmt: skip
        out.update({f"{study}/{k}": v for k, v in table.items()})
    for k, v in exp_hodosmc.PUBLISHED_OBSTACLE.items():
        kind, q = k.split(".")
        out[f"exp-hodosmc-obstacle/{kind}.case3.{q}"] = v
    return out


#: The book's numbers of Tables 6.4-6.8, keyed ``<run name>.<metric>``.
PUBLISHED: dict[str, float] = _published()


def _cfg(study: str, twin: Twin) -> dict[str, Any]:
    from mwip.studies.twin_settings import study_settings

    return study_settings(study, None, twin)[0]


def _controller(run: Run, cfg: Mapping[str, Any], nominal: Params) -> Any:
    if run.study.startswith("exp-hodosmc"):
        from mwip.laws.smc.controller import SMCDesignWarning
        from mwip.studies.exp_hodosmc import make_controller

        q1d = 0.0 if run.study == "exp-hodosmc-balance" else float(cfg["speed"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SMCDesignWarning)
            return make_controller(run.kind, cfg, q1d, nominal)
    if run.study == "exp-asta":
        from mwip.studies.exp_asta import make_controller as make_asta

        return make_asta(run.kind, cfg, nominal)
    from mwip.laws.fig53.controller import Fig53Controller
    from mwip.studies.exp_it2 import design, targets

    p_d, alpha_d = targets(cfg)[run.exp]
    return Fig53Controller([design(cfg, nominal)], [run.kind], [p_d], [alpha_d],
                           params=nominal, Ts=cfg["Ts"])  # fmt: skip


def _window_mask(t: NDArray[np.float64], window: tuple[float, float]) -> NDArray[np.bool_]:
    return (t >= window[0] - 1e-12) & (t <= window[1] + 1e-12)


def _rms_rows(t: NDArray[np.float64], x: NDArray[np.float64],
              window: tuple[float, float]) -> NDArray[np.float64]:  # fmt: skip
    """(6.3) per row of ``x`` (N, K) over ``window``."""
    m = _window_mask(t, window)
    return np.sqrt(np.mean(x[:, m] ** 2, axis=1))


def _settling_rows(t: NDArray[np.float64], psi_dot: NDArray[np.float64], start: float,
                   band: tuple[float, float]) -> NDArray[np.float64]:  # fmt: skip
    from mwip.studies.exp_hodosmc import obstacle_settling_time

    return np.array([obstacle_settling_time(t, row, start, band) for row in psi_dot])


def _metrics(
    run: Run, res: SimResult, cfg: Mapping[str, Any], nominal: Params
) -> dict[str, NDArray]:
    """Per-row metrics of one batched run (measured signals; ``nan`` where a row fell)."""
    t = res.t
    ok = res.status == "ok"
    y = res.series()["y_meas"]  # (N, K, 8): psi, theta, alpha, psi', theta', alpha', x, y
    th, speed = y[:, :, 1], y[:, :, 3]
    nan = np.full(ok.shape, np.nan)
    out: dict[str, NDArray] = {"stands": ok.astype(float), "t_end": np.asarray(res.t_end, float)}

    def keep(v: NDArray) -> NDArray:
        return np.where(ok, v, nan)

    if run.study in ("exp-hodosmc-balance", "exp-hodosmc-speed"):
        q1d = 0.0 if run.study == "exp-hodosmc-balance" else float(cfg["speed"])
        window = (float(cfg["rms_window"][0]), float(cfg["rms_window"][1]))
        last = t >= t[-1] - TRACK_WINDOW - 1e-9
        out["rms_theta"] = keep(_rms_rows(t, np.nan_to_num(th), window))
        out["rms_speed_err"] = keep(_rms_rows(t, np.nan_to_num(speed - q1d), window))
        out["final_speed"] = keep(np.mean(np.nan_to_num(speed[:, last]), axis=1))
    elif run.study == "exp-hodosmc-obstacle":
        from mwip.studies.exp_hodosmc import BAND

        start = float(cfg["stick_start"])
        out["settling_time"] = keep(_settling_rows(t, np.nan_to_num(speed), start, BAND))
        out["rms_speed_err"] = keep(_rms_rows(t, np.nan_to_num(speed - float(cfg["speed"])),
                                              (float(cfg["rms_start"]), start)))  # fmt: skip
    elif run.study == "exp-asta":
        window = (float(cfg["rms_window"][0]), float(cfg["rms_window"][1]))
        s1 = res.series()["sigma"][:, :, 0]
        out["rms_theta"] = keep(_rms_rows(t, np.nan_to_num(th), window))
        out["rms_s1"] = keep(_rms_rows(t, np.nan_to_num(s1), window))
    else:
        from mwip.studies.exp_it2 import OSC_WINDOW, targets

        p_d, alpha_d = targets(cfg)[run.exp]
        tail = t >= t[-1] - OSC_WINDOW - 1e-9
        thn = np.nan_to_num(th)
        out["osc_amp"] = keep(np.ptp(thn[:, tail], axis=1))
        out["final_abs_theta"] = keep(np.abs(thn[:, -1]))
        if p_d is not None:
            p = float(nominal.r) * np.nan_to_num(y[:, -1, 0])
            out["final_pos_err"] = keep(np.abs(p - p_d))
        if alpha_d is not None:
            out["final_alpha_err"] = keep(np.abs(np.nan_to_num(y[:, -1, 2]) - alpha_d))
    return out


def run_batch(
    values: Mapping[str, NDArray[np.float64]],
    *,
    twin: Twin | None = None,
    runs: tuple[Run, ...] = RUNS,
    plant: Params | None = None,
    nominal: Params | None = None,
    duration: float | None = None,
    progress: Callable[[str], None] | None = None,
    drive_logs: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Every run of ``runs`` on the batch of twins ``values`` (name -> (N,) array of the
    prior's unknowns, the rest from ``twin``, default the default twin), on the robot ``plant``
    (default Table 6.1) with designs on ``nominal`` (default Table 6.2). ``duration``
    overrides the studies' durations (a smoke test; windows are clipped to it). The runs need
    only the measured signals, so they run in the compiled twin loop (``drive_logs=False``
    of :func:`mwip.hardware.twin.run_on_twin`; ``True``: the Python loop, equal to round-off).
    Returns columns ``<run name>.<metric>`` of (N,) arrays."""
    from mwip.studies.registry import robot as book_robot

    tw = Twin() if twin is None else twin
    base, nom = book_robot(plant, nominal)
    n = len(next(iter(values.values()))) if values else 1
    cols: dict[str, NDArray[np.float64]] = {}
    for run in runs:
        cfg = dict(_cfg(run.study, tw))
        if duration is not None:
            cfg["duration"] = min(float(cfg["duration"]), duration)
            if "rms_window" in cfg:
                lo, hi = cfg["rms_window"]
                cfg["rms_window"] = [min(lo, cfg["duration"] / 2), min(hi, cfg["duration"])]
            if "stick_start" in cfg:
                cfg["stick_start"] = min(float(cfg["stick_start"]), cfg["duration"] * 0.6)
                cfg["rms_start"] = min(float(cfg["rms_start"]), cfg["stick_start"] / 2)
        ctrl = _controller(run, cfg, nom)
        case = run.case
        kw: dict[str, Any] = {}
        if case == 3:
            kw.update(stick_speed=cfg["stick_speed"], stick_start=cfg["stick_start"])
            if "stick.height" not in values:
                kw["stick_height"] = cfg["stick_height"]
        q0 = np.tile([0.0, float(cfg["theta0"]), 0.0], (n, 1))
        res = run_on_twin(
            ctrl, case, twin=tw, base=base, values=values, q0=q0, duration=float(cfg["duration"]),
            record_every=int(cfg["record_every"]), seed=int(cfg["seed"]),
            drive_logs=drive_logs, **kw,
        )  # fmt: skip
        for k, v in _metrics(run, res, cfg, nom).items():
            cols[f"{run.name}.{k}"] = np.asarray(v, dtype=float)
        if progress is not None:
            progress(run.name)
    return cols
