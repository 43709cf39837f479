"""Study ``asta-velocity`` (Figs. 4.5-4.7): ASTA vs ASMC, velocity control.

Set-up as :mod:`mwip.studies.asta_balance` with the desired wheel speed ``q1d_dot = psi'_d =
0.5`` rad/s (SPEC.md section 4); 10 s, ``Ts = dt = 0.5 ms``. ``rms_speed_err`` is the RMS of
``psi' - psi'_d`` over 5-10 s (after the transient; the book zooms into 7-8 s). The figure
follows the book's layout with a zoomed inset over 7-8 s.

On the sliding surface ``theta' + lambda_1 theta + lambda_2 (psi' - psi'_d) = 0`` a steady
speed needs ``lambda_1 theta = lambda_2 (psi'_d - psi')`` while the plant's steady state needs
``2 Dw psi' = Gb sin(theta)``: with the SPEC's damping the speed settles at
``psi' ~ lambda_2 psi'_d / (lambda_2 + lambda_1 2 Dw / Gb)`` (about 0.015 rad/s), not 0.5 rad/s,
for *any* controller that reaches this surface (``speed_on_surface`` in metrics).

Settings (``scenarios/asta-velocity.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``psi_dot_d``, ``duration``, ``rms_window``, ``Ts``, ``dt``, ``lam``, ``K``, ``rate``,
``Gamma0``, ``eps`` (this study's own file; the runs are :mod:`mwip.studies.asta_balance`'s).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mwip.metrics import rms
from mwip.studies import robot, settings
from mwip.studies.asta_balance import (
    common_metrics,
    run_pair,
    runs_doc,
    settings_doc,
    three_panel_figure,
)  # fmt: skip
from mwip.studies.common import metrics_document, write_metrics

SOURCE = "Figs. 4.5-4.7"
NAME = "asta-velocity"


def speed_on_surface(p: Any, psi_dot_d: float, lam: Sequence[float]) -> float:
    """Steady wheel speed on sigma_1 = 0 for the plant ``p`` (small-angle): see module doc."""
    l1, l2 = lam[0], lam[1]
    return float(l2 * psi_dot_d / (l2 + l1 * 2.0 * p.Dw / p.Gb))


def run(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """Run the study into ``out/asta-velocity``; returns the metrics document."""
    folder = Path(out) / NAME
    cfg = settings.current(NAME)
    duration = min(1.5, cfg["duration"]) if quick else cfg["duration"]
    window = (0.5 * duration, duration) if quick else tuple(cfg["rms_window"])
    psi_dot_d = cfg["psi_dot_d"]
    runs = run_pair(cfg, duration, psi_dot_d)
    metrics: dict[str, float] = {}
    for name, (res, s, sd, _) in runs.items():
        metrics[f"{name}.rms_speed_err"] = float(rms(res.t, res.q_dot[:, 0] - psi_dot_d, window))
        metrics[f"{name}.final_psi_dot"] = float(res.q_dot[-1, 0])
        metrics[f"{name}.final_abs_theta"] = float(abs(res.theta[-1]))
        metrics.update(common_metrics(name, res, s, sd))
    metrics["real.speed_on_surface"] = speed_on_surface(robot.plant(), psi_dot_d, cfg["lam"])
    metrics["matched.speed_on_surface"] = speed_on_surface(robot.nominal(), psi_dot_d, cfg["lam"])
    claims = []
    for p, where in (("", "real plant"), ("matched.", "nominal plant (extra)")):
        claims += [
            {"text": f"both reach the desired speed {psi_dot_d:g} rad/s (book, Fig. 4.5): RMS "
                     f"speed error < 0.05 rad/s, {where}",
             "holds": bool(max(metrics[f"{p}asta.rms_speed_err"],
                               metrics[f"{p}asmc.rms_speed_err"]) < 0.05),
             "keys": [f"{p}asta.rms_speed_err", f"{p}asmc.rms_speed_err"]},
            {"text": f"ASMC chatters, ASTA is smooth: ASTA's control and sliding variable have "
                     f"less total variation (book, Figs. 4.5-4.7), {where}",
             "holds": bool(metrics[f"{p}asta.u_tv"] < metrics[f"{p}asmc.u_tv"]
                           and metrics[f"{p}asta.s_tv"] < metrics[f"{p}asmc.s_tv"]),
             "keys": [f"{p}asta.u_tv", f"{p}asmc.u_tv", f"{p}asta.s_tv", f"{p}asmc.s_tv"]},
            {"text": f"ASTA: sigma and sigma' both converge (second-order sliding), {where}",
             "holds": bool(metrics[f"{p}asta.tail_max_abs_sigma1"] < 1e-3
                           and metrics[f"{p}asta.tail_max_abs_sigma1_dot"] < 0.1),
             "keys": [f"{p}asta.tail_max_abs_sigma1", f"{p}asta.tail_max_abs_sigma1_dot"]},
        ]  # fmt: skip
    doc = metrics_document(
        NAME, SOURCE, metrics, {}, claims, runs_doc(runs),
        {**settings_doc(cfg), "duration": duration, "window": list(window), "seed": 0,
         "plant": "real (matched.*: nominal)", "design": "nominal", "psi_dot_d": psi_dot_d,
         "published_note": "the book prints no numbers for this case (figures only)"},
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    three_panel_figure(runs, ("velocity", lambda r, s, sd: r.q_dot[:, 0], "[rad/s]"),
                       (0.7 * duration, 0.8 * duration),
                       "ASTA vs ASMC, velocity control, real plant (Figs. 4.5-4.7)",
                       folder / "asta-velocity.png")  # fmt: skip
    for name, (res, *_rest) in runs.items():
        res.to_npz(folder / f"{name.replace('.', '_')}.npz")
    write_metrics(folder, doc)
    return doc
