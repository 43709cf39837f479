"""``mwip list | run | scenario``: the studies by name (each a claim of the book, run into a
results folder with its report), and their study files (TOML) to copy, edit and run."""

from __future__ import annotations

from pathlib import Path

import click

from mwip.cli._common import (
    DAMPING,
    FILE_FORCE,
    FORCE,
    NonEmptyPath,
    file_ok,
    out_ok,
    record_file,
)
from mwip.cli._studies import (
    GONE,
    JOBS,
    QUICK,
    ROBOT,
    RUN_OUT,
    VERBOSE,
    execute,
    robot_inputs,
    robot_notes,
    run_study_files,
    worker_count,
)

__all__ = ["list_cmd", "run_cmd", "scenario"]


@click.command("list")
def list_cmd() -> None:
    """List the studies with their book sources."""
    from mwip.studies.registry import declared

    for study in declared():  # read from the study modules' source, none imported
        click.echo(f"{study.name:24s} {study.source}")


@click.command("run")
@click.argument("studies", nargs=-1)
@click.option(
    "--scenario",
    "scenarios",
    multiple=True,
    type=NonEmptyPath(dir_okay=False, path_type=Path),
    help="A study file (TOML; `mwip scenario STUDY` prints one to copy); repeatable.",
)
@RUN_OUT
@QUICK
@ROBOT
@GONE
@DAMPING
@JOBS
@VERBOSE
@FORCE
@click.pass_context
def run_cmd(
    ctx: click.Context,
    studies: tuple[str, ...],
    scenarios: tuple[Path, ...],
    out: Path | None,
    quick: bool,
    robot_file: Path | None,
    damping: str,
    jobs: int,
    verbose: bool,
    force: bool,
) -> None:
    """Run one or more studies (see `mwip list`) into OUT (default runs/<STUDY>) and update
    OUT/index.html."""
    from mwip.studies import study_names

    known = study_names()
    for study in studies:
        if study not in known:
            raise click.BadParameter(
                f"unknown study {study!r}; choose from: {', '.join(known)}", param_hint="STUDY"
            )
    if not studies and not scenarios:
        raise click.UsageError("give at least one STUDY or --scenario FILE")
    if out is None:
        stems = [*dict.fromkeys(studies), *(f.stem for f in scenarios)]
        label = "+".join(stems) if len("+".join(stems)) <= 80 else f"{stems[0]}+{len(stems) - 1}"
        out = Path("runs") / label
    out_ok(out, force, "run")
    plant, design, twin = robot_inputs(robot_file, damping)
    if scenarios:
        given = ctx.get_parameter_source("damping") is not click.core.ParameterSource.DEFAULT
        run_study_files(scenarios, out, quick, robot_file, verbose,
                        damping if given else None)  # fmt: skip
    if studies:
        names = list(dict.fromkeys(studies))
        notes = robot_notes(names, robot_file)
        execute(names, out, quick, worker_count(jobs), plant, design, verbose, damping=damping,
                 twin=twin, robot=notes)  # fmt: skip


@click.command()
@click.argument("study")
@click.option(
    "--out",
    type=NonEmptyPath(dir_okay=False, path_type=Path),
    default=None,
    help="Write the study file here (default: print it); an existing file that mwip did not "
    "write is refused unless --force.",
)
@FILE_FORCE
def scenario(study: str, out: Path | None, force: bool) -> None:
    """Print (or write) the study file of STUDY: which study, the robot, and all its settings.

    Copy it, edit it, run it with `mwip run --scenario FILE.toml`.
    """
    from mwip.io import write_text_atomic
    from mwip.studies import study_names
    from mwip.studies.settings import packaged_text

    known = study_names()
    if study not in known:
        raise click.BadParameter(
            f"unknown study {study!r}; choose from: {', '.join(known)}", param_hint="STUDY"
        )
    text = packaged_text(study)
    if out is None:
        click.echo(text, nl=False)
    else:
        file_ok(out, force)
        write_text_atomic(out, text)
        record_file(out)
        click.echo(f"wrote {out}")
