"""``mwip bench [CONTROLLER...] --out DIR``: the robustness benchmark (:mod:`mwip.bench`)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mwip.cli._common import NonEmptyPath, robot_option

__all__ = ["bench"]


@click.command("bench")
@click.argument("controllers", nargs=-1, metavar="[CONTROLLER...]")
@click.option("--out", type=NonEmptyPath(path_type=Path), default=None,
              help="Results folder (created; a rerun continues an interrupted run).")
@click.option("--settings", "settings_files", multiple=True, metavar="FILE",
              help="Enter a controller with the settings of FILE ([controller] name, "
              "[settings]; e.g. mwip tune's best.toml). Repeatable.")
@click.option("--scenario", "scenario_files", multiple=True, metavar="FILE",
              help="Enter the controller of scenario FILE (its controller, [controller] "
              "settings and [design] model). Repeatable.")
@click.option("--quick", is_flag=True, help="The definition's [quick] sizes (a first look).")
@click.option("--samples", type=int, default=None,
              help="Runs per level (overrides the definition's bench.samples).")
@click.option("--jobs", type=int, default=None,
              help="Worker processes of the local Dask cluster (default: the CPUs); 1 runs in "
              "this process. Does not change the scores.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on an existing Dask cluster (e.g. tcp://host:8786).")
@click.option("--max-hours", "max_hours", type=float, default=None,
              help="Refuse a benchmark estimated to take more than this many hours of one "
              "core (default 48; ~500 robot-seconds a second on the twin).")
@click.option("--definition", default=None, metavar="FILE",
              help="A benchmark definition (default: the built-in one; print it with --show).")
@click.option("--show", is_flag=True, help="Print the built-in definition and exit.")
@click.option("--robot", "robot_file", type=NonEmptyPath(dir_okay=False, path_type=Path),
              default=None, help="The robot (a robot file, docs/robot.md): its body is every "
              "run's real robot, its twin the hardware, its design model the one the "
              "registry's and settings files' controllers are designed on (default: the "
              "book's robot, its identified twin and posterior).")
def bench(controllers: tuple[str, ...], out: Path | None, settings_files: tuple[str, ...],
          scenario_files: tuple[str, ...], quick: bool, samples: int | None, jobs: int | None,
          scheduler: str | None, max_hours: float | None, definition: str | None,
          show: bool, robot_file: Path | None) -> None:  # fmt: skip
    """Score each CONTROLLER (default: every registered one) on the robustness axes.

    Every entrant runs on the robot's twin (default: the book's robot's identified twin)
    over the axes of the definition (model parameters, the twin's unknowns, measurement and
    actuator noise, dead-band, responsiveness, delay, payload, push); each axis's level is a
    success fraction over a fixed, seeded set of runs with its Wilson 95 % interval. Writes
    DIR/scores.parquet, DIR/index.html (the leaderboard), DIR/leaderboard.png and
    DIR/levels.png (docs/bench.md).
    """
    from mwip.bench.spec import MAX_SAMPLES, builtin_text, load_bench

    if show:
        click.echo(builtin_text(), nl=False)
        return
    from mwip.cli._common import need_extra

    need_extra("campaign", "mwip bench",  # (Dask unless in this process; Parquet)
               ("pyarrow", "pandas") if jobs == 1 and scheduler is None else None)  # fmt: skip
    if out is None:
        raise click.UsageError("Missing option '--out'.")
    if not str(out).strip():
        raise click.BadParameter("the name is empty; give a path", param_hint="--out")
    from mwip.bench.entrants import resolve_entrants
    from mwip.bench.finish import run_bench
    from mwip.bench.run import BenchRun
    from mwip.campaign.execute import max_jobs, n_blocks

    if samples is not None and not 1 <= samples <= MAX_SAMPLES:
        raise click.BadParameter(f"must be an integer in [1, {MAX_SAMPLES}], got {samples}",
                                 param_hint="--samples")  # fmt: skip
    if jobs is not None and not 1 <= jobs <= max_jobs():
        raise click.BadParameter(f"must be an integer in [1, {max_jobs()}] (4 per CPU), got "
                                 f"{jobs}", param_hint="--jobs")  # fmt: skip
    spec = load_bench(definition, quick)
    if samples is not None:
        spec = spec.with_samples(samples)
    robot = None if robot_file is None else robot_option(robot_file)
    design = None if robot is None else robot.design
    entrants = resolve_entrants(list(controllers), settings_files, scenario_files, design)
    work = BenchRun(spec, entrants, robot)
    n_blocks(work)  # type: ignore[arg-type]  # the sizes are refused before anything is written
    if out.exists() and not out.is_dir():
        raise click.BadParameter(f"{str(out)!r} exists and is not a folder", param_hint="--out")
    from mwip.outdir import hold

    click.get_current_context().with_resource(hold(out))  # a second run here is refused
    res = run_bench(work, out, jobs=jobs, scheduler=scheduler, max_hours=max_hours)
    if res.status == "interrupted":
        click.echo(f"mwip: interrupted; {res.blocks_run} blocks saved this run in {out}; "
                   "run the same command to continue", err=True)  # fmt: skip
        sys.exit(130)
    done = ("already finished; scores rewritten" if res.status == "finished-before"
            else f"{res.blocks_run} of {res.blocks_total} blocks run now, {res.wall_s:.1f} s")
    click.echo(f"wrote {out / 'scores.parquet'} and {out / 'index.html'} ({len(entrants)} "
               f"entrants, {res.runs} runs; {done})")  # fmt: skip
