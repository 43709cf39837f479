"""Command-line interface: ``mwip simulate | design | params | run | reproduce``.

Errors in the input are reported as one line ``mwip: error: ...`` on stderr with exit code 2
and no traceback; nothing is written before all input has been validated, and every file is
written atomically.
"""

from __future__ import annotations

import contextlib
import json
import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mwip.cli_campaign import campaign as _campaign_cmd
from mwip.cli_controllers import controllers as _controllers_cmd
from mwip.cli_kernels import kernels as _kernels_group
from mwip.cli_plot import animate_cmd as _animate_cmd
from mwip.cli_plot import plot_cmd as _plot_cmd
from mwip.damping import DAMPING_READINGS
from mwip.export.cli import export as _export_group
from mwip.tune.command import tune as _tune_cmd

if TYPE_CHECKING:  # NumPy and the rest load with the command that needs them (issue 18)
    import numpy as np

    from mwip.control.registry import ControllerSpec
    from mwip.params import Params

__all__ = ["main", "cli", "entry"]


def _params(value: str, what: str, base: str | None = None, damping: str = "units") -> Params:
    """``real``, ``nominal`` (the book's sets under the ``damping`` reading) or a parameter
    TOML (its Db, Dw are rotational, N m s/rad; missing fields from the book's set ``base``:
    by default real for ``--plant``/``--params``, nominal otherwise); errors name ``what``."""
    from mwip.params import book_params, load_params

    key = value.lower()
    if key in ("real", "nominal"):
        return book_params(key, damping)
    path = Path(value)
    if not value.strip() or not path.exists():
        raise click.BadParameter(
            f"must be 'real', 'nominal' or an existing TOML file, got {value!r}", param_hint=what
        )
    if base is None:
        base = "real" if what in ("--plant", "--params") else "nominal"
    return load_params(path, base=book_params(base, damping))


