"""``mwip campaign report DIR``: ``DIR/report.html`` and its PNGs from ``DIR/results.parquet``.

Robustness campaigns:

- a league table per controller: success rate ``k / n`` with its Wilson 95 % interval
  (:func:`mwip.campaign.stats.wilson`), then the median and 95th percentile of each metric
  over the samples that did not fall (``fall_time``: over those that fell);
- success rate against each uncertain parameter and initial-state coordinate (the samples
  binned on it; a bin's rate with its Wilson interval);
- region-of-attraction maps: the success rate on the ``theta0 x theta_dot0`` plane and on
  parameter planes (``mb x l`` and any pair of grid axes), one panel per controller, with the
  boundary (the 50 % contour of the rate) drawn.

Claims campaigns: per claim, the fraction of plausible settings under which it holds, with
its interval (:mod:`mwip.campaign.claims`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.campaign.metrics import METRICS
from mwip.campaign.spec import INITIAL_KEYS
from mwip.campaign.stats import wilson
from mwip.io import html_text, write_atomic, write_text_atomic
from mwip.params import PARAM_FIELDS

__all__ = ["league_table", "write_campaign_report", "success_by_bins", "plane_rates",
           "torque_note"]

_NUMERIC = [m for m in METRICS if m not in ("status", "success")]
_UNITS = {
    "fall_time": "s",
    "settling_time": "s",
    "rms_theta": "rad",
    "rms_speed_error": "m/s",
    "peak_torque": "N m",
    "control_tv": "N m/s",
    "energy": "J",
}
_LABELS = {
    "theta0": "theta0 (rad)",
    "theta_dot0": "theta_dot0 (rad/s)",
    "psi_dot0": "psi_dot0 (rad/s)",
    "alpha0": "alpha0 (rad)",
    "alpha_dot0": "alpha_dot0 (rad/s)",
    "psi0": "psi0 (rad)",
    "mb": "mb (kg)",
    "mw": "mw (kg)",
    "Iby": "Iby (kg m^2)",
    "Ibz": "Ibz (kg m^2)",
    "Iwa": "Iwa (kg m^2)",
    "Iwd": "Iwd (kg m^2)",
    "l": "l (m)",
    "b": "b (m)",
    "r": "r (m)",
    "Db": "Db (N m s/rad)",
    "Dw": "Dw (N m s/rad)",
    "g": "g (m/s^2)",
    "Iyaw": "Iyaw (kg m^2)",
}


def league_table(df: Any) -> list[dict[str, Any]]:
    """One row per controller (table order): n, successes, rate, Wilson interval, and the
    median and 95th percentile of every metric."""
    rows = []
    for name in dict.fromkeys(df["controller"]):
        g = df[df["controller"] == name]
        k, n = int(g["success"].sum()), len(g)
        lo, hi = wilson(k, n)
        row: dict[str, Any] = {
            "controller": name,
            "n": n,
            "success": k,
            "rate": k / n,
            "lo": lo,
            "hi": hi,
            "fell": int((g["status"] != "ok").sum()),
        }
        up = g[g["status"] == "ok"]
        for m in _NUMERIC:
            vals = (g if m == "fall_time" else up)[m].to_numpy(dtype=float)
            vals = vals[np.isfinite(vals)]
            row[f"{m}_median"] = float(np.median(vals)) if vals.size else math.nan
            row[f"{m}_p95"] = float(np.percentile(vals, 95)) if vals.size else math.nan
        rows.append(row)
    return rows


def _varying(df: Any, cols: list[str]) -> list[str]:
    return [c for c in cols if c in df and df[c].nunique() > 1]


def success_by_bins(df: Any, col: str, bins: int = 8) -> dict[str, Any]:
    """Per controller: bin centres of ``col`` and the success rate with its interval in each
    bin (distinct values as bins when there are at most ``bins`` of them, else equal-width)."""
    x = df[col].to_numpy(dtype=float)
    distinct = np.unique(x)
    if distinct.size <= bins:
        centres, which = distinct, np.searchsorted(distinct, x)
    else:
        edges = np.linspace(x.min(), x.max(), bins + 1)
        centres = 0.5 * (edges[:-1] + edges[1:])
        which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
    out: dict[str, Any] = {"x": centres, "controllers": {}}
    succ = df["success"].to_numpy(dtype=bool)
    ctrl = df["controller"].to_numpy()
    for name in dict.fromkeys(ctrl):
        rate, lo, hi = [], [], []
        for b in range(centres.size):
            m = (ctrl == name) & (which == b)
            k, n = int(succ[m].sum()), int(m.sum())
            w = wilson(k, n)
            rate.append(k / n if n else math.nan)
            lo.append(w[0])
            hi.append(w[1])
        out["controllers"][name] = (np.array(rate), np.array(lo), np.array(hi))
    return out


def plane_rates(df: Any, x: str, y: str) -> tuple[Any, Any, dict[str, Any]]:
    """Success rate on the ``x``-``y`` plane per controller. A column that repeats its values
    (a grid axis: at most 60 distinct values, each used twice or more on average) keeps them;
    otherwise equal-width bins, as many as give about 8 samples per cell (4 to 15 a side)."""
    n_per = len(df) / max(df["controller"].nunique(), 1)
    bins = int(np.clip(np.sqrt(n_per / 8.0), 4, 15))
    xv, yv = df[x].to_numpy(dtype=float), df[y].to_numpy(dtype=float)
    axes = []
    for v in (xv, yv):
        d = np.unique(v)
        if d.size <= 60 and d.size <= n_per / 2:
            axes.append((d, np.searchsorted(d, v)))
        else:
            edges = np.linspace(v.min(), v.max(), bins + 1)
            which = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, bins - 1)
            axes.append((0.5 * (edges[:-1] + edges[1:]), which))
    (cx, ix), (cy, iy) = axes
    succ = df["success"].to_numpy(dtype=float)
    ctrl = df["controller"].to_numpy()
    maps = {}
    for name in dict.fromkeys(ctrl):
        m = ctrl == name
        tot = np.zeros((cy.size, cx.size))
        hit = np.zeros((cy.size, cx.size))
        np.add.at(tot, (iy[m], ix[m]), 1.0)
        np.add.at(hit, (iy[m], ix[m]), succ[m])
        with np.errstate(invalid="ignore"):
            maps[name] = hit / tot
    return cx, cy, maps


def _save(fig: Figure, path: Path) -> str:
    import warnings

    with warnings.catch_warnings():  # a label with a control character draws a box, silently
        warnings.filterwarnings("ignore", message="Glyph .* missing from font")
        write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=110))
    return path.name


def _fig_league(rows: list[dict[str, Any]], path: Path) -> str:
    fig = Figure(figsize=(7.0, 0.45 * len(rows) + 1.4), layout="constrained")
    ax = fig.add_subplot()
    names = [r["controller"] for r in rows][::-1]
    rate = np.array([r["rate"] for r in rows])[::-1] * 100
    lo = np.array([r["lo"] for r in rows])[::-1] * 100
    hi = np.array([r["hi"] for r in rows])[::-1] * 100
    ax.barh(names, rate, color="tab:blue", alpha=0.7)
    ax.errorbar(rate, names, xerr=[rate - lo, hi - rate], fmt="none", ecolor="k", capsize=4)
    ax.set_xlim(0, 100)
    ax.set_xlabel("success rate (%), Wilson 95 % interval")
    ax.grid(axis="x", alpha=0.3)
    return _save(fig, path)


def _fig_bins(df: Any, col: str, path: Path) -> str:
    data = success_by_bins(df, col)
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.add_subplot()
    for name, (rate, lo, hi) in data["controllers"].items():
        line = ax.plot(data["x"], 100 * rate, "o-", label=name)[0]
        ax.fill_between(data["x"], 100 * lo, 100 * hi, color=line.get_color(), alpha=0.12)
    ax.set_ylim(-3, 103)
    ax.set_xlabel(_LABELS.get(col, col))
    ax.set_ylabel("success rate (%)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="lower left")
    return _save(fig, path)


def _fig_plane(df: Any, x: str, y: str, path: Path) -> str:
    cx, cy, maps = plane_rates(df, x, y)
    n = len(maps)
    cols = min(3, n)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(3.6 * cols + 0.8, 3.1 * rows + 0.4), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    im = None
    for ax, (name, rate) in zip(axes.flat, maps.items(), strict=False):
        dx = (cx[1] - cx[0]) / 2 if cx.size > 1 else 0.5
        dy = (cy[1] - cy[0]) / 2 if cy.size > 1 else 0.5
        im = ax.imshow(
            rate,
            origin="lower",
            aspect="auto",
            vmin=0,
            vmax=1,
            cmap="RdYlGn",
            extent=(cx[0] - dx, cx[-1] + dx, cy[0] - dy, cy[-1] + dy),
        )
        if cx.size > 1 and cy.size > 1 and np.nanmin(rate) < 0.5 < np.nanmax(rate):
            ax.contour(
                cx, cy, np.nan_to_num(rate, nan=0.0), levels=[0.5], colors="k", linewidths=1.5
            )
        ax.set_title(name, fontsize=10)
        ax.set_xlabel(_LABELS.get(x, x), fontsize=9)
        ax.set_ylabel(_LABELS.get(y, y), fontsize=9)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    if im is not None:
        fig.colorbar(im, ax=axes, shrink=0.8, label="success rate (black: 50 % boundary)")
    return _save(fig, path)


def torque_note() -> str:
    """What ``peak_torque`` is, beside the drive limit ``mwip simulate`` and the run figures
    name (the two torques of a run; the limit is the default twin's)."""
    from mwip.hardware.identified import wheel_torque_limit

    return ("peak_torque: the largest |torque| applied to a wheel in a run (N m per wheel; "
            "median / p95 over the runs that did not fall). On the plain plant that is the "
            "controller's command, which no drive limits; on the twin, what its drive delivered. "
            "The robot's drive (the default twin's RE25 through its gearbox at its current "
            f"limit, `mwip robot show`) gives at most {wheel_torque_limit():.3g} N m per wheel: "
            "the \"drive limit\" that `mwip simulate` compares its commanded max |u| with and "
            "the run figures draw. A plain-plant run whose peak_torque exceeds it asked for more "
            "than the robot could give.")  # fmt: skip


def _fmt(x: float) -> str:
    return "" if not math.isfinite(x) else f"{x:.3g}"


def _league_html(rows: list[dict[str, Any]]) -> str:
    head = ["controller", "n", "success (95 % interval)", "fell"] + [
        f"{m} ({_UNITS[m]}) median / p95" for m in _NUMERIC
    ]
    out = ["<table><tr>" + "".join(f"<th>{html_text(h)}</th>" for h in head) + "</tr>"]
    for r in rows:
        cells = [
            html_text(str(r["controller"])),
            str(r["n"]),
            f"{100 * r['rate']:.1f} % ({100 * r['lo']:.1f}-{100 * r['hi']:.1f} %)",
            str(r["fell"]),
        ]
        cells += [f"{_fmt(r[f'{m}_median'])} / {_fmt(r[f'{m}_p95'])}" for m in _NUMERIC]
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return "\n".join(out + ["</table>"])


_CSS = (
    "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em}"
    "table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;"
    "padding:3px 6px;text-align:right}td:first-child{text-align:left}"
    "img{max-width:100%;display:block;margin:0.5em 0}"
)


def write_campaign_report(out: str | Path) -> Path:
    """Write ``out/report.html`` and ``out/fig-*.png``; returns the page's path."""
    import pandas as pd

    out = Path(out)
    df = pd.read_parquet(out / "results.parquet")
    rec: Any = {}
    path = out / "campaign.json"
    if path.exists():
        try:
            rec = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise ValueError(f"{str(path)!r} is not a campaign record (not JSON: {exc})") from None
    spec = rec.get("campaign", {}) if isinstance(rec, dict) else None
    camp = spec.get("campaign", {}) if isinstance(spec, dict) else None
    if not isinstance(camp, dict):
        raise ValueError(f"{str(path)!r} is not a campaign record (no campaign table); rerun "
                         "`mwip campaign run` into a new folder")  # fmt: skip
    title = str(camp.get("title", "")) or out.name
    parts = [
        f"<!doctype html><html><head><meta charset='utf-8'><title>{html_text(title)}"
        f"</title><style>{_CSS}</style></head><body><h1>{html_text(title)}</h1>"
    ]
    if "claim" in df:
        parts.append(_claims_html(df))
    else:
        parts.append(
            f"<p>{df['sample'].nunique()} samples x {df['controller'].nunique()} "
            "controllers. Success: did not fall and |theta| stayed below the "
            "campaign's success_theta throughout the last second. Metrics over the samples "
            "that did not fall "
            "(fall time: over those that fell).</p>"
        )
        rows = league_table(df)
        parts.append("<h2>League table</h2>" + _league_html(rows) + f"<p>{torque_note()}</p>")
        parts.append(f"<img src='{_fig_league(rows, out / 'fig-league.png')}' alt='league'>")
        inputs = _varying(df, list(PARAM_FIELDS) + [f"{k}0" for k in INITIAL_KEYS])
        if inputs:
            parts.append("<h2>Success against each uncertain input</h2>")
            for col in inputs:
                name = _fig_bins(df, col, out / f"fig-success-{col}.png")
                parts.append(f"<h3>{html_text(col)}</h3><img src='{name}' alt='{col}'>")
        src = rec.get("campaign", {})
        unc = src.get("robot", {}).get("uncertainty", {})
        grid = [k for k, v in unc.items() if isinstance(v, dict) and "grid" in v]
        init = src.get("initial", {})
        grid += [f"{k}0" for k, v in init.items() if isinstance(v, dict) and "grid" in v]
        candidates = [("theta0", "theta_dot0"), ("mb", "l")]
        if len(grid) >= 2 and set(grid[:2]) not in [set(c) for c in candidates]:
            candidates.append((grid[0], grid[1]))
        planes = [(x, y) for x, y in candidates if x in inputs and y in inputs]
        if planes:
            parts.append("<h2>Regions of attraction</h2>")
            for x, y in planes:
                name = _fig_plane(df, x, y, out / f"fig-roa-{x}-{y}.png")
                parts.append(f"<h3>{x} x {y}</h3><img src='{name}' alt='roa {x} {y}'>")
    parts.append("</body></html>\n")
    return write_text_atomic(out / "report.html", "\n".join(parts))


def _claims_html(df: Any) -> str:
    from mwip.campaign.claims import claim_robustness

    table = claim_robustness(df)
    errors = int((df["error"] != "").sum())
    rows = [
        "<h2>Claims over their open settings</h2>",
        f"<p>{errors} study runs failed (excluded).</p>" if errors else "",
        "<table><tr><th>study</th><th>claim</th><th>book</th><th>holds in</th>"
        "<th>95 % interval</th><th>n</th></tr>",
    ]
    for r in table.values():
        rows.append(
            f"<tr><td>{html_text(r.study)}</td><td>{html_text(r.claim)}</td>"
            f"<td>{html_text(r.book)}</td><td>{100 * r.fraction:.0f} %</td>"
            f"<td>{100 * r.lo:.0f}-{100 * r.hi:.0f} %</td><td>{r.n}</td></tr>"
        )
    return "\n".join(rows + ["</table>"])
