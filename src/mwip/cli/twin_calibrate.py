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
              help="Stage A's prior draws per structure (default: the declaration's, or the "
                   "facts file's [sample]; fewer: a smoke test, not the declared result).")
@click.option("--kernel-draws", "kernel_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="Stage B's kernel draws per structure, a search around "
                                 "the twins meeting the most facts (default: the declaration's, "
                                 "or the facts file's [sample] search_draws).")
@click.option("--directed-draws", "directed_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="Stage C's twins per generation, the directed search where "
                                 "stages A and B found no twin meeting every fact (default: "
                                 "the declaration's revision 8; 0: none).")
@click.option("--importance-draws", "importance_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="Stage D's twins per structure, importance sampling of the "
                                 "evidence around the twins meeting every fact (default: the "
                                 "declaration's revision 9; 0: none).")
@click.option("--duration", type=click.FloatRange(0.0, 15.0), default=0.0,
              help="Cap every run at this many seconds (a smoke test; 0: the studies' own).")
@click.option("--replay", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              default=None, help="Rebuild the result from this per-twin file (draws.parquet; "
                                 "the shipped one: docs/book_calibration/structures.parquet) "
                                 "without running a twin.")
@click.option("--force", is_flag=True, help="Write into a non-empty folder that is not mwip's.")
@click.option("--robot", "robot_file", type=click.Path(path_type=Path), default=None,
              help="With a facts file as EVIDENCE: the robot file to calibrate (its [prior] "
                   "declares the unknowns; default: the default robot).")
@click.option("--record", is_flag=True,
              help="Instead: the five-stage calibration of structure S0 of record "
                   "(book-evidence.toml's revisions 1-5: the default robot's; about 2 hours).")
@click.option("--samples", type=click.IntRange(1, 100_000), default=None,
              help="--record: prior draws (default: the declaration's, 2000).")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=None,
              help="--record: seed of the prior draws (default: the declaration's).")
@click.option("--stage2-draws", "stage2", type=click.IntRange(0, 100_000), default=None,
              help="--record: twins of stage 2, the declared box proposal (default: the "
              "declaration's, 1000; 0: none).")
@click.option("--chain-steps", "chain_steps", type=click.IntRange(0, 100_000), default=None,
              help="--record: generations of stage 3's Markov chains, burn-in scaled alike "
              "(default: the declaration's, 500; 0: no chains).")
@click.option("--mixture-draws", "mixture_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="--record: twins of stage 4's mixture draws (default: the "
              "declaration's, 6000; 0: no stages 4-5).")
@click.option("--envelope-draws", "envelope_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="--record: twins of stage 5's envelope draws, without "
              "revision 5's extension (default: the declaration's 20000, extended until the "
              "effective size is 100; 0: no stage 5).")
