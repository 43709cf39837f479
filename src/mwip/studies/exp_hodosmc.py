"""Experiments ``exp-hodosmc-{balance,speed,obstacle}`` (Sec. 6.2.1) emulated on the twin.

Set-up (SPEC.md section 5): the digital twin (:mod:`mwip.hardware.twin`: IMU complementary
fusion, encoders, RE25 motors through 23:1 gearboxes and the PWM driver, 5 ms sampling, plant
step 0.5 ms); controllers designed on the nominal parameters (Table 6.2) with Table 6.3's
gains: all ``lambda = (3, 0.01, 0.1, 3)``, ``gamma = 1``; SMC ``K = (25, 21)``, DO1SMC
``K = (17.3, 14)`` (first-order DO, ``L = 50 I3``: the book prints none), DO4SMC
``K = (6.3, 4)`` (4th-order DO with the Sec. 3.6.1 gains); saturation switching with boundary
layer ``phi = 0.05`` (the book used saturation on the robot and prints no width).
``theta0 = pi/18``, 10 s, records every 10 ms, RMS (6.3) over 2-10 s.

- balance (Table 6.4): ``q1d' = 0``, Cases 1 and 2;
- speed (Table 6.5): ``q1d' = -7 rad/s``, Cases 1 and 2;
- obstacle (Table 6.6): ``q1d' = -7 rad/s``, Case 3 (payload + stick at 6 s); settling time
  after the stick until ``psi'`` stays in (-9, -5) rad/s.

Runs whose plant falls get ``null`` metrics (status in ``runs``). Extra runs, keys prefixed
``ideal.``: the same on the twin with ideal sensors and actuator (what the hardware adds);
``alt.``: the same experiments under the *alternative damping reading* (the tables' Db, Dw as
linear damping in N s/m, i.e. rotational ``D r^2``, in both the plant and the controllers'
nominal model), under which the -7 rad/s target is reachable (docs/twin.md). The obstacle
study also runs ``case1_stick`` (the stick without the payload) in both readings.

Settings (``scenarios/exp-hodosmc-{balance,speed,obstacle}.toml``, one file per study,
:mod:`mwip.studies.settings`): ``theta0``, ``speed``, ``lambdas``, ``smc_K``, ``do1smc_K``,
``do4smc_K``, ``do1_gain``, ``phi``, ``duration``, ``Ts``, ``record_every``, ``seed``; balance
and speed also ``rms_window``; obstacle also ``rms_start``, ``stick_start``, ``stick_speed``.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.control.smc import SMCDesignWarning, make_smc
from mwip.control.switching import Switching
from mwip.hardware.twin import Twin, case_plant, run_on_twin
from mwip.metrics import rms, total_variation_rate
from mwip.params import Params
from mwip.sim import SimResult
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, save_figure, write_metrics

SOURCE_BALANCE = "Sec. 6.2.1, Figs. 6.4-6.5, Table 6.4"
SOURCE_SPEED = "Sec. 6.2.1, Figs. 6.6-6.7, Table 6.5"
SOURCE_OBSTACLE = "Sec. 6.2.1, Fig. 6.8, Table 6.6"

NAME_BALANCE = "exp-hodosmc-balance"
NAME_SPEED = "exp-hodosmc-speed"
NAME_OBSTACLE = "exp-hodosmc-obstacle"

KINDS = ("smc", "do1smc", "do4smc")
#: Table 6.3's dbar and gamma (printed, not used: the gains K are given directly, settings)
DBAR_PRINTED = {"smc": 20.0, "do1smc": 13.0, "do4smc": 3.0}
GAMMA_PRINTED = (1.0, 1.0)
#: Table 6.6's steady-state band of ``psi'`` (rad/s) for the obstacle settling time
BAND = (-9.0, -5.0)

PUBLISHED_BALANCE = {
    "smc.case1.rms_theta": 0.0216, "smc.case2.rms_theta": 0.0257,
    "do1smc.case1.rms_theta": 0.0156, "do1smc.case2.rms_theta": 0.0158,
    "do4smc.case1.rms_theta": 0.0055, "do4smc.case2.rms_theta": 0.0079,
    "smc.case1.rms_speed_err": 1.3240, "smc.case2.rms_speed_err": 1.8414,
    "do1smc.case1.rms_speed_err": 0.8442, "do1smc.case2.rms_speed_err": 0.9886,
    "do4smc.case1.rms_speed_err": 0.5113, "do4smc.case2.rms_speed_err": 0.6157,
}  # fmt: skip
PUBLISHED_SPEED = {
    "smc.case1.rms_speed_err": 1.4640, "smc.case2.rms_speed_err": 1.6085,
    "do1smc.case1.rms_speed_err": 0.9974, "do1smc.case2.rms_speed_err": 1.2081,
    "do4smc.case1.rms_speed_err": 0.7353, "do4smc.case2.rms_speed_err": 0.9144,
}  # fmt: skip
PUBLISHED_OBSTACLE = {
    "smc.settling_time": 1.74,
    "do1smc.settling_time": 0.86,
    "do4smc.settling_time": 0.19,
}


def alt_damping(p: Params) -> Params:
    """Alternative reading (extra runs only): Db, Dw in N s/m, rotational ``D r^2``."""
    return replace(p, Db=p.Db * p.r**2, Dw=p.Dw * p.r**2)


def make_controller(
    kind: str, cfg: Mapping[str, Any], q1d_dot: float = 0.0, params: Params | None = None
) -> Any:
    """Table 6.3's controller ``kind`` (smc, do1smc, do4smc) with saturation, gains from the
    calling study's settings ``cfg`` (``lambdas``, ``{kind}_K``, ``do1_gain``, ``phi``,
    ``Ts``), designed on ``params`` (default: the robot's nominal model,
    :func:`mwip.studies.robot.nominal`)."""
    if params is None:
        params = robot.nominal()
    obs = [cfg["do1_gain"]] if kind == "do1smc" else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SMCDesignWarning)
        return make_smc(kind, tuple(cfg["lambdas"]), K=tuple(cfg[f"{kind}_K"]),
                        observer_gains=obs, params=params, Ts=cfg["Ts"],
                        switching=Switching("sat", cfg["phi"]), q1d_dot=q1d_dot)  # fmt: skip


def _plant(case: int, reading: str) -> Params:
    p = case_plant(case, base=robot.plant())
    return alt_damping(p) if reading == "alt" else p


#: reading -> (key prefix, claim label). "spec": SPEC damping on the twin (the study's keys);
#: "ideal": the same plant with ideal sensors and actuator (separates the hardware's share of a
#: gap); "alt": the alternative damping reading on the twin.
READINGS = {
    "spec": ("", ""),
    "ideal": ("ideal.", " [extra: ideal sensors and actuator]"),
    "alt": ("alt.", " [extra: alternative damping reading]"),
}


def twin_for(reading: str, twin: Twin | None, Ts: float | None = None) -> Twin | None:
    """The twin of ``reading``: ideal sensors and actuator for "ideal", else ``twin`` (or,
    when ``None`` and ``Ts`` is given, the default twin sampled every ``Ts``)."""
    if reading == "ideal":
        return Twin.ideal() if Ts is None else Twin.ideal(Ts=Ts)
    return Twin(Ts=Ts) if twin is None and Ts is not None else twin


def run_one(
    kind: str, case: int, q1d_dot: float, cfg: Mapping[str, Any], *, reading: str = "spec",
    duration: float | None = None, twin: Twin | None = None,
) -> SimResult:  # fmt: skip
    """One controller on the twin for a case (3 = payload + stick; ``case=-1``: stick on the
    Case 1 robot) under the damping ``reading`` ("spec", "ideal" or "alt"), with the calling
    study's settings ``cfg`` (``duration`` default: ``cfg["duration"]``; the stick from
    ``stick_start``, ``stick_speed`` where ``cfg`` has them)."""
    nominal = robot.nominal()
    if reading == "alt":
        nominal = alt_damping(nominal)
    ctrl = make_controller(kind, cfg, q1d_dot, nominal)
    plant_case = 1 if case == -1 else case
    stick = {k: cfg[k] for k in ("stick_speed", "stick_start") if k in cfg}
    return run_on_twin(
        ctrl,
        3 if case in (3, -1) else case,
        twin=twin_for(reading, twin, cfg["Ts"]),
        plant=_plant(plant_case, reading),
        q0=(0.0, cfg["theta0"], 0.0), record_every=cfg["record_every"], seed=cfg["seed"],
        duration=cfg["duration"] if duration is None else duration, **stick,
    )  # fmt: skip


def _rms_metrics(res: SimResult, q1d_dot: float, window: tuple[float, float]) -> dict[str, float]:
    ok = res.status[0] == "ok"
    s = res.series()
    nan = float("nan")
    lim = s.get("drive_limited")
    return {
        "rms_theta": float(rms(res.t, res.theta, window)) if ok else nan,
        "rms_speed_err": float(rms(res.t, res.q_dot[:, 0] - q1d_dot, window)) if ok else nan,
        "u_tv": float(np.sum(total_variation_rate(res.t, res.u.T))),
        "max_abs_u": float(np.nanmax(np.abs(s["u_applied"]))),
        "sat_fraction": float(np.nanmean(lim)) if lim is not None else 0.0,
        "t_end": float(res.t_end[0]),
    }


def _ordered(metrics: dict[str, float], fmt: str, quantity: str) -> bool:
    vals = [metrics.get(fmt.format(k=k, q=quantity), float("nan")) for k in
            ("do4smc", "do1smc", "smc")]  # fmt: skip
    return bool(np.all(np.isfinite(vals)) and vals[0] < vals[1] < vals[2])


def _runs_doc(runs: dict[str, SimResult]) -> dict[str, dict[str, Any]]:
    return {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()}


def _settings(
    cfg: Mapping[str, Any], extra: dict[str, Any], duration: float, window: tuple[float, float]
) -> dict:
    base = {
        "dt": Twin().dt, "Ts": cfg["Ts"], "window": list(window), "seed": cfg["seed"],
        "duration": duration, "record_every": cfg["record_every"],
        "record_period": cfg["Ts"] * cfg["record_every"],
        "mode": f"sampled on the digital twin ({cfg['Ts'] * 1e3:g} ms)",
        "lambdas": list(cfg["lambdas"]), "gamma": list(GAMMA_PRINTED),
        "K": {k: list(cfg[f"{k}_K"]) for k in KINDS}, "dbar_printed": dict(DBAR_PRINTED),
        "switching": f"saturation, phi = {cfg['phi']}", "phi": cfg["phi"],
        "theta0": cfg["theta0"], "do1_gain": cfg["do1_gain"],
        "observers": f"DO1: L = {cfg['do1_gain']:g} I3; DO4: Sec. 3.6.1 gains",
        "twin": "complementary fusion (tau 0.5 s), HED-5540 2000 cpr, RE25 + 23:1, 24 V, 4 A",
        "alt": "extra runs: Db, Dw read as linear damping (rotational D r^2) in plant and model",
        "ideal": "extra runs: SPEC plant, ideal sensors and actuator",
    }  # fmt: skip
    base.update(extra)
    return base


def _rms_experiment(
    study: str, source: str, published: dict[str, float], out: Path, quick: bool,
    keys: tuple[str, ...],
) -> dict[str, Any]:  # fmt: skip
    folder = Path(out) / study
    cfg = settings.current(study)
    q1d_dot = cfg["speed"]
    duration = min(4.0, cfg["duration"]) if quick else cfg["duration"]
    window = (2.0, duration) if quick else tuple(cfg["rms_window"])
    readings = ("spec",) if quick else tuple(READINGS)
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for reading in readings:
        pre = READINGS[reading][0]
        for case in (1, 2):
            for kind in KINDS:
                res = run_one(kind, case, q1d_dot, cfg, reading=reading, duration=duration)
                name = f"{pre}{kind}.case{case}"
                runs[name] = res
                for q, v in _rms_metrics(res, q1d_dot, window).items():
                    metrics[f"{name}.{q}"] = v
    claims = []
    for reading in readings:
        pre, label = READINGS[reading]
        for case in (1, 2):
            for q in keys:
                claims.append({
                    "text": f"DO4SMC < DO1SMC < SMC in {q}, Case {case} (book){label}",
                    "holds": _ordered(metrics, pre + "{k}.case" + str(case) + ".{q}", q),
                    "keys": [f"{pre}{k}.case{case}.{q}" for k in ("do4smc", "do1smc", "smc")],
                })  # fmt: skip
            claims.append({
                "text": f"all three controllers keep the robot up for {duration:g} s, Case "
                        f"{case}{label}",
                "holds": all(runs[f"{pre}{k}.case{case}"].status[0] == "ok" for k in KINDS),
                "keys": [f"{pre}{k}.case{case}.t_end" for k in KINDS],
            })  # fmt: skip
    doc = metrics_document(study, source, metrics, published, claims, _runs_doc(runs),
                           _settings(cfg, {"q1d_dot": q1d_dot}, duration, window))  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    _figure(runs, q1d_dot, folder / f"{study}.png", study)
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    write_metrics(folder, doc)
    return doc


def run_balance(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-balance``: Table 6.4 on the twin (Cases 1-2, ``q1d' = 0``)."""
    return _rms_experiment(NAME_BALANCE, SOURCE_BALANCE, PUBLISHED_BALANCE, out, quick,
                           ("rms_theta", "rms_speed_err"))  # fmt: skip


