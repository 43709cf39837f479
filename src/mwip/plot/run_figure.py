"""The figure of one run, ``run.png``: what a person checks first after a simulation.

Six panels over time (SPEC.md section 2 conventions, SI units, angles in rad):

- pitch ``theta`` (rad);
- wheel speed ``psi'`` (rad/s) and its reference ``psi'_d`` where the run has one;
- yaw ``alpha`` (rad);
- wheel torques ``u_r, u_l`` (N m): commanded (the controller's output) and, on the digital
  twin, applied (``u_applied``: what the drive delivered);
- the estimated lumped disturbance ``tau_hat`` of (2.36) (rad/s^2, one trace per channel
  psi, theta, alpha) where an observer runs (a controller's ``tau_hat`` log, or an observer
  bank's ``do<n>`` logs), otherwise the pitch and yaw rates ``theta'``, ``alpha'`` (rad/s)
  with a note that no observer ran (no panel is left empty);
- the path ``(x, y)`` (m) from ``x' = v cos(alpha)``, ``y' = v sin(alpha)``.

The status (``ok``/``fell``/``diverged``) and the stop time are in the title; a run that
stopped early has a red line at its stop time on every time panel.

Every time panel spans at least :data:`MIN_SPAN` of its quantity, so that a signal is drawn
at its physical size: a yaw of 1e-17 rad (rounding) is a flat line at zero, not noise
magnified to full height. A torque beyond the drive's limit (:func:`torque_limit`: the
twin's RE25 drives at their current limit, ``DriveSpec.wheel_torque_limit``) is flagged:
the limit drawn at +-limit and the panel's title in red with the ratio.

The figure is drawn for display at its natural size, 1000 px wide (10 in at 100 dpi), with
fonts of at least 10 pt (14 px).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from mwip.io import write_atomic
from mwip.plot.runs import Run

__all__ = ["run_figure", "write_run_figure", "disturbance_estimates", "torque_limit",
           "MIN_SPAN", "DPI"]  # fmt: skip

DPI = 100
_STOPPED = "#c0392b"

#: The smallest y-axis span of a time panel, per unit: below it a signal is drawn flat.
MIN_SPAN = {"rad": 0.02, "rad/s": 0.1, "N m": 0.1, "rad/s^2": 0.1, "m": 0.1}


def torque_limit(run: Run) -> float:
    """The largest wheel torque the robot's drive gives (N m per wheel): ``run.torque_limit``
    when set (the run's twin), else the identified default twin's
    (:func:`mwip.hardware.identified.wheel_torque_limit`)."""
    if run.torque_limit is not None:
        return float(run.torque_limit)
    from mwip.hardware.identified import wheel_torque_limit

    return float(wheel_torque_limit())


def _min_span(ax: Axes, unit: str, *series: Any, axis: str = "y", fix: bool = True) -> None:
    """Widen ``ax``'s ``axis`` range to :data:`MIN_SPAN` ``[unit]`` about the data's middle:
    by fixing the limits, or (not ``fix``: an axes of equal aspect, whose limits matplotlib
    adjusts itself and would otherwise warn "Ignoring fixed y limits") by widening the data
    limits that autoscaling follows."""
    vals = np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in series])
    vals = vals[np.isfinite(vals)]
    span = MIN_SPAN[unit]
    lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 0.0)
    if hi - lo < span:
        mid = 0.5 * (lo + hi)
        mid = 0.0 if abs(mid) < 1e-9 * span else mid
        if fix:
            (ax.set_ylim if axis == "y" else ax.set_xlim)(mid - span / 2, mid + span / 2)
            return
        box = ax.dataLim
        at = box.x0 if axis == "y" else box.y0
        ends = [(at, mid - span / 2), (at, mid + span / 2)]
        ax.update_datalim(ends if axis == "y" else [(e, a) for a, e in ends])
        ax.autoscale_view()


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
    _min_span(a_th, "rad", x[:, 1])
    a_sp.plot(t, x[:, 3], color="C0", label="psi' (plant)")
    if run.reference is not None:
        a_sp.axhline(run.reference, color="k", ls=":", lw=1.4, label="reference psi'_d")
    a_sp.set_ylabel("wheel speed psi' (rad/s)")
    _min_span(a_sp, "rad/s", x[:, 3], *([] if run.reference is None else [[run.reference]]))
    a_sp.legend(loc="best", fontsize=10)
    a_al.plot(t, x[:, 2], color="C0")
    a_al.set_ylabel("yaw alpha (rad)")
    _min_span(a_al, "rad", x[:, 2])
    a_u.plot(t, u[:, 0], color="C1", lw=1.2, label="u_r commanded")
    a_u.plot(t, u[:, 1], color="C2", lw=1.2, ls=(0, (4, 2)), label="u_l commanded")
    applied = res.logs.get("u_applied")
    torques = [u]
    if applied is not None:  # wide and light, under the commanded torques
        ap = np.asarray(applied, dtype=float)
        ap = ap[0] if ap.ndim == 3 else ap
        a_u.plot(t, ap[:, 0], color="C1", lw=3.5, alpha=0.35, zorder=1, label="u_r applied")
        a_u.plot(t, ap[:, 1], color="C2", lw=3.5, alpha=0.35, zorder=1, label="u_l applied")
        torques.append(ap)
    a_u.set_ylabel("wheel torque (N m)")
    _min_span(a_u, "N m", *torques)
    limit = torque_limit(run)
    peak = float(np.nanmax(np.abs(u), initial=0.0))
    if peak > limit:
        for sign in (1, -1):
            a_u.axhline(sign * limit, color=_STOPPED, ls=":", lw=1.4,
                        label=f"drive limit +-{limit:.3g} N m" if sign > 0 else None)  # fmt: skip
        a_u.set_title(f"max |u| {peak:.3g} N m: {peak / limit:.1f}x the drive's limit",
                      color=_STOPPED, fontsize=11)  # fmt: skip
    a_u.legend(loc="best", fontsize=10, ncol=2)
    est = disturbance_estimates(run)
    if est:
        name, d = next(iter(est.items())) if "tau_hat" not in est else ("tau_hat", est["tau_hat"])
        for j, ch in enumerate(("psi", "theta", "alpha")):
            a_d.plot(t, d[:, j], color=f"C{j + 3}", label=f"{ch} channel")
        a_d.set_ylabel(f"estimated disturbance {name} (rad/s^2)", fontsize=10)
        a_d.legend(loc="best", fontsize=10)
        _min_span(a_d, "rad/s^2", d)
    else:  # no observer: the rates, so that no panel is empty
        a_d.plot(t, x[:, 4], color="C0", label="pitch rate theta'")
        a_d.plot(t, x[:, 5], color="C4", ls=(0, (4, 2)), label="yaw rate alpha'")
        a_d.set_ylabel("rates (rad/s)")
        a_d.set_title("no disturbance observer in this run", fontsize=10, color="#555")
        a_d.legend(loc="best", fontsize=10)
        _min_span(a_d, "rad/s", x[:, 4], x[:, 5])
    for ax in (a_th, a_sp, a_al, a_u, a_d):
        _stop_line(ax, run)
    a_xy.plot(x[:, 6], x[:, 7], color="C0")
    a_xy.plot(x[:1, 6], x[:1, 7], "o", color="k", label="start")
    a_xy.plot(x[-1:, 6], x[-1:, 7], "s", color=_STOPPED if run.status != "ok" else "C0",
              label="end")  # fmt: skip
    a_xy.set_xlabel("x (m)")
    a_xy.set_ylabel("y (m)")
    _min_span(a_xy, "m", x[:, 6], axis="x", fix=False)
    _min_span(a_xy, "m", x[:, 7], fix=False)
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
