"""Study ``tsmc-equilibrium`` (Figs. 4.8-4.11): TSMC vs LQR, equilibrium control.

Set-up (SPEC.md section 4): real-parameter plant, nominal design, ``alpha0 = 0.5``,
``theta0 = 0.1``, ``v0 = 1`` m/s (``psi'0 = v0 / r_real``), 20 s. TSMC (4.30)-(4.32), (4.43)
with ``F~ = 0.8 |F^|``, ``C = 2.5 I``, ``Gamma = 10 I``, ``D = 0.4 I``, ``T_f = 1`` s,
saturation ``sat(s / phi)`` with ``phi = 0.05``. LQR: the book's ``Q, R``, continuous design.

Both laws are static functions of ``(t, measurement)``, so both run the book's way: in the
engine's ``"continuous"`` mode (law inside the right-hand side, L-stable ROS2 with the
closed-loop Jacobian), ``dt = 1 ms``, records every 5 ms. (Sampled at 0.5 ms the TSMC's
cancellation of the stiff damping terms and its state-dependent gain ``k ~ 2 |F^|`` make the
boundary layer unstable: ``k Ts / phi > 2``; see docs/chapter4.md.) The TSMC's sliding
variables are recomputed from the records with the same law (it is static).

Metrics: ``final_norm`` is ``||[theta, alpha, theta', v, alpha']||`` at the end;
``settling_time`` the time after which that norm stays below 2 % of its initial value.

Settings (``scenarios/tsmc-equilibrium.toml``, :mod:`mwip.studies.settings`): ``theta0``,
``alpha0``, ``v0``, ``duration``, ``Ts_record``, ``dt``, ``C``, ``Gamma``, ``D``,
``Ftilde_ratio``, ``Tf``, ``phi``, ``Q_diag``, ``R_diag``. The helpers below take what they
need as arguments, so the other TSMC studies run them with their own settings.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.control.lqr import LQR, design_lqr
from mwip.control.switching import Switching
from mwip.control.tsmc import TSMC
from mwip.io import write_atomic
from mwip.metrics import settling_time, total_variation_rate
from mwip.sim import SimResult, simulate
from mwip.sim.sensors import Measurement
from mwip.studies import robot, settings
from mwip.studies.common import metrics_document, save_figure, write_metrics

SOURCE = "Figs. 4.8-4.11"
NAME = "tsmc-equilibrium"


def state_norm_series(res: SimResult, v_ref: float = 0.0, alpha_dot_ref: float = 0.0) -> Any:
    """``||[theta, alpha - alpha*(t), theta', v - v*, alpha' - alpha'*]||`` per record."""
    al = res.alpha - alpha_dot_ref * res.t
    x = np.column_stack(
        [res.theta, al, res.q_dot[:, 1], res.v - v_ref, res.q_dot[:, 2] - alpha_dot_ref]
    )
    return np.linalg.norm(x, axis=1)


def save_npz(path: Path, **arrays: Any) -> None:
    """Write arrays to a compressed ``.npz`` atomically."""
    write_atomic(path, lambda fh: np.savez_compressed(fh, **arrays))


def replay(ctrl: TSMC, res: SimResult) -> dict[str, np.ndarray]:
    """Recompute the TSMC's logs (``s``, ``k``, ``aug``) on the records (the law is static)."""
    y = res.state
    ctrl.reset(Measurement(t=float(res.t[0]), y=y[:1]))
    out: dict[str, list[np.ndarray]] = {"s": [], "k": [], "aug": []}
    for i, t in enumerate(res.t):
        if not np.all(np.isfinite(y[i])):
            for v in out.values():
                v.append(np.full(2, np.nan))
            continue
        ctrl(float(t), Measurement(t=float(t), y=y[i : i + 1]))
        for name, v in out.items():
            v.append(np.asarray(ctrl.log()[name])[0])
    return {name: np.array(v) for name, v in out.items()}


def run_continuous(ctrl: Any, duration: float, *, Ts: float, dt: float, **kw: Any) -> SimResult:
    """The study's loop: ``ctrl`` inside the right-hand side of the real plant, integration
    step ``dt``, records (and Jacobian refreshes) every ``Ts``."""
    return simulate(ctrl, robot.plant(), duration=duration, Ts=Ts, dt=dt, mode="continuous", **kw)


def tsmc_from(cfg: Mapping[str, Any], **kw: Any) -> TSMC:
    """The TSMC with the gains of the settings ``cfg`` (``C``, ``Gamma``, ``D``,
    ``Ftilde_ratio``, ``Tf``, ``phi``) on the nominal model; ``kw``: its references."""
    return TSMC(
        robot.nominal(), C=tuple(cfg["C"]), Gamma=tuple(cfg["Gamma"]), D=cfg["D"],
        Ftilde_ratio=cfg["Ftilde_ratio"], Tf=cfg["Tf"], switching=Switching("sat", cfg["phi"]),
        **kw,
    )  # fmt: skip


def tsmc_doc(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The TSMC gains of the settings ``cfg`` as recorded in metrics.json."""
    return {"C": cfg["C"], "Gamma": cfg["Gamma"], "D": cfg["D"],
            "Ftilde_ratio": cfg["Ftilde_ratio"], "Tf": cfg["Tf"],
            "switching": f"sat(s/{cfg['phi']})"}  # fmt: skip


def state_figure(
    res: SimResult,
    targets: dict[str, Any],
    title: str,
    path: Path,
    *,
    xy: bool = False,
) -> None:
    """The book's layout: theta, theta' / alpha, alpha' / v (Figs. 4.8, 4.10, ...), the wheel
    torques below (Figs. 4.9, 4.11, ...), and optionally the x-y path (Fig. 4.17)."""
    rows = 5 if xy else 4
    fig = Figure(figsize=(11, 2.4 * rows), layout="constrained")
    gs = fig.add_gridspec(rows, 2)
    panels = [
        ("theta", res.theta, "theta [rad]"),
        ("theta_dot", res.q_dot[:, 1], "d theta/dt [rad/s]"),
        ("alpha", res.alpha, "alpha [rad]"),
        ("alpha_dot", res.q_dot[:, 2], "d alpha/dt [rad/s]"),
    ]
    for j, (key, series, label) in enumerate(panels):
        ax = fig.add_subplot(gs[j // 2, j % 2])
        ax.plot(res.t, series, "k", lw=1.2)
        if key in targets:
            ax.plot(res.t, np.broadcast_to(targets[key], res.t.shape), "r", lw=1.0)
        ax.set_ylabel(label)
        ax.set_xlabel("time [s]")
    ax = fig.add_subplot(gs[2, :])
    ax.plot(res.t, res.v, "k", lw=1.2)
    if "v" in targets:
        ax.plot(res.t, np.broadcast_to(targets["v"], res.t.shape), "r", lw=1.0)
    ax.set_ylabel("v [m/s]")
    ax.set_xlabel("time [s]")
    ax = fig.add_subplot(gs[3, :])
    ax.plot(res.t, res.u[:, 0], "b", lw=1.0, label="tau_r")
    ax.plot(res.t, res.u[:, 1], "r--", lw=1.0, label="tau_l")
    ax.set_ylabel("tau [N m]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right")
    if xy:
        ax = fig.add_subplot(gs[4, :])
        ax.plot(res.x, res.y, "k", lw=1.2, label="path")
        if "circle" in targets:
            cx, cy, rad = targets["circle"]
            ang = np.linspace(0, 2 * np.pi, 200)
            ax.plot(cx + rad * np.cos(ang), cy + rad * np.sin(ang), "r", lw=0.8, label="target")
        ax.set_xlabel("X [m]")
        ax.set_ylabel("Y [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(loc="upper right")
    fig.suptitle(title)
    save_figure(fig, path)


def run(out: Path, *, quick: bool = False) -> dict[str, Any]:
    """Run the study into ``out/tsmc-equilibrium``; returns the metrics document."""
    folder = Path(out) / NAME
    cfg = settings.current(NAME)
    duration = min(1.5, cfg["duration"]) if quick else cfg["duration"]
    Tf = cfg["Tf"]
    init = {"q0": (0.0, cfg["theta0"], cfg["alpha0"]),
            "qdot0": (cfg["v0"] / robot.plant().r, 0.0, 0.0),
            "Ts": cfg["Ts_record"], "dt": cfg["dt"]}  # fmt: skip
    tsmc = tsmc_from(cfg)
    lqr = LQR(design_lqr(robot.nominal(), np.diag(cfg["Q_diag"]), np.diag(cfg["R_diag"]), Ts=None))
    runs = {
        "tsmc": run_continuous(tsmc, duration, **init),
        "lqr": run_continuous(lqr, duration, **init),
    }
    logs = replay(tsmc, runs["tsmc"])

    metrics: dict[str, float] = {}
    for name, res in runs.items():
        norm = state_norm_series(res)
        metrics[f"{name}.final_norm"] = float(norm[-1])
        metrics[f"{name}.settling_time"] = settling_time(res.t, norm, band=0.02 * norm[0])
        metrics[f"{name}.max_abs_u"] = float(np.nanmax(np.abs(res.u)))
        metrics[f"{name}.u_tv"] = float(np.sum(total_variation_rate(res.t, res.u.T)))
        metrics[f"{name}.final_abs_u"] = float(np.max(np.abs(res.u[-1])))
        i_tf = min(int(np.searchsorted(res.t, Tf)), len(res.t) - 1)  # a run shorter than T_f: end
        metrics[f"{name}.abs_theta_at_Tf"] = float(abs(res.theta[i_tf]))
        metrics[f"{name}.abs_alpha_at_Tf"] = float(abs(res.alpha[i_tf]))
        metrics[f"{name}.t_end"] = float(res.t_end[0])
    tail = runs["tsmc"].t >= Tf
    metrics["tsmc.max_abs_s_after_Tf"] = (
        float(np.nanmax(np.abs(logs["s"][tail]))) if tail.any() else float("nan")
    )
    metrics["tsmc.abs_s0"] = float(np.max(np.abs(logs["s"][0])))
    tol = 0.01  # of a norm that starts at 1.12
    claims = [
        {"text": "TSMC drives the states to the equilibrium (book, Fig. 4.8)",
         "holds": bool(runs["tsmc"].ok and metrics["tsmc.final_norm"] < tol),
         "keys": ["tsmc.t_end", "tsmc.final_norm"]},
        {"text": "LQR drives the states to the equilibrium (book, Fig. 4.10)",
         "holds": bool(runs["lqr"].ok and metrics["lqr.final_norm"] < tol),
         "keys": ["lqr.t_end", "lqr.final_norm"]},
        {"text": "TSMC torques converge to zero (book, Fig. 4.9)",
         "holds": bool(metrics["tsmc.final_abs_u"] < 0.01), "keys": ["tsmc.final_abs_u"]},
        {"text": "augmented surface is zero at t = 0 (cubic initial conditions (4.43))",
         "holds": bool(metrics["tsmc.abs_s0"] < 1e-9), "keys": ["tsmc.abs_s0"]},
        {"text": f"TSMC: theta and alpha within 0.01 rad of their targets at T_f = {Tf:g} s",
         "holds": bool(metrics["tsmc.abs_theta_at_Tf"] < 0.01
                       and metrics["tsmc.abs_alpha_at_Tf"] < 0.01),
         "keys": ["tsmc.abs_theta_at_Tf", "tsmc.abs_alpha_at_Tf"]},
    ]  # fmt: skip
    doc = metrics_document(
        NAME, SOURCE, metrics, {}, claims,
        {k: {"status": str(v.status[0]), "t_end": float(v.t_end[0])} for k, v in runs.items()},
        {"dt": cfg["dt"], "Ts": cfg["Ts_record"], "mode": "continuous (law inside the "
         "right-hand side, ROS2 with closed-loop Jacobian); Ts is the record/Jacobian-refresh "
         "period",
         "duration": duration, "plant": "real", "design": "nominal", "seed": 0,
         "initial": {"theta0": cfg["theta0"], "alpha0": cfg["alpha0"], "v0": cfg["v0"]},
         "tsmc": tsmc_doc(cfg), "lqr": "Q_diag, R_diag, continuous design",
         "Q_diag": cfg["Q_diag"], "R_diag": cfg["R_diag"],
         "settling": "||x|| stays below 2 % of ||x(0)||",
         "published_note": "the book prints no numbers for this case (figures only)"},
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    targets = {"theta": 0.0, "theta_dot": 0.0, "alpha": 0.0, "alpha_dot": 0.0, "v": 0.0}
    state_figure(runs["tsmc"], targets, "TSMC, equilibrium control (Figs. 4.8-4.9)",
                 folder / "tsmc-equilibrium_tsmc.png")  # fmt: skip
    state_figure(runs["lqr"], targets, "LQR, equilibrium control (Figs. 4.10-4.11)",
                 folder / "tsmc-equilibrium_lqr.png")  # fmt: skip
    for name, res in runs.items():
        res.to_npz(folder / f"{name}.npz")
    save_npz(folder / "tsmc_sliding.npz", t=runs["tsmc"].t, **logs)
    write_metrics(folder, doc)
    return doc
