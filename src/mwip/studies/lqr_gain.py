"""Study ``lqr-gain`` (Section 4.4.2): the LQR gain and both ways of running it.

Designs the LQR on the nominal parameters with the book's ``Q, R`` (continuous, as printed,
and for the 5 ms sample period), compares the gain with the printed rows, and balances the
real-parameter plant from ``theta0 = 0.1745`` rad (10 deg) with

- the continuous gain inside the right-hand side (``mode="continuous"``), and
- the sampled gain with 5 ms zero-order hold (``mode="sampled"``),

plus, to show why the sampled design is needed, the continuous gain applied with 5 ms hold.

Settings (``scenarios/lqr-gain.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``duration``, ``Ts``, ``dt_continuous``, ``Q_diag``, ``R_diag``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.control.lqr import LQR, design_lqr
from mwip.sim import simulate
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, save_figure, write_metrics

SOURCE = "Sec. 4.4.2"
#: The printed K row (both rows printed equal; yaw entries flip sign between wheels).
PRINTED_K_ROW = (-207.87, 70.71, -75.62, 15.33, 219.80)
NAME = "lqr-gain"


def run(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """Run the study into ``out/lqr-gain``; returns the metrics document."""
    folder = Path(out) / NAME
    cfg = settings.current(NAME)
    duration = min(3.0, cfg["duration"]) if quick else cfg["duration"]
    Ts, q0 = cfg["Ts"], (0.0, cfg["theta0"], 0.0)
    Q, R = np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"])
    plant, nominal = robot.plant(), robot.nominal()
    cont = design_lqr(nominal, Q, R, Ts=None)
    samp = design_lqr(nominal, Q, R, Ts=Ts)
    runs = {
        "continuous": simulate(LQR(cont), plant, q0=q0, duration=duration, Ts=Ts,
                               dt=cfg["dt_continuous"], mode="continuous"),
        "sampled": simulate(LQR(samp), plant, q0=q0, duration=duration),
        "continuous_gain_held": simulate(
            LQR(cont), plant, q0=q0, duration=duration, Ts=Ts, mode="sampled"
        ),
    }  # fmt: skip
    names = ("theta", "alpha", "theta_dot", "v", "alpha_dot")
    metrics: dict[str, float] = {}
    published: dict[str, float] = {}
    for j, name in enumerate(names):
        metrics[f"continuous.K_r.{name}"] = float(cont.K[0, j])
        metrics[f"continuous.K_l.{name}"] = float(cont.K[1, j])
        metrics[f"sampled.K_r.{name}"] = float(samp.K[0, j])
        metrics[f"sampled.K_l.{name}"] = float(samp.K[1, j])
        published[f"continuous.K_r.{name}"] = PRINTED_K_ROW[j]
        published[f"continuous.K_l.{name}"] = PRINTED_K_ROW[j]
    for key, res in runs.items():
        s = res.summary()
        metrics[f"{key}.settling_time"] = s["settling_time"]
        metrics[f"{key}.max_abs_u"] = s["max_abs_u"]
        metrics[f"{key}.t_end"] = float(res.t_end[0])
    poles = np.sort(cont.poles.real)
    metrics["continuous.fastest_pole"] = float(poles[0])
    metrics["sampled.max_abs_eig"] = float(np.max(np.abs(samp.poles)))
    yaw_match = bool(np.allclose(np.abs(cont.K[:, [1, 4]]), [[70.71, 219.80]] * 2, rtol=0.005))
    claims = [
        {"text": "yaw gains match the printed 70.71 and 219.80 (within 0.5 %)", "holds": yaw_match,
         "keys": [f"continuous.K_{s}.{q}" for s in "rl" for q in ("alpha", "alpha_dot")]},
        {"text": "continuous LQR balances the real plant (continuous mode)",
         "holds": runs["continuous"].status[0] == "ok", "keys": ["continuous.t_end"]},
        {"text": "the 5 ms design balances the real plant with zero-order hold",
         "holds": runs["sampled"].status[0] == "ok", "keys": ["sampled.t_end"]},
        {"text": "the continuous gain with 5 ms hold is unstable (SPEC section 2)",
         "holds": runs["continuous_gain_held"].status[0] != "ok",
         "keys": ["continuous_gain_held.t_end"]},
    ]  # fmt: skip
    doc = metrics_document(
        "lqr-gain", SOURCE, metrics, published, claims,
        {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()},
        {"dt": {"continuous": cfg["dt_continuous"], "sampled": runs["sampled"].settings["dt"]},
         "Ts": Ts, "duration": duration, "theta0": cfg["theta0"], "Q_diag": cfg["Q_diag"],
         "R_diag": cfg["R_diag"], "plant": "real", "design": "nominal"},
    )  # fmt: skip
    fig = Figure(figsize=(9, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for key in ("continuous", "sampled"):
        res = runs[key]
        ax1.plot(res.t, res.theta, label=key)
        ax2.plot(res.t, res.u[:, 0], label=f"{key} u_r")
    ax1.set_ylabel("theta (rad)")
    ax1.legend()
    ax2.set_ylabel("u_r (N m)")
    ax2.set_xlabel("t (s)")
    ax1.set_title("LQR balance of the real plant from 10 deg (nominal design)")
    folder.mkdir(parents=True, exist_ok=True)
    save_figure(fig, folder / "lqr-gain.png")
    for key, res in runs.items():
        res.to_npz(folder / f"{key}.npz")
    write_metrics(folder, doc)
    return doc
