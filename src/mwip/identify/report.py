"""The outputs of ``mwip twin fit``: ``robot.toml``, ``fit.json``, ``fit.png``, ``index.html``.

``robot.toml`` is the robot the fit started from (``--robot FILE``, default the book's) with
the fitted values (:mod:`mwip.robot.file`): each fitted or fixed value's source says so in
``[provenance]`` (the fit, its standard error, the logs by SHA-256), the robot's notes list
the logs, the free and fixed parameters; no date, so the same logs give the same file.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.fit import FitResult
from mwip.identify.logs import Log

__all__ = ["fitted_robot", "robot_text", "fit_json", "write_figure", "page_html",
           "write_outputs"]


def fitted_robot(result: FitResult, logs: Sequence[Log], base: Any = None) -> Any:
    """The robot ``base`` (default: the default robot) with the fitted and fixed values, and
    their provenance (module docstring)."""
    from mwip.robot import robot_or_default

    robot = robot_or_default(base)
    use = {n: v for n, v in result.estimates.items()
           if result.status[n] in ("fitted", "fixed", "not identified")}  # fmt: skip
    sha = ", ".join(f"{os.path.basename(lg.path)} ({lg.sha256[:12]})" for lg in logs)
    sources: dict[str, str] = {}
    for n in use:
        st = result.status[n]
        se = result.stderr.get(n)
        if st == "fixed":
            sources[n] = "fixed by `mwip twin fit --fix`"
        else:
            err = f" +- {se:.3g} (1 standard error)" if se is not None and np.isfinite(se) else ""
            sources[n] = f"{st}: `mwip twin fit`{err} on the logs {sha}"
    tm = result.torque_map
    if tm is not None:  # both pairs logged: the firmware's torque-to-duty map
        use["firmware.torque_gain"] = tm["torque_gain"]
        sources["firmware.torque_gain"] = (
            f"fitted: `mwip twin fit`, torque-to-duty map d = a u of the logged torque and duty "
            f"(a = {tm['a']:.5g}, misfit {100 * tm['misfit']:.2g} %) with the fitted gear ratio"
            f" +- {tm['stderr']:.3g} (1 standard error) on the logs {sha}")  # fmt: skip
    notes = ["Fitted by `mwip twin fit` (docs/twin_fit.md) from the logs (SHA-256):"]
    notes += [f"  {lg.sha256}  {os.path.basename(lg.path)}" for lg in logs]
    notes.append(f"free: {', '.join(result.free) or '(none)'}")
    fx = ", ".join(f"{k}={v:g}" for k, v in result.fixed.items())
    notes.append(f"fixed: {fx or '(none)'}")
    ni = [n for n, st in result.status.items() if st == "not informed"]
    notes.append(f"not informed (the starting robot's values kept): {', '.join(ni) or '(none)'}")
    if robot.notes:
        notes += ["", f"Started from the robot {robot.name!r}:", robot.notes]
    from dataclasses import replace

    out = replace(robot.with_values(use), notes="\n".join(notes))
    return out.with_sources(sources)


def robot_text(result: FitResult, logs: Sequence[Log], base: Any = None) -> str:
    """``robot.toml`` (module docstring)."""
    from mwip.robot import robot_to_toml

    return robot_to_toml(fitted_robot(result, logs, base))


def fit_json(result: FitResult, logs: Sequence[Log]) -> dict[str, Any]:
    out = result.to_json()
    out["logs"] = [{"file": os.path.basename(lg.path), "sha256": lg.sha256, "rows": lg.n,
                    "inputs": lg.inputs} for lg in logs]  # fmt: skip
    return out


def write_figure(result: FitResult, path: Path) -> None:
    """``fit.png``: the wheels-off-ground rows of the whole log, measured against predicted
    (each segment from its own start: the encoder angle from the segment's start, per wheel),
    the residuals over time, and their autocorrelation against the 95 % band of white noise
    (the residual diagnostics: structure the model lacks shows as correlated residuals)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mwip.io import write_atomic

    fig, axes = plt.subplots(4, 1, figsize=(9, 10))
    tr = result.trace
    if tr:
        S = tr["t"].shape[0]
        res = tr["enc"] - tr["pred"]
        for wheel, ax in enumerate(axes[:2]):
            for s in range(S):
                ax.plot(tr["t"][s], tr["enc"][s, :, wheel], "k.", ms=1.5,
                        label="measured" if s == 0 else None)  # fmt: skip
                ax.plot(tr["t"][s], tr["pred"][s, :, wheel], "r-", lw=0.8,
                        label="predicted" if s == 0 else None)  # fmt: skip
            ax.set_ylabel(f"enc_{'rl'[wheel]} (rad)")
            ax.legend(loc="best", fontsize=8)
            ax.set_title(f"{'right' if wheel == 0 else 'left'} wheel, {S} segments of "
                         f"{tr['t'].shape[1]} samples, each from its own start", fontsize=9)
        for wheel in range(2):
            axes[2].plot(tr["t"].ravel(), res[:, :, wheel].ravel(), ".", ms=1.5,
                         label=f"enc_{'rl'[wheel]}")  # fmt: skip
        axes[2].set_ylabel("residual (rad)")
        axes[2].set_xlabel("t (s)")
        axes[2].legend(loc="best", fontsize=8)
        lags, acf = _autocorrelation(res)
        axes[3].stem(lags, acf, basefmt=" ")
        band = 1.96 / np.sqrt(max(res.size, 1))
        axes[3].axhspan(-band, band, color="0.85", label="white noise, 95 %")
        axes[3].set_xlabel("lag (samples)")
        axes[3].set_ylabel("residual autocorrelation")
        axes[3].legend(loc="best", fontsize=8)
    else:
        axes[0].text(0.5, 0.5, "no wheels-off-ground segments", ha="center",
                     transform=axes[0].transAxes)  # fmt: skip
    fig.suptitle("mwip twin fit: wheels-off-ground rows, measured and predicted")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, metadata={"Software": None})
    plt.close(fig)
    write_atomic(path, lambda fh: fh.write(buf.getvalue()))


