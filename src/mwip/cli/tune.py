"""``mwip tune CONTROLLER --out DIR``: robust gain tuning with Optuna (:mod:`mwip.tune`)."""

from __future__ import annotations

from pathlib import Path

import click

from mwip.cli._common import NonEmptyPath, robot_option

__all__ = ["tune"]


@click.command("tune")
@click.argument("controller")
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Results folder: best.toml, index.html, trials.csv, validation.json and the "
    "study (study.db); the same command continues an interrupted run.",
)
@click.option(
    "--objective",
    default="robust",
    show_default=True,
    metavar="NAME|FILE",
    help="A built-in objective (robust: the twin; plain: the plain plant; pareto) "
    "or an objective TOML file (docs/tune.md).",
)
@click.option(
    "--trials",
    type=int,
    default=100,
    show_default=True,
    help="Finished (complete or pruned) trials the study should hold, >= 1.",
)
@click.option(
    "--storage",
    default=None,
    metavar="URL",
    help="An Optuna RDB URL (sqlite:///..., postgresql://...) shared by several "
    "`mwip tune` processes (default: sqlite in OUT). The connection and the database's "
    "handshake must answer within 10 s.",
)
@click.option(
    "--sampler",
    type=click.Choice(["tpe", "cmaes", "nsga2"]),
    default=None,
    help="Optuna sampler (default: tpe; nsga2 for a pareto objective).",
)
@click.option(
    "--seed",
    type=int,
    default=0,
    show_default=True,
    help="Sampler seed (the robots' seeds are the objective's).",
)
@click.option(
    "--force",
    is_flag=True,
    help="Write into OUT even if it is a non-empty folder mwip did not create.",
)
@click.option(
    "--robot", "robot_file", type=NonEmptyPath(dir_okay=False, path_type=Path), default=None,
    help="The robot to tune for (a robot file, docs/robot.md: its body, design model and "
    "twin; replaces the objective's [robots] robot; default the book's robot).",
)  # fmt: skip
def tune(controller: str, out: Path, objective: str, trials: int, storage: str | None,
         sampler: str | None, seed: int, force: bool, robot_file: Path | None) -> None:  # fmt: skip
    """Tune CONTROLLER's settings for robustness: every trial evaluates candidate settings on a
    batch of robots (a campaign's distribution, on the twin or the plain plant); writes
    OUT/best.toml (`mwip simulate --controller C --settings OUT/best.toml`)."""
    import sys

    try:
        from mwip.tune.run import execute, plan

        robot = None if robot_file is None else robot_option(robot_file)
        p = plan(controller, out, objective, trials, storage, sampler, seed, force, robot)
        execute(p, log=lambda text: click.echo(text, err=True))
    except KeyboardInterrupt:
        # one line, no traceback (Optuna's or ours); the trials finished so far are in the
        # study and every file in OUT is as it was: the same command continues
        click.echo(f"mwip tune: interrupted; the finished trials are kept, {str(out)!r} is as "
                   "it was; run the same command to continue", err=True)  # fmt: skip
        sys.exit(130)
