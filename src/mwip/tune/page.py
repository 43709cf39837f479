"""The result page of a tuning run: ``DIR/index.html`` and its figures (PNG, matplotlib).

- ``history.png``: every trial's cost (pruned trials at their bound, marked), the best so far;
  pareto mode: the failure rate per trial;
- ``importance.png``: the parameters' importances for the (first) objective (Optuna's fANOVA);
- ``pareto.png``: the trials in the plane of the first two objectives (failure rate and the
  first term), the Pareto front joined; scalar mode: success rate against the first term;
- ``validation.png``: success rates of the book's and the tuned settings on the tuning and
  validation robots with their Wilson 95 % intervals.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mwip.io import html_text

__all__ = ["write_page", "pareto_front"]


def pareto_front(points: Any) -> list[int]:
    """Indices of the non-dominated rows of ``points`` (N, M) (all objectives minimised), in
    input order."""
    pts = np.asarray(points, dtype=float)
    keep = []
    for i, p in enumerate(pts):
        dominated = np.any(np.all(pts <= p, axis=1) & np.any(pts < p, axis=1))
        if not dominated:
            keep.append(i)
    return keep


def _save(fig: Any, path: Path) -> str:
    from mwip.io import write_atomic

    write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=110))
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path.name


def _history(trials: Sequence[Mapping[str, Any]], out: Path) -> str:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.6))
    done = [t for t in trials if t["state"] == "COMPLETE"]
    pruned = [t for t in trials if t["state"] == "PRUNED" and t.get("bound") is not None]
    x = [t["number"] for t in done]
    y = [t["values"][0] for t in done]
    ax.plot(x, y, "o", ms=4, color="C0", label="complete")
    if pruned:
        ax.plot([t["number"] for t in pruned], [t["bound"] for t in pruned], "x", ms=5,
                color="C3", label="pruned (its bound)")  # fmt: skip
    if y:
        ax.step(x, np.minimum.accumulate(y), where="post", color="k", lw=1.2, label="best so far")
    ax.set_xlabel("trial")
    ax.set_ylabel("cost (failures + terms) / N" if trials and len(done[0]["values"]) == 1
                  else "failure rate")  # fmt: skip
    shown = [v for v in y + [t["bound"] for t in pruned] if v is not None]
    if shown and min(shown) > 0:
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("optimisation history")
    fig.tight_layout()
    return _save(fig, out / "history.png")


def _importance(importances: Mapping[str, float], out: Path) -> str | None:
    if not importances:
        return None
    import matplotlib.pyplot as plt

    names = list(importances)[::-1]
    fig, ax = plt.subplots(figsize=(6, 0.35 * len(names) + 1.2))
    ax.barh(names, [importances[n] for n in names], color="C0")
    ax.set_xlabel("importance (fANOVA, share of the cost's variance)")
    ax.set_title("parameter importances")
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return _save(fig, out / "importance.png")


def _pareto(trials: Sequence[Mapping[str, Any]], labels: Sequence[str], out: Path) -> str | None:
    done = [t for t in trials if t["state"] == "COMPLETE" and t.get("objectives")]
    if not done or len(labels) < 2:
        return None
    import matplotlib.pyplot as plt

    pts = np.array([t["objectives"][:2] for t in done], dtype=float)
    front = pareto_front(pts)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(pts[:, 1], 100 * (1 - pts[:, 0]), "o", ms=4, color="0.6", label="trials")
    fp = pts[front][np.argsort(pts[front][:, 1])]
    ax.plot(fp[:, 1], 100 * (1 - fp[:, 0]), "o-", ms=5, color="C3", label="Pareto front")
    ax.set_xlabel(f"{labels[1]} (mean over successful robots)")
    ax.set_ylabel("success rate (%)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("success against the first term")
    fig.tight_layout()
    return _save(fig, out / "pareto.png")


def _validation(val: Mapping[str, Any], out: Path) -> str | None:
    if not val:
        return None
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.4))
    sets = list(val)
    for j, who in enumerate(("book", "tuned")):
        xs = np.arange(len(sets)) + (j - 0.5) * 0.3
        rate = [100 * val[s][who]["success_rate"] for s in sets]
        lo = [100 * val[s][who]["success_interval"][0] for s in sets]
        hi = [100 * val[s][who]["success_interval"][1] for s in sets]
        err = np.array([np.subtract(rate, lo), np.subtract(hi, rate)])
        ax.bar(xs, rate, 0.28, yerr=err, capsize=4, label=who, color=f"C{j}")
    ax.set_xticks(np.arange(len(sets)), [f"{s} ({val[s]['robots']} robots)" for s in sets])
    ax.set_ylabel("success rate (%), Wilson 95 %")
    ax.set_ylim(0, 105)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title("book against tuned settings")
    fig.tight_layout()
    return _save(fig, out / "validation.png")


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return "n/a" if not math.isfinite(x) else f"{x:.4g}"
    if isinstance(x, list | tuple):
        return "[" + ", ".join(_fmt(v) for v in x) + "]"
    return html_text(str(x))


def write_page(
    out: Path,
    *,
    title: str,
    summary: Mapping[str, Any],
    trials: Sequence[Mapping[str, Any]],
    labels: Sequence[str],
    importances: Mapping[str, float],
    validation: Mapping[str, Any],
    best_settings: Mapping[str, Any],
) -> list[str]:
    """Write the figures and ``index.html`` (atomically); returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    from mwip.io import write_text_atomic

    made = (_history(trials, out), _importance(importances, out), _pareto(trials, labels, out),
            _validation(validation, out))  # fmt: skip
    figs = [f for f in made if f]
    rows = "".join(f"<tr><th>{html_text(str(k))}</th><td>{_fmt(v)}</td></tr>"
                   for k, v in summary.items())  # fmt: skip
    best = "".join(f"<tr><th>{html_text(k)}</th><td>{_fmt(v)}</td></tr>"
                   for k, v in best_settings.items())  # fmt: skip
    val_rows = ""
    for s, e in validation.items():
        for who in ("book", "tuned"):
            r = e[who]
            terms = "; ".join(f"{k} {_fmt(v['mean'])} {_fmt(v['interval'])}"
                              for k, v in r["terms"].items())  # fmt: skip
            val_rows += (f"<tr><td>{html_text(s)}</td><td>{who}</td>"
                         f"<td>{r['successes']}/{r['robots']} = {100 * r['success_rate']:.1f} % "
                         f"[{100 * r['success_interval'][0]:.1f}, "
                         f"{100 * r['success_interval'][1]:.1f}]</td>"
                         f"<td>{_fmt(r['cost'])}</td><td>{terms}</td></tr>")  # fmt: skip
        d = e["difference"]
        val_rows += (f"<tr><td>{html_text(s)}</td><td>tuned - book</td>"
                     f"<td>{100 * d['success_rate']:+.1f} points "
                     f"[{100 * d['interval'][0]:+.1f}, {100 * d['interval'][1]:+.1f}]</td>"
                     "<td></td><td></td></tr>")  # fmt: skip
    imgs = "".join(f'<p><img src="{f}" alt="{f}"></p>' for f in figs)
    text = f"""<!doctype html>
<html><head><meta charset="utf-8"><title>{html_text(title)}</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:.2em .5em;text-align:left}}
img{{max-width:100%}}</style></head><body>
<h1>{html_text(title)}</h1>
<table>{rows}</table>
<h2>Best settings (best.toml)</h2><table>{best}</table>
<h2>Validation</h2>
<p>Success rate with its Wilson 95 % interval; terms: mean over the successful robots with a
95 % bootstrap interval; the difference is paired (the same robots and noise).</p>
<table><tr><th>robots</th><th>settings</th><th>success</th><th>cost</th><th>terms</th></tr>
{val_rows}</table>
<h2>Figures</h2>{imgs}
</body></html>
"""
    write_text_atomic(out / "index.html", text)
    return [*figs, "index.html"]
