"""The TSMC studies' shared kit (``tsmc-equilibrium``, ``tsmc-velocity``, ``tsmc-circle``;
Sec. 4.4): the TSMC built from a study's settings, the continuous-mode loop, the replay of the
sliding variables, the book's state figure and a few measures. Not a study itself: the three
studies import it, none imports another. The steady-motion physics they share is
:mod:`mwip.models.steady`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.laws.switching import Switching
from mwip.laws.tsmc.controller import TSMC
from mwip.models.linear import linearize
from mwip.params import Params
from mwip.sim import SimResult, simulate
from mwip.sim.sensors import Measurement

__all__ = ["fitted_decay_time", "lean_text", "replay", "run_continuous", "slowest_lqr_pole",
           "state_figure", "state_norm_series", "tsmc_doc", "tsmc_from"]  # fmt: skip


def state_norm_series(res: SimResult, v_ref: float = 0.0, alpha_dot_ref: float = 0.0) -> Any:
    """``||[theta, alpha - alpha*(t), theta', v - v*, alpha' - alpha'*]||`` per record."""
    al = res.alpha - alpha_dot_ref * res.t
    x = np.column_stack(
        [res.theta, al, res.q_dot[:, 1], res.v - v_ref, res.q_dot[:, 2] - alpha_dot_ref]
    )
    return np.linalg.norm(x, axis=1)


def fitted_decay_time(t: Any, v: Any, t_from: float) -> float:
    """Time constant of ``|v|`` fitted as ``log|v|`` slope between the later of ``t_from`` and
    the middle of the record and its end; NaN when ``v`` does not decay there (or hits 0)."""
    t, v = np.asarray(t, dtype=float), np.abs(np.asarray(v, dtype=float))
    i0 = int(np.searchsorted(t, max(t_from, 0.5 * float(t[-1]))))
    if i0 >= t.size - 1 or not (v[i0] > v[-1] > 0.0):
        return float("nan")
    return float((t[-1] - t[i0]) / np.log(v[i0] / v[-1]))


def slowest_lqr_pole(K: Any, plant: Params, r_nominal: float) -> float:
    """Real part (rad/s) of the slowest closed-loop pole of ``u = -K x`` on the plant's
    linearisation, with ``v`` measured as ``r_nominal psi'`` (as :class:`LQR` does)."""
    A, B = linearize(plant)
    Km = np.array(K, dtype=float)
    Km[:, 3] *= r_nominal / plant.r  # the law's v = r_nom psi' = (r_nom / r) v_plant
    return float(np.max(np.linalg.eigvals(A - B @ Km).real))


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


def run_continuous(
    ctrl: Any, plant: Params, duration: float, *, Ts: float, dt: float, **kw: Any
) -> SimResult:
    """The studies' loop: ``ctrl`` inside the right-hand side of ``plant``, integration step
    ``dt``, records (and Jacobian refreshes) every ``Ts``."""
    return simulate(ctrl, plant, duration=duration, Ts=Ts, dt=dt, mode="continuous", **kw)


def tsmc_from(cfg: Mapping[str, Any], nominal: Params, **kw: Any) -> TSMC:
    """The TSMC with the gains of the settings ``cfg`` (``C``, ``Gamma``, ``D``,
    ``Ftilde_ratio``, ``Tf``, ``phi``) on the design model ``nominal``; ``kw``: its
    references."""
    return TSMC(
        nominal, C=tuple(cfg["C"]), Gamma=tuple(cfg["Gamma"]), D=cfg["D"],
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
    *,
    xy: bool = False,
) -> Figure:
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
        ax.plot(res.t, series, "k", lw=1.2, label="run")
        if key in targets:
            ax.plot(res.t, np.broadcast_to(targets[key], res.t.shape), "r", lw=1.0,
                    label="target")  # fmt: skip
        ax.set_ylabel(label)
        ax.set_xlabel("time [s]")
        ax.legend(loc="upper right", fontsize=8)
    ax = fig.add_subplot(gs[2, :])
    ax.plot(res.t, res.v, "k", lw=1.2, label="run")
    if "v" in targets:
        ax.plot(res.t, np.broadcast_to(targets["v"], res.t.shape), "r", lw=1.0, label="target")
    ax.set_ylabel("v [m/s]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
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
    return fig


def lean_text(lean: float) -> str:
    """``lean_for_speed``'s answer in words (NaN: no lean can hold the speed)."""
    if np.isfinite(lean):
        return f"a lean of {lean:.4f} rad"
    return "more than any lean gives (sin(theta) would exceed 1)"
