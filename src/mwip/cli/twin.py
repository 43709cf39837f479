"""``mwip twin``: the digital twin's configuration and its model sensitivities.

- ``mwip twin show [--twin FILE]``: the twin file (default twin, or FILE's after validation),
  every value commented with its source;
- ``mwip twin sensitivity [--twin FILE] [--json]``: the Case 2 payload / Case 3 stick
  assumptions and the gear ratio, varied (:mod:`mwip.hardware.sensitivity`);
- ``mwip twin fit LOG... --out DIR``: the twin identified from robot logs
  (:mod:`mwip.identify`, docs/twin_fit.md);
- ``mwip twin excite --out FILE``: the excitation schedule to record those logs.

Hardware modules are imported per command.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from mwip.cli._common import FILE_FORCE, TWIN_OPTION, file_ok, load_twin_option, record_file

__all__ = ["twin"]


@click.group()
def twin() -> None:
    """The digital twin of the Chapter 6 robot (docs/twin_model.md)."""


@twin.command("show")
@TWIN_OPTION
@click.option("--datasheet", is_flag=True,
              help="The data-sheet twin (every unknown at its data-sheet guess, the prior's "
              "centre) instead of the identified default twin.")  # fmt: skip
def twin_show(twin_file: Path | None, datasheet: bool) -> None:
    """Print the twin file: the default twin (the book's robot identified from its evidence,
    with its provenance), or FILE's after validation, every value with its source."""
    from mwip.hardware import identified
    from mwip.hardware.twin_config import twin_to_toml

    if twin_file is not None and datasheet:
        raise click.UsageError("give --twin FILE or --datasheet, not both")
    if datasheet:
        click.echo(twin_to_toml(identified.datasheet_twin()), nl=False)
    elif twin_file is None:
        click.echo(identified.provenance() + twin_to_toml(
            identified.default_twin(), identified="most probable twin of the book calibration "
            "(above)"), nl=False)  # fmt: skip
    else:
        click.echo(twin_to_toml(load_twin_option(twin_file)), nl=False)  # type: ignore[arg-type]


@twin.command("sensitivity")
@TWIN_OPTION
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def twin_sensitivity(twin_file: Path | None, as_json: bool) -> None:
    """Case 2 payload, Case 3 stick and gear-ratio sensitivities of the plant model."""
    from mwip.hardware.sensitivity import sensitivity_tables, tables_markdown

    tables = sensitivity_tables(load_twin_option(twin_file))  # type: ignore[arg-type]
    if as_json:
        click.echo(json.dumps(tables, indent=1))
    else:
        click.echo(tables_markdown(tables))


@twin.command("fit")
@click.argument("logs", nargs=-1, required=False, type=click.Path(path_type=Path))
@click.option("--out", "out", required=True, type=click.Path(path_type=Path),
              help="Output folder (twin.toml, fit.json, fit.png); new, empty or mwip's own.")
@TWIN_OPTION
@click.option("--free", "free", default=None,
              help="Comma-separated parameters to fit (default: those the logs inform).")
@click.option("--fix", "fix", multiple=True, metavar="NAME=VALUE",
              help="Hold a parameter at a value (repeatable).")
@click.option("--validate", "validate", type=click.Path(path_type=Path), default=None,
              help="A held-out log: prediction error of the fit against the prior centre's.")
@click.option("--segment", default=40, show_default=True, type=int,
              help="Samples per multiple-shooting segment.")
@click.option("--force", is_flag=True, help="Write into a non-empty folder that is not mwip's.")
@click.option("--evidence", type=click.Choice(["book"]), default=None,
              help="Instead of logs: condition the book's robot on the book's Chapter 6 "
              "evidence (prior draws on Dask, resumable; docs/twin_fit.md).")
@click.option("--samples", type=click.IntRange(1, 100_000), default=None,
              help="--evidence: prior draws (default: the declaration's, 2000).")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=None,
              help="--evidence: seed of the prior draws (default: the declaration's).")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True,
              help="--evidence: worker processes (Dask when > 1).")
@click.option("--duration", type=click.FloatRange(0.0, 15.0), default=0.0,
              help="--evidence: cap every run at this many seconds (a smoke test; 0: the "
              "studies' own durations).")
@click.option("--stage2-draws", "stage2", type=click.IntRange(0, 100_000), default=None,
              help="--evidence: twins of stage 2, the declared box proposal (default: the "
              "declaration's, 1000; 0: none).")
@click.option("--chain-steps", "chain_steps", type=click.IntRange(0, 100_000), default=None,
              help="--evidence: generations of stage 3's Markov chains, burn-in scaled alike "
              "(default: the declaration's, 500; 0: no chains).")
@click.option("--mixture-draws", "mixture_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="--evidence: twins of stage 4's mixture draws (default: the "
              "declaration's, 6000; 0: no stages 4-5).")
@click.option("--envelope-draws", "envelope_draws", type=click.IntRange(0, 1_000_000),
              default=None, help="--evidence: twins of stage 5's envelope draws, without "
              "revision 5's extension (default: the declaration's 20000, extended until the "
              "effective size is 100; 0: no stage 5).")
