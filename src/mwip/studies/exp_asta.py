"""Experiment ``exp-asta`` (Sec. 6.2.2, Figs. 6.9-6.16, Tables 6.7-6.8) on the digital twin.

Set-up (SPEC.md section 5): the twin (:mod:`mwip.hardware.twin`), 5 ms sampling; ASTA and
ASMC designed on the nominal parameters with (6.1)-(6.2): ``lambda = (10, 0.3, 3)``,
``K1 = K2 = 10``, ``Gamma1 = Gamma2 = 5`` read as the adaptation rates of (4.5) with
``Gamma(0) = 0`` (:mod:`mwip.control.asta`), boundary layer ``eps = 0.01``;
``theta0 = -pi/18``, targets zero, 10 s. Case 1 the robot, Case 2 with the payload. RMS (6.3)
of ``q2`` and of the sliding variable ``S1`` (the controller's, from measurements) over
2-10 s from 10 ms records.

Extra runs: keys prefixed ``ideal.``, the same with ideal sensors and actuator; ``alt.``, the
same under the alternative damping reading (Db, Dw as linear damping, rotational ``D r^2``, in
the plant and the nominal model; docs/twin.md).

Settings (``scenarios/exp-asta.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``lambdas``, ``K``, ``Gamma_rate``, ``Gamma0``, ``eps``, ``duration``, ``rms_window``,
``Ts``, ``record_every``, ``seed``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.control.asta import ASMC, ASTA
from mwip.hardware.twin import Twin, case_plant, run_on_twin
from mwip.metrics import rms, total_variation_rate
from mwip.params import Params
from mwip.sim import SimResult
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, save_figure, write_metrics
from mwip.studies.exp_hodosmc import READINGS, alt_damping, twin_for

SOURCE = "Sec. 6.2.2, Figs. 6.9-6.16, Tables 6.7-6.8"
NAME = "exp-asta"
KINDS = ("asmc", "asta")
PUBLISHED = {
    "asmc.case1.rms_theta": 0.0138, "asmc.case1.rms_s1": 0.4184,
    "asta.case1.rms_theta": 0.0087, "asta.case1.rms_s1": 0.3546,
    "asmc.case2.rms_theta": 0.0176, "asmc.case2.rms_s1": 0.8317,
    "asta.case2.rms_theta": 0.0154, "asta.case2.rms_s1": 0.4769,
}  # fmt: skip


def make_controller(kind: str, cfg: Mapping[str, Any], params: Params | None = None) -> ASTA | ASMC:
    """ASTA or ASMC with (6.1)-(6.2), gains and sample period from the settings ``cfg``,
    designed on ``params`` (default: the robot's nominal model,
    :func:`mwip.studies.robot.nominal`)."""
    if params is None:
        params = robot.nominal()
    cls = ASTA if kind == "asta" else ASMC
    return cls(params, lam=tuple(cfg["lambdas"]), K=tuple(cfg["K"]),
               rate=tuple(cfg["Gamma_rate"]), Gamma0=tuple(cfg["Gamma0"]), eps=cfg["eps"],
               Ts=cfg["Ts"])  # fmt: skip


def run_one(
    kind: str, case: int, cfg: Mapping[str, Any], *, reading: str = "spec",
    duration: float | None = None, twin: Twin | None = None,
) -> SimResult:  # fmt: skip
    """One controller on the twin, Case 1 or 2, ``reading`` "spec", "ideal" or "alt", with
    the settings ``cfg`` (``duration`` default: ``cfg["duration"]``)."""
    plant = case_plant(case, base=robot.plant())
    nominal = robot.nominal()
    if reading == "alt":
        plant, nominal = alt_damping(plant), alt_damping(nominal)
    return run_on_twin(
        make_controller(kind, cfg, nominal), case, twin=twin_for(reading, twin, cfg["Ts"]),
        plant=plant, q0=(0.0, cfg["theta0"], 0.0),
        duration=cfg["duration"] if duration is None else duration,
        record_every=cfg["record_every"], seed=cfg["seed"],
    )  # fmt: skip


def run(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """Run the experiment into ``out/exp-asta``; returns the metrics document."""
    study = NAME
    folder = Path(out) / study
    cfg = settings.current(NAME)
    duration = min(4.0, cfg["duration"]) if quick else cfg["duration"]
    window = (2.0, duration) if quick else tuple(cfg["rms_window"])
    readings = ("spec",) if quick else tuple(READINGS)
    runs: dict[str, SimResult] = {}
    metrics: dict[str, float] = {}
    nan = float("nan")
    for reading in readings:
        pre = READINGS[reading][0]
        for case in (1, 2):
            for kind in KINDS:
                res = run_one(kind, case, cfg, reading=reading, duration=duration)
                name = f"{pre}{kind}.case{case}"
                runs[name] = res
                ok = res.status[0] == "ok"
                s = res.series()
                metrics[f"{name}.rms_theta"] = float(rms(res.t, res.theta, window)) if ok else nan
                metrics[f"{name}.rms_s1"] = (
                    float(rms(res.t, s["sigma"][:, 0], window)) if ok else nan
                )
                metrics[f"{name}.u_tv"] = float(np.sum(total_variation_rate(res.t, res.u.T)))
                metrics[f"{name}.final_gamma1"] = float(s["Gamma"][-1, 0])
                metrics[f"{name}.max_abs_u"] = float(np.nanmax(np.abs(s["u_applied"])))
                metrics[f"{name}.sat_fraction"] = float(np.nanmean(s["drive_limited"]))
                metrics[f"{name}.t_end"] = float(res.t_end[0])
    claims = []
    for reading in readings:
        pre, label = READINGS[reading]
        for case in (1, 2):
            for q in ("rms_theta", "rms_s1"):
                a = metrics[f"{pre}asta.case{case}.{q}"]
                b = metrics[f"{pre}asmc.case{case}.{q}"]
                claims.append(
                    {
                        "text": f"ASTA < ASMC in {q}, Case {case} (book){label}",
                        "holds": bool(np.isfinite(a) and np.isfinite(b) and a < b),
                        "keys": [f"{pre}asta.case{case}.{q}", f"{pre}asmc.case{case}.{q}"],
                    }
                )
            claims.append({
                "text": f"both keep the robot up for {duration:g} s, Case {case}{label}",
                "holds": all(runs[f"{pre}{k}.case{case}"].status[0] == "ok" for k in KINDS),
                "keys": [f"{pre}{k}.case{case}.t_end" for k in KINDS],
            })  # fmt: skip
    doc = metrics_document(
        study, SOURCE, metrics, PUBLISHED, claims,
        {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()},
        {"dt": Twin().dt, "Ts": cfg["Ts"], "window": list(window), "seed": cfg["seed"],
         "duration": duration, "record_every": cfg["record_every"],
         "record_period": cfg["Ts"] * cfg["record_every"],
         "mode": f"sampled on the digital twin ({cfg['Ts'] * 1e3:g} ms)",
         "lambda": list(cfg["lambdas"]), "K": list(cfg["K"]), "rate": list(cfg["Gamma_rate"]),
         "Gamma0": list(cfg["Gamma0"]), "eps": cfg["eps"], "theta0": cfg["theta0"],
         "alt": "extra runs: Db, Dw read as linear damping (rotational D r^2)",
         "ideal": "extra runs: SPEC plant, ideal sensors and actuator"},
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    _figure(runs, folder / f"{study}.png")
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    write_metrics(folder, doc)
    return doc


def _figure(runs: dict[str, SimResult], path: Path) -> None:
    """Figs. 6.9-6.16 layout: angle, S1, adaptive gain, torque per case; time in 0.1 s."""
    fig = Figure(figsize=(12, 11), layout="constrained")
    axes = fig.subplots(4, 2, sharex=True)
    colors = {"asmc": "tab:blue", "asta": "tab:red"}
    for j, case in enumerate((1, 2)):
        for kind in KINDS:
            res = runs[f"{kind}.case{case}"]
            s = res.series()
            t = res.t * 10.0
            kw = {"color": colors[kind], "lw": 0.9, "label": kind.upper()}
            axes[0, j].plot(t, res.theta, **kw)
            axes[1, j].plot(t, s["sigma"][:, 0], **kw)
            axes[2, j].plot(t, s["Gamma"][:, 0], **kw)
            axes[3, j].plot(t, s["u_applied"][:, 0], **kw)
        axes[0, j].set_title(f"Case {case}")
        for ax, lab in zip(axes[:, j], ("Angle [rad]", "S", "gain", "Torque [N.m]"), strict=True):
            ax.set_ylabel(lab)
        axes[3, j].set_xlabel("Time [0.1s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("exp-asta on the digital twin (SPEC damping reading)")
    save_figure(fig, path)
