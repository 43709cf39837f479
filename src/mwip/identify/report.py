"""The outputs of ``mwip twin fit``: ``robot.toml``, ``fit.json``, ``fit.png``.

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

from mwip.identify.fit import FitResult
from mwip.identify.logs import Log

__all__ = ["fitted_robot", "robot_text", "fit_json", "write_figure", "write_outputs"]


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


def write_figure(result: FitResult, path: Path, max_segments: int = 12) -> None:
    """``fit.png``: measured vs predicted encoder angle of the first segments."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mwip.io import write_atomic

    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    tr = result.trace
    if tr:
        S = min(max_segments, tr["t"].shape[0])
        for wheel, ax in enumerate(axes):
            for s in range(S):
                ax.plot(tr["t"][s], tr["enc"][s, :, wheel], "k.", ms=2,
                        label="measured" if s == 0 else None)  # fmt: skip
                ax.plot(tr["t"][s], tr["pred"][s, :, wheel], "r-", lw=1,
                        label="predicted" if s == 0 else None)  # fmt: skip
            ax.set_ylabel(f"enc_{'rl'[wheel]} (rad, from segment start)")
            ax.legend(loc="best", fontsize=8)
    else:
        axes[0].text(0.5, 0.5, "no wheels-off-ground segments", ha="center",
                     transform=axes[0].transAxes)  # fmt: skip
    axes[-1].set_xlabel("t (s)")
    fig.suptitle("mwip twin fit: wheels-off-ground segments")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, metadata={"Software": None})
    plt.close(fig)
    write_atomic(path, lambda fh: fh.write(buf.getvalue()))


def write_outputs(out: Path, result: FitResult, logs: Sequence[Log],
                  base: object | None = None) -> list[Path]:  # fmt: skip
    """Write the three files into ``out`` (already claimed), atomically."""
    from mwip.io import write_json_atomic, write_text_atomic

    files = [out / "robot.toml", out / "fit.json", out / "fit.png"]
    write_text_atomic(files[0], robot_text(result, logs, base))
    write_json_atomic(files[1], fit_json(result, logs))
    write_figure(result, files[2])
    return files


def _np(x: Any) -> Any:  # pragma: no cover - helper for json
    return x.tolist() if isinstance(x, np.ndarray) else x
