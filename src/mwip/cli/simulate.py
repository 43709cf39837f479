"""``mwip simulate``: one closed-loop run of any registered controller, on the book's robot,
a parameter file's or the digital twin, described by a :class:`~mwip.scenario.Scenario`.

The options are turned into one scenario (a scenario file's, with the options given on the
command line replacing its fields); the scenario validates every field, and a refused field
that came from an option is reported under that option's name (``--duration``, ``--set``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import click

from mwip.cli._common import (
    DAMPING,
    FORCE,
    ROBOT_OPTION,
    NonEmptyPath,
    gone_option,
    in_range,
    out_ok,
    progress,
    robot_option,
    split_sets,
)

__all__ = ["simulate"]

#: the scenario's fields that options set, and the options' names in errors
_OPTION_OF = {"controller": "--controller", "settings": "--set", "duration": "--duration",
              "Ts": "--Ts", "dt": "--dt", "initial.theta": "--theta0",
              "initial.alpha": "--alpha0", "initial.v": "--v0"}  # fmt: skip


@click.command()
@click.option(
    "--controller",
    default="lqr",
    show_default=True,
    help="Control law: a name of `mwip controllers` (lqr, dlqr, smc, do1smc, hodosmc, asta, "
    "asmc, tsmc, it2, t1).",
)
@click.option(
    "--set",
    "sets",
    multiple=True,
    metavar="KEY=VALUE",
    help="A controller setting (repeatable), e.g. --set K=20,15; see `mwip controllers NAME`.",
)
@click.option(
    "--settings",
    "settings_file",
    type=NonEmptyPath(dir_okay=False, path_type=Path),
    default=None,
    help="A settings file ([controller] name, [settings]; e.g. `mwip tune`'s best.toml); "
    "--set overrides it.",
)
@ROBOT_OPTION
@click.option(
    "--twin",
    "twin",
    is_flag=True,
    default=False,
    help="Run on the robot's digital twin (Chapter 6: IMU fusion, encoders, drives, "
    "firmware; sampled).",
)
@click.option(
    "--case",
    type=click.IntRange(1, 3),
    default=1,
    show_default=True,
    help="With --twin: 1 the robot, 2 with the payload, 3 payload + a stick at ~6 s.",
)
@click.option(
    "--seed", type=click.IntRange(0), default=0, show_default=True, help="Sensor-noise seed."
)
@click.option(
    "--theta0",
    type=float,
    default=0.1745,
    show_default=True,
    help="Initial pitch (rad), in (-pi/2, pi/2).",
)
@click.option("--alpha0", type=float, default=0.0, show_default=True, help="Initial yaw (rad).")
@click.option("--v0", type=float, default=0.0, show_default=True, help="Initial speed (m/s).")
@click.option(
    "--duration",
    type=float,
    default=10.0,
    show_default=True,
    help="Simulated time (s), in (0, 3600].",
)
@click.option(
    "--Ts", "Ts", type=float, default=0.005, show_default=True, help="Sample period (s), in (0, 1]."
)
@click.option("--dt", type=float, default=None, help="Integration step (s); divides Ts.")
@click.option(
    "--mode",
    type=click.Choice(["sampled", "continuous"]),
    default="sampled",
    show_default=True,
    help="Zero-order hold at Ts, or the law inside the ODE.",
)
@gone_option("--params", "--plant", hint="the simulated robot is --robot FILE (a robot file: "
             "`mwip robot show` prints the default; an old parameter file loads as one)")
@gone_option("--nominal", "--design-params", hint="the design model is the robot file's "
             "[design] table (--robot FILE)")
@click.option(
    "--disturbance",
    type=click.Choice(["none", "book"]),
    default="none",
    show_default=True,
    help="External disturbance (book: Section 3.6 sinusoids).",
)
@click.option(
    "--out",
    type=NonEmptyPath(file_okay=False, path_type=Path),
    default=None,
    help="Folder for timeseries.csv, timeseries.npz and summary.json (default: none, "
    "nothing is written; a folder of `mwip simulate`'s own).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--plot", is_flag=True, help="Also draw OUT/run.png (needs --out).")
@DAMPING
@FORCE
@click.option(
    "--max-steps",
    type=float,
    default=None,
    help="Refuse runs needing more integration steps (or sample periods) than this "
    "(default 2e9 steps, 2e7 sample periods; mwip.budget).",
)
@click.option(
    "--max-memory",
    type=float,
    default=None,
    help="Refuse runs needing more memory for their records than this, in GiB (default 4).",
)
@click.option(
    "--scenario",
    "scenario_file",
    type=NonEmptyPath(dir_okay=False, path_type=Path),
    default=None,
    help="A scenario TOML (see examples/); options given on the command line override it.",
)
@click.pass_context
def simulate(
    ctx: click.Context, controller: str, sets: tuple[str, ...], settings_file: Path | None,
    robot_file: Path | None, twin: bool, case: int, seed: int,
    theta0: float, alpha0: float, v0: float,
    duration: float, Ts: float, dt: float | None, mode: str,
    disturbance: str, out: Path | None, as_json: bool, plot: bool, damping: str, force: bool,
    max_steps: float | None, max_memory: float | None, scenario_file: Path | None,
) -> None:  # fmt: skip
    """Simulate a closed loop and print status, settling time and max |u|.

    Any controller of `mwip controllers`, on the default robot (the book's: Table 6.1,
    designed on Table 6.2) or --robot FILE, on its body or its digital twin (--twin, --case).
    """
    from mwip.budget import DEFAULT, Budget, estimate
    from mwip.scenario import Scenario, ScenarioError, load_scenario
    from mwip.sim import BOOK_SINUSOIDS
    from mwip.sim.engine import DEFAULT_DT

    def given(name: str) -> bool:
        return ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT

    steps = None if max_steps is None else in_range("--max-steps", max_steps, 0.0, 1e18)
    budget = Budget(
        max_steps=DEFAULT.max_steps if steps is None else steps,
        max_samples=DEFAULT.max_samples if steps is None else steps,  # a sample is >= 1 step
        max_bytes=DEFAULT.max_bytes if max_memory is None
        else in_range("--max-memory", max_memory, 0.0, 1e6) * 2**30,
    )  # fmt: skip
    if plot and out is None:
        raise click.BadParameter("needs --out FOLDER to write run.png into", param_hint="--plot")
    if out is not None:
        out_ok(out, force, "simulate")
    base = None
    if scenario_file is not None:
        if not str(scenario_file).strip() or not scenario_file.exists():
            raise click.BadParameter(f"{str(scenario_file)!r} does not exist",
                                     param_hint="--scenario")  # fmt: skip
        base = load_scenario(scenario_file)
    # the fields the command line sets (all of them over a scenario file's), each once
    changes: dict[str, Any] = {}
    name = controller if base is None or given("controller") else base.controller
    settings = dict(base.settings) if base is not None and name == base.controller else {}
    if settings_file is not None:
        from mwip.laws.settings_file import load_settings

        try:
            file_name, file_settings = load_settings(settings_file)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--settings") from None
        if given("controller") and file_name != controller:
            raise click.BadParameter(f"{str(settings_file)!r} holds settings of {file_name!r}, "
                                     f"not of --controller {controller!r}",
                                     param_hint="--settings")  # fmt: skip
        if file_name != name:
            settings = dict(base.settings) if base is not None and file_name == base.controller \
                else {}  # fmt: skip
        name = file_name
        settings.update(file_settings)
    settings.update(split_sets(sets))
    changes.update(controller=name, settings=settings)
    for key, val in (("duration", duration), ("Ts", Ts), ("dt", dt), ("mode", mode),
                     ("case", case), ("seed", seed)):  # fmt: skip
        if given(key):
            changes[key] = val
    if twin:
        changes["twin"] = True
    if robot_file is not None or given("damping"):
        rb = robot_option(robot_file, damping)
        changes.update(robot=rb, plant=rb.body, design=rb.design)
    if given("disturbance"):
        changes["disturbance"] = BOOK_SINUSOIDS if disturbance == "book" else None
    initial = {} if base is None else dict(base.initial)
    for opt, key, val in (("theta0", "theta", theta0), ("alpha0", "alpha", alpha0),
                          ("v0", "v", v0)):  # fmt: skip
        if given(opt) or (base is None and key == "theta"):  # (no file: --theta0's default)
            initial[key] = val
    changes["initial"] = initial
    try:
        sc = Scenario(**changes) if base is None else base.with_overrides(**changes)
    except ScenarioError as exc:
        option = _OPTION_OF.get(exc.field)
        if option is None or not _from_options(exc.field, ctx, base is None):
            raise click.UsageError(str(exc)) from None
        raise click.BadParameter(exc.reason, param_hint=option) from None
    cost = estimate(sc.duration, sc.Ts, sc.dt if sc.dt is not None else min(sc.Ts, DEFAULT_DT),
                    mode=sc.mode)  # fmt: skip
    budget.check(cost, "this simulation")
    long = cost.seconds() > 5.0
    if long:
        click.echo(f"mwip: {cost.text()}, about {cost.seconds():.0f} s", err=True)
    n = max(int(round(sc.duration / sc.Ts)), 1)
    with progress(n, "simulating", long) as prog:
        res = sc.run(progress=prog, budget=budget)
    _report(sc, res, out, plot, as_json)


def _from_options(field: str, ctx: click.Context, no_file: bool) -> bool:
    """Whether the scenario's ``field`` came from the command line (an option given, or
    without a scenario file the controller, its settings and --theta0's default)."""
    param = {"settings": "sets", "initial.theta": "theta0", "initial.alpha": "alpha0",
             "initial.v": "v0"}.get(field, field)  # fmt: skip
    if field in ("controller", "settings") or (no_file and field == "initial.theta"):
        return True
    return ctx.get_parameter_source(param) is not click.core.ParameterSource.DEFAULT


