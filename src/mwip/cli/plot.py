"""``mwip plot RUN_DIR`` and ``mwip animate RUN_DIR``: pictures of any saved run -- a
``simulate --out`` folder, a study's folder (e.g. a digital-twin run of Chapter 6, with the
commanded and applied torques and the observer's estimate) or a run's ``.npz``.

The drawing modules (NumPy, matplotlib) are imported when a command runs, not when the CLI
starts (issue 18: ``mwip --help`` under 0.3 s).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import click

from mwip.cli._common import FILE_FORCE, file_ok, record_file

__all__ = ["plot_cmd", "animate_cmd"]

_RUN_DIR = click.argument("run_dir", type=click.Path(path_type=Path))
_RUN = click.option(
    "--run", "run_name", default=None,
    help="Which run of a study's folder (default: the study's main run).",
)  # fmt: skip


@click.command("plot")
@_RUN_DIR
@_RUN
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="FILE.png (default: RUN_DIR/plot/<run>.png, apart from a study's own figures).",
)
@FILE_FORCE
def plot_cmd(run_dir: Path, run_name: str | None, out: Path | None, force: bool) -> None:
    """Draw a run: pitch, wheel speed and reference, yaw, wheel torques (commanded and
    applied), the estimated disturbance where an observer runs, the path and the status.

    RUN_DIR is a folder written by `mwip simulate --out`, a study's folder (OUT/<study>), or a
    run's .npz file (`mwip simulate --plot` draws the same figure as OUT/run.png).
    """
    from mwip.plot.runs import RunFolderError, load_run

    if out is not None and out.suffix.lower() != ".png":
        raise click.BadParameter(f"must end in .png, got {out.name!r}", param_hint="--out")
    try:
        run = load_run(run_dir, run_name)
    except RunFolderError as exc:
        raise click.UsageError(str(exc)) from None
    if out is None:
        out = (run_dir if run_dir.is_dir() else run_dir.parent) / "plot" / f"{run.name}.png"
    file_ok(out, force)
    from mwip.plot.run_figure import write_run_figure

    title = f"{run.study}: {run.name}" if run.study else run.name
    write_run_figure(run, out, title=title)
    record_file(out)
    click.echo(f"wrote {out} ({run.name}: {run.status}, {run.t_end:.3g} s)")


@click.command("animate")
@_RUN_DIR
@_RUN
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="FILE.gif (default RUN_DIR/<run>.gif), FILE.mp4 (needs ffmpeg) or FILE.html.",
)
@click.option("--fps", type=float, default=20.0, show_default=True,
              help="Frames per second of the video, in [1, 60].")  # fmt: skip
@click.option("--speed", type=float, default=1.0, show_default=True,
              help="Speed-up over real time, in [0.05, 100].")  # fmt: skip
@FILE_FORCE
def animate_cmd(run_dir: Path, run_name: str | None, out: Path | None, fps: float,
                speed: float, force: bool) -> None:  # fmt: skip
    """Animate a run: the robot to scale (side view) beside its path (top view), with a time
    cursor on theta and the wheel torques.

    RUN_DIR is a folder written by `mwip simulate --out`, a study's folder (OUT/<study>), or a
    run's .npz file. A run that fell is shown up to the fall, which is held for a second.
    """
    from mwip.animate import FORMATS, AnimationError, animate_run
    from mwip.plot.runs import RunFolderError, load_run

    if not (math.isfinite(fps) and 1.0 <= fps <= 60.0):
        raise click.BadParameter(f"must be in [1, 60], got {fps!r}", param_hint="--fps")
    if not (math.isfinite(speed) and 0.05 <= speed <= 100.0):
        raise click.BadParameter(f"must be in [0.05, 100], got {speed!r}", param_hint="--speed")
    if out is not None and out.suffix.lower() not in FORMATS:
        raise click.BadParameter(f"must end in {', '.join(FORMATS)}, got {out.name!r}",
                                 param_hint="--out")  # fmt: skip
    if out is not None and out.suffix.lower() == ".mp4" and shutil.which("ffmpeg") is None:
        raise click.BadParameter("FILE.mp4 needs ffmpeg on the PATH (not found); use .gif or "
                                 ".html", param_hint="--out")  # fmt: skip
    try:
        run = load_run(run_dir, run_name)
        if out is None:
            folder = run_dir if run_dir.is_dir() else run_dir.parent
            out = folder / f"{run.name}.gif"
        file_ok(out, force)
        animate_run(run, out, fps=fps, speed=speed)
        record_file(out)
    except RunFolderError as exc:
        raise click.UsageError(str(exc)) from None
    except AnimationError as exc:  # the encoder's failure, not the input's
        raise click.ClickException(str(exc)) from None
    click.echo(f"wrote {out} ({run.name}: {run.status}, {run.t_end:.3g} s)")