def _autocorrelation(res: NDArray[np.float64], max_lag: int = 20,
                     ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:  # fmt: skip
    """The residuals' autocorrelation within segments (S, L, 2), lags 1..``max_lag``."""
    r = res - res.mean(axis=1, keepdims=True)
    den = float(np.sum(r * r)) or 1.0
    L = r.shape[1]
    lags = np.arange(1, min(max_lag, L - 1) + 1)
    acf = np.array([float(np.sum(r[:, k:] * r[:, :-k])) / den for k in lags])
    return lags, acf


def page_html(result: FitResult, logs: Sequence[Log]) -> str:
    """``index.html``: what a person reads (issue 37, item 5): the estimates beside the prior
    (value, 1 standard error, status, prior range and centre), the torque gain where both
    pairs were logged, the validation log's prediction errors, the notes, the correlation
    matrix of the fitted parameters, the residual diagnostics and ``fit.png``."""
    import html

    from mwip.identify.bounds import BOUNDS, centre
    from mwip.identify.fit import at_bound

    e = html.escape
    rows = []
    for n, v in result.estimates.items():
        se, st = result.stderr.get(n), result.status[n]
        lo, hi = BOUNDS[n]
        side = at_bound(n, v) if st in ("fitted", "not identified") else None
        rows.append(f"<tr><td>{e(n)}</td><td>{v:.5g}</td><td>{'-' if se is None else f'{se:.2g}'}"
                    f"</td><td>{e(st)}{f' <b>(at its {side} bound)</b>' if side else ''}</td>"
                    f"<td>[{lo:g}, {hi:g}]</td><td>{centre(n):.4g}</td></tr>")  # fmt: skip
    tm = result.torque_map
    if tm is not None:
        rows.append(f"<tr><td>firmware.torque_gain</td><td>{tm['torque_gain']:.5g}</td>"
                    f"<td>{tm['stderr']:.2g}</td><td>fitted (torque-to-duty map, misfit "
                    f"{100 * tm['misfit']:.2g} %)</td><td>-</td><td>-</td></tr>")  # fmt: skip
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>mwip twin fit</title>"
        "<style>body{font-family:sans-serif;max-width:60em;margin:1em auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;"
        "text-align:right}td:first-child{text-align:left}</style></head><body>",
        "<h1>mwip twin fit</h1>",
        "<p>Logs: " + ", ".join(f"{e(os.path.basename(lg.path))} ({lg.n} rows, "
                                f"{e(lg.inputs)}, SHA-256 {lg.sha256[:12]})" for lg in logs)
        + f". Sample period {result.Ts * 1000:g} ms, segments of {result.segment} samples."
        "</p>",  # fmt: skip
        "<h2>Estimates</h2><table><tr><th>parameter</th><th>estimate</th><th>+- 1 s.e.</th>"
        "<th>status</th><th>prior range</th><th>prior centre</th></tr>" + "".join(rows)
        + "</table>",
    ]
    val = result.validation
    if val:
        fit_e, pri_e = val.get("fitted") or {}, val.get("prior_centre") or {}
        vrows = "".join(f"<tr><td>{e(k)}</td><td>{fit_e[k]:.4g}</td>"
                        f"<td>{pri_e.get(k, float('nan')):.4g}</td></tr>"
                        for k in fit_e if isinstance(fit_e[k], float))  # fmt: skip
        parts.append(f"<h2>Validation on {e(str(val.get('log')))}</h2><p>RMS prediction "
                     "errors of the fitted twin and of the prior centre on a log the fit did "
                     "not see.</p><table><tr><th>error</th><th>fitted</th><th>prior centre</th>"
                     f"</tr>{vrows}</table>")  # fmt: skip
    if result.flags:
        parts.append("<h2>Notes</h2><ul>" + "".join(f"<li>{e(f)}</li>" for f in result.flags)
                     + "</ul>")  # fmt: skip
    corr = result.correlation or {}
    names, mat = corr.get("names") or [], corr.get("matrix") or []
    if names:
        head = "".join(f"<th>{e(n.split('.')[-1])}</th>" for n in names)
        body = "".join(f"<tr><td>{e(n)}</td>" + "".join(
            f"<td{' style=background:#fcc' if i != j and abs(x) > 0.9 else ''}>{x:+.2f}</td>"
            for j, x in enumerate(row)) + "</tr>" for i, (n, row) in enumerate(
                zip(names, mat, strict=True)))  # fmt: skip
        parts.append("<h2>Correlation of the fitted parameters</h2><p>Above 0.9 in size "
                     "(shaded): not separately identified by these logs.</p>"
                     f"<table><tr><th></th>{head}</tr>{body}</table>")  # fmt: skip
    diag = "".join(f"<tr><td>{e(k)}</td><td>{v.get('rms', float('nan')):.3g}</td>"
                   f"<td>{v.get('whiteness', float('nan')):.3g}</td><td>{v.get('n', 0):.0f}"
                   "</td></tr>" for k, v in (result.residuals or {}).items())  # fmt: skip
    parts.append("<h2>Residual diagnostics</h2><p>RMS of each signal's residual, and its "
                 "whiteness (the fit.json statistic: the share of its autocorrelations at lags "
                 "1-20 inside white noise's 95 % band; near 1 for white residuals, lower where "
                 "the model lacks a structure).</p><table><tr><th>signal</th><th>RMS</th>"
                 f"<th>whiteness</th><th>values</th></tr>{diag}</table>")  # fmt: skip
    parts.append("<h2>Measured and predicted</h2><img src='fit.png' alt='fit.png' "
                 "style='max-width:100%'></body></html>")  # fmt: skip
    return "\n".join(parts) + "\n"


def write_outputs(out: Path, result: FitResult, logs: Sequence[Log],
                  base: object | None = None) -> list[Path]:  # fmt: skip
    """Write the three files into ``out`` (already claimed), atomically."""
    from mwip.io import write_json_atomic, write_text_atomic

    files = [out / "robot.toml", out / "fit.json", out / "fit.png", out / "index.html"]
    write_text_atomic(files[0], robot_text(result, logs, base))
    write_json_atomic(files[1], fit_json(result, logs))
    write_figure(result, files[2])
    write_text_atomic(files[3], page_html(result, logs))
    return files


def _np(x: Any) -> Any:  # pragma: no cover - helper for json
    return x.tolist() if isinstance(x, np.ndarray) else x
