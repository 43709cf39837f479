"""``mwip report``: rebuild a results folder's report (index.html) and print its summary."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mwip.cli._common import NonEmptyPath, cut
from mwip.cli._studies import VERBOSE

__all__ = ["report"]


@click.command()
@click.option(
    "--out",
    type=NonEmptyPath(file_okay=False, exists=True, path_type=Path),
    default=Path("out"),
    show_default=True,
    help="Results folder to report on.",
)
@click.option(
    "--compare",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="A second results folder (e.g. under the other damping reading) whose verdicts are "
    "shown beside; default: OUT/compare-* if there is one.",
)
@click.option(
    "--claims",
    "claims_campaign",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="A finished `mwip campaign run claims` folder: each claim shows how often it holds "
    "over the settings the book leaves open; default: OUT/claims-campaign if present.",
)
@VERBOSE
def report(out: Path, compare: Path | None, claims_campaign: Path | None, verbose: bool) -> None:
    """Rebuild OUT/index.html from the results in OUT and print the summary."""
    from mwip.report import load_results, load_run_record, summary_lines, write_report
    from mwip.report.claims import find_compare, load_comparison
    from mwip.studies import study_names

    known = study_names()
    names = [n for n in known if (out / n / "metrics.json").exists()]
    if not names:
        raise click.UsageError(f"--out: no study results in {out}")
    if compare is not None and not any((compare / n / "metrics.json").is_file() for n in known):
        raise click.BadParameter(f"no study results in {compare}", param_hint="--compare")
    compare = compare if compare is not None else find_compare(out)
    if claims_campaign is not None and not (claims_campaign / "results.parquet").is_file():
        raise click.BadParameter(f"no finished campaign (results.parquet) in {claims_campaign}",
                                 param_hint="--claims")  # fmt: skip
    path = write_report(out, names, compare, claims_campaign)
    cmp = load_comparison(compare) if compare is not None else None
    for problem in cmp.unreadable if cmp is not None else ():
        click.echo(f"mwip: notice: --compare: {cut(problem, 200)}; that study is left out of "
                   "the comparison", err=True)  # fmt: skip
    import shutil

    results = load_results(out, names)
    cols = shutil.get_terminal_size((100, 40)).columns
    width = max(40, cols) if verbose else max(100, cols)  # -v wraps every claim to the terminal
    for line in summary_lines(results, width=width, verbose=verbose,
                              damping=load_run_record(out).get("damping"),
                              compare=cmp):  # fmt: skip
        click.echo(line)
    from mwip.report.html import twin_headline
    from mwip.studies.registry import declared

    chapter6 = {s.name for s in declared() if s.place[0] == 6}  # the line is about them all
    if chapter6 <= set(names) and (twin_line := twin_headline(load_run_record(out))):
        click.echo(twin_line)
    click.echo(f"report: {path}")
    bad = [r.error for r in results if r.doc is None and r.error and "metrics.json" in r.error]
    for message in bad:
        click.echo(f"mwip: error: {message}", err=True)
    if bad:
        sys.exit(1)
