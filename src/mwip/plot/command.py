"""``mwip plot RUN_DIR``: the run figure (:mod:`mwip.plot.run_figure`) of any saved run -- a
``simulate --out`` folder, a study's folder (e.g. a digital-twin run of Chapter 6, with the
commanded and applied torques and the observer's estimate) or a run's ``.npz``."""

from __future__ import annotations

from pathlib import Path

import click

from mwip.plot.run_figure import write_run_figure
from mwip.plot.runs import RunFolderError, load_run

__all__ = ["plot_cmd"]


@click.command("plot")
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("--run", "run_name", default=None,
              help="Which run of a study's folder (default: the study's main run).")  # fmt: skip
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="FILE.png (default: RUN_DIR/plot/<run>.png, apart from a study's own figures).",
)
def plot_cmd(run_dir: Path, run_name: str | None, out: Path | None) -> None:
    """Draw a run: pitch, wheel speed and reference, yaw, wheel torques (commanded and
    applied), the estimated disturbance where an observer runs, the path and the status.

    RUN_DIR is a folder written by `mwip simulate --out`, a study's folder (OUT/<study>), or a
    run's .npz file (`mwip simulate --plot` draws the same figure as OUT/run.png).
    """
    if out is not None and out.suffix.lower() != ".png":
        raise click.BadParameter(f"must end in .png, got {out.name!r}", param_hint="--out")
    try:
        run = load_run(run_dir, run_name)
    except RunFolderError as exc:
        raise click.UsageError(str(exc)) from None
    if out is None:
        out = (run_dir if run_dir.is_dir() else run_dir.parent) / "plot" / f"{run.name}.png"
    title = f"{run.study}: {run.name}" if run.study else run.name
    write_run_figure(run, out, title=title)
    click.echo(f"wrote {out} ({run.name}: {run.status}, {run.t_end:.3g} s)")
