"""The leaderboard page: ``DIR/index.html``, ``DIR/leaderboard.png`` and ``DIR/levels.png``.

- the leaderboard: entrants ranked by their score (:mod:`mwip.bench.scores`), each axis's
  pooled success fraction with its Wilson 95 % interval, and the nominal runs' performance;
- ``leaderboard.png``: the same fractions as a heat map (entrants x axes, the number in each
  cell), 100 dpi at its size;
- ``levels.png``: per axis, the success fraction of each entrant against the axis's levels
  (shaded: the Wilson interval);
- per axis: its definition and source, and a table of every level.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from mwip.bench.scores import PERFORMANCE, POOLED, leaderboard
from mwip.bench.spec import Bench
from mwip.io import html_text, write_atomic, write_text_atomic

__all__ = ["write_page"]

_UNITS = {"rms_theta": "rad", "rms_speed_error": "m/s", "control_tv": "N m/s",
          "peak_torque": "N m"}  # fmt: skip
_CSS = ("body{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em}"
        "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;"
        "padding:2px 6px;text-align:right}th{background:#f0f0f0}td.l,th.l{text-align:left}"
        "img{max-width:100%}.note{color:#555}")  # fmt: skip


def _png(path: Path, fig: Figure) -> Path:
    import warnings

    with warnings.catch_warnings():  # a label with a control character draws a box, silently
        warnings.filterwarnings("ignore", message="Glyph .* missing from font")
        return write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=100))


def _heatmap(board: Any, bench: Bench) -> Figure:
    axes = [a.name for a in bench.axes]
    data = board[axes].to_numpy(dtype=float)
    rows, cols = data.shape
    fig = Figure(figsize=(1.0 * cols + 2.6, 0.42 * rows + 1.6), layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(data, vmin=0.0, vmax=1.0, cmap="RdYlGn", aspect="auto")
    ax.set_xticks(range(cols), [a.replace("_", "\n") for a in axes], fontsize=9)
    ax.set_yticks(range(rows), [f"{c}  ({s:.2f})" for c, s in
                                zip(board["controller"], board["score"], strict=True)],
                  fontsize=9)  # fmt: skip
    for i in range(rows):
        for j in range(cols):
            v = data[i, j]
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=8,
                    color="black" if 0.25 < v < 0.85 else "white")  # fmt: skip
    ax.set_title("success fraction per axis (entrant: score = mean over the axes but nominal)",
                 fontsize=10)  # fmt: skip
    fig.colorbar(im, ax=ax, shrink=0.8)
    return fig


def _levels_figure(scores: Any, bench: Bench, labels: list[str]) -> Figure:
    axes = [a for a in bench.axes if len(a.levels) > 1]
    n = max(len(axes), 1)
    cols = min(3, n)
    rows = -(-n // cols)
    fig = Figure(figsize=(4.4 * cols, 3.0 * rows + 0.6), layout="constrained")
    for k, a in enumerate(axes):
        ax = fig.add_subplot(rows, cols, k + 1)
        x = np.arange(len(a.levels))
        for c in labels:
            part = scores[(scores["controller"] == c) & (scores["axis"] == a.name)
                          & (scores["level"] != POOLED)]  # fmt: skip
            line = ax.plot(x, part["fraction"].to_numpy(), marker="o", ms=3, lw=1, label=c)[0]
            ax.fill_between(x, part["wilson_lo"].to_numpy(), part["wilson_hi"].to_numpy(),
                            color=line.get_color(), alpha=0.08)  # fmt: skip
        ax.set_xticks(x, [lv.label for lv in a.levels], fontsize=7,
                      rotation=60 if len(a.levels) > 5 else 0)  # fmt: skip
        ax.set_ylim(-0.03, 1.03)
        ax.set_title(a.name, fontsize=10)
        ax.set_ylabel("success fraction", fontsize=8)
        ax.grid(alpha=0.3)
    if axes:
        handles, names = fig.axes[0].get_legend_handles_labels()
        fig.legend(handles, names, loc="outside lower center", ncol=min(len(labels), 6),
                   fontsize=8)  # fmt: skip
    return fig


def _cell(f: float, lo: float, hi: float) -> str:
    return f"{f:.2f} <small>[{lo:.2f}, {hi:.2f}]</small>"


def _num(x: float) -> str:
    return "&ndash;" if not np.isfinite(x) else f"{x:.3g}"


def write_page(out: Path, scores: Any, bench: Bench, labels: list[str],
               notes: list[str]) -> Path:  # fmt: skip
    """Write the page and its two PNGs into ``out``; returns ``out/index.html``."""
    board = leaderboard(scores, bench)
    _png(out / "leaderboard.png", _heatmap(board, bench))
    _png(out / "levels.png", _levels_figure(scores, bench, labels))
    e = html_text
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(bench.title)}"
             f"</title><style>{_CSS}</style></head><body><h1>{e(bench.title)}</h1>"]
    n_runs = bench.samples * len(bench.levels)
    parts.append(f"<p>{len(labels)} entrants x {len(bench.levels)} levels x {bench.samples} "
                 f"runs of {bench.duration:g} s ({n_runs} runs each; seed {bench.seed}"
                 f"{', quick sizes' if bench.quick else ''}). Success: never fell and "
                 f"|theta| &lt; {bench.success_theta:g} rad throughout the last second. "
                 "Intervals: Wilson 95 %. Definitions: docs/bench.md.</p>")
    parts += [f"<p class='note'>{e(x)}</p>" for x in notes]
    parts.append("<h2>Leaderboard</h2><img src='leaderboard.png' alt='leaderboard'>")
    from mwip.hardware.identified import wheel_torque_limit

    parts.append(f"<p class='note'>peak_torque: the largest |torque| the twin's drive applied "
                 "to a wheel in a run (N m per wheel, mwip.campaign.metrics); the identified "
                 f"twin's drive gives at most {wheel_torque_limit():.3g} N m per wheel (the "
                 "\"drive limit\" of `mwip simulate`, which compares the commanded torque "
                 "with it, and of the run figures).</p>")  # fmt: skip
    head = "".join(f"<th>{e(a.name)}</th>" for a in bench.axes)
    perf = "".join(f"<th>{e(m)} ({_UNITS[m]})</th>" for m in PERFORMANCE)
    parts.append(f"<table><tr><th>#</th><th class='l'>entrant</th><th>score</th>{head}{perf}"
                 "</tr>")
    for i, row in board.iterrows():
        cells = "".join(f"<td>{_cell(row[a.name], row[a.name + '_lo'], row[a.name + '_hi'])}"
                        "</td>" for a in bench.axes)  # fmt: skip
        pc = "".join(f"<td>{_num(row['median_' + m])}</td>" for m in PERFORMANCE)
        parts.append(f"<tr><td>{i + 1}</td><td class='l'>{e(str(row['controller']))}</td>"
                     f"<td>{row['score']:.3f}</td>{cells}{pc}</tr>")
    parts.append("</table><p class='note'>Performance: medians over the successful nominal "
                 "runs.</p>")
    parts.append("<h2>Levels</h2><img src='levels.png' alt='success against the levels'>")
    for a in bench.axes:
        parts.append(f"<h3>{e(a.name)}: {e(a.title)}</h3><p class='note'>{e(a.source)}</p>")
        ch = "".join(f"<th>{e(c)}</th>" for c in labels)
        parts.append(f"<table><tr><th class='l'>level</th>{ch}</tr>")
        for name in [*(x.label for x in a.levels), POOLED]:
            row_cells: list[str] = []
            for c in labels:
                r = scores[(scores["controller"] == c) & (scores["axis"] == a.name)
                           & (scores["level"] == name)].iloc[0]  # fmt: skip
                row_cells.append(f"<td>{_cell(r['fraction'], r['wilson_lo'], r['wilson_hi'])}"
                                 "</td>")
            parts.append(f"<tr><td class='l'>{e(name)}</td>{''.join(row_cells)}</tr>")
        parts.append("</table>")
    parts.append("<p>Data: <code>scores.parquet</code> (one row per entrant x axis x level), "
                 "<code>results.parquet</code> (one row per run).</p></body></html>")
    return write_text_atomic(out / "index.html", "\n".join(parts))
