"""``mwip reproduce``: every study on built-in defaults, under both damping readings, into
one results folder with its report."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mwip.cli._common import DAMPING, FORCE, out_ok
from mwip.cli._studies import (
    GONE,
    JOBS,
    OUT,
    QUICK,
    ROBOT,
    VERBOSE,
    execute,
    robot_inputs,
    robot_notes,
    worker_count,
)
from mwip.damping import DAMPING_READINGS

__all__ = ["reproduce"]


@click.command()
@OUT
@QUICK
@ROBOT
@GONE
@DAMPING
@JOBS
@VERBOSE
@FORCE
@click.option("--list", "list_only", is_flag=True, help="List the studies and exit.")
@click.option(
    "--compare/--no-compare",
    default=None,
    help="Also run every study under the other damping reading into OUT/compare-<reading>/; "
    "the report shows each book claim's verdict under both (default: on for the book's "
    "robot; a robot file's damping has one reading).",
)
def reproduce(
    out: Path,
    quick: bool,
    robot_file: Path | None,
    damping: str,
    jobs: int,
    verbose: bool,
    force: bool,
    list_only: bool,
    compare: bool | None,
) -> None:
    """Run every study on built-in defaults; write OUT/<study>/, OUT/index.html, OUT/run.json.

    Results are written to a staging folder and moved into OUT when complete (Ctrl-C leaves
    OUT as it was). A study that fails is reported with its error and does not stop the
    others; the exit code is then 1.
    """
    from mwip.studies import study_names
    from mwip.studies.registry import declared

    if list_only:
        for s in declared():
            click.echo(f"{s.name:24s} {s.source}")
        return
    if compare and robot_file is not None:
        raise click.UsageError("--compare runs the book's tables under both damping readings; a "
                               "robot file (--robot) gives its own Db, Dw: give one of the two")
    compare = robot_file is None if compare is None else compare
    out_ok(out, force, "reproduce")
    plant, design, twin = robot_inputs(robot_file, damping)
    notes = robot_notes(study_names(), robot_file)
    from mwip.outdir import claim, hold

    claim(out, "reproduce")  # OUT holds the staging (and the comparison) from now on
    click.get_current_context().with_resource(hold(out))  # a second reproduce is refused
    code = 0
    if compare:  # first the other reading, so that the main report finds it
        other = next(d for d in DAMPING_READINGS if d != damping)
        click.echo(f"under the {other} damping reading, into {out / f'compare-{other}'}:",
                   err=True)  # fmt: skip
        try:
            execute(study_names(), out / f"compare-{other}", quick, worker_count(jobs),
                     *robot_inputs(None, other)[:2], damping=other,
                     summary=False, twin=twin, command="reproduce", robot=notes,
                     label=f"pass 1/2 ({other} reading): studies")  # fmt: skip
        except SystemExit as exc:
            code = int(exc.code or 0)
    execute(study_names(), out, quick, worker_count(jobs), plant, design, verbose, damping=damping,
             twin=twin, command="reproduce", robot=notes,
             label=f"pass 2/2 ({damping} reading): studies" if compare else "studies")  # fmt: skip
    if code:
        sys.exit(code)
