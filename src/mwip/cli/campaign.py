"""``mwip campaign run | show | report``: robustness campaigns (:mod:`mwip.campaign`)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mwip.cli._common import NonEmptyPath, robot_option

__all__ = ["campaign"]


@click.group()
def campaign() -> None:
    """Robustness campaigns: Monte Carlo, regions of attraction, claim robustness."""


@campaign.command("show")
@click.argument("name", required=False)
def show_cmd(name: str | None) -> None:
    """Print built-in campaign NAME's file (to copy and edit); without NAME, list them."""
    from mwip.campaign.spec import builtin_names, builtin_text

    if name is None:
        for n in builtin_names():
            click.echo(n)
        return
    click.echo(builtin_text(name), nl=False)


@campaign.command("run")
@click.argument("campaign_name", metavar="NAME|FILE.toml")
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Results folder (created; a rerun continues an interrupted run).",
)
@click.option(
    "--samples",
    type=int,
    default=None,
    help="Number of samples N (overrides the file's campaign.samples), >= 1.",
)
@click.option(
    "--jobs",
    type=int,
    default=None,
    help="Worker processes of the local Dask cluster (default: the CPUs); 1 runs in this process.",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Run on an existing Dask cluster (e.g. tcp://host:8786).",
)
@click.option(
    "--max-hours",
    "max_hours",
    type=float,
    default=None,
    help="Refuse a run estimated to take more than this many hours of one core (default 48; "
    "the estimate: ~500 robot-seconds a second on the twin, ~10,000 on the plain plant).",
)
@click.option(
    "--chunk",
    type=int,
    default=None,
    help="Samples per chunk (rounded up to whole blocks); does not change results.",
)
@click.option(
    "--robot", "robot_file", type=NonEmptyPath(dir_okay=False, path_type=Path), default=None,
    help="The robot (a robot file, docs/robot.md): its body is 'real', its design model "
    "'nominal' and its hardware the twin (replaces the file's [robot] file; default the "
    "book's robot). Robustness campaigns only.",
)  # fmt: skip
def run_cmd(
    campaign_name: str,
    out: Path,
    samples: int | None,
    jobs: int | None,
    scheduler: str | None,
    chunk: int | None,
    max_hours: float | None,
    robot_file: Path | None,
) -> None:
    """Run (or continue) campaign NAME (built-in) or FILE.toml into --out."""
    from mwip.cli._common import need_extra

    need_extra("campaign", "mwip campaign run",  # (Dask unless in this process; Parquet)
               ("pyarrow", "pandas") if jobs == 1 and scheduler is None else None)  # fmt: skip
    from mwip.campaign.execute import max_jobs, run_campaign
    from mwip.campaign.spec import load_campaign

    robot = None if robot_file is None else robot_option(robot_file)
    camp = load_campaign(campaign_name, robot=robot)
    if samples is not None:
        try:  # the campaign validates its sample count
            camp = camp.with_samples(samples)
        except ValueError as exc:  # "samples must be ...": under the option's name
            raise click.BadParameter(str(exc).removeprefix("samples "),
                                     param_hint="--samples") from None  # fmt: skip
    if jobs is not None and not 1 <= jobs <= max_jobs():
        raise click.BadParameter(f"must be an integer in [1, {max_jobs()}] (4 per CPU), got "
                                 f"{jobs}", param_hint="--jobs")  # fmt: skip
    if chunk is not None and chunk < 1:
        raise click.BadParameter(f"must be an integer >= 1, got {chunk}", param_hint="--chunk")
    from mwip.campaign.execute import n_blocks
    from mwip.outdir import hold

    n_blocks(camp)  # the sizes are refused before anything is created
    if not out.exists() or out.is_dir():  # (else run_campaign names the problem)
        click.get_current_context().with_resource(hold(out))  # a second run here is refused
    res = run_campaign(camp, out, jobs=jobs, scheduler=scheduler, chunk=chunk,
                       max_hours=max_hours)
    if res.status == "finished-before":
        click.echo(f"campaign already finished: {res.path} ({res.rows} rows); nothing to do")
    elif res.status == "interrupted":
        click.echo(
            f"mwip: interrupted; {res.blocks_run} blocks saved this run in {out}; "
            "run the same command to continue",
            err=True,
        )
        sys.exit(130)  # (click's Exit is swallowed by mwip.cli.main's non-standalone mode)
    else:
        click.echo(
            f"wrote {res.path} ({res.rows} rows; {res.blocks_run} of "
            f"{res.blocks_total} blocks run now, {res.wall_s:.1f} s)"
        )


@campaign.command("report")
@click.argument("out", type=click.Path(path_type=Path))
def report_cmd(out: Path) -> None:
    """Write OUT/report.html and its PNGs from OUT/results.parquet."""
    from mwip.cli._common import need_extra

    need_extra("campaign", "mwip campaign report", ("pyarrow", "pandas"))
    from mwip.campaign.report import write_campaign_report

    if not (out / "results.parquet").exists():
        raise click.BadParameter(
            f"no results.parquet in {str(out)!r}; run the campaign first", param_hint="DIR"
        )
    path = write_campaign_report(out)
    click.echo(f"report: {path}")