def run_speed(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-speed``: Table 6.5 on the twin (Cases 1-2, ``q1d' = -7 rad/s``)."""
    return _rms_experiment(NAME_SPEED, SOURCE_SPEED, PUBLISHED_SPEED, out, quick,
                           ("rms_speed_err",))  # fmt: skip


def obstacle_settling_time(
    t: np.ndarray, psi_dot: np.ndarray, start: float = 6.0,
    band: tuple[float, float] = BAND,
) -> float:  # fmt: skip
    """Time after ``start`` until ``psi'`` enters ``band`` for good (Table 6.6's definition:
    "steady state ... when the actual velocity falls within (-9, -5)"); 0 if it never leaves
    the band after ``start``, ``nan`` if it is outside at the end (never settles)."""
    after = t >= start - 1e-12
    tt, x = t[after], psi_dot[after]
    if tt.size == 0 or not np.all(np.isfinite(x)):
        return float("nan")
    outside = np.nonzero((x <= band[0]) | (x >= band[1]))[0]
    if outside.size == 0:
        return 0.0
    if outside[-1] == x.size - 1:
        return float("nan")
    return float(tt[outside[-1] + 1] - start)


def run_obstacle(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """``exp-hodosmc-obstacle``: Table 6.6 on the twin (Case 3: payload + stick at 6 s)."""
    study = NAME_OBSTACLE
    folder = Path(out) / study
    cfg = settings.current(study)
    speed, stick_start = cfg["speed"], cfg["stick_start"]
    duration = min(7.0, cfg["duration"]) if quick else cfg["duration"]
    readings = ("spec",) if quick else tuple(READINGS)
    variants = ((3, ""),) if quick else ((3, ""), (-1, "case1_stick."))
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    for reading in readings:
        pre = READINGS[reading][0]
        for case, tag in variants:
            for kind in KINDS:
                res = run_one(kind, case, speed, cfg, reading=reading, duration=duration)
                name = f"{pre}{tag}{kind}"
                runs[name] = res
                ok = res.status[0] == "ok"
                metrics[f"{name}.settling_time"] = (
                    obstacle_settling_time(res.t, res.q_dot[:, 0], stick_start)
                    if ok
                    else float("nan")
                )
                metrics[f"{name}.rms_speed_err"] = (
                    float(rms(res.t, res.q_dot[:, 0] - speed, (cfg["rms_start"], stick_start)))
                    if ok else float("nan")
                )  # fmt: skip
                pre_stick = res.t < stick_start
                metrics[f"{name}.speed_before_stick"] = (
                    float(np.nanmean(res.q_dot[pre_stick, 0][-50:])) if ok else float("nan")
                )
    claims = []
    for reading in readings:
        pre, label = READINGS[reading]
        for _case, tag in variants:
            what = "Case 3" if not tag else "stick without payload (extra)"
            claims.append({
                "text": f"settling time DO4SMC < DO1SMC < SMC, {what} (book){label}",
                "holds": _ordered(metrics, pre + tag + "{k}.{q}", "settling_time"),
                "keys": [f"{pre}{tag}{k}.settling_time" for k in ("do4smc", "do1smc", "smc")],
            })  # fmt: skip
            claims.append({
                "text": f"all three cross the stick and settle in (-9, -5) rad/s, {what}{label}",
                "holds": all(np.isfinite(metrics[f"{pre}{tag}{k}.settling_time"]) for k in KINDS),
                "keys": [f"{pre}{tag}{k}.settling_time" for k in KINDS],
            })  # fmt: skip
    stick = _stick_doc(cfg["stick_speed"], stick_start)
    doc = metrics_document(
        study, SOURCE_OBSTACLE, metrics, PUBLISHED_OBSTACLE, claims, _runs_doc(runs),
        _settings(cfg, {"q1d_dot": speed, "band": list(BAND), "stick": stick,
                        "stick_speed": cfg["stick_speed"]},
                  duration, (cfg["rms_start"], stick_start)),
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    _figure(runs, speed, folder / f"{study}.png", study, cases=("",))
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    write_metrics(folder, doc)
    return doc


def _stick_doc(speed: float, start: float) -> dict[str, float]:
    from mwip.hardware.twin import stick_for

    s = stick_for(case_plant(3, base=robot.plant()), speed, start)
    return {"height": s.height, "start": s.start, "duration_each": s.duration,
            "torque": s.torque, "mass": s.mass}  # fmt: skip


def _figure(
    runs: dict[str, SimResult], q1d_dot: float, path: Path, title: str,
    cases: tuple[str, ...] = (".case1", ".case2"),
) -> None:  # fmt: skip
    """The book's layout (Figs. 6.4-6.8): angle, speed and torque against time in 0.1 s."""
    fig = Figure(figsize=(6 * len(cases), 9), layout="constrained")
    axes = fig.subplots(3, len(cases), squeeze=False)
    colors = {"smc": "tab:blue", "do1smc": "tab:green", "do4smc": "tab:red"}
    for j, case in enumerate(cases):
        for kind in KINDS:
            res = runs[f"{kind}{case}"]
            t = res.t * 10.0
            kw = {"color": colors[kind], "lw": 0.9, "label": kind.upper()}
            axes[0, j].plot(t, res.theta, **kw)
            axes[1, j].plot(t, res.q_dot[:, 0], **kw)
            axes[2, j].plot(t, res.series()["u_applied"][:, 0], **kw)
        axes[0, j].set_title(case.strip(".") or "case 3")
        if q1d_dot != 0:
            axes[1, j].axhline(q1d_dot, color="k", ls=":", lw=0.8)
        axes[0, j].set_ylabel("Angle [rad]")
        axes[1, j].set_ylabel("Speed [rad/s]")
        axes[2, j].set_ylabel("Torque [N.m] (right wheel, applied)")
        axes[2, j].set_xlabel("Time [0.1s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title} on the digital twin (SPEC damping reading)")
    save_figure(fig, path)
