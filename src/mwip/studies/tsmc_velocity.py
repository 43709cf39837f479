"""Study ``tsmc-velocity`` (Figs. 4.12-4.15): TSMC vs LQR, velocity control without yaw.

Set-up (SPEC.md section 4): real plant, nominal design, ``alpha0 = 0.5``, ``theta0 = 0.1``,
``v0 = 0``, desired ``theta = alpha = theta' = alpha' = 0``, ``v_d = 1`` m/s, 20 s. TSMC with
``F~ = 0.9 |F^|``, ``C = diag(2.5, 0.5)``, ``Gamma = (5, 20)``, ``D = 0.4 I``, ``T_f = 1``,
``sat(s / 0.05)``; LQR with the book's ``Q, R`` (continuous design) and the reference
``x_ref = [0, 0, 0, v_d, 0]``. Both run in the engine's continuous mode (as
:mod:`mwip.studies.tsmc_equilibrium`).

The book's TSMC for this case has no speed input (its surfaces act on ``theta, alpha``); it
claims ``v -> v_d`` from the internal dynamics (4.35)-(4.40). On this plant the steady state
of (2.33) requires ``2 Dw psi' = Gb sin theta`` (no yaw), so ``theta -> 0`` forces
``v -> 0`` for *any* controller, and ``v = 1`` m/s would need ``sin theta = 2 Dw v / (r Gb)
= 25`` (real parameters): impossible. The claim is therefore reported with ``holds = false``.
To show what the velocity result (4.40) does give, an extra run ``tsmc_lean`` asks for a
feasible speed with the pitch target set to the lean of (4.40)'s equilibrium
(:func:`mwip.control.tsmc.lean_for_speed`, nominal parameters, clipped to 0.5 rad).

Settings (``scenarios/tsmc-velocity.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``alpha0``, ``v0``, ``v_d``, ``v_feasible``, ``theta_max``, ``duration``, ``Ts_record``,
``dt``, ``C``, ``Gamma``, ``D``, ``Ftilde_ratio``, ``Tf``, ``phi``, ``Q_diag``, ``R_diag``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mwip.control.lqr import LQR, design_lqr
from mwip.control.tsmc import lean_for_speed
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, write_metrics
from mwip.studies.tsmc_equilibrium import (
    replay,
    run_continuous,
    save_npz,
    state_figure,
    tsmc_doc,
    tsmc_from,
)  # fmt: skip

SOURCE = "Figs. 4.12-4.15"
NAME = "tsmc-velocity"


def max_steady_speed(p: Any) -> float:
    """Largest constant speed the plant can hold without yaw: ``r Gb / (2 Dw)`` (theta = 90 deg)."""
    return float(p.r * p.Gb / (2.0 * p.Dw))


def run(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """Run the study into ``out/tsmc-velocity``; returns the metrics document."""
    folder = Path(out) / NAME
    cfg = settings.current(NAME)
    duration = min(1.5, cfg["duration"]) if quick else cfg["duration"]
    v_d, v_feasible = cfg["v_d"], cfg["v_feasible"]
    real, nominal = robot.plant(), robot.nominal()
    init = {"q0": (0.0, cfg["theta0"], cfg["alpha0"]), "qdot0": (cfg["v0"] / real.r, 0.0, 0.0),
            "Ts": cfg["Ts_record"], "dt": cfg["dt"]}  # fmt: skip
    tsmc = tsmc_from(cfg, v_ref=v_d)
    lean = tsmc_from(cfg, v_ref=v_feasible, speed="lean", theta_max=cfg["theta_max"])
    Q, R = np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"])
    lqr = LQR(design_lqr(nominal, Q, R, Ts=None), reference=(0.0, 0.0, 0.0, v_d, 0.0))
    runs = {
        "tsmc": run_continuous(tsmc, duration, **init),
        "lqr": run_continuous(lqr, duration, **init),
        "tsmc_lean": run_continuous(lean, duration, **init),
    }
    targets_v = {"tsmc": v_d, "lqr": v_d, "tsmc_lean": v_feasible}
    metrics: dict[str, float] = {}
    for name, res in runs.items():
        metrics[f"{name}.final_v_err"] = float(abs(res.v[-1] - targets_v[name]))
        metrics[f"{name}.final_theta"] = float(res.theta[-1])
        metrics[f"{name}.final_v"] = float(res.v[-1])
        metrics[f"{name}.final_alpha"] = float(res.alpha[-1])
        metrics[f"{name}.max_abs_u"] = float(np.nanmax(np.abs(res.u)))
        # steady-state balance of (2.33): 2 Dw psi' - Gb sin(theta) (real parameters)
        psid = res.q_dot[-1, 0]
        metrics[f"{name}.steady_balance_residual"] = float(
            2.0 * real.Dw * psid - real.Gb * np.sin(res.theta[-1])
        )
    metrics["tsmc_lean.theta_target"] = lean.theta_ref
    metrics["tsmc_lean.v_target"] = v_feasible
    metrics["real.max_steady_speed"] = max_steady_speed(real)
    metrics["real.sin_theta_needed_for_v_d"] = float(2 * real.Dw * v_d / (real.r * real.Gb))
    published = {"tsmc.final_v_err": 0.0, "tsmc.final_theta": 0.0}
    small = 0.02
    t_ok = metrics["tsmc.final_v_err"] < small * v_d and abs(metrics["tsmc.final_theta"]) < small
    l_ok = metrics["lqr.final_v_err"] < small * v_d and abs(metrics["lqr.final_theta"]) < small
    claims = [
        {"text": f"TSMC reaches v_d = {v_d:g} m/s with theta -> 0 (book, Fig. 4.12): v within 2 % "
                 "of v_d and |theta| < 0.02 rad at the end", "holds": bool(t_ok),
         "keys": ["tsmc.final_v_err", "tsmc.final_theta"]},
        {"text": "LQR cannot bring both v to v_d and theta to 0 (book, Fig. 4.14)",
         "holds": bool(not l_ok), "keys": ["lqr.final_v_err", "lqr.final_theta"]},
        {"text": "TSMC brings theta and alpha to 0 (its surfaces' targets)",
         "holds": bool(abs(metrics["tsmc.final_theta"]) < small
                       and abs(metrics["tsmc.final_alpha"]) < small),
         "keys": ["tsmc.final_theta", "tsmc.final_alpha"]},
        {"text": f"no controller can hold v_d = {v_d:g} m/s on this plant: a steady speed needs "
                 "2 Dw psi' = Gb sin(theta), i.e. sin(theta) = "
                 f"{metrics['real.sin_theta_needed_for_v_d']:.1f} > 1 (SPEC section 2 damping)",
         "holds": bool(np.isnan(lean_for_speed(real, v_d))),
         "keys": ["real.sin_theta_needed_for_v_d", "real.max_steady_speed"]},
        {"text": f"with the pitch target from (4.40)'s equilibrium, TSMC holds the feasible "
                 f"speed {v_feasible} m/s within 20 % (nominal-model lean, no speed feedback)",
         "holds": bool(metrics["tsmc_lean.final_v_err"] < 0.2 * v_feasible),
         "keys": ["tsmc_lean.final_v_err", "tsmc_lean.v_target"]},
    ]  # fmt: skip
    doc = metrics_document(
        NAME, SOURCE, metrics, published, claims,
        {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()},
        {"dt": cfg["dt"], "Ts": cfg["Ts_record"], "mode": "continuous (law inside the "
         "right-hand side)", "duration": duration, "plant": "real", "design": "nominal",
         "seed": 0, "v_d": v_d,
         "initial": {"theta0": cfg["theta0"], "alpha0": cfg["alpha0"], "v0": cfg["v0"]},
         "tsmc": {**tsmc_doc(cfg), "speed": "none (book)"},
         "tsmc_lean": {"v_ref": v_feasible, "theta_target": lean.theta_ref,
                       "theta_max": cfg["theta_max"]},
         "lqr": "Q_diag, R_diag, continuous design, reference [0, 0, 0, v_d, 0]",
         "Q_diag": cfg["Q_diag"], "R_diag": cfg["R_diag"],
         "published_note": "published values read from Fig. 4.12 (v -> v_d, theta -> 0); "
                           "the book prints no numbers"},
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    base = {"theta": 0.0, "theta_dot": 0.0, "alpha": 0.0, "alpha_dot": 0.0}
    state_figure(runs["tsmc"], {**base, "v": v_d},
                 "TSMC, velocity control without yaw (Figs. 4.12-4.13)",
                 folder / "tsmc-velocity_tsmc.png")  # fmt: skip
    state_figure(runs["lqr"], {**base, "v": v_d},
                 "LQR, velocity control without yaw (Figs. 4.14-4.15)",
                 folder / "tsmc-velocity_lqr.png")  # fmt: skip
    state_figure(runs["tsmc_lean"], {**base, "theta": lean.theta_ref, "v": v_feasible},
                 f"TSMC with the lean of (4.40) for v = {v_feasible} m/s (extra)",
                 folder / "tsmc-velocity_tsmc_lean.png")  # fmt: skip
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    save_npz(folder / "tsmc_sliding.npz", t=runs["tsmc"].t, **replay(tsmc, runs["tsmc"]))
    write_metrics(folder, doc)
    return doc
