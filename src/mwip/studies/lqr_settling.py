"""Study ``lqr-settling`` (Sec. 4.4.2; the worked example of docs/extending.md): how long the
sampled LQR takes to balance the robot from a range of initial pitches.

The LQR with the book's weights ``Q, R`` (Sec. 4.4.2), designed for the sample period ``Ts``
on the design model (:func:`mwip.laws.lqr.controller.design_lqr`), balances the plant from
``n_starts`` initial pitches evenly spread over ``theta0_range`` (one batch run, all other
states zero). Settling time: ``|theta|`` stays within ``max(2 % of its peak, 1 mrad)``
(:func:`mwip.metrics.settling_time`). The claim (ours; the book prints no settling time for
its LQR): every start balances and settles within ``settle_within``.

Settings (``scenarios/lqr-settling.toml``): ``theta0_range``, ``n_starts``, ``duration``,
``Ts``, ``Q_diag``, ``R_diag``, ``settle_within``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.laws.lqr.controller import LQR, design_lqr
from mwip.metrics import settling_time
from mwip.schema.claims import finish_claims
from mwip.sim import simulate
from mwip.studies.study import Study, StudyContext, save_study

NAME = "lqr-settling"
SOURCE = "Sec. 4.4.2"


def run(ctx: StudyContext) -> dict[str, Any]:
    """Run the study into ``ctx.out``; returns the metrics document."""
    cfg = ctx.settings
    duration = min(4.0, cfg["duration"]) if ctx.quick else cfg["duration"]
    lo, hi = cfg["theta0_range"]
    starts = np.linspace(lo, hi, cfg["n_starts"])
    gain = design_lqr(ctx.nominal, np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"]), Ts=cfg["Ts"])
    q0 = np.column_stack([np.zeros_like(starts), starts, np.zeros_like(starts)])
    res = simulate(LQR(gain), ctx.plant, q0=q0, duration=duration, Ts=cfg["Ts"])

    metrics: dict[str, float] = {}
    for i, theta0 in enumerate(starts):
        st = settling_time(res.t, res.theta[i], status=str(res.status[i]))
        metrics[f"start{i}.theta0"] = float(theta0)
        metrics[f"start{i}.settling_time"] = st
    times = [metrics[f"start{i}.settling_time"] for i in range(len(starts))]
    metrics["max_settling_time"] = float(np.max(times))  # nan if any start did not settle
    metrics["max_abs_u"] = float(np.nanmax(np.abs(res.u)))
    claims = [
        {"id": "settles", "book": False,
         "text": f"the {cfg['Ts'] * 1e3:g} ms LQR balances the plant from every initial pitch "
                 f"in {cfg['theta0_range']} rad and settles within {cfg['settle_within']:g} s",
         "holds": bool(np.all(res.status == "ok")
                       and metrics["max_settling_time"] < cfg["settle_within"]),
         "keys": ["max_settling_time"]},
    ]  # fmt: skip

    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.subplots()
    for i, theta0 in enumerate(starts):
        ax.plot(res.t, res.theta[i], lw=1.0, label=f"theta0 = {theta0:.3g} rad")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("theta (rad)")
    ax.legend(fontsize=8)
    ax.set_title(f"Sampled LQR from {len(starts)} initial pitches, {ctx.plant_label}")
    return save_study(
        ctx,
        metrics=metrics,
        claims=finish_claims(claims, metrics, ctx.plant_label),
        runs={f"start{i}": {"status": str(res.status[i]), "t_end": float(res.t_end[i])}
              for i in range(len(starts))},
        settings={**cfg, "duration": duration, "plant": ctx.plant_label, "design": "nominal",
                  "seed": ctx.seed},
        series={"runs": res},
        figures={"lqr-settling.png": fig},
    )  # fmt: skip


STUDY = Study(name=NAME, source=SOURCE, run=run, place=(4, 10), cost=2)
