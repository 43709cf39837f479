"""``mwip reproduce``: every study on built-in defaults, under both damping readings, into
one results folder with its report."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mwip.cli._common import DAMPING, FORCE, TWIN_OPTION, load_twin_option, out_ok
from mwip.cli._studies import (
    JOBS,
    NOMINAL,
    OUT,
    PLANT,
    QUICK,
    VERBOSE,
    execute,
    plant_and_design,
    robot_notes,
    worker_count,
)
from mwip.damping import DAMPING_READINGS

__all__ = ["reproduce"]


@click.command()
@OUT
@QUICK
@PLANT
@NOMINAL
@DAMPING
@TWIN_OPTION
@JOBS
@VERBOSE
@FORCE
@click.option("--list", "list_only", is_flag=True, help="List the studies and exit.")
@click.option(
    "--compare/--no-compare",
    default=True,
    show_default=True,
    help="Also run every study under the other damping reading into OUT/compare-<reading>/; "
    "the report shows each book claim's verdict under both.",
)
def reproduce(
    out: Path,
    quick: bool,
    params_file: str | None,
    nominal_file: str | None,
    damping: str,
    twin_file: Path | None,
    jobs: int,
    verbose: bool,
    force: bool,
    list_only: bool,
    compare: bool,
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
    out_ok(out, force, "reproduce")
    plant, design = plant_and_design(params_file, nominal_file, damping)
    twin = None if twin_file is None else load_twin_option(twin_file)
    notes = robot_notes(study_names(), params_file, nominal_file, twin_file)
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
                     *plant_and_design(params_file, nominal_file, other), damping=other,
                     summary=False, twin=twin, command="reproduce", robot=notes,
                     label=f"pass 1/2 ({other} reading): studies")  # fmt: skip
        except SystemExit as exc:
            code = int(exc.code or 0)
    execute(study_names(), out, quick, worker_count(jobs), plant, design, verbose, damping=damping,
             twin=twin, command="reproduce", robot=notes,
             label=f"pass 2/2 ({damping} reading): studies" if compare else "studies")  # fmt: skip
    if code:
        sys.exit(code)