class _Path(click.Path):
    """``click.Path`` that refuses an empty name (``Path("")`` would be the current folder)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail("the name is empty; give a path", param, ctx)
        return super().convert(value, param, ctx)


_FORCE = click.option(
    "--force",
    is_flag=True,
    help="Write into OUT even if it is a non-empty folder that mwip did not create, or one "
    "another mwip command owns (entries of the same names are replaced).",
)


def _out_ok(out: Path, force: bool, command: str | None = None) -> Path:
    """OUT if mwip may write there (:mod:`mwip.outdir`; not a folder another command than
    ``command`` owns), else exit 2 naming --out."""
    from mwip.outdir import check

    try:
        return check(out, force, command=command)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None


_DAMPING = click.option(
    "--damping",
    type=click.Choice(DAMPING_READINGS),
    default="units",
    show_default=True,
    help="How the book's tables' Db, Dw (printed in N s/m) enter (2.32): units = D r^2 "
    "(SPEC.md section 2), literal = the printed numbers in N m s/rad. Applies to the book's "
    "sets (real, nominal); a parameter file gives rotational coefficients directly.",
)


def _in_range(name: str, value: float, lo: float, hi: float, *, lo_open: bool = True) -> float:
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        raise click.BadParameter(
            f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}], got {value!r}", param_hint=name
        )
    return value


@contextmanager
def _progress(n: int, label: str, long: bool = False) -> Iterator[Callable[[int], None] | None]:
    """A click progress bar on stderr when it is a terminal; otherwise, for a ``long`` run,
    a line at every tenth of the way; nothing for a short one."""
    if not sys.stderr.isatty():
        if not long:
            yield None
            return
        done = [0, 0]

        def lines(k: int) -> None:
            done[0] += k
            tenth = 10 * done[0] // max(n, 1)
            if tenth > done[1]:
                done[1] = tenth
                click.echo(f"{label}: {10 * tenth}% ({done[0]}/{n})", err=True)

        yield lines
        return
    with click.progressbar(length=n, label=label, file=sys.stderr) as bar:
        yield bar.update


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mwip")
def cli() -> None:
    """mwip: models, observers, controllers and simulation of mobile wheeled inverted pendulums."""


# ---------------------------------------------------------------------------------------------
@cli.command()
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
    type=_Path(dir_okay=False, path_type=Path),
    default=None,
    help="A settings file ([controller] name, [settings]; e.g. `mwip tune`'s best.toml); "
    "--set overrides it.",
)
@click.option(
    "--twin",
    "twin",
    is_flag=False,
    flag_value="default",
    default=None,
    metavar="[FILE]",
    help="Run on the digital twin (Chapter 6: IMU fusion, encoders, RE25 drives; sampled); "
    "with a twin file ([twin] TOML, `mwip twin show`) that twin.",
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
@click.option(
    "--params",
    "--plant",
    "plant",
    default="real",
    show_default=True,
    help="The simulated robot: real, nominal or a parameter TOML file (--plant: the old name).",
)
@click.option(
    "--nominal",
    "--design-params",
    "design_params",
    default="nominal",
    show_default=True,
    help="The design model the controller is built on: real, nominal or a TOML file "
    "(--design-params: the old name).",
)
@click.option(
    "--disturbance",
    type=click.Choice(["none", "book"]),
    default="none",
    show_default=True,
    help="External disturbance (book: Section 3.6 sinusoids).",
)
@click.option(
    "--out",
    type=_Path(file_okay=False, path_type=Path),
    default=None,
    help="Folder for timeseries.csv, timeseries.npz and summary.json (default: none, "
    "nothing is written; a folder of `mwip simulate`'s own).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--plot", is_flag=True, help="Also draw OUT/run.png (needs --out).")
@_DAMPING
@_FORCE
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
    type=_Path(dir_okay=False, path_type=Path),
    default=None,
    help="A scenario TOML (see examples/); options given on the command line override it.",
)
@click.pass_context
def simulate(
    ctx: click.Context, controller: str, sets: tuple[str, ...], settings_file: Path | None,
    twin: str | None, case: int,
    seed: int,
    theta0: float, alpha0: float, v0: float,
    duration: float, Ts: float, dt: float | None, mode: str, plant: str, design_params: str,
    disturbance: str, out: Path | None, as_json: bool, plot: bool, damping: str, force: bool,
    max_steps: float | None, max_memory: float | None, scenario_file: Path | None,
) -> None:  # fmt: skip
    """Simulate a closed loop and print status, settling time and max |u|.

    Any controller of `mwip controllers`, on the default robot (Table 3.1), on --params FILE,
    or on the digital twin (--twin, --case).
    """
    from mwip.cli_controllers import parse_sets
    from mwip.scenario import Scenario, load_scenario
    from mwip.sim import BOOK_SINUSOIDS

    def given(name: str) -> bool:
        return ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT

    if not (math.isfinite(theta0) and abs(theta0) < math.pi / 2):
        raise click.BadParameter(
            f"must be in (-1.5708, 1.5708) rad, got {theta0!r}", param_hint="--theta0"
        )
    _in_range("--duration", duration, 0.0, 3600.0)
    _in_range("--Ts", Ts, 0.0, 1.0)
    if dt is not None:
        _in_range("--dt", dt, 0.0, Ts)
    for name, val in (("--alpha0", alpha0), ("--v0", v0)):
        if not (math.isfinite(val) and abs(val) <= 1e3):
            raise click.BadParameter(f"must be in [-1000, 1000], got {val!r}", param_hint=name)
    from mwip.budget import DEFAULT, Budget, estimate
    from mwip.sim.engine import DEFAULT_DT

    steps = None if max_steps is None else _in_range("--max-steps", max_steps, 0.0, 1e18)
    budget = Budget(
        max_steps=DEFAULT.max_steps if steps is None else steps,
        max_samples=DEFAULT.max_samples if steps is None else steps,  # a sample is >= 1 step
        max_bytes=DEFAULT.max_bytes if max_memory is None
        else _in_range("--max-memory", max_memory, 0.0, 1e6) * 2**30,
    )  # fmt: skip
    if plot and out is None:
        raise click.BadParameter("needs --out FOLDER to write run.png into", param_hint="--plot")
    if out is not None:
        _out_ok(out, force, "simulate")
    if scenario_file is not None:
        if not str(scenario_file).strip() or not scenario_file.exists():
            raise click.BadParameter(f"{str(scenario_file)!r} does not exist",
                                     param_hint="--scenario")  # fmt: skip
        sc = load_scenario(scenario_file)
    else:
        sc = Scenario(initial={"theta": theta0})
    changes: dict[str, Any] = {}
    name = controller if given("controller") else sc.controller
    settings = dict(sc.settings) if name == sc.controller else {}
    if settings_file is not None:
        from mwip.control.settings_file import read_settings_file

        file_name, file_settings = read_settings_file(settings_file)
        if given("controller") and file_name != controller:
            raise click.BadParameter(f"{str(settings_file)!r} holds settings of {file_name!r}, "
                                     f"not of --controller {controller!r}",
                                     param_hint="--settings")  # fmt: skip
        settings = dict(sc.settings) if file_name == sc.controller else {}
        name = file_name
        settings.update(file_settings)
    settings.update(parse_sets(name, sets))
    changes.update(controller=name, settings=settings)
    fields: tuple[tuple[str, str, Any], ...] = (
        ("duration", "duration", duration),
        ("Ts", "Ts", Ts),
        ("dt", "dt", dt),
        ("mode", "mode", mode),
        ("case", "case", case),
        ("seed", "seed", seed),
    )
    for opt, key, val in fields:
        if given(opt):
            changes[key] = val
    if twin is not None:
        changes["twin"] = True
        if twin != "default":
            from mwip.hardware.twin_cli import load_twin_option

            changes["twin_config"] = load_twin_option(Path(twin))
    if given("plant") or given("damping"):
        changes["plant"] = _params(plant, "--params", damping=damping)
    if given("design_params") or given("damping"):
        changes["design"] = _params(design_params, "--nominal", damping=damping)
    if given("disturbance"):
        changes["disturbance"] = BOOK_SINUSOIDS if disturbance == "book" else None
    initial = dict(sc.initial)
    for opt, key, val in (("theta0", "theta", theta0), ("alpha0", "alpha", alpha0),
                          ("v0", "v", v0)):  # fmt: skip
        if given(opt):
            initial[key] = val
    try:
        sc = sc.with_overrides(initial=initial, **changes)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    cost = estimate(sc.duration, sc.Ts, sc.dt if sc.dt is not None else min(sc.Ts, DEFAULT_DT),
                    mode=sc.mode)  # fmt: skip
    budget.check(cost, "this simulation")
    long = cost.seconds() > 5.0
    if long:
        click.echo(f"mwip: {cost.text()}, about {cost.seconds():.0f} s", err=True)
    n = max(int(round(sc.duration / sc.Ts)), 1)
    with _progress(n, "simulating", long) as prog:
        res = sc.run(progress=prog, budget=budget)
    mode, Ts = sc.mode, sc.Ts
    summary: dict[str, Any] = dict(res.summary())
    summary.update(
        controller=sc.controller,
        settings=_get_spec(sc.controller).resolve(sc.settings),
        twin=f"case {sc.case}" if sc.twin else None,
        mode=mode,
        Ts=Ts,
        dt=res.settings["dt"],
        design="continuous" if mode == "continuous" else f"sampled Ts={Ts:g}",
    )
    from mwip.hardware.identified import wheel_torque_limit  # the drive's, not the twin

    tw = sc.twin_config
    limit = float(wheel_torque_limit() if tw is None
                  else tw.drive.wheel_torque_limit(tw.motor))  # fmt: skip
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
        click.echo(json.dumps(summary, indent=2))
    else:
        st, umax = summary["settling_time"], summary["max_abs_u"]  # None: not finite
        click.echo(
            f"status: {summary['status']}  t_end: {summary['t_end']:.3f} s  "
            f"settling time: {'n/a' if st is None else f'{st:.3f} s'}  "
            f"max |u|: {'n/a' if umax is None else f'{umax:.4g} N m'}"
        )
        if over:
            click.echo(f"torque: max |u| {peak:.4g} N m is {peak / limit:.1f}x the drive's limit "
                       f"of {limit:.3g} N m per wheel (RE25 at its current limit, `mwip twin "
                       "show`): the robot could not follow this run")  # fmt: skip
        if out is not None:
            click.echo(f"wrote {out / 'timeseries.csv'}, {out / 'timeseries.npz'}, "
                       f"{out / 'summary.json'}, {', '.join(map(str, written))}")  # fmt: skip
    if summary["status"] != "ok":
        sys.exit(1)


def _get_spec(name: str) -> ControllerSpec:
    from mwip.control.registry import get

    return get(name)


# ---------------------------------------------------------------------------------------------
@cli.group()
def design() -> None:
    """Gain design: LQR, disturbance-observer LMIs, IT2 PDC LMIs."""


def _matrix_text(M: np.ndarray) -> str:
    return "\n".join("  [" + ", ".join(f"{v:10.4f}" for v in row) + "]" for row in M)


@design.command("lqr")
@click.option(
    "--Ts",
    "Ts",
    type=float,
    default=None,
    help="Design for this sample period (discrete Riccati on the ZOH model); "
    "default: the continuous (book's) gain, with the 5 ms gain alongside.",
)
@click.option(
    "--params",
    "params_name",
    default="nominal",
    show_default=True,
    help="real, nominal or a TOML file.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def design_lqr_cmd(Ts: float | None, params_name: str, as_json: bool) -> None:
    """LQR gain K (u = -K x, x = [theta, alpha, theta', v, alpha']) for the book's Q, R."""
    from mwip.control.lqr import BOOK_Q, BOOK_R, design_lqr

    if Ts is not None:
        _in_range("--Ts", Ts, 0.0, 1.0)
    p = _params(params_name, "--params")
    main_d = design_lqr(p, Ts=Ts)
    other = design_lqr(p, Ts=0.005) if Ts is None else design_lqr(p, Ts=None)

    def block(d: Any) -> dict[str, Any]:
        return {
            "Ts": d.Ts,
            "K": d.K.tolist(),
            ("poles" if d.Ts is None else "eigenvalues"): [
                [float(z.real), float(z.imag)] for z in d.poles
            ],
        }

    doc = {**block(main_d), "Q": BOOK_Q.tolist(), "R": BOOK_R.tolist(), "params": params_name,
           "state": ["theta", "alpha", "theta_dot", "v", "alpha_dot"], "input": ["u_r", "u_l"],
           "sampled" if Ts is None else "continuous": block(other)}  # fmt: skip
    if as_json:
        click.echo(json.dumps(doc, indent=2))
        return
    for d in (main_d, other):
        kind = "continuous (book)" if d.Ts is None else f"sampled, Ts = {d.Ts:g} s"
        click.echo(f"K, {kind}, designed on {params_name} parameters:")
        click.echo(_matrix_text(d.K))
        if d.Ts is None:
            click.echo("  closed-loop poles: " + ", ".join(f"{z.real:.4g}" for z in d.poles))
        else:
            click.echo("  |eig(Ad - Bd K)|: " + ", ".join(f"{abs(z):.3g}" for z in d.poles))


