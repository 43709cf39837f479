"""The figure of one run, ``run.png``: what a person checks first after a simulation.

Six panels over time (SPEC.md section 2 conventions, SI units, angles in rad):

- pitch ``theta`` (rad);
- wheel speed ``psi'`` (rad/s) and its reference ``psi'_d`` where the run has one;
- yaw ``alpha`` (rad);
- wheel torques ``u_r, u_l`` (N m): commanded (the controller's output) and, on the digital
  twin, applied (``u_applied``: what the drive delivered);
- the estimated lumped disturbance ``tau_hat`` of (2.36) (rad/s^2, one trace per channel
  psi, theta, alpha) where an observer runs (a controller's ``tau_hat`` log, or an observer
  bank's ``do<n>`` logs), otherwise a note saying there is none;
- the path ``(x, y)`` (m) from ``x' = v cos(alpha)``, ``y' = v sin(alpha)``.

The status (``ok``/``fell``/``diverged``) and the stop time are in the title; a run that
stopped early has a red line at its stop time on every time panel.

The figure is drawn for display at its natural size, 1000 px wide (10 in at 100 dpi), with
fonts of at least 10 pt (14 px).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from mwip.io import write_atomic
from mwip.plot.runs import Run

__all__ = ["run_figure", "write_run_figure", "disturbance_estimates", "DPI"]

DPI = 100
_STOPPED = "#c0392b"


def disturbance_estimates(run: Run) -> dict[str, np.ndarray]:
    """The run's disturbance estimates, name -> (K, 3) (``tau_hat``, ``do<n>``); an estimate
    that is zero throughout is a law without observer (conventional SMC logs ``tau_hat = 0``)
    and is left out."""
    out = {}
    for name, arr in run.result.logs.items():
        a = np.asarray(arr, dtype=float)
        a = a[0] if a.ndim == 3 else a
        named = name == "tau_hat" or re.fullmatch(r"do\d+", name)
        if named and a.ndim == 2 and a.shape[1] == 3 and np.nanmax(np.abs(a), initial=0.0) > 0:
            out[name] = a
    return out


def _stop_line(ax: Axes, run: Run) -> None:
    if run.status != "ok":
        ax.axvline(run.t_end, color=_STOPPED, lw=1.2, ls="--")


def run_figure(run: Run, title: str | None = None) -> Figure:
    """Draw ``run`` (see module docstring); returns a matplotlib Figure (no pyplot)."""
    res = run.result
    t = np.asarray(res.t, dtype=float)
    x = np.asarray(res.state, dtype=float)
    u = np.asarray(res.u, dtype=float)
    fig = Figure(figsize=(10, 9.6), dpi=DPI, layout="constrained")
    axs = fig.subplots(3, 2)
    (a_th, a_u), (a_sp, a_d), (a_al, a_xy) = axs
    for ax in (a_th, a_sp, a_al, a_u, a_d):
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("t (s)")
    a_th.plot(t, x[:, 1], color="C0")
    a_th.set_ylabel("pitch theta (rad)")
    a_sp.plot(t, x[:, 3], color="C0", label="psi' (plant)")
    if run.reference is not None:
        a_sp.axhline(run.reference, color="k", ls=":", lw=1.4, label="reference psi'_d")
    a_sp.set_ylabel("wheel speed psi' (rad/s)")
    a_sp.legend(loc="best", fontsize=10)
    a_al.plot(t, x[:, 2], color="C0")
    a_al.set_ylabel("yaw alpha (rad)")
    a_u.plot(t, u[:, 0], color="C1", lw=1.2, label="u_r commanded")
    a_u.plot(t, u[:, 1], color="C2", lw=1.2, ls=(0, (4, 2)), label="u_l commanded")
    applied = res.logs.get("u_applied")
    if applied is not None:  # wide and light, under the commanded torques
        ap = np.asarray(applied, dtype=float)
        ap = ap[0] if ap.ndim == 3 else ap
        a_u.plot(t, ap[:, 0], color="C1", lw=3.5, alpha=0.35, zorder=1, label="u_r applied")
        a_u.plot(t, ap[:, 1], color="C2", lw=3.5, alpha=0.35, zorder=1, label="u_l applied")
    a_u.set_ylabel("wheel torque (N m)")
    a_u.legend(loc="best", fontsize=10, ncol=2)
    est = disturbance_estimates(run)
    if est:
        name, d = next(iter(est.items())) if "tau_hat" not in est else ("tau_hat", est["tau_hat"])
        for j, ch in enumerate(("psi", "theta", "alpha")):
            a_d.plot(t, d[:, j], color=f"C{j + 3}", label=f"{ch} channel")
        a_d.set_ylabel(f"estimated disturbance {name} (rad/s^2)", fontsize=10)
        a_d.legend(loc="best", fontsize=10)
    else:
        a_d.text(0.5, 0.5, "no disturbance observer in this run", ha="center", va="center",
                 transform=a_d.transAxes, fontsize=11, color="#555")  # fmt: skip
        a_d.set_ylabel("estimated disturbance (rad/s^2)", fontsize=10)
        a_d.set_yticks([])
    for ax in (a_th, a_sp, a_al, a_u, a_d):
        _stop_line(ax, run)
    a_xy.plot(x[:, 6], x[:, 7], color="C0")
    a_xy.plot(x[:1, 6], x[:1, 7], "o", color="k", label="start")
    a_xy.plot(x[-1:, 6], x[-1:, 7], "s", color=_STOPPED if run.status != "ok" else "C0",
              label="end")  # fmt: skip
    a_xy.set_xlabel("x (m)")
    a_xy.set_ylabel("y (m)")
    a_xy.set_aspect("equal", adjustable="datalim")
    a_xy.grid(True, alpha=0.3)
    a_xy.legend(loc="best", fontsize=10)
    status = run.status if run.status == "ok" else f"{run.status.upper()} at t = {run.t_end:.3f} s"
    head = title or run.name
    fig.suptitle(f"{head}: status {status} (records 0-{run.t_end:.3g} s)", fontsize=13,
                 color="k" if run.status == "ok" else _STOPPED)  # fmt: skip
    return fig


def write_run_figure(run: Run, path: Path, title: str | None = None) -> Path:
    """Draw ``run`` and save it as PNG at ``path`` (atomically)."""
    fig = run_figure(run, title)
    return write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=DPI))
