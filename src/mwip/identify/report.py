"""The outputs of ``mwip twin fit``: ``robot.toml``, ``fit.json``, ``fit.png``, ``index.html``.

``robot.toml`` is the robot the fit started from (``--robot FILE``, default the book's) with
the fitted values (:mod:`mwip.robot.file`): each fitted or fixed value's source says so in
``[provenance]`` (the fit, its standard error, the logs by SHA-256), the robot's notes list
the logs, the free and fixed parameters; no date, so the same logs give the same file.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mwip.identify.fit import FitResult
from mwip.identify.logs import Log

__all__ = ["fitted_robot", "robot_text", "fit_json", "Panel", "figure_panels", "write_figure",
           "page_html", "write_outputs"]


def fitted_robot(result: FitResult, logs: Sequence[Log], base: Any = None) -> Any:
    """The robot ``base`` (default: the default robot) with the fitted and fixed values, the
    body stage's fields precise enough to replace the file's (``body.l``, ``body.Iyy``:
    :meth:`mwip.identify.body.BodyResult.written`), and their provenance (module
    docstring)."""
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
            sc = result.structure
            if sc is not None and sc.rejected and n in sc.widened and se is not None:
                err = (f" +- {sc.widened[n]:.3g} (1 standard error widened by the structure "
                       f"test's ratio {sc.ratio:.3g}: the twin's structure was rejected on "
                       f"these logs; primary {se:.3g})")  # fmt: skip
            sources[n] = f"{st}: `mwip twin fit`{err} on the logs {sha}"
    tm = result.torque_map
    if tm is not None:  # both pairs logged: the firmware's torque-to-duty map
        use["firmware.torque_gain"] = tm["torque_gain"]
        sources["firmware.torque_gain"] = (
            f"fitted: `mwip twin fit`, torque-to-duty map d = a u of the logged torque and duty "
            f"(a = {tm['a']:.5g}, misfit {100 * tm['misfit']:.2g} %) with the fitted gear ratio"
            f" +- {tm['stderr']:.3g} (1 standard error) on the logs {sha}")  # fmt: skip
    bres = result.body
    written = bres.written() if bres is not None else {}
    if written:  # the body stage's fields, the file's mass held (mwip.identify.body.physical)
        from dataclasses import replace as _replace

        phys = {"l": "l", "Iyy": "Iby"}
        robot = _replace(robot, body=_replace(robot.body, **{phys[n]: v
                                                             for n, v in written.items()}))
        for n in written:
            se = bres.fields[n][1] if bres is not None else float("nan")
            how = "Gb = mb g l" if n == "l" else "m22 = mb l^2 + Iyy + the reflected rotor"
            sources[f"body.{n}"] = (f"fitted: `mwip twin fit` body stage ({how}; mb from the "
                                    f"robot file) +- {se:.3g} (1 standard error) on the logs "
                                    f"{sha}")  # fmt: skip
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


#: Segments shown per time panel of fit.png (evenly spread over the log).
SHOWN = 6

_MEAS = {"color": "k", "marker": ".", "ls": "none", "ms": 2.0}
_FIT = {"color": "tab:red", "lw": 1.0}
_PRIOR = {"color": "tab:blue", "lw": 1.0, "ls": "--"}


@dataclass
class Panel:
    """One panel of ``fit.png``: its ``title``, the sentence ``index.html`` says of it, and
    ``draw(ax)``; ``wide`` spans the row."""

    title: str
    text: str
    draw: Callable[[Any], None]
    wide: bool = False


def _pick(S: int, k: int = SHOWN) -> list[int]:
    """``k`` segments of ``S`` evenly spread (first and last included)."""
    return sorted({int(round(x)) for x in np.linspace(0, S - 1, min(k, S))})


def _segments(ax: Any, t: NDArray, meas: NDArray, preds: Sequence[tuple[str, NDArray, dict]],
              ylabel: str) -> None:  # fmt: skip
    """Measured and predicted (label, (S, L), style) of a few segments against time."""
    for n, s in enumerate(_pick(t.shape[0])):
        ax.plot(t[s], meas[s], label="measured" if n == 0 else None, **_MEAS)
        for label, pr, style in preds:
            ax.plot(t[s], pr[s], label=label if n == 0 else None, **style)
    _label(ax, ylabel)


def _series(ax: Any, t: NDArray, meas: NDArray, preds: Sequence[tuple[str, NDArray, dict]],
            ylabel: str) -> None:  # fmt: skip
    """Measured and predicted over time, each log apart (the logs' times may overlap)."""
    cuts = np.flatnonzero(np.diff(t) <= 0) + 1
    for n, part in enumerate(np.split(np.arange(t.size), cuts)):
        ax.plot(t[part], meas[part], label="measured" if n == 0 else None,
                **{**_MEAS, "ms": 1.0})  # fmt: skip
        for label, pr, style in preds:
            ax.plot(t[part], pr[part], label=label if n == 0 else None, **style)
    _label(ax, ylabel)


def _label(ax: Any, ylabel: str) -> None:
    ax.set_xlabel("t (s)")
    ax.set_ylabel(ylabel)
    ax.legend(loc="best", fontsize=7)


def _mode_panels(tr: dict[str, dict[str, NDArray]], prior: dict[str, dict[str, NDArray]] | None,
                 where: str) -> list[list[Panel]]:  # fmt: skip
    """Rows of panels of one log set's traces (:attr:`FitResult.trace`): the fitted twin's
    predictions, and the prior centre's where ``prior`` (the validation log's) is given."""
    rows: list[list[Panel]] = []
    pre = "" if prior is None else "validation, "
    also = "" if prior is None else ", and the prior centre's prediction"

    def preds(mode: str, key: str, sl: Any = Ellipsis) -> list[tuple[str, NDArray, dict]]:
        out = [("fitted twin", tr[mode][key][sl], _FIT)]
        if prior is not None and mode in prior:
            out.append(("prior centre", prior[mode][key][sl], _PRIOR))
        return out

    wog = tr.get("wheels-off-ground")
    if wog:
        S, L = wog["t"].shape
        k = len(_pick(S))
        def wheel(w: int, side: str) -> Callable[[Any], None]:
            sl = (slice(None), slice(None), w)
            return lambda ax: _segments(ax, wog["t"], wog["enc"][sl],
                                        preds("wheels-off-ground", "pred", sl),
                                        f"enc_{side[0]} (rad)")  # fmt: skip

        row = []
        for w, side in ((0, "right"), (1, "left")):
            row.append(Panel(
                f"{pre}wheels-off-ground: {side}-wheel encoder ({k} of {S} segments)",
                f"The {side} wheel's encoder angle in {k} of the {S} wheels-off-ground segments "
                f"of {L} samples {where} (each from its own start), measured and as the fitted "
                f"twin predicts it from the segment's fitted start speeds{also}.",
                wheel(w, side)))  # fmt: skip
        rows.append(row)
        if prior is None:
            res = wog["enc"] - wog["pred"]

            def residuals(ax: Any) -> None:
                for w in range(2):
                    ax.plot(wog["t"].ravel(), res[:, :, w].ravel(), ".", ms=1.5,
                            label=f"enc_{'rl'[w]}")  # fmt: skip
                _label(ax, "residual (rad)")

            def acf(ax: Any) -> None:
                lags, a = _autocorrelation(res)
                ax.stem(lags, a, basefmt=" ")
                band = 1.96 / np.sqrt(max(res.size, 1))
                ax.axhspan(-band, band, color="0.85", label="white noise, 95 %")
                ax.set_xlabel("lag (samples)")
                ax.set_ylabel("autocorrelation")
                ax.legend(loc="best", fontsize=7)

            rows.append([
                Panel("wheels-off-ground: encoder residuals",
                      "The encoder residuals (measured minus predicted) of every "
                      "wheels-off-ground segment over time.", residuals),
                Panel("wheels-off-ground: residual autocorrelation",
                      "Their autocorrelation within segments at lags 1-20 against white "
                      "noise's 95 % band: correlated residuals show a structure the model "
                      "lacks.", acf)])  # fmt: skip
    st = tr.get("static")
    if st:
        row = [Panel(f"{pre}static: gyro (body held still)",
                     f"The gyro in the rows with the body held still (static and "
                     f"wheels-off-ground) {where} against the fitted imu.gyro_bias{also}.",
                     lambda ax: _series(ax, st["t"], st["theta_rate"],
                                        preds("static", "theta_rate_pred"),
                                        "theta_rate (rad/s)"))]  # fmt: skip
        if "accel_x" in st:
            row.append(Panel(f"{pre}static: accelerometer (body held still)",
                             f"accel_x in those rows against the fitted imu.accel_bias{also}.",
                             lambda ax: _series(ax, st["t"], st["accel_x"],
                                                preds("static", "accel_x_pred"),
                                                "accel_x (m/s^2)")))  # fmt: skip
        rows.append(row)
    bal = tr.get("balancing")
    if bal:
        S, H = bal["t"].shape
        k = len(_pick(S))
        rows.append([
            Panel(f"{pre}balancing: right-wheel encoder ({k} of {S} segments, "
                  f"{H} samples ahead)",
                  f"The right wheel's encoder angle in {k} of the {S} balancing segments of "
                  f"{H} samples {where}, measured and as the fitted twin predicts it from the "
                  f"segment's fitted start state (pitch, pitch rate, wheel speeds){also}.",
                  lambda ax: _segments(ax, bal["t"], bal["enc"][:, :, 0],
                                       preds("balancing", "enc_pred",
                                             (slice(None), slice(None), 0)),
                                       "enc_r (rad)")),
            Panel(f"{pre}balancing: gyro ({k} of {S} segments, {H} samples ahead)",
                  f"The gyro in the same segments, measured and predicted (pitch rate plus "
                  f"the fitted imu.gyro_bias){also}.",
                  lambda ax: _segments(ax, bal["t"], bal["gyro"], preds("balancing", "gyro_pred"),
                                       "theta_rate (rad/s)"))])  # fmt: skip
    fu = tr.get("fusion")
    if fu:
        def fres(ax: Any) -> None:
            ax.plot(fu["t"], fu["theta"] - fu["theta_pred"], ".", ms=1.0, color="k")
            ax.set_xlabel("t (s)")
            ax.set_ylabel("theta residual (rad)")

        rows.append([
            Panel(f"{pre}fusion: pitch, one sample ahead",
                  f"The logged pitch theta {where} against the board's complementary filter "
                  "one sample ahead (the previous theta, the gyro and the accelerometer) with "
                  "the fitted firmware.fusion.tau.",
                  lambda ax: _series(ax, fu["t"], fu["theta"], preds("fusion", "theta_pred"),
                                     "theta (rad)")),
            Panel("fusion: pitch residual", "Their difference over time.", fres)])  # fmt: skip
    return rows


def figure_panels(result: FitResult) -> list[list[Panel]]:
    """The rows of ``fit.png``: a row (or two) per mode present in the fitted logs, then the
    validation log's rows (measured, the fitted twin's and the prior centre's predictions)."""
    rows = _mode_panels(result.trace, None, "of the fitted logs")
    vt = result.validation_trace
    if vt:
        name = os.path.basename(str(vt.get("log")))
        rows += _mode_panels(vt.get("fitted") or {}, vt.get("prior_centre") or {},
                             f"of the validation log {name}")  # fmt: skip
    return rows


def write_figure(result: FitResult, path: Path) -> list[str]:
    """``fit.png``: the panels of :func:`figure_panels`, two a row; returns their titles.
    Without any trace, one panel says so."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mwip.io import write_atomic

    rows = figure_panels(result)
    fig = plt.figure(figsize=(11, 2.8 * max(len(rows), 1)))
    titles: list[str] = []
    if rows:
        grid = fig.add_gridspec(len(rows), 2)
        for i, row in enumerate(rows):
            for j, panel in enumerate(row):
                ax = fig.add_subplot(grid[i, :] if len(row) == 1 else grid[i, j])
                panel.draw(ax)
                ax.set_title(panel.title, fontsize=9)
                titles.append(panel.title)
    else:
        ax = fig.add_subplot(1, 1, 1)
        ax.text(0.5, 0.5, "no measured signal to show", ha="center", transform=ax.transAxes)
        ax.set_axis_off()
    height = 2.8 * max(len(rows), 1)
    fig.suptitle("mwip twin fit: measured and predicted")
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.35 / height))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, metadata={"Software": None})
    plt.close(fig)
    write_atomic(path, lambda fh: fh.write(buf.getvalue()))
    return titles


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
    sc = result.structure
    wide = sc.widened if sc is not None and sc.rejected else {}
    for n, v in result.estimates.items():
        se, st = result.stderr.get(n), result.status[n]
        lo, hi = BOUNDS[n]
        side = at_bound(n, v) if st in ("fitted", "not identified") else None
        err = "-" if se is None else f"{se:.2g}"
        if n in wide and se is not None:
            err = f"<b>{wide[n]:.2g}</b> (primary {se:.2g})"
        rows.append(f"<tr><td>{e(n)}</td><td>{v:.5g}</td><td>{err}"
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
    if sc is not None:
        parts.append("<h2>Structure</h2><p>" + e(sc.summary()) + ". The test: the fit's "
                     "encoder residual against the one the twin's own structure leaves on the "
                     "same commands, simulated with the fitted values and the robot file's "
                     "sensors (docs/twin_fit.md).</p>")  # fmt: skip
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
    items = "".join(f"<li><b>{e(p.title)}</b>: {e(p.text)}</li>"
                    for row in figure_panels(result) for p in row)  # fmt: skip
    parts.append("<h2>Measured and predicted</h2><p>fit.png, row by row (measured: black "
                 "dots; the fitted twin: red; the prior centre: dashed blue):</p>"
                 f"<ul>{items}</ul><img src='fit.png' alt='fit.png' style='max-width:100%'>"
                 "</body></html>")  # fmt: skip
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