@design.command("hodo")
@click.option("--order", "-n", type=int, required=True, help="Observer order n, in [1, 8].")
@click.option(
    "--ie",
    "ie_target",
    type=float,
    default=None,
    help="Prescribed impulse-to-energy gain: the slowest gains with ie <= IE "
    "(the book picks 0.3). Default: minimise ie, the LMI (3.36).",
)
@click.option(
    "--radius",
    type=float,
    default=None,
    help="Bound on |eig(D_n)| (rad/s) for the minimisation; without it (3.36) has "
    "no minimiser and the gains grow to the solver's tolerance.",
)
@click.option(
    "--solver",
    type=click.Choice(["CLARABEL", "SCS"]),
    default="CLARABEL",
    show_default=True,
    help="cvxpy solver.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def design_hodo_cmd(
    order: int, ie_target: float | None, radius: float | None, solver: str, as_json: bool
) -> None:
    """Observer gains L_1..L_n by the LMI of Theorem 3.2 (3.36), or for a prescribed ie."""
    from mwip.observers.design import ObserverDesignError, design_for_ie, solve_ie_lmi

    if not 1 <= order <= 8:
        raise click.BadParameter(f"must be in [1, 8], got {order}", param_hint="--order")
    if ie_target is not None:
        _in_range("--ie", ie_target, 0.0, 1e6)
        if radius is not None:
            raise click.BadParameter("use either --ie or --radius", param_hint="--radius")
    if radius is not None:
        _in_range("--radius", radius, 0.0, 1e9)
    try:
        if ie_target is not None:
            d = design_for_ie(order, ie_target, solver=solver)
        else:
            d = solve_ie_lmi(order, radius=radius, solver=solver)
    except ObserverDesignError as exc:
        raise click.ClickException(f"observer design failed: {exc}") from None
    import numpy as np

    eig = np.sort_complex(d.eigenvalues)
    doc = {
        "order": order,
        "problem": "prescribed ie" if ie_target is not None else "min ie (3.36)",
        "ie_target": ie_target,
        "radius": d.radius,
        "v": list(d.scalar_gains) if d.scalar_gains is not None else None,
        "L": [g.tolist() for g in d.gains],
        "ie": d.ie,
        "ie_lmi": d.ie_lmi,
        "eigenvalues": [[float(z.real), float(z.imag)] for z in eig],
        "solver": d.solver,
        "status": d.status,
    }
    note = None
    if ie_target is None and radius is None:
        note = (
            "(3.36) without a pole bound has no minimiser (ie -> 0 as the gains grow): "
            "these gains are set by the solver's tolerance; use --radius or --ie"
        )
        doc["note"] = note
    if as_json:
        click.echo(json.dumps(doc, indent=2))
        return
    click.echo(f"order {order}, {doc['problem']}, solver {d.solver}: {d.status}")
    if d.scalar_gains is not None:
        click.echo("  L_i = v_i I3, v = (" + ", ".join(f"{v:.6g}" for v in d.scalar_gains) + ")")
    else:
        for i, g in enumerate(d.gains, 1):
            click.echo(f"  L_{i} =\n" + _matrix_text(g))
    click.echo(f"  ie = {d.ie:.6g} (recomputed from the gains, (3.39)-(3.41)); "
               f"LMI bound {d.ie_lmi:.6g}")  # fmt: skip
    uniq = sorted({(round(z.real, 6), round(abs(z.imag), 6)) for z in eig})
    click.echo("  eig(D_n): " + ", ".join(
        f"{re:.5g}" + (f" +- {im:.5g}j" if im else "") for re, im in uniq))  # fmt: skip
    if note:
        click.echo(f"  note: {note}")


