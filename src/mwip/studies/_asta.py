"""The ASTA studies' shared kit (``asta-balance``, ``asta-velocity``; Sec. 4.3): the controllers
built from a study's settings, the paired runs, the sliding-variable measures and the book's
three-panel figure. Not a study itself: both studies import it, neither imports the other.

The settings read here (``theta0``, ``Ts``, ``dt``, ``lam``, ``K``, ``rate``, ``Gamma0``,
``eps``) are in both study files.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.laws.asta.controller import ASMC, ASTA, asta_surface
from mwip.metrics import total_variation_rate
from mwip.models.reduced import accelerations
from mwip.params import Params
from mwip.sim import SimResult, simulate
from mwip.studies.study import StudyContext

__all__ = ["REACHED", "ConventionalASMC", "common_metrics", "make", "reach_time", "run_pair",
           "runs_doc", "settings_doc", "sigma_dot", "three_panel_figure"]  # fmt: skip

REACHED = 0.01  # the reaching phase ends when |sigma_1| first falls to 1 % of |sigma_1(0)|


def make(
    kind: str, cfg: Mapping[str, Any], nominal: Params, psi_dot_ref: float = 0.0
) -> ASTA | ASMC:
    """The study's ASTA, ASMC or (``"casmc"``) conventional ASMC with the gains of ``cfg``,
    designed on ``nominal``."""
    classes: dict[str, type[ASTA] | type[ASMC]] = {"asta": ASTA, "asmc": ASMC,
                                                   "casmc": ConventionalASMC}  # fmt: skip
    cls = classes[kind]
    return cls(nominal, lam=tuple(cfg["lam"]), K=tuple(cfg["K"]),
               rate=tuple(cfg["rate"]), Gamma0=tuple(cfg["Gamma0"]), eps=cfg["eps"],
               psi_dot_ref=psi_dot_ref, Ts=cfg["Ts"])  # fmt: skip


class ConventionalASMC(ASMC):
    """Ours, an extra baseline (SPEC.md section 3): a conventional adaptive SMC,
    ``u_i = [-a_i - Gamma_i(t) sgn(sigma_i)] / b_i`` with the adaptive law (4.5), i.e. the
    book-defined ASMC without the super-twisting proportional term ``K_i |sigma_i|^(1/2)``."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # the same law and adaptive gain as ASMC, with no proportional STA term: K = 0 (the
        # one implementation, mwip.laws.asta.kernel.asta_sample, in both loops)
        self.K = np.zeros(2)


def sigma_dot(
    res: SimResult, plant: Params, lam: tuple[float, ...], psi_dot_ref: float = 0.0
) -> np.ndarray:
    """True ``sigma'`` (K, 2) from the plant's accelerations at each record (surface ``lam``)."""
    acc = accelerations(plant, res.q, res.q_dot, res.u)
    l1, l2, l3 = lam
    qd = res.q_dot
    return np.column_stack([acc[:, 1] + l1 * qd[:, 1] + l2 * acc[:, 0], acc[:, 2] + l3 * qd[:, 2]])


def run_pair(
    ctx: StudyContext, duration: float, psi_dot_ref: float = 0.0
) -> dict[str, tuple[SimResult, np.ndarray, np.ndarray, Params]]:
    """ASTA and ASMC on the plant and on the design model ("matched"), with the study's
    settings (``theta0``, ``Ts``, ``dt``, ``lam``, ``K``, ``rate``, ``Gamma0``, ``eps``)."""
    cfg = ctx.settings
    lam = tuple(cfg["lam"])
    out = {}
    for prefix, plant in (("", ctx.plant), ("matched.", ctx.nominal)):
        for kind in ("asta", "asmc"):
            ctrl = make(kind, cfg, ctx.nominal, psi_dot_ref)
            res = simulate(ctrl, plant, q0=(0.0, cfg["theta0"], 0.0), duration=duration,
                           Ts=cfg["Ts"], dt=cfg["dt"])  # fmt: skip
            s = asta_surface(res.q, res.q_dot, lam, (psi_dot_ref, 0.0, 0.0, 0.0))
            out[prefix + kind] = (res, s, sigma_dot(res, plant, lam, psi_dot_ref), plant)
    return out


