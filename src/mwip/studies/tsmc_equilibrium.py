"""Study ``tsmc-equilibrium`` (Figs. 4.8-4.11): TSMC vs LQR, equilibrium control.

Set-up (SPEC.md section 4): real-parameter plant, nominal design, ``alpha0 = 0.5``,
``theta0 = 0.1``, ``v0 = 1`` m/s (``psi'0 = v0 / r_real``), 20 s. TSMC (4.30)-(4.32), (4.43)
with ``F~ = 0.8 |F^|``, ``C = 2.5 I``, ``Gamma = 10 I``, ``D = 0.4 I``, ``T_f = 1`` s,
saturation ``sat(s / phi)`` with ``phi = 0.05``. LQR: the book's ``Q, R``, continuous design.

Both laws are static functions of ``(t, measurement)``, so both run the book's way (its
simulations are continuous-time, SPEC.md section 2): in the engine's ``"continuous"`` mode
(law inside the right-hand side, L-stable ROS2 with the closed-loop Jacobian), ``dt = 1 ms``,
records every 5 ms. The continuous LQR of the book's ``Q, R`` has poles near -1e5 rad/s
(SPEC.md section 2), which only this stiff-capable loop can run. The TSMC's sliding
variables are recomputed from the records with the same law (it is static).

Speed. The TSMC acts on ``theta`` and ``alpha`` only; ``v`` follows the internal dynamics
(4.37), which (4.38) makes decay through the wheel damping alone. With ``theta`` held at 0,
the sum of the wheel and pitch rows of (2.33) gives ``(m11 + m12) psi'' = -2 Dw psi'``: a
time constant ``(m11 + m12) / (2 Dw)`` of 4.4 s on the real plant under the SPEC's units
reading of ``Dw`` (7 ms under the literal one). The boundary layer's residual lean (``s``
stays inside the layer with a model-mismatch offset; the lean is about proportional to
``v``) slows it further. So ``v0 = 1`` m/s has not died out by 20 s: the book's
"converge to the equilibrium" is judged at the end of its 20 s, and the decay itself is
reported (``tsmc.v_decay_time``, fitted on the run).

Metrics: ``final_norm`` is ``||[theta, alpha, theta', v, alpha']||`` at the end;
``settling_time`` the time after which that norm stays below 2 % of its initial value (NaN
when it does not settle, or the run fell); ``v_decay_time`` the time constant of ``v``
fitted after ``T_f`` (log-slope over the second half of the run); ``final_abs_u`` and
``max_abs_u`` the largest wheel torque at the end and over the run.

Settings (``scenarios/tsmc-equilibrium.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``alpha0``, ``v0``, ``duration``, ``Ts_record``, ``dt``, ``C``, ``Gamma``, ``D``,
``Ftilde_ratio``, ``Tf``, ``phi``, ``Q_diag``, ``R_diag``; the ones the book leaves open
(``phi``, ``dt``, ``Ts_record``) are declared with their ranges in the file's ``[open]``
table. The loop, the TSMC and the figure come from the TSMC studies' kit
:mod:`mwip.studies._tsmc`; the speed's time constant from :mod:`mwip.models.steady`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.metrics import settling_time, total_variation_rate
from mwip.models.steady import speed_time_constant
from mwip.params import book_params
from mwip.schema.claims import finish_claims
from mwip.studies._tsmc import (
    fitted_decay_time,
    replay,
    run_continuous,
    slowest_lqr_pole,
    state_figure,
    state_norm_series,
    tsmc_doc,
    tsmc_from,
)  # fmt: skip
from mwip.studies.study import Study, StudyContext, runs_record, save_study

SOURCE = "Figs. 4.8-4.11"
NAME = "tsmc-equilibrium"


def run(ctx: StudyContext) -> dict[str, Any]:
    """Run the study into ``ctx.out``; returns the metrics document."""
    cfg = ctx.settings
    duration = min(1.5, cfg["duration"]) if ctx.quick else cfg["duration"]
    Tf = cfg["Tf"]
    init = {"q0": (0.0, cfg["theta0"], cfg["alpha0"]),
            "qdot0": (cfg["v0"] / ctx.plant.r, 0.0, 0.0),
            "Ts": cfg["Ts_record"], "dt": cfg["dt"]}  # fmt: skip
    tsmc = tsmc_from(cfg, ctx.nominal)
    lqr = LQR(design_lqr(ctx.nominal, np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"]), Ts=None))
    runs = {
        "tsmc": run_continuous(tsmc, ctx.plant, duration, **init),
        "lqr": run_continuous(lqr, ctx.plant, duration, **init),
    }
    logs = replay(tsmc, runs["tsmc"])

    metrics: dict[str, float] = {}
    for name, res in runs.items():
        norm = state_norm_series(res)
        status = str(res.status[0])
        metrics[f"{name}.final_norm"] = float(norm[-1])
        metrics[f"{name}.settling_time"] = settling_time(
            res.t, norm, band=0.02 * norm[0], status=status
        )
        metrics[f"{name}.max_abs_u"] = float(np.nanmax(np.abs(res.u)))
        metrics[f"{name}.u_tv"] = float(np.sum(total_variation_rate(res.t, res.u.T)))
        metrics[f"{name}.final_abs_u"] = float(np.max(np.abs(res.u[-1])))
        i_tf = min(int(np.searchsorted(res.t, Tf)), len(res.t) - 1)  # a run shorter than T_f: end
        metrics[f"{name}.abs_theta_at_Tf"] = float(abs(res.theta[i_tf]))
        metrics[f"{name}.abs_alpha_at_Tf"] = float(abs(res.alpha[i_tf]))
        metrics[f"{name}.final_v"] = float(res.v[-1])
        metrics[f"{name}.final_abs_theta"] = float(abs(res.theta[-1]))
        metrics[f"{name}.t_end"] = float(res.t_end[0])
    ts = runs["tsmc"]
    tail = ts.t >= Tf
    metrics["tsmc.max_abs_s_after_Tf"] = (
        float(np.nanmax(np.abs(logs["s"][tail]))) if tail.any() else float("nan")
    )
    metrics["tsmc.abs_s0"] = float(np.max(np.abs(logs["s"][0])))
    metrics["tsmc.v_decay_time"] = fitted_decay_time(ts.t, ts.v, Tf)
    metrics["real.v_time_constant"] = speed_time_constant(book_params("real", "units"))
    metrics["real_literal.v_time_constant"] = speed_time_constant(book_params("real", "literal"))
    metrics["tsmc.final_controlled_err"] = float(np.max(np.abs(
        [ts.theta[-1], ts.alpha[-1], ts.q_dot[-1, 1], ts.q_dot[-1, 2]])))  # fmt: skip
    v_after = ts.v[tail] if tail.any() else ts.v[-1:]
    metrics["tsmc.v_max_rise_after_Tf"] = float(np.max(np.diff(np.abs(v_after)), initial=0.0))
    metrics["lqr.slowest_pole"] = slowest_lqr_pole(lqr.K, ctx.plant, float(ctx.nominal.r))
    tol = 0.01  # of a norm that starts at 1.12
    u_rel = 0.01  # "converge to zero": 1 % of the run's peak torque (scale-free)
    t_end, book_T = float(ts.t[-1]), 20.0
    tau_fit = metrics["tsmc.v_decay_time"]
    fit_text = f"{tau_fit:.1f} s fitted on the run" if np.isfinite(tau_fit) else "not fitted"
    speed_evidence = (
        f"the TSMC does not act on v, which decays only through the wheel damping (4.38): time "
        f"constant (m11 + m12)/(2 Dw) = {metrics['real.v_time_constant']:.1f} s under the units "
        f"reading ({1e3 * metrics['real_literal.v_time_constant']:.0f} ms under the literal "
        f"one), {fit_text}, slower because the boundary layer leaves a forward lean "
        f"({metrics['tsmc.final_abs_theta']:.1e} rad at the end) that carries part of the speed; "
        f"v = {metrics['tsmc.final_v']:.3f} m/s at t = {t_end:g} s."
    )
    slow = metrics["lqr.slowest_pole"]
    lqr_ok = bool(runs["lqr"].ok and metrics["lqr.final_norm"] < tol)
    torque_ok = bool(metrics["tsmc.final_abs_u"] < u_rel * metrics["tsmc.max_abs_u"])
    claims = [
        {"id": "tsmc.equilibrium", "book": True,
         "text": "TSMC drives the states to the equilibrium (Fig. 4.8): ||x|| below 0.01 at "
                 "the end of the run",
         "holds": bool(ts.ok and metrics["tsmc.final_norm"] < tol),
         "cause": "damping-reading", "evidence": speed_evidence,
         "keys": ["tsmc.t_end", "tsmc.final_norm", "tsmc.final_v", "tsmc.v_decay_time"]},
        {"id": "lqr.equilibrium", "book": True,
         "text": "LQR drives the states to the equilibrium (Fig. 4.10): ||x|| below 0.01 at the "
                 "end of the run",
         "holds": lqr_ok, "cause": "implementation",
         "evidence": f"||x|| = {metrics['lqr.final_norm']:.3g} at t = {t_end:g} s"
                     + (f", a quick run shorter than the book's {book_T:g} s" if t_end < book_T
                        else "")
                     + f"; the LQR's slowest closed-loop pole, {slow:.3f} rad/s, needs about "
                       f"{4.0 / abs(slow):.0f} s to settle.",
         "keys": ["lqr.t_end", "lqr.final_norm", "lqr.slowest_pole"]},
        {"id": "tsmc.torque_to_zero", "book": True,
         "text": "TSMC torques converge to zero (Fig. 4.9): below 1 % of their peak at the end",
         "holds": torque_ok, "cause": "damping-reading",
         "evidence": f"the torques at the end ({metrics['tsmc.final_abs_u']:.2g} N m, "
                     f"{metrics['tsmc.final_abs_u'] / metrics['tsmc.max_abs_u']:.0%} of the "
                     f"peak {metrics['tsmc.max_abs_u']:.2g} N m) hold the lean that goes with "
                     f"the speed still left: " + speed_evidence,
         "keys": ["tsmc.final_abs_u", "tsmc.max_abs_u"]},
        {"id": "tsmc.s0", "book": False,
         "text": "augmented surface is zero at t = 0 (cubic initial conditions (4.43))",
         "holds": bool(metrics["tsmc.abs_s0"] < 1e-9), "keys": ["tsmc.abs_s0"]},
        {"id": "tsmc.targets_at_Tf", "book": False,
         "text": f"TSMC: theta and alpha within 0.01 rad of their targets at T_f = {Tf:g} s",
         "holds": bool(metrics["tsmc.abs_theta_at_Tf"] < 0.01
                       and metrics["tsmc.abs_alpha_at_Tf"] < 0.01),
         "keys": ["tsmc.abs_theta_at_Tf", "tsmc.abs_alpha_at_Tf"]},
        {"id": "tsmc.v_decays", "book": False,
         "text": "reachable form of Fig. 4.8: after T_f theta, alpha, theta', alpha' stay at "
                 "their targets (within 0.01 at the end) and v decreases monotonically (the "
                 "internal dynamics (4.38) are stable; how far v gets depends on the damping)",
         "holds": bool(ts.ok and metrics["tsmc.final_controlled_err"] < tol
                       and metrics["tsmc.v_max_rise_after_Tf"] <= 0.0
                       and np.isfinite(tau_fit) and tau_fit > 0),
         "keys": ["tsmc.final_controlled_err", "tsmc.v_max_rise_after_Tf",
                  "tsmc.v_decay_time", "real.v_time_constant"]},
    ]  # fmt: skip
    claims = finish_claims(claims, metrics, ctx.plant_label)
    doc_runs = runs_record(runs)
    doc_settings = (
        {"dt": cfg["dt"], "Ts": cfg["Ts_record"], "mode": "continuous (law inside the "
         "right-hand side, ROS2 with closed-loop Jacobian); Ts is the record/Jacobian-refresh "
         "period",
         "duration": duration, "plant": "real", "design": "nominal", "seed": ctx.seed,
         "initial": {"theta0": cfg["theta0"], "alpha0": cfg["alpha0"], "v0": cfg["v0"]},
         "tsmc": tsmc_doc(cfg), "lqr": "Q_diag, R_diag, continuous design",
         "Q_diag": cfg["Q_diag"], "R_diag": cfg["R_diag"],
         "settling": "||x|| stays below 2 % of ||x(0)||",
         "damping": "units (SPEC.md section 2: Db, Dw of the tables times r^2)",
         "published_note": "the book prints no numbers for this case (figures only)"}
    )  # fmt: skip
    targets = {"theta": 0.0, "theta_dot": 0.0, "alpha": 0.0, "alpha_dot": 0.0, "v": 0.0}
    figures = {
        "tsmc-equilibrium_tsmc.png": state_figure(
            runs["tsmc"], targets, "TSMC, equilibrium control (Figs. 4.8-4.9)"),
        "tsmc-equilibrium_lqr.png": state_figure(
            runs["lqr"], targets, "LQR, equilibrium control (Figs. 4.10-4.11)"),
    }  # fmt: skip
    t_rec = runs["tsmc"].t
    return save_study(
        ctx,
        metrics=metrics,
        claims=claims,
        runs=doc_runs,
        settings=doc_settings,
        series=runs,
        figures=figures,
        arrays={"tsmc_sliding.npz": {"t": t_rec, **logs}},
    )


STUDY = Study(name=NAME, source=SOURCE, run=run, place=(4, 8), cost=4)
