"""``mwip twin``: the digital twin's configuration and its model sensitivities.

- ``mwip twin sensitivity [--robot FILE] [--json]``: the Case 2 payload / Case 3 stick
  assumptions and the gear ratio, varied (:mod:`mwip.hardware.sensitivity`);
- ``mwip twin fit LOG... --out DIR [--robot FILE]``: the robot's twin identified from its
  logs, starting from its robot file (:mod:`mwip.identify`, docs/twin_fit.md);
- ``mwip twin excite --out FILE``: the excitation schedule to record those logs;
- ``mwip twin log (--excite FILE | --controller NAME) --out LOG [--robot FILE]``: the log the
  robot would write, simulated on its twin (try the fit before touching hardware).

Hardware modules are imported per command.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from mwip.cli._common import (
    FILE_FORCE,
    ROBOT_OPTION,
    file_ok,
    gone_option,
    record_file,
    robot_option,
)

__all__ = ["twin"]


@click.group()
def twin() -> None:
    """The digital twin of the Chapter 6 robot (docs/twin_model.md)."""


@twin.command("show", hidden=True, context_settings={"ignore_unknown_options": True})
@click.argument("args", nargs=-1, type=click.UNPROCESSED)
def twin_show(args: tuple[str, ...]) -> None:
    """Gone: `mwip robot show` prints the robot file (the twin is its hardware part)."""
    raise click.UsageError("`mwip twin show` is gone: `mwip robot show [FILE] [--datasheet]` "
                           "prints the robot file, the twin's values with the robot's")


@twin.command("sensitivity")
@ROBOT_OPTION
@gone_option("--twin", hint="give the robot file with --robot FILE")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def twin_sensitivity(robot_file: Path | None, as_json: bool) -> None:
    """Case 2 payload, Case 3 stick and gear-ratio sensitivities of the plant model."""
    from mwip.hardware.sensitivity import sensitivity_tables, tables_markdown

    tables = sensitivity_tables(robot_option(robot_file))
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(tables, indent=1))
    else:
        click.echo(tables_markdown(tables))


@twin.command("fit")
@click.argument("logs", nargs=-1, required=False, type=click.Path())
@click.option("--out", "out", required=True, type=click.Path(path_type=Path),
              help="Output folder (robot.toml, fit.json, fit.png, index.html); new, empty or "
              "mwip's own.")
@ROBOT_OPTION
@gone_option("--twin", hint="the starting robot is --robot FILE (a robot file)")
@click.option("--free", "free", default=None,
              help="Comma-separated parameters to fit (default: those the logs inform).")
@click.option("--fix", "fix", multiple=True, metavar="NAME=VALUE",
              help="Hold a parameter at a value (repeatable).")
@click.option("--validate", "validate", type=click.Path(), default=None,
              help="A held-out log: prediction error of the fit against the prior centre's.")
@click.option("--segment", default=40, show_default=True, type=click.IntRange(5, 400),
              help="Samples per multiple-shooting segment.")
@click.option("--force", is_flag=True, help="Write into a non-empty folder that is not mwip's.")
@click.option("--max-rows", "max_rows", type=click.IntRange(3, 10**9), default=None,
              help="Rows of the logs together, at most (default 500000, 42 min at 5 ms: a "
              "fit of some 1.5 GB and 6 minutes; the fit takes ~3 kB and ~0.7 ms per row).")
@gone_option("--evidence", hint="the book's robot from the book's evidence is `mwip twin "
             "calibrate book --record` (twin fit takes only logs)")
def twin_fit(logs: tuple[str, ...], out: Path, robot_file: Path | None, free: str | None,
             fix: tuple[str, ...], validate: str | None, segment: int,
             force: bool, max_rows: int | None) -> None:  # fmt: skip
    """Identify the twin from robot logs (docs/twin_fit.md); the book's robot, which left
    no logs, is `mwip twin calibrate book`."""
    from mwip import outdir

    if not logs:
        raise click.UsageError("missing LOG files (the book's robot from the book's evidence: "
                               "mwip twin calibrate book)")
    from mwip.identify.bounds import NAMES, centre
    from mwip.identify.fit import fit, predict
    from mwip.identify.logs import read_log
    from mwip.identify.report import write_outputs

    target = outdir.check(out, force, command="twin fit")
    robot = robot_option(robot_file)
    base = robot.twin
    fixed: dict[str, float] = {}
    for item in fix:
        name, sep, val = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise click.BadParameter(f"{item!r} is not NAME=VALUE", param_hint="--fix")
        if name in fixed:
            raise click.BadParameter(f"{name!r} is fixed twice", param_hint="--fix")
        try:
            fixed[name] = float(val)
        except ValueError:
            raise click.BadParameter(f"{item!r}: {val!r} is not a number",
                                     param_hint="--fix") from None  # fmt: skip
        if not math.isfinite(fixed[name]):
            raise click.BadParameter(f"{item!r}: the value must be a finite number",
                                     param_hint="--fix")  # fmt: skip
    names = None if free is None else [n.strip() for n in free.split(",") if n.strip()]
    if names is not None and not names:
        raise click.BadParameter(f"is an empty list ({free!r}); give NAME[,NAME...] of "
                                 f"{', '.join(NAMES)}, or leave it out (those the logs "
                                 "inform)", param_hint="--free")  # fmt: skip
    if names is not None and len(set(names)) != len(names):
        raise click.BadParameter("names a parameter twice", param_hint="--free")

    from mwip.identify.logs import MAX_ROWS, LogError

    limit = MAX_ROWS if max_rows is None else max_rows
    read: list[Any] = []
    for p in [*logs, *([validate] if validate is not None else [])]:
        left = limit - sum(lg.n for lg in read)  # the logs together, counted while read
        if left < 3:
            raise LogError(f"log {p!r}: the logs before it hold {limit - left} rows, the "
                           f"most for one fit (--max-rows {limit}); raise it or cut the logs")
        read.append(read_log(p, max_rows=left))
    held = read.pop() if validate is not None else None
    result = fit(read, base, free=names, fixed=fixed, segment=segment, body=robot.body,
                 progress=lambda line: click.echo(line, err=True))  # fmt: skip
    if held is not None:
        from mwip.identify.model import Known

        prior = {n: centre(n) for n in result.estimates}
        prior.update(result.fixed)
        known = Known.from_twin(base, held.Ts, robot.body)
        fitted, tr_fit = predict(held, result.robot_values(base), known, segment, twin=base,
                                 body=robot.body)  # fmt: skip
        at_prior, tr_prior = predict(held, prior, known, segment, twin=base, body=robot.body)
        result.validation = {"log": str(validate), "sha256": held.sha256,
                             "fitted": fitted, "prior_centre": at_prior}  # fmt: skip
        result.validation_trace = {"log": str(validate), "fitted": tr_fit,
                                   "prior_centre": tr_prior}  # fmt: skip
    outdir.claim(target, "twin fit")
    files = write_outputs(target, result, read, robot)
    click.echo(f"wrote {', '.join(str(f) for f in files)}")
    from mwip.identify.fit import summary_lines

    for line in summary_lines(result):
        click.echo(line)
    if result.body is not None:
        click.echo(result.body.summary())
    enc = (result.residuals or {}).get("enc") or {}
    if enc.get("rms") is not None:  # the units of the progress lines
        click.echo(f"encoder residual RMS {enc['rms']:.3g} rad (fit.json: residuals)")
    for flag in result.flags:
        if not flag.startswith("identifiability: "):  # (printed before the fit's progress)
            click.echo(f"note: {flag}")


@twin.command("excite")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="CSV file of the schedule (t, duty_r, duty_l, mode).")
@click.option("--ts", "Ts", default=0.005, show_default=True, type=float, help="Sample period (s).")
@click.option("--static", default=2.0, show_default=True, type=float, help="Static hold (s).")
@click.option("--step", default=0.25, show_default=True, type=float, help="Each duty step (s).")
@click.option("--chirp", default=4.0, show_default=True, type=float, help="Chirp length (s).")
@click.option("--max-samples", "max_samples", type=click.IntRange(1, 10**9), default=None,
              help="Rows of the schedule, at most (default 2000000: some 90 MB of CSV).")
@FILE_FORCE
def twin_excite(out: Path, Ts: float, static: float, step: float, chirp: float,
                max_samples: int | None, force: bool) -> None:  # fmt: skip
    """Write the excitation schedule to run on the robot (docs/twin_fit.md)."""
    from mwip.identify.excite import MAX_SAMPLES, schedule
    from mwip.io import write_text_atomic

    file_ok(out, force)
    t, duty, mode = schedule(Ts, static, step, chirp,
                             max_samples=MAX_SAMPLES if max_samples is None else max_samples)
    lines = ["t,duty_r,duty_l,mode"]
    lines += [f"{t[i]:.6f},{duty[i, 0]:.6f},{duty[i, 1]:.6f},{mode[i]}" for i in range(t.size)]
    write_text_atomic(out, "\n".join(lines) + "\n")
    record_file(out)
    click.echo(f"wrote {out} ({t.size} samples, {t[-1] + Ts:g} s)")


@twin.command("log")
@ROBOT_OPTION
@click.option("--excite", "excite_file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="A schedule of 'mwip twin excite': the wheels-off-ground and "
              "static log of running it on the robot held on a stand.")  # fmt: skip
@click.option("--controller", default=None, metavar="NAME",
              help="A controller of 'mwip controllers' (designed on the robot's design model): "
              "the log of the robot balancing under it.")  # fmt: skip
@click.option("--duration", type=click.FloatRange(0.1, 600.0), default=5.0, show_default=True,
              help="Seconds of balancing (with --controller).")
@click.option("--theta0", type=click.FloatRange(-0.3, 0.3), default=0.05, show_default=True,
              help="Initial lean (rad; with --controller).")
@click.option("--dither", type=click.FloatRange(0.0, 1.0), default=0.0, show_default=True,
              help="A known random binary torque (N m per wheel, held 50 ms) added to the "
                   "controller's command and logged with it: excitation the body's fit "
                   "needs (with --controller; docs/twin_fit.md).")
@click.option("--inputs", type=click.Choice(["duty", "torque", "both"]), default=None,
              help="The command columns: the duties before the back-EMF compensation (duty_r, "
              "duty_l; the default with --excite), the torques the law commanded (u_r, u_l; "
              "the default with --controller) or both, as a board logs them.")  # fmt: skip
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True,
              help="Seed of the sensors' noise.")
@click.option("--out", "out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The log (CSV, the columns 'mwip twin fit' reads).")
@FILE_FORCE
def twin_log(robot_file: Path | None, excite_file: Path | None, controller: str | None,
             duration: float, theta0: float, dither: float, inputs: str | None, seed: int,
             out: Path, force: bool) -> None:  # fmt: skip
    """Simulate the log ROBOT would write (its body, drive, firmware and sensors, from the robot
    file): on a stand for an excitation schedule, or balancing under a controller. The whole
    chain (log -> `mwip twin fit` -> tune, bench, export) can so be tried before hardware."""
    from mwip.identify import excite, synth
    from mwip.io import write_text_atomic

    if (excite_file is None) == (controller is None):
        raise click.UsageError("give one of --excite FILE (a stand log) or --controller NAME "
                               "(a balancing log)")  # fmt: skip
    if dither > 0.0 and controller is None:
        raise click.UsageError("--dither adds to a controller's command: give --controller")
    robot = robot_option(robot_file)
    file_ok(out, force)
    if excite_file is not None:
        try:
            duty, mode = excite.read_schedule(excite_file, robot.Ts)
        except ValueError as exc:
            raise click.UsageError(f"--excite: {exc}") from None
        cols = synth.stand_log_on(robot.twin, robot.body, duty, mode, seed=seed,
                                  inputs=inputs or "duty")  # fmt: skip
        what = f"on a stand, {excite_file}"
    else:
        from mwip.laws.registry import build, get

        name = str(controller)  # given: checked above
        try:
            get(name)
        except ValueError as exc:
            raise click.UsageError(f"--controller: {exc}") from None
        ctrl = build(name, robot.design, {}, Ts=robot.Ts)
        if dither > 0.0:
            from mwip.identify.dither import Dithered

            ctrl = Dithered(ctrl, dither, robot.Ts, duration, seed=seed)
        cols = synth.balancing_log_on(robot.twin, robot.body, ctrl, duration, seed,
                                      q0=(0.0, theta0, 0.0), inputs=inputs or "torque")  # fmt: skip
        what = f"balancing under {name} from a lean of {theta0:g} rad" + (
            f", dither {dither:g} N m" if dither > 0.0 else "")
    write_text_atomic(out, synth.csv_text(cols))
    record_file(out)
    n = len(cols["t"])
    who = f"robot {robot_file}" if robot_file is not None else "the default robot"
    click.echo(f"wrote {out} ({n} samples, {n * robot.Ts:g} s; {who}, {what})")