def twin_calibrate(evidence: str, out: Path, structures: str | None, jobs: int,
                   draws: int | None, kernel_draws: int | None, directed_draws: int | None,
                   importance_draws: int | None, duration: float,
                   replay: Path | None, force: bool, record: bool, samples: int | None,
                   seed: int | None, stage2: int | None, chain_steps: int | None,
                   mixture_draws: int | None, envelope_draws: int | None,
                   robot_file: Path | None) -> None:  # fmt: skip
    """A robot from evidence of what it did. EVIDENCE `book`: the book's robot from the book's
    Chapter 6 evidence (book-evidence.toml), comparing the declared twin structures
    (book-structures.toml), or with --record the calibration of record. EVIDENCE a facts file
    ([[fact]] entries: "it stood with these gains", "this metric was this value" on your
    scenarios): the robot of --robot calibrated on them, its [prior] the unknowns; writes
    calibration.md, calibration.json and the calibrated robot.toml (docs/twin_fit.md)."""
    from mwip import outdir

    facts = _facts_path(evidence)
    if facts is not None:
        _robot_mode(click.get_current_context(), facts, robot_file, out, force, jobs, draws,
                    kernel_draws, duration)  # fmt: skip
        return
    if robot_file is not None:
        raise click.UsageError("--robot: only with a facts file as EVIDENCE ([[fact]] entries "
                               "on your scenarios); the book's evidence calibrates the book's "
                               "robot")  # fmt: skip
    _one_mode(click.get_current_context(), record)
    if record:
        if evidence != "book":
            raise click.UsageError("--record: the calibration of record is the book's "
                                   "(EVIDENCE 'book')")  # fmt: skip
        from mwip.cli._common import need_extra

        need_extra("campaign", "mwip twin calibrate book --record",  # (a campaign's engine)
                   None if jobs > 1 else ("pyarrow", "pandas"))  # fmt: skip
        _record(out, force, samples, seed, jobs, duration, stage2, chain_steps, mixture_draws,
                envelope_draws)
        return
    from mwip.calibration.comparison import (
        DRAWS_FILE,
        RESULT_FILE,
        ROBOT_FILE,
        STATUS_FILE,
        run_comparison,
    )
    from mwip.calibration.comparison_report import headline

    path = None if evidence == "book" else Path(evidence)
    names = _structures(structures)
    if names is not None:
        from mwip.calibration.structures import load_structures

        known = list(load_structures())
        bad = [n for n in names if n not in known]
        if bad:
            raise click.UsageError(f"--structures: unknown structure {bad[0]!r}; allowed: "
                                   f"{', '.join(known)}")  # fmt: skip
    if replay is not None and ((draws, kernel_draws, directed_draws, importance_draws)
                               != (None,) * 4 or duration):  # fmt: skip
        raise click.UsageError("--replay rebuilds a stored result: leave out --draws, "
                               "--kernel-draws, --directed-draws, --importance-draws and "
                               "--duration")  # fmt: skip
    target = outdir.check(out, force, command="twin calibrate")
    if replay is None and (draws, kernel_draws) == (None, None):
        click.echo("mwip: the declared sample evaluates 6,000 twins per structure on the 25 "
                   "Chapter 6 runs, 3,000 more in a directed search where none meets every "
                   "fact, and 4,000 more by importance sampling where one does (about 40 "
                   "minutes with --jobs 2 on a 2-core machine, BENCHMARKS.md); it is "
                   "resumable (Ctrl-C, then the same command continues)",
                   err=True)  # fmt: skip
    outdir.claim(target, "twin calibrate")
    try:
        doc = run_comparison(target, evidence=path, names=names, jobs=jobs, duration=duration,
                             prior_draws=draws, kernel_draws=kernel_draws, replay=replay,
                             directed_draws=directed_draws, importance_draws=importance_draws,
                             note=lambda line: click.echo(line, err=True))  # fmt: skip
    except ValueError as exc:
        raise click.UsageError(str(exc).splitlines()[0]) from None
    click.echo(headline(doc))
    wrote = [RESULT_FILE, "structures.md", "structures.png"] + ([] if replay is not None
                                                                else [DRAWS_FILE])  # fmt: skip
    if doc.get("member") is not None:
        wrote += [ROBOT_FILE, STATUS_FILE]
    click.echo(f"wrote {target / wrote[0]}, " + ", ".join(wrote[1:]))


def _facts_path(evidence: str) -> Path | None:
    """``evidence`` as a facts file (``[[fact]]`` entries), else ``None`` (the book's form)."""
    if evidence == "book":
        return None
    from mwip.calibration.facts_file import is_facts_file

    path = Path(evidence)
    if not path.is_file():
        raise click.UsageError(f"EVIDENCE: {evidence!r} is neither 'book' nor a file")
    try:
        return path if is_facts_file(path) else None
    except ValueError as exc:
        raise click.UsageError(f"EVIDENCE: {str(exc).splitlines()[0]}") from None


def _robot_mode(ctx: click.Context, facts: Path, robot_file: Path | None, out: Path,
                force: bool, jobs: int, draws: int | None, kernel_draws: int | None,
                duration: float) -> None:  # fmt: skip
    """``twin calibrate FACTS [--robot FILE]``: :func:`mwip.calibration.robot_evidence.
    calibrate_robot` into ``out`` (a rerun resumes its draws)."""
    from click.core import ParameterSource

    from mwip import outdir
    from mwip.calibration.robot_evidence import (
        DRAWS_FILE,
        RESULT_FILE,
        calibrate_robot,
        prepare,
    )
    from mwip.calibration.robot_evidence_report import headline
    from mwip.cli._common import need_extra, robot_option

    book_only = [p for p in ctx.command.params
                 if p.name in ("structures", "replay", "record", "directed_draws",
                               "importance_draws") + _RECORD_ONLY
                 and ctx.get_parameter_source(p.name) == ParameterSource.COMMANDLINE]
    if book_only:
        names = ", ".join(max(p.opts, key=len) for p in book_only if isinstance(p, click.Option))
        raise click.UsageError(f"{names}: only for the book's evidence (EVIDENCE 'book'); a "
                               "facts file calibrates the --robot file's own prior")  # fmt: skip
    robot = robot_option(robot_file)
    label = "the default robot" if robot_file is None else str(robot_file)
    need_extra("campaign", "mwip twin calibrate FACTS", ("pyarrow", "pandas"))
    try:
        prepare(facts, robot, label, duration)  # bad input: one line, nothing written
    except ValueError as exc:
        raise click.UsageError(str(exc).splitlines()[0]) from None
    target = outdir.check(out, force, command="twin calibrate")
    outdir.claim(target, "twin calibrate")
    try:
        doc = calibrate_robot(target, facts, robot, robot_label=label, jobs=jobs, draws=draws,
                              search_draws=kernel_draws, duration=duration,
                              note=lambda line: click.echo(line, err=True))  # fmt: skip
    except ValueError as exc:
        raise click.UsageError(str(exc).splitlines()[0]) from None
    click.echo(headline(doc))
    wrote = [RESULT_FILE, "calibration.md", DRAWS_FILE] + (["robot.toml"] if "member" in doc
                                                           else [])  # fmt: skip
    click.echo(f"wrote {target / wrote[0]}, " + ", ".join(wrote[1:]))