def twin_fit(logs: tuple[Path, ...], out: Path, twin_file: Path | None, free: str | None,
             fix: tuple[str, ...], validate: Path | None, segment: int,
             force: bool, evidence: str | None, samples: int | None, seed: int | None,
             jobs: int, duration: float, stage2: int | None,
             chain_steps: int | None, mixture_draws: int | None,
             envelope_draws: int | None) -> None:  # fmt: skip
    """Identify the twin from robot logs (docs/twin_fit.md), or with --evidence book the
    book's robot from the book's evidence."""
    from mwip import outdir

    if evidence is not None:
        if logs:
            raise click.UsageError("give LOG files or --evidence book, not both")
        from mwip.cli._common import need_extra

        need_extra("campaign", "mwip twin fit --evidence book",  # (a campaign's engine)
                   None if jobs > 1 else ("pyarrow", "pandas"))  # fmt: skip
        _fit_book(out, force, samples, seed, jobs, duration, stage2, chain_steps,
                  mixture_draws, envelope_draws)
        return
    if not logs:
        raise click.UsageError("missing LOG files (or --evidence book)")
    from mwip.identify.bounds import centre
    from mwip.identify.fit import fit, predict_error
    from mwip.identify.logs import read_log
    from mwip.identify.report import write_outputs

    target = outdir.check(out, force, command="twin fit")
    base = load_twin_option(twin_file)
    fixed: dict[str, float] = {}
    for item in fix:
        name, sep, val = item.partition("=")
        if not sep:
            raise click.BadParameter(f"{item!r} is not NAME=VALUE", param_hint="--fix")
        try:
            fixed[name.strip()] = float(val)
        except ValueError:
            raise click.BadParameter(f"{item!r}: {val!r} is not a number",
                                     param_hint="--fix") from None  # fmt: skip
    names = None if free is None else [n.strip() for n in free.split(",") if n.strip()]
    read = [read_log(p) for p in logs]
    held = read_log(validate) if validate is not None else None
    result = fit(read, base, free=names, fixed=fixed, segment=segment,
                 progress=lambda line: click.echo(line, err=True))  # fmt: skip
    if held is not None:
        from mwip.identify.model import Known

        prior = {n: centre(n) for n in result.estimates}
        prior.update(result.fixed)
        known = Known.from_twin(base, held.Ts)
        fitted = predict_error(held, result.estimates, known, segment, twin=base)
        at_prior = predict_error(held, prior, known, segment, twin=base)
        result.validation = {"log": str(validate), "sha256": held.sha256,
                             "fitted": fitted, "prior_centre": at_prior}  # fmt: skip
    outdir.claim(target, "twin fit")
    files = write_outputs(target, result, read, base)
    click.echo(f"wrote {', '.join(str(f) for f in files)}")
    enc = (result.residuals or {}).get("enc") or {}
    if enc.get("rms") is not None:  # the units of the progress lines
        click.echo(f"encoder residual RMS {enc['rms']:.3g} rad (fit.json: residuals)")
    for flag in result.flags:
        click.echo(f"note: {flag}")


def _fit_book(out: Path, force: bool, samples: int | None, seed: int | None, jobs: int,
              duration: float, stage2: int | None = None,
              chain_steps: int | None = None,
              mixture_draws: int | None = None,
              envelope_draws: int | None = None) -> None:  # fmt: skip
    """``twin fit --evidence book``: :func:`mwip.calibration.book.calibrate_book` into ``out``
    (a folder of mwip's own: a rerun resumes the prior draws)."""
    from mwip import outdir
    from mwip.calibration.book import calibrate_book

    target = outdir.check(out, force, command="twin fit")
    if (samples, stage2, chain_steps, mixture_draws, envelope_draws) == (None,) * 5:
        slower = "" if jobs >= 2 else f"; slower with --jobs {jobs}"
        click.echo("mwip: --evidence book at the declared sizes evaluates about 100,000 twins "
                   "in five stages: about 2 hours with --jobs 2 on a 2-core machine "
                   f"(BENCHMARKS.md){slower}", err=True)  # fmt: skip
        click.echo("mwip: it is resumable (Ctrl-C, then the same command continues); a first "
                   "look: --samples 20 --stage2-draws 0 --chain-steps 0 --mixture-draws 0",
                   err=True)  # fmt: skip
    outdir.claim(target, "twin fit")
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
    click.echo(f"wrote {target / 'posterior.md'}, posterior.json, twin.toml, marginals.png")


@twin.command("excite")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="CSV file of the schedule (t, duty_r, duty_l, mode).")
@click.option("--ts", "Ts", default=0.005, show_default=True, type=float, help="Sample period (s).")
@click.option("--static", default=2.0, show_default=True, type=float, help="Static hold (s).")
@click.option("--step", default=0.25, show_default=True, type=float, help="Each duty step (s).")
@click.option("--chirp", default=4.0, show_default=True, type=float, help="Chirp length (s).")
@FILE_FORCE
def twin_excite(out: Path, Ts: float, static: float, step: float, chirp: float,
                force: bool) -> None:  # fmt: skip
    """Write the excitation schedule to run on the robot (docs/twin_fit.md)."""
    from mwip.identify.excite import schedule
    from mwip.io import write_text_atomic

    file_ok(out, force)
    t, duty, mode = schedule(Ts, static, step, chirp)
    lines = ["t,duty_r,duty_l,mode"]
    lines += [f"{t[i]:.6f},{duty[i, 0]:.6f},{duty[i, 1]:.6f},{mode[i]}" for i in range(t.size)]
    write_text_atomic(out, "\n".join(lines) + "\n")
    record_file(out)
    click.echo(f"wrote {out} ({t.size} samples, {t[-1] + Ts:g} s)")