def _report(sc: Any, res: Any, out: Path | None, plot: bool, as_json: bool) -> None:
    """Print the run's summary (and write OUT's files); exit 1 unless it ended ok."""
    from mwip.laws.registry import get

    mode, Ts = sc.mode, sc.Ts
    summary: dict[str, Any] = dict(res.summary())
    summary.update(
        controller=sc.controller,
        settings=get(sc.controller).resolve(sc.settings),
        twin=f"case {sc.case}" if sc.twin else None,
        mode=mode,
        Ts=Ts,
        dt=res.settings["dt"],
        design="continuous" if mode == "continuous" else f"sampled Ts={Ts:g}",
    )
    from mwip.hardware.identified import wheel_torque_limit  # the drive's, not the twin

    limit = float(wheel_torque_limit()) if sc.robot is None else sc.robot.wheel_torque_limit
    peak = float(summary.get("max_abs_u") or 0.0)
    over = math.isfinite(peak) and peak > limit
    summary.update(torque_limit=limit, over_torque_limit=bool(over))
    summary = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
               for k, v in summary.items()}  # fmt: skip
    if out is not None:
        from mwip.io import write_json_atomic
        from mwip.outdir import claim

        claim(out, "simulate")
        res.to_csv(out / "timeseries.csv")
        res.to_npz(out / "timeseries.npz")
        write_json_atomic(out / "summary.json", summary)
        from mwip.plot.simulate_files import write_simulate_extras

        written = write_simulate_extras(res, sc.plant, out, plot=plot, torque_limit=limit)
    if as_json:
        from mwip.io import json_text

        click.echo(json_text(summary, indent=2))
    else:
        st, umax = summary["settling_time"], summary["max_abs_u"]  # None: not finite
        click.echo(
            f"status: {summary['status']}  t_end: {summary['t_end']:.3f} s  "
            f"settling time: {'n/a' if st is None else f'{st:.3f} s'}  "
            f"max |u|: {'n/a' if umax is None else f'{umax:.4g} N m'}"
        )
        if over:
            click.echo(f"torque: the controller commanded up to {peak:.4g} N m (max |u|), "
                       f"{peak / limit:.1f}x the drive limit of {limit:.3g} N m per wheel (the "
                       "RE25 through its gearbox at its current limit, `mwip robot show`): the "
                       "robot could not follow this run (a twin's drive applies at most the "
                       "limit; campaigns' peak_torque is the torque applied)")  # fmt: skip
        if out is not None:
            click.echo(f"wrote {out / 'timeseries.csv'}, {out / 'timeseries.npz'}, "
                       f"{out / 'summary.json'}, {', '.join(map(str, written))}")  # fmt: skip
    if summary["status"] != "ok":
        sys.exit(1)