#: options of each mode: refused in the other one
_COMPARE_ONLY = ("structures", "draws", "kernel_draws", "directed_draws", "importance_draws",
                 "replay")
_RECORD_ONLY = ("samples", "seed", "stage2", "chain_steps", "mixture_draws", "envelope_draws")


def _one_mode(ctx: click.Context, record: bool) -> None:
    """Refuse an option given on the command line that the mode does not use (one line)."""
    from click.core import ParameterSource

    given = [p for p in ctx.command.params
             if p.name in (_COMPARE_ONLY if record else _RECORD_ONLY)
             and ctx.get_parameter_source(p.name) in (ParameterSource.COMMANDLINE,
                                                      ParameterSource.ENVIRONMENT)]  # fmt: skip
    if given:
        names = ", ".join(max(p.opts, key=len) for p in given if isinstance(p, click.Option))
        if record:
            raise click.UsageError(f"{names}: not used by --record (the five-stage calibration "
                                   "of structure S0); leave them out")  # fmt: skip
        raise click.UsageError(f"{names}: only used with --record; leave them out when "
                               "comparing structures")  # fmt: skip


def _record(out: Path, force: bool, samples: int | None, seed: int | None, jobs: int,
              duration: float, stage2: int | None = None,
              chain_steps: int | None = None,
              mixture_draws: int | None = None,
              envelope_draws: int | None = None) -> None:  # fmt: skip
    """``twin calibrate book --record``: :func:`mwip.calibration.book.calibrate_book` into ``out``
    (a folder of mwip's own: a rerun resumes the prior draws)."""
    from mwip import outdir
    from mwip.calibration.book import calibrate_book

    target = outdir.check(out, force, command="twin calibrate")
    if (samples, stage2, chain_steps, mixture_draws, envelope_draws) == (None,) * 5:
        slower = "" if jobs >= 2 else f"; slower with --jobs {jobs}"
        click.echo("mwip: --record at the declared sizes evaluates about 100,000 twins "
                   "in five stages: about 2 hours with --jobs 2 on a 2-core machine "
                   f"(BENCHMARKS.md){slower}", err=True)  # fmt: skip
        click.echo("mwip: it is resumable (Ctrl-C, then the same command continues); a first "
                   "look: --samples 20 --stage2-draws 0 --chain-steps 0 --mixture-draws 0",
                   err=True)  # fmt: skip
    outdir.claim(target, "twin calibrate")
    res = calibrate_book(target, samples=samples, seed=seed, jobs=jobs, duration=duration,
                         proposal_draws=stage2, chains=None if chain_steps == 0 else True,
                         chain_steps=chain_steps or None,
                         mixture=None if mixture_draws == 0 else True,
                         mixture_draws=mixture_draws or None,
                         envelope=None if envelope_draws == 0 else True,
                         envelope_draws=envelope_draws or None,
                         note=lambda line: click.echo(line, err=True))
    # fmt: skip
    p, c = res.doc["posterior"], res.doc["claim_counts"]
    smp = p.get("sampler") or {}
    s3 = p.get("stage3") or (smp if smp and smp.get("kind") != "mixture" else None)
    chains = (f"; stage 3: {s3['chains']} chains x {s3['kept']} kept generations, "
              f"{s3['evaluations']} twins evaluated" if s3 else "")
    if smp.get("kind") == "mixture":
        chains += (f"; stage 4: {smp['draws']} mixture draws, {smp['hits']['mixture']} "
                   "consistent")
        if smp.get("envelope"):
            chains += (f"; stage 5: {smp['envelope']['draws']} envelope draws, "
                       f"{smp['hits']['envelope']} consistent")
    click.echo(f"twins evaluated {res.doc['evaluated']} (prior draws and stage 2{chains}), "
               f"posterior {p['size']} (effective {p['effective_size']:.0f})"
               + (f" (conditioned on {len(p['used'])} facts; dropped: {len(p['dropped'])})"
                  if p["dropped"] else ""))  # fmt: skip
    click.echo(f"held-out claims: {c['holds']} hold, {c['fails']} fail, {c['undecided']} "
               "undecided")  # fmt: skip
    click.echo(f"wrote {target / 'posterior.md'}, posterior.json, robot.toml, marginals.png")