def settings_doc(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """The settings block shared by both ASTA studies (the values used)."""
    Ts, dt = cfg["Ts"], cfg["dt"]
    step = (
        f"Ts = dt = {Ts * 1e3:g} ms" if Ts == dt else f"Ts = {Ts * 1e3:g} ms, dt = {dt * 1e3:g} ms"
    )
    return {"dt": dt, "Ts": Ts, "mode": f"sampled, quasi-continuous ({step})",
            "theta0": cfg["theta0"], "lambda": cfg["lam"], "K": cfg["K"],
            "adaptation_rate": cfg["rate"], "Gamma0": cfg["Gamma0"], "eps": cfg["eps"]}  # fmt: skip


def reach_time(t: np.ndarray, sigma: np.ndarray, fraction: float = REACHED) -> float:
    """First time ``|sigma| <= fraction |sigma(0)|`` (the end of the reaching phase); ``nan``
    if never."""
    a = np.abs(sigma)
    hit = np.flatnonzero(a <= fraction * a[0])
    return float(t[hit[0]]) if hit.size else float("nan")


def common_metrics(name: str, res: SimResult, s: np.ndarray, sd: np.ndarray) -> dict[str, float]:
    """Chattering and sliding measures shared by both ASTA studies."""
    t = res.t
    tail = t >= 0.5 * t[-1]
    g = res.series()["Gamma"]
    return {
        f"{name}.reach_time": reach_time(t, s[:, 0]),
        f"{name}.u_tv": float(np.sum(total_variation_rate(t, res.u.T))),
        f"{name}.s_tv": float(total_variation_rate(t, s[:, 0])),
        f"{name}.sdot_tv": float(total_variation_rate(t, sd[:, 0])),
        f"{name}.tail_max_abs_sigma1": float(np.nanmax(np.abs(s[tail, 0]))),
        f"{name}.tail_max_abs_sigma1_dot": float(np.nanmax(np.abs(sd[tail, 0]))),
        f"{name}.final_Gamma1": float(g[-1, 0]),
        f"{name}.tail_Gamma1_growth": float(g[-1, 0] - g[np.argmax(tail), 0]),
        f"{name}.max_abs_u": float(np.nanmax(np.abs(res.u))),
    }


def runs_doc(runs: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {k: {"status": str(v[0].status[0]), "t_end": float(v[0].t_end[0])}
            for k, v in runs.items()}  # fmt: skip


def three_panel_figure(
    runs: dict[str, Any],
    first: tuple[str, Any, str],
    zoom: tuple[float, float],
    title: str,
) -> Figure:
    """Book layout: a state (Fig. 4.2/4.5), sigma (4.3/4.6) and sigma' (4.4/4.7), each with a
    zoomed inset over ``zoom``; real-plant runs."""
    fig = Figure(figsize=(9, 10), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    label, getter, unit = first
    panels = [(label, getter, unit), ("S", lambda r, s, sd: s[:, 0], "[rad/s]"),
              ("dS", lambda r, s, sd: sd[:, 0], "[rad/s^2]")]  # fmt: skip
    for ax, (name, get, u) in zip(axes, panels, strict=True):
        ins = ax.inset_axes((0.55, 0.5, 0.4, 0.42))
        for kind, style in (("asmc", "r-"), ("asta", "b-")):
            res, s, sd, _ = runs[kind]
            y = get(res, s, sd)
            ax.plot(res.t, y, style, lw=0.8, label=kind.upper())
            win = (res.t >= zoom[0]) & (res.t <= zoom[1])
            ins.plot(res.t[win], y[win], style, lw=0.8)
        ins.tick_params(labelsize=7)
        ax.set_ylabel(f"{name} {u}")
        ax.legend(loc="lower left", fontsize=8)
    axes[-1].set_xlabel("Time [s]")
    fig.suptitle(title)
    return fig
