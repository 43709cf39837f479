"""What ``mwip run`` and ``mwip reproduce`` share: their options, the robot of ``--robot``,
and running studies with a progress bar and the summary."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mwip.cli._common import ROBOT_OPTION, NonEmptyPath, gone_option, robot_option

if TYPE_CHECKING:
    from mwip.params import Params

__all__ = ["OUT", "RUN_OUT", "QUICK", "ROBOT", "GONE", "VERBOSE", "JOBS", "robot_inputs",
           "worker_count", "execute", "run_study_files", "robot_notes"]  # fmt: skip

OUT = click.option(
    "--out",
    type=NonEmptyPath(file_okay=False, path_type=Path),
    default=Path("out"),
    show_default=True,
    help="Output folder: OUT/<study>/, OUT/index.html, OUT/run.json (a folder of `mwip "
    "reproduce`'s own: other commands do not write into it without --force).",
)
RUN_OUT = click.option(
    "--out",
    type=NonEmptyPath(file_okay=False, path_type=Path),
    default=None,
    help="Output folder: OUT/<study>/, OUT/index.html, OUT/run.json (default: runs/<STUDY>, "
    "runs/<STUDY>+<STUDY>... for several, runs/<FILE's stem> for --scenario FILE; a folder of "
    "`mwip run`'s own, never `mwip reproduce`'s without --force).",
)
QUICK = click.option("--quick", is_flag=True, help="Shorter runs (for smoke tests).")
ROBOT = ROBOT_OPTION


def GONE(f: Any) -> Any:  # noqa: N802 - a decorator of options, named as the others
    """The options a robot file replaced: ``--params``, ``--nominal``, ``--twin FILE``."""
    for opt in (
        gone_option("--params", hint="the robot is --robot FILE (a robot file: `mwip robot "
                    "show` prints the default; an old parameter file loads as one)"),
        gone_option("--nominal", hint="the design model is the robot file's [design] table "
                    "(--robot FILE)"),
        gone_option("--twin", hint="the twin is the robot file's (--robot FILE; an old twin "
                    "file loads as one)"),
    ):  # fmt: skip
        f = opt(f)
    return f
VERBOSE = click.option(
    "--verbose", "-v", is_flag=True, help="List every claim in the summary, not only failures."
)
JOBS = click.option(
    "--jobs",
    "-j",
    type=int,
    default=0,
    show_default=True,
    help="Studies run in parallel processes (0: one per CPU; 1: in this process).",
)


def robot_inputs(robot_file: Path | None, damping: str = "units") -> tuple[Params, Params, Any]:
    """``(plant, design, twin)`` of ``--robot FILE`` (the book's robot under the ``--damping``
    reading without one; its twin ``None``: the default twin)."""
    r = robot_option(robot_file, damping)
    return r.body, r.design, (r.twin if robot_file is not None else None)


def worker_count(jobs: int) -> int:
    import os

    if jobs < 0 or jobs > 64:
        raise click.BadParameter(f"must be in [0, 64], got {jobs}", param_hint="--jobs")
    return jobs or (os.cpu_count() or 1)


def execute(
    names: list[str], out: Path, quick: bool, jobs: int, plant: Params, design: Params,
    verbose: bool = False, overrides: dict[str, dict[str, Any]] | None = None,
    damping: str = "units", summary: bool = True, twin: Any = None, command: str = "run",
    robot: dict[str, str] | None = None, label: str = "studies",
) -> None:  # fmt: skip
    """Run ``names`` with a progress bar, then print the one-screen summary (not
    ``summary``: its headline only, on stderr); exits 1 if a study failed. ``twin``: the
    Chapter 6 studies' twin configuration (default: the default twin); ``command`` owns OUT;
    ``robot[name]``: what study ``name`` runs on when not the book's robot (report titles);
    ``label`` names the studies in the progress display (e.g. a pass of ``reproduce``)."""
    from mwip.report import load_results, summary_lines
    from mwip.report.claims import find_compare, load_comparison
    from mwip.studies import get_study
    from mwip.studies.progress import StudyProgress
    from mwip.studies.runner import expected_runs, run_studies

    failed: list[str] = []
    prog = StudyProgress(names, {n: get_study(n).cost for n in names},
                         expected_runs(names, quick), label=label)  # fmt: skip
    tty = sys.stderr.isatty()
    steps = 1000  # the bar counts thousandths of the work (weighted by Study.cost): its ETA
    with click.progressbar(length=steps, label=label, file=sys.stderr, show_eta=True,
                           item_show_func=lambda x: x) as bar:  # fmt: skip

        def advance() -> None:
            bar.update(max(0, round(steps * prog.fraction()) - bar.pos), prog.status())

        def done(outcome: tuple[str, Any, str | None, float]) -> None:
            name, _, error, wall = outcome
            if error is not None:
                failed.append(name)
                click.echo(f"\n{name}: FAILED after {wall:.1f} s: {error}", err=True)
            line = prog.done(name, wall, error)
            if tty:
                advance()
            else:
                click.echo(line, err=True)

        def run_done(study: str) -> None:
            line = prog.run(study)
            if tty:
                advance()
            elif line is not None:
                click.echo(line, err=True)

        record = run_studies(names, out, quick=quick, jobs=jobs, plant=plant, nominal=design,
                             overrides=overrides, on_done=done, on_run=run_done,
                             damping=damping, twin=twin, command=command,
                             robot=robot)  # fmt: skip
    import shutil

    cols = shutil.get_terminal_size((120, 40)).columns
    width = max(40, cols) if verbose else max(100, cols)  # -v wraps every claim to the terminal
    compare = find_compare(out) if summary else None
    cmp = load_comparison(compare) if compare is not None else None
    lines = summary_lines(load_results(out, names), width=width, verbose=verbose,
                          damping=damping, compare=cmp)  # fmt: skip
    for line in lines if summary else [f"{out.name}: {lines[0]}"]:
        click.echo(line, err=not summary)
    from mwip.report.html import twin_headline
    from mwip.studies.registry import declared

    # the across-twins verdicts are about every Chapter 6 study: said when all of them ran
    chapter6 = {s.name for s in declared() if s.place[0] == 6}
    if summary and chapter6 <= set(names) and (twin_line := twin_headline(record)):
        click.echo(twin_line)
    plural = "study" if len(names) == 1 else "studies"
    click.echo(f"{len(names) - len(failed)}/{len(names)} {plural} done in "
               f"{record['wall_s']:.1f} s; report: {out / 'index.html'}",
               err=not summary)  # fmt: skip
    if failed:
        sys.exit(1)


def run_study_files(
    files: tuple[Path, ...], out: Path, quick: bool, robot_file: Path | None, verbose: bool,
    damping: str | None,
) -> None:  # fmt: skip
    """Run each study file (its robot unless --robot overrides it; ``damping``, when given on
    the command line, replaces the files' [robot] damping)."""
    from mwip.studies.study_file import load_study_file

    parsed = [load_study_file(f, damping) for f in files]  # validate all before running any
    for sf in parsed:
        reading = damping or "units"
        plant, design, twin = sf.plant, sf.nominal, sf.twin
        if robot_file is not None:
            plant, design, twin = robot_inputs(robot_file, reading)
        click.echo(f"{sf.path}: {sf.name}", err=True)
        notes = robot_notes([sf.name], robot_file)
        if robot_file is None and sf.robot is not None:
            notes[sf.name] = f"the robot of {sf.path}"
        execute([sf.name], out, quick or sf.quick, 1, plant, design, verbose,
                 {sf.name: sf.settings}, damping=reading, twin=twin, robot=notes)  # fmt: skip


def robot_notes(names: list[str], robot_file: Path | None) -> dict[str, str]:
    """What each study of ``names`` runs on besides the book's robot (its body, design model
    and, for the Chapter 6 studies, its twin), as the report's section titles say it."""
    if robot_file is None:
        return {}
    return {name: f"robot {robot_file}" for name in names}
