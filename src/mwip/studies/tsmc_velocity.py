"""Study ``tsmc-velocity`` (Figs. 4.12-4.15): TSMC vs LQR, velocity control without yaw.

Set-up (SPEC.md section 4): real plant, nominal design, ``alpha0 = 0.5``, ``theta0 = 0.1``,
``v0 = 0``, desired ``theta = alpha = theta' = alpha' = 0``, ``v_d = 1`` m/s, 20 s. TSMC with
``F~ = 0.9 |F^|``, ``C = diag(2.5, 0.5)``, ``Gamma = (5, 20)``, ``D = 0.4 I``, ``T_f = 1``,
``sat(s / 0.05)``; LQR with the book's ``Q, R`` (continuous design) and the reference
``x_ref = [0, 0, 0, v_d, 0]``. Both run in the engine's continuous mode (as
:mod:`mwip.studies.tsmc_equilibrium`).

The book's TSMC for this case has no speed input (its surfaces act on ``theta, alpha``); it
claims ``v -> v_d`` with ``theta -> 0`` from the internal dynamics (4.35)-(4.40). With any
``Dw > 0`` a steady speed needs a steady lean: adding the wheel and pitch rows of (2.33) at a
steady motion gives ``Gb sin(theta) = 2 Dw psi'`` (SPEC.md section 3), i.e. about 0.041 rad
for 1 m/s on the real plant under the units reading of ``Dw``; and (4.38) itself makes ``v``
decay to 0 once ``theta -> 0``. So the claim as worded cannot hold (cause
``claim-definition``). Its reachable form, judged beside it: ``v`` reaches ``v_d`` with the
lean that speed needs. The TSMC reaches it only if its pitch target is that lean (the
equilibrium of (4.40), :func:`mwip.models.steady.lean_for_speed`, computed on the *nominal*
model: the controller sees nothing else) - the extra run ``tsmc_lean``; there is still no
speed feedback, so the speed it reaches is the one the real plant's damping and gravity
balance at that lean. The LQR, which feeds back ``v``, reaches ``v_d`` by leaning.

Settings (``scenarios/tsmc-velocity.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``alpha0``, ``v0``, ``v_d``, ``theta_max``, ``duration``, ``Ts_record``, ``dt``, ``C``,
``Gamma``, ``D``, ``Ftilde_ratio``, ``Tf``, ``phi``, ``Q_diag``, ``R_diag``; the open ones
(``phi``, ``dt``, ``Ts_record``, ``theta_max``) in its ``[open]`` table.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.models.steady import balance_residual, lean_for_speed
from mwip.schema.claims import finish_claims
from mwip.studies._tsmc import (
    lean_text,
    replay,
    run_continuous,
    state_figure,
    tsmc_doc,
    tsmc_from,
)  # fmt: skip
from mwip.studies.study import Study, StudyContext, runs_record, save_study

SOURCE = "Figs. 4.12-4.15"
NAME = "tsmc-velocity"


def run(ctx: StudyContext) -> dict[str, Any]:
    """Run the study into ``ctx.out``; returns the metrics document."""
    cfg = ctx.settings
    duration = min(1.5, cfg["duration"]) if ctx.quick else cfg["duration"]
    v_d = cfg["v_d"]
    real, nominal = ctx.plant, ctx.nominal
    init = {"q0": (0.0, cfg["theta0"], cfg["alpha0"]), "qdot0": (cfg["v0"] / real.r, 0.0, 0.0),
            "Ts": cfg["Ts_record"], "dt": cfg["dt"]}  # fmt: skip
    tsmc = tsmc_from(cfg, nominal, v_ref=v_d)
    lean = tsmc_from(cfg, nominal, v_ref=v_d, speed="lean", theta_max=cfg["theta_max"])
    Q, R = np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"])
    lqr = LQR(design_lqr(nominal, Q, R, Ts=None), reference=(0.0, 0.0, 0.0, v_d, 0.0))
    runs = {
        "tsmc": run_continuous(tsmc, real, duration, **init),
        "lqr": run_continuous(lqr, real, duration, **init),
        "tsmc_lean": run_continuous(lean, real, duration, **init),
    }
    metrics: dict[str, float] = {}
    for name, res in runs.items():
        metrics[f"{name}.final_v_err"] = float(abs(res.v[-1] - v_d))
        metrics[f"{name}.final_theta"] = float(res.theta[-1])
        metrics[f"{name}.final_v"] = float(res.v[-1])
        metrics[f"{name}.final_alpha"] = float(res.alpha[-1])
        metrics[f"{name}.max_abs_u"] = float(np.nanmax(np.abs(res.u)))
        metrics[f"{name}.t_end"] = float(res.t_end[0])
        metrics[f"{name}.steady_balance_residual"] = balance_residual(
            real, res.q_dot[-1, 0], res.theta[-1]
        )
    metrics["real.lean_for_v_d"] = lean_for_speed(real, v_d)
    metrics["tsmc_lean.theta_target"] = lean.theta_ref
    metrics["lqr.lean_err"] = float(
        abs(metrics["lqr.final_theta"] - metrics["real.lean_for_v_d"])
        / metrics["real.lean_for_v_d"]
    )
    published = {"tsmc.final_v_err": 0.0, "tsmc.final_theta": 0.0}
    small = 0.02
    m = metrics
    t_end = float(runs["tsmc"].t[-1])
    t_ok = m["tsmc.final_v_err"] < small * v_d and abs(m["tsmc.final_theta"]) < small
    l_ok = m["lqr.final_v_err"] < small * v_d and abs(m["lqr.final_theta"]) < small
    claims = [
        {"id": "tsmc.v_to_vd_theta_to_0", "book": True,
         "text": f"TSMC reaches v_d = {v_d:g} m/s with theta -> 0 (Fig. 4.12): v within 2 % of "
                 "v_d and |theta| < 0.02 rad at the end", "holds": bool(t_ok),
         "cause": "claim-definition",
         "evidence": f"a steady {v_d:g} m/s needs Gb sin(theta) = 2 Dw psi', "
                     f"{lean_text(m['real.lean_for_v_d'])} on the real plant, and the TSMC of "
                     "(4.30)-(4.32) has no speed feedback, so by (4.38) v decays once theta -> "
                     f"0: at t = {t_end:g} s v = {m['tsmc.final_v']:.3f} m/s with theta = "
                     f"{m['tsmc.final_theta']:.4f} rad.",
         "keys": ["tsmc.final_v_err", "tsmc.final_theta", "real.lean_for_v_d"]},
        {"id": "lqr.not_both", "book": True,
         "text": "LQR cannot bring both v to v_d and theta to 0 (Fig. 4.14)",
         "holds": bool(not l_ok), "cause": "damping-reading",
         "evidence": f"the LQR ends at v = {m['lqr.final_v']:.3f} m/s with theta = "
                     f"{m['lqr.final_theta']:.4f} rad: a plant whose damping needs no lean.",
         "keys": ["lqr.final_v_err", "lqr.final_theta"]},
        {"id": "tsmc.theta_alpha_to_0", "book": False,
         "text": "TSMC brings theta and alpha to 0 (its surfaces' targets), within 0.02 rad",
         "holds": bool(abs(m["tsmc.final_theta"]) < small and abs(m["tsmc.final_alpha"]) < small),
         "keys": ["tsmc.final_theta", "tsmc.final_alpha"]},
        {"id": "lqr.lean_for_vd", "book": False,
         "text": "the LQR (which feeds back v) holds v_d by leaning as a steady speed needs: v "
                 "within 5 % of v_d and theta within 10 % of the lean Gb sin(theta) = 2 Dw psi' "
                 "gives on the real plant",
         "holds": bool(m["lqr.final_v_err"] < 0.05 * v_d and m["lqr.lean_err"] < 0.1),
         "keys": ["lqr.final_v", "lqr.final_theta", "real.lean_for_v_d", "lqr.lean_err"]},
        {"id": "tsmc_lean.reaches_vd", "book": False,
         "text": "reachable form of Fig. 4.12: with its pitch target at the lean v_d needs "
                 "(equilibrium of (4.40) on the nominal model), the TSMC brings v within 20 % "
                 "of v_d (no speed feedback)",
         "holds": bool(m["tsmc_lean.final_v_err"] < 0.2 * v_d),
         "evidence": f"the nominal model's lean for v_d is {m['tsmc_lean.theta_target']:.4f} "
                     f"rad against {m['real.lean_for_v_d']:.4f} rad on the real plant (2 Dw / "
                     "(r Gb) differ); without speed feedback the TSMC ends at v = "
                     f"{m['tsmc_lean.final_v']:.3f} m/s with theta = "
                     f"{m['tsmc_lean.final_theta']:.4f} rad, the speed that lean carries "
                     f"(steady-balance residual {m['tsmc_lean.steady_balance_residual']:.1%}).",
         "keys": ["tsmc_lean.final_v", "tsmc_lean.theta_target", "tsmc_lean.final_theta",
                  "real.lean_for_v_d"]},
    ]  # fmt: skip
    claims = finish_claims(claims, metrics, ctx.plant_label)
    doc_runs = runs_record(runs)
    doc_settings = (
        {"dt": cfg["dt"], "Ts": cfg["Ts_record"], "mode": "continuous (law inside the "
         "right-hand side)", "duration": duration, "plant": "real", "design": "nominal",
         "damping": "units (SPEC.md section 2: Db, Dw of the tables times r^2)",
         "seed": ctx.seed, "v_d": v_d,
         "initial": {"theta0": cfg["theta0"], "alpha0": cfg["alpha0"], "v0": cfg["v0"]},
         "tsmc": {**tsmc_doc(cfg), "speed": "none (book)"},
         "tsmc_lean": {"v_ref": v_d, "theta_target": lean.theta_ref,
                       "theta_max": cfg["theta_max"]},
         "lqr": "Q_diag, R_diag, continuous design, reference [0, 0, 0, v_d, 0]",
         "Q_diag": cfg["Q_diag"], "R_diag": cfg["R_diag"],
         "published_note": "published values read from Fig. 4.12 (v -> v_d, theta -> 0); "
                           "the book prints no numbers"}
    )  # fmt: skip
    base = {"theta": 0.0, "theta_dot": 0.0, "alpha": 0.0, "alpha_dot": 0.0, "v": v_d}
    figures = {
        "tsmc-velocity_tsmc.png": state_figure(
            runs["tsmc"], base, "TSMC, velocity control without yaw (Figs. 4.12-4.13)"),
        "tsmc-velocity_lqr.png": state_figure(
            runs["lqr"], base, "LQR, velocity control without yaw (Figs. 4.14-4.15)"),
        "tsmc-velocity_tsmc_lean.png": state_figure(
            runs["tsmc_lean"], {**base, "theta": lean.theta_ref},
            f"TSMC with the lean of (4.40) for v = {v_d:g} m/s (extra)"),
    }  # fmt: skip
    t_rec, logs = runs["tsmc"].t, replay(tsmc, runs["tsmc"])
    return save_study(
        ctx,
        metrics=metrics,
        published=published,
        claims=claims,
        runs=doc_runs,
        settings=doc_settings,
        series=runs,
        figures=figures,
        arrays={"tsmc_sliding.npz": {"t": t_rec, **logs}},
    )


STUDY = Study(name=NAME, source=SOURCE, run=run, place=(4, 12), cost=8)
