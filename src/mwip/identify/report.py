"""The outputs of ``mwip twin fit``: ``twin.toml``, ``fit.json``, ``fit.png``.

``twin.toml`` is the base twin with the fitted values (:mod:`mwip.hardware.twin_config`),
preceded by a date-free provenance comment block (the logs' SHA-256, the free and fixed
lists), so the same logs give the same file. ``drive.emf_compensation`` is the fitted
fraction (``fit.json`` has it too).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mwip.identify.fit import FitResult
from mwip.identify.logs import Log

__all__ = ["fitted_twin", "twin_text", "fit_json", "write_figure", "write_outputs"]


def fitted_twin(result: FitResult, base: object | None = None) -> Any:
    """The base twin (default: the default twin) with the fitted and fixed values."""
    from mwip.hardware.twin import Twin

    tw: Twin = Twin() if base is None else base  # type: ignore[assignment]
    use = {n: v for n, v in result.estimates.items()
           if result.status[n] in ("fitted", "fixed", "not identified")}  # fmt: skip

    return tw.with_values(use)


def twin_text(result: FitResult, logs: Sequence[Log], base: object | None = None) -> str:
    """``twin.toml``: provenance comments, then the fitted twin's tables."""
    from mwip.hardware.twin_config import twin_to_toml

    lines = ["# Fitted by `mwip twin fit` (docs/twin_fit.md) from the logs (SHA-256):"]
    for lg in logs:
        lines.append(f"#   {lg.sha256}  {os.path.basename(lg.path)}")
    lines.append(f"# free: {', '.join(result.free) or '(none)'}")
    fx = ", ".join(f"{k}={v:g}" for k, v in result.fixed.items())
    lines.append(f"# fixed: {fx or '(none)'}")
    ni = [n for n, s in result.status.items() if s == "not informed"]
    lines.append(f"# not informed (prior kept): {', '.join(ni) or '(none)'}")
    lines.append("")
    return "\n".join(lines) + "\n" + twin_to_toml(fitted_twin(result, base))


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

    files = [out / "twin.toml", out / "fit.json", out / "fit.png"]
    write_text_atomic(files[0], twin_text(result, logs, base))
    write_json_atomic(files[1], fit_json(result, logs))
    write_figure(result, files[2])
    return files


def _np(x: Any) -> Any:  # pragma: no cover - helper for json
    return x.tolist() if isinstance(x, np.ndarray) else x