@design.command("it2")
@click.option(
    "--epsilon",
    type=float,
    required=True,
    help="Radius of the initial-state ball of Lemma 5.2 (5.20), > 0.",
)
@click.option("--rho", type=float, required=True, help="Input bound of Lemma 5.2 (N m), > 0.")
@click.option(
    "--robust",
    type=float,
    default=None,
    help="Also stabilise +-ROBUST relative parameter variations (e.g. 0.35).",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@_DAMPING
def design_it2_cmd(
    epsilon: float, rho: float, robust: float | None, as_json: bool, damping: str
) -> None:
    """IT2 PDC balance gains G1, G2 from the LMIs of Lemma 5.1/5.2 (5.12)-(5.20), on the
    book's nominal set. Every design is checked (LMI residuals, vertex closed-loop
    stability); one that fails exits 1 with a one-line error, whatever the solver's status."""
    from mwip.fuzzy.design_cli import design_it2
    from mwip.fuzzy.pdc import PDCInfeasibleError
    from mwip.params import book_params

    _in_range("--epsilon", epsilon, 0.0, 10.0)
    _in_range("--rho", rho, 0.0, 1e6)
    if robust is not None:
        _in_range("--robust", robust, 0.0, 0.9)
    try:
        _, text = design_it2(
            epsilon, rho, as_json=as_json, robust=robust, params=book_params("nominal", damping)
        )
    except PDCInfeasibleError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(text)


# ---------------------------------------------------------------------------------------------
@cli.group()
def check() -> None:
    """Design checks (sliding-mode surfaces, ...)."""


def _floats(text: str, hint: str) -> tuple[float, ...]:
    items = text.replace(" ", "").split(",")
    if any(not x for x in items):
        raise click.BadParameter(f"must be comma-separated numbers with none left empty, "
                                 f"got {text!r}", param_hint=hint)  # fmt: skip
    try:
        return tuple(float(x) for x in items)
    except ValueError:
        raise click.BadParameter(f"must be comma-separated numbers, got {text!r}",
                                 param_hint=hint) from None  # fmt: skip


@check.command("smc")
@click.option(
    "--lambdas", required=True, help="l1,l2,l3[,l4] of the surface (3.49), e.g. 3,0.2,0.3,3."
)
@click.option(
    "--theta-max",
    type=float,
    default=0.35,
    show_default=True,
    help="Operating range |theta| <= THETA_MAX (rad) over which to check.",
)
@click.option(
    "--wheel-damping/--no-wheel-damping",
    "damping",
    default=False,
    show_default=True,
    help="Include the wheel damping Dw that the book's (3.58) omits.",
)
@click.option(
    "--params",
    "params_name",
    default="nominal",
    show_default=True,
    help="real, nominal or a TOML file.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
def check_smc_cmd(
    lambdas: str, theta_max: float, damping: bool, params_name: str, as_json: bool
) -> None:
    """Check (3.52), the Hurwitz conditions (3.66) and the sign of g2 + l3 g1."""
    from mwip.control.smc_design import check_smc_design

    lam = _floats(lambdas, "--lambdas")
    if len(lam) not in (3, 4) or not all(math.isfinite(x) and x > 0 for x in lam):
        raise click.BadParameter(f"needs 3 or 4 numbers in (0, inf), got {lambdas!r}",
                                 param_hint="--lambdas")  # fmt: skip
    if not (math.isfinite(theta_max) and 0 <= theta_max < math.pi / 2):
        raise click.BadParameter(f"must be in [0, 1.5708), got {theta_max!r}",
                                 param_hint="--theta-max")  # fmt: skip
    rep = check_smc_design(lam, _params(params_name, "--params"), theta_max, damping=damping)
    if as_json:
        click.echo(json.dumps(rep.to_dict(), indent=2))
    else:
        click.echo(f"lambdas {lam}, |theta| <= {theta_max:g} rad, "
                   f"{'with' if damping else 'without'} wheel damping:")  # fmt: skip
        for c in rep.conditions:
            click.echo(f"  {'ok  ' if c.holds else 'FAIL'} {c.name:8s} {c.expression:48s} "
                       f"worst {c.value: .4g}")  # fmt: skip
        eig = ", ".join(f"{z.real:.4g}{f'{z.imag:+.4g}j' if z.imag else ''}"
                        for z in rep.eigenvalues)  # fmt: skip
        click.echo(f"  sliding dynamics at upright: eig(A) = {eig}")
    if not rep.ok:
        sys.exit(1)


# ---------------------------------------------------------------------------------------------
@cli.group()
def params() -> None:
    """Show or write robot parameters."""


@params.command("show")
@click.argument("which", default="real")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@_DAMPING
def params_show(which: str, as_json: bool, damping: str) -> None:
    """Show parameters (real, nominal or a TOML file) and the derived coefficients of (2.32).

    Db, Dw are shown as the equations use them: rotational damping in N m s/rad.
    """
    from mwip.params import UNITS, steady_speed_cap

    p = _params(which, "WHICH", damping=damping)
    derived = {k: float(getattr(p, k)) for k in ("m11", "m12", "m22", "m33", "Ibl", "Gb")}
    derived["steady_speed_cap"] = float(steady_speed_cap(p))
    book = which.lower() in ("real", "nominal")
    if as_json:
        doc = {"params": p.to_dict(), "units": UNITS, "derived": derived,
               "damping": damping if book else "file (rotational coefficients)"}  # fmt: skip
        click.echo(json.dumps(doc, indent=2))
        return
    units = {**UNITS, "m11": "kg m^2", "m12": "kg m^2", "m22": "kg m^2", "m33": "kg m^2",
             "Ibl": "kg m^2", "Gb": "N m", "steady_speed_cap": "rad/s (Gb / (2 Dw))"}  # fmt: skip
    for k, v in {**p.to_dict(), **derived}.items():
        click.echo(f"{k:>16} = {v:<12.6g} {units.get(k, '')}")
    if book:
        click.echo(
            f"damping reading: {damping} (the table's Db, Dw in N s/m "
            + ("times r^2" if damping == "units" else "taken as N m s/rad")
            + ")"
        )
    else:
        click.echo("Db, Dw as in the file: rotational coefficients of (2.32), N m s/rad")


@params.command("save")
@click.argument("which")
@click.argument("path", type=_Path(dir_okay=False, path_type=Path))
@_DAMPING
def params_save(which: str, path: Path, damping: str) -> None:
    """Write parameters (real or nominal) to a TOML file to edit for your own robot.

    The file holds Db, Dw as rotational coefficients (N m s/rad), as the equations use them.
    """
    from mwip.params import save_params

    save_params(_params(which, "WHICH", damping=damping), path)
    click.echo(f"wrote {path}")


# ---------------------------------------------------------------------------------------------
from mwip.hardware.twin_cli import TWIN_OPTION, load_twin_option  # noqa: E402
from mwip.hardware.twin_cli import twin as _twin_group  # noqa: E402 - a group of its own module

cli.add_command(_twin_group)


@cli.command("list")
def list_cmd() -> None:
    """List the studies with their book sources."""
    from mwip.studies.registry import declared

    for study in declared():  # read from the study modules' source, none imported
        click.echo(f"{study.name:24s} {study.source}")


_OUT = click.option(
    "--out",
    type=_Path(file_okay=False, path_type=Path),
    default=Path("out"),
    show_default=True,
    help="Output folder: OUT/<study>/, OUT/index.html, OUT/run.json (a folder of `mwip "
    "reproduce`'s own: other commands do not write into it without --force).",
)
_RUN_OUT = click.option(
    "--out",
    type=_Path(file_okay=False, path_type=Path),
    default=None,
    help="Output folder: OUT/<study>/, OUT/index.html, OUT/run.json (default: runs/<STUDY>, "
    "runs/<STUDY>+<STUDY>... for several, runs/<FILE's stem> for --scenario FILE; a folder of "
    "`mwip run`'s own, never `mwip reproduce`'s without --force).",
)
_QUICK = click.option("--quick", is_flag=True, help="Shorter runs (for smoke tests).")
_PLANT = click.option(
    "--params",
    "params_file",
    default=None,
    help="The simulated robot: a parameter TOML file (default: the book's, Table 3.1).",
)
_NOMINAL = click.option(
    "--nominal",
    "nominal_file",
    default=None,
    help="The design model: a parameter TOML file (default: the book's, Table 3.2).",
)
_VERBOSE = click.option(
    "--verbose", "-v", is_flag=True, help="List every claim in the summary, not only failures."
)
_JOBS = click.option(
    "--jobs",
    "-j",
    type=int,
    default=0,
    show_default=True,
    help="Studies run in parallel processes (0: one per CPU; 1: in this process).",
)


def _robot(
    params_file: str | None, nominal_file: str | None, damping: str = "units"
) -> tuple[Params, Params]:
    plant = _params(params_file or "real", "--params", damping=damping)
    design = _params(nominal_file or "nominal", "--nominal", damping=damping)
    return plant, design


def _jobs(jobs: int) -> int:
    import os

    if jobs < 0 or jobs > 64:
        raise click.BadParameter(f"must be in [0, 64], got {jobs}", param_hint="--jobs")
    return jobs or (os.cpu_count() or 1)


def _execute(
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

    width = max(100, shutil.get_terminal_size((120, 40)).columns)
    compare = find_compare(out) if summary else None
    cmp = load_comparison(compare) if compare is not None else None
    lines = summary_lines(load_results(out, names), width=width, verbose=verbose,
                          damping=damping, compare=cmp)  # fmt: skip
    for line in lines if summary else [f"{out.name}: {lines[0]}"]:
        click.echo(line, err=not summary)
    from mwip.report.html import twin_headline

    if summary and (twin_line := twin_headline(record)):
        click.echo(twin_line)
    click.echo(f"{len(names) - len(failed)}/{len(names)} studies done in "
               f"{record['wall_s']:.1f} s; report: {out / 'index.html'}",
               err=not summary)  # fmt: skip
    if failed:
        sys.exit(1)


def _run_scenarios(
    files: tuple[Path, ...], out: Path, quick: bool, params_file: str | None,
    nominal_file: str | None, verbose: bool, damping: str | None, twin: Any = None,
    twin_file: Path | None = None,
) -> None:  # fmt: skip
    """Run each study file (its robot unless --params/--nominal override it, its twin unless
    --twin does; ``damping``, when given on the command line, replaces the files' [robot]
    damping)."""
    from mwip.studies.study_file import load_study_file

    parsed = [load_study_file(f, damping) for f in files]  # validate all before running any
    for sf in parsed:
        reading = damping or "units"
        plant = sf.plant if params_file is None else _params(params_file, "--params",
                                                             damping=reading)  # fmt: skip
        design = sf.nominal if nominal_file is None else _params(nominal_file, "--nominal",
                                                                 damping=reading)  # fmt: skip
        click.echo(f"{sf.path}: {sf.name}", err=True)
        from mwip.studies.study import plant_label

        notes = _robot_notes([sf.name], params_file, nominal_file, twin_file)
        book = ("real plant", "real plant (literal damping)")
        if params_file is None and plant_label(plant) not in book:
            mine = f"the robot of {sf.path}"
            notes[sf.name] = f"{mine}, {notes[sf.name]}" if sf.name in notes else mine
        _execute([sf.name], out, quick or sf.quick, 1, plant, design, verbose,
                 {sf.name: sf.settings}, damping=reading,
                 twin=twin if twin is not None else sf.twin, robot=notes)  # fmt: skip


def _robot_notes(names: list[str], params_file: str | None, nominal_file: str | None,
                 twin_file: Path | None) -> dict[str, str]:  # fmt: skip
    """What each study of ``names`` runs on besides the book's robot, design model and default
    twin (the Chapter 6 studies'), as the report's section titles say it."""
    from mwip.studies import get_study

    parts = []
    if params_file is not None and params_file.lower() != "real":
        parts.append(f"robot {params_file}")
    if nominal_file is not None and nominal_file.lower() != "nominal":
        parts.append(f"design model {nominal_file}")
    notes = {}
    for name in names:
        here = [*parts, *([f"twin {twin_file}"] if twin_file is not None
                          and get_study(name).place[0] == 6 else [])]  # fmt: skip
        if here:
            notes[name] = ", ".join(here)
    return notes


@cli.command("run")
@click.argument("studies", nargs=-1)
@click.option(
    "--scenario",
    "scenarios",
    multiple=True,
    type=_Path(dir_okay=False, path_type=Path),
    help="A study file (TOML; `mwip scenario STUDY` prints one to copy); repeatable.",
)
@_RUN_OUT
@_QUICK
@_PLANT
@_NOMINAL
@_DAMPING
@TWIN_OPTION
@_JOBS
@_VERBOSE
@_FORCE
@click.pass_context
def run_cmd(
    ctx: click.Context,
    studies: tuple[str, ...],
    scenarios: tuple[Path, ...],
    out: Path | None,
    quick: bool,
    params_file: str | None,
    nominal_file: str | None,
    damping: str,
    twin_file: Path | None,
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
    _out_ok(out, force, "run")
    plant, design = _robot(params_file, nominal_file, damping)
    twin = None if twin_file is None else load_twin_option(twin_file)
    if scenarios:
        given = ctx.get_parameter_source("damping") is not click.core.ParameterSource.DEFAULT
        _run_scenarios(scenarios, out, quick, params_file, nominal_file, verbose,
                       damping if given else None, twin, twin_file)  # fmt: skip
    if studies:
        names = list(dict.fromkeys(studies))
        notes = _robot_notes(names, params_file, nominal_file, twin_file)
        _execute(names, out, quick, _jobs(jobs), plant, design, verbose, damping=damping,
                 twin=twin, robot=notes)  # fmt: skip


@cli.command()
@_OUT
@_QUICK
@_PLANT
@_NOMINAL
@_DAMPING
@TWIN_OPTION
@_JOBS
@_VERBOSE
@_FORCE
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
    _out_ok(out, force, "reproduce")
    plant, design = _robot(params_file, nominal_file, damping)
    twin = None if twin_file is None else load_twin_option(twin_file)
    notes = _robot_notes(study_names(), params_file, nominal_file, twin_file)
    from mwip.outdir import claim, hold

    claim(out, "reproduce")  # OUT holds the staging (and the comparison) from now on
    click.get_current_context().with_resource(hold(out))  # a second reproduce is refused
    code = 0
    if compare:  # first the other reading, so that the main report finds it
        other = next(d for d in DAMPING_READINGS if d != damping)
        click.echo(f"under the {other} damping reading, into {out / f'compare-{other}'}:",
                   err=True)  # fmt: skip
        try:
            _execute(study_names(), out / f"compare-{other}", quick, _jobs(jobs),
                     *_robot(params_file, nominal_file, other), damping=other,
                     summary=False, twin=twin, command="reproduce", robot=notes,
                     label=f"pass 1/2 ({other} reading): studies")  # fmt: skip
        except SystemExit as exc:
            code = int(exc.code or 0)
    _execute(study_names(), out, quick, _jobs(jobs), plant, design, verbose, damping=damping,
             twin=twin, command="reproduce", robot=notes,
             label=f"pass 2/2 ({damping} reading): studies" if compare else "studies")  # fmt: skip
    if code:
        sys.exit(code)


@cli.command()
@click.argument("study")
@click.option(
    "--out",
    type=_Path(dir_okay=False, path_type=Path),
    default=None,
    help="Write the study file here (default: print it).",
)
def scenario(study: str, out: Path | None) -> None:
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
        write_text_atomic(out, text)
        click.echo(f"wrote {out}")


@cli.command()
@click.option(
    "--out",
    type=_Path(file_okay=False, exists=True, path_type=Path),
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
@_VERBOSE
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
        click.echo(f"mwip: notice: --compare: {_cut(problem, 200)}; that study is left out of "
                   "the comparison", err=True)  # fmt: skip
    results = load_results(out, names)
    for line in summary_lines(results, verbose=verbose,
                              damping=load_run_record(out).get("damping"),
                              compare=cmp):  # fmt: skip
        click.echo(line)
    from mwip.report.html import twin_headline

    if twin_line := twin_headline(load_run_record(out)):
        click.echo(twin_line)
    click.echo(f"report: {path}")
    bad = [r.error for r in results if r.doc is None and r.error and "metrics.json" in r.error]
    for message in bad:
        click.echo(f"mwip: error: {message}", err=True)
    if bad:
        sys.exit(1)


cli.add_command(_controllers_cmd)
cli.add_command(_kernels_group)
cli.add_command(_export_group)
cli.add_command(_campaign_cmd)
cli.add_command(_tune_cmd)


cli.add_command(_animate_cmd)
cli.add_command(_plot_cmd)


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI, turning input errors into one-line messages (exit code 2).

    Never a traceback: bad input is exit 2, Ctrl-C exit 130 (a second Ctrl-C while the first
    is being handled ends the process at once), any other failure one line and exit 1
    (``MWIP_TRACEBACK=1`` shows the traceback).
    """
    import warnings

    fmt, warnings.formatwarning = warnings.formatwarning, _warning_line
    try:
        with _interrupts():
            try:
                return _main(argv)
            except KeyboardInterrupt:  # raised outside click's own handling (start-up, clean-up)
                click.echo("mwip: interrupted; earlier results are left as they were", err=True)
                return 130
    finally:
        warnings.formatwarning = fmt


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  line: str | None = None) -> str:  # fmt: skip
    """A warning shown by the CLI: one line, ``mwip: warning: ...`` (not Python's file, line
    number and source line)."""
    text = _cut(str(message), 300).removeprefix("mwip: ")
    return f"mwip: warning: {text}\n"


def _main(argv: list[str] | None) -> int:
    import os

    try:
        cli.main(args=argv, prog_name="mwip", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.UsageError as exc:
        click.echo(f"mwip: error: {_cut(exc.format_message())}", err=True)
        return 2
    except click.ClickException as exc:  # a failure that is not bad input (e.g. a solver)
        click.echo(f"mwip: error: {_cut(exc.format_message())}", err=True)
        return exc.exit_code
    except click.Abort:
        click.echo("mwip: interrupted; earlier results are left as they were", err=True)
        return 130
    except (ValueError, TypeError, FileNotFoundError) as exc:
        click.echo(f"mwip: error: {_one_line(exc)}", err=True)
        return 2
    except BrokenPipeError:  # the reader went away (`mwip list | head -1`)
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # the file system said no (permissions, full disk, ...)
        import errno

        where = f" {_cut(repr(exc.filename), 80)}" if exc.filename else ""
        click.echo(f"mwip: error:{where} {exc.strerror or _one_line(exc)}", err=True)
        # a path the user gave that cannot be used is bad input; a full disk or an I/O
        # error is the machine's
        bad_path = {errno.EACCES, errno.EPERM, errno.EISDIR, errno.ENOTDIR, errno.ENAMETOOLONG,
                    errno.ELOOP, errno.EEXIST, errno.EROFS, errno.ENOENT}  # fmt: skip
        return 2 if exc.errno in bad_path else 1
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except (MemoryError, RecursionError) as exc:
        click.echo(f"mwip: error: {type(exc).__name__}: the input asks for more than this "
                   "machine can give; reduce the sizes or durations", err=True)  # fmt: skip
        return 1
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback on request
        if os.environ.get("MWIP_TRACEBACK"):
            raise
        click.echo(f"mwip: internal error: {type(exc).__name__}: {_one_line(exc)} "
                   "(set MWIP_TRACEBACK=1 to see where)", err=True)  # fmt: skip
        return 1
    return 0


def _one_line(exc: BaseException) -> str:
    return _cut(str(exc)) or type(exc).__name__


def _cut(text: str, limit: int = 400) -> str:
    """``text`` on one line, at most ``limit`` characters (a huge bad value is quoted in
    part)."""
    text = " ".join(text.split())
    return text if len(text) <= limit else f"{text[: limit - 40]} ... ({len(text)} characters)"


@contextmanager
def _interrupts() -> Iterator[None]:
    """SIGINT: the first raises ``KeyboardInterrupt`` (clean-up runs); a second one while
    that is under way ends the process at once with exit code 130, without a traceback."""
    import os
    import signal
    import threading

    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is signal.SIG_IGN):  # fmt: skip
        yield
        return
    seen = [False]

    def handler(signum: int, frame: Any) -> None:
        if seen[0]:
            with contextlib.suppress(OSError):
                os.write(2, b"\nmwip: interrupted again; stopping now\n")
            os._exit(130)
        seen[0] = True
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main interpreter
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


def entry() -> None:
    """Console-script entry point (exits with :func:`main`'s code).

    After Ctrl-C the process ends at once (``os._exit`` once the output is flushed): the
    clean-up that matters (the staging folder, the worker processes) is done by then, and
    the interpreter's own exit handlers (joining pools and queues) would only add delay, or
    another Ctrl-C and a traceback.
    """
    import os
    import signal

    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _exit_130)  # outside main(): stop at once, quietly
    code = main()
    if code == 130:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(130)
    sys.exit(code)


def _exit_130(signum: int, frame: Any) -> None:
    import os

    os._exit(130)
