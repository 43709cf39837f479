"""``mwip twin calibrate``: the book's robot by comparing declared twin structures by their
evidence (docs/twin_fit.md, "Calibrating on evidence"; :mod:`mwip.calibration.comparison`)."""

from __future__ import annotations

from pathlib import Path

import click

from mwip.cli.twin import twin

__all__: list[str] = []  # a subcommand of ``mwip twin`` (added to it on import)


def _structures(text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    if not names:
        raise click.UsageError("--structures: give names separated by commas, e.g. S0,S1")
    return names


@twin.command("calibrate")
@click.argument("evidence", metavar="EVIDENCE")
@click.option("--out", "out", required=True, type=click.Path(path_type=Path),
              help="Output folder (a rerun resumes its draws).")
@click.option("--structures", "structures", default=None, metavar="S0,S1,...",
              help="The declared structures to compare (default: all of "
                   "book-structures.toml).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Worker processes per block of twins.")
@click.option("--draws", type=click.IntRange(1, 1_000_000), default=None,
              help="Stage A's prior draws per structure (default: the declaration's; fewer: "
                   "a smoke test, not the declared result).")
@click.option("--kernel-draws", "kernel_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="Stage B's kernel draws per structure (default: the "
                                 "declaration's).")
@click.option("--duration", type=click.FloatRange(0.0, 15.0), default=0.0,
              help="Cap every run at this many seconds (a smoke test; 0: the studies' own).")
@click.option("--replay", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="Rebuild the result from this per-twin file (draws.parquet; "
                                 "the shipped one: docs/book_calibration/structures.parquet) "
                                 "without running a twin.")
@click.option("--force", is_flag=True, help="Write into a non-empty folder that is not mwip's.")
def twin_calibrate(evidence: str, out: Path, structures: str | None, jobs: int,
                   draws: int | None, kernel_draws: int | None, duration: float,
                   replay: Path | None, force: bool) -> None:  # fmt: skip
    """Compare the declared twin structures of the book's robot by their evidence: EVIDENCE is
    `book` (the book's Chapter 6 evidence, book-evidence.toml) or an evidence file of the same
    form."""
    from mwip import outdir
    from mwip.calibration.comparison import DRAWS_FILE, RESULT_FILE, run_comparison
    from mwip.calibration.comparison_report import headline

    path = None if evidence == "book" else Path(evidence)
    if path is not None and not path.is_file():
        raise click.UsageError(f"EVIDENCE: {evidence!r} is neither 'book' nor a file")
    names = _structures(structures)
    if names is not None:
        from mwip.calibration.structures import load_structures

        known = list(load_structures())
        bad = [n for n in names if n not in known]
        if bad:
            raise click.UsageError(f"--structures: unknown structure {bad[0]!r}; allowed: "
                                   f"{', '.join(known)}")  # fmt: skip
    if replay is not None and (draws, kernel_draws) != (None, None) or (
            replay is not None and duration):
        raise click.UsageError("--replay rebuilds a stored result: leave out --draws, "
                               "--kernel-draws and --duration")  # fmt: skip
    target = outdir.check(out, force, command="twin calibrate")
    if replay is None and (draws, kernel_draws) == (None, None):
        click.echo("mwip: the declared sample evaluates 6,000 twins per structure on the 25 "
                   "Chapter 6 runs (BENCHMARKS.md); it is resumable (Ctrl-C, then the same "
                   "command continues)", err=True)  # fmt: skip
    outdir.claim(target, "twin calibrate")
    try:
        doc = run_comparison(target, evidence=path, names=names, jobs=jobs, duration=duration,
                             prior_draws=draws, kernel_draws=kernel_draws, replay=replay,
                             note=lambda line: click.echo(line, err=True))  # fmt: skip
    except ValueError as exc:
        raise click.UsageError(str(exc).splitlines()[0]) from None
    click.echo(headline(doc))
    wrote = [RESULT_FILE, "structures.md"] + ([] if replay is not None else [DRAWS_FILE])
    click.echo(f"wrote {target / wrote[0]}, " + ", ".join(wrote[1:]))
