"""``mwip export c``: a registered controller as plain C99 for the robot, verified in the loop
(:mod:`mwip.export`)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from mwip.cli._common import ROBOT_OPTION, gone_option, robot_option, split_sets

__all__ = ["export"]


@click.group("export")
def export() -> None:
    """Export a controller for the robot or another tool."""


@export.command("c")
@click.option(
    "--controller", "name", required=True, help="A registered controller (`mwip controllers`)."
)
@click.option(
    "--set",
    "sets",
    multiple=True,
    metavar="KEY=VALUE",
    help="A controller setting (repeatable); see `mwip controllers NAME`.",
)
@click.option(
    "--settings",
    "settings_file",
    default=None,
    help="A settings file of the controller ([controller] name, [settings]; e.g. `mwip "
    "tune`'s best.toml); --set overrides it.",
)
@ROBOT_OPTION
@gone_option("--params", hint="your robot is --robot FILE (a robot file: the controller is "
             "designed on its [design] model, --verify and --pil run its body or twin)")
@gone_option("--nominal", hint="the design model is the robot file's [design] table")
@click.option(
    "--Ts",
    "Ts",
    type=float,
    default=None,
    help="Sample period in s (default: the controller's, 5 ms for the robot).",
)
@click.option(
    "--float",
    "single",
    is_flag=True,
    help="Single precision (for a board without double-precision hardware).",
)
@click.option("--prefix", default=None, help="C name prefix (default mwip_NAME).")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help="Folder for PREFIX.h and PREFIX.c: new, empty or mwip's own (as for every command).",
)
@click.option("--force", is_flag=True, help="Write into --out even if it holds other files.")
@click.option(
    "--verify",
    is_flag=True,
    help="Compile with the system C compiler and run the closed loop against the "
    "Python controller (software in the loop).",
)
@click.option(
    "--pil",
    is_flag=True,
    help="Processor in the loop: cross-compile for the board's Cortex-M3 (GNU Arm toolchain, "
    "soft float) and run the closed loop on an emulated processor (unicorn): its difference "
    "from the host's build, the instructions per step and their time at 50 MHz; writes "
    "OUT/pil.json, OUT/pil_steps.csv, OUT/robot.toml (the robot with the measured delay) "
    "and the images (docs/export.md).",
)
@click.option(
    "--board",
    "board",
    is_flag=True,
    help="With --pil: also run the firmware on QEMU's lm3s6965evb over its UART (the whole "
    "board; qemu-system-arm) and compare it with the emulated processor.",
)
@click.option(
    "--push",
    type=float,
    default=0.5,
    show_default=True,
    help="With --pil: a push on the pitch, N m for 0.1 s half-way through the run (0: none).",
)
@click.option(
    "--duration",
    type=float,
    default=10.0,
    show_default=True,
    help="With --verify or --pil: simulated time in s.",
)
@click.option(
    "--theta0",
    type=float,
    default=0.1,
    show_default=True,
    help="With --verify or --pil: initial pitch in rad.",
)
@click.option(
    "--twin", is_flag=True, help="With --verify or --pil: run on the digital twin (Chapter 6)."
)
def export_c(
    name: str, sets: tuple[str, ...], settings_file: str | None, robot_file: Path | None,
    Ts: float | None, single: bool, prefix: str | None, out: Path, force: bool, verify: bool,
    pil: bool, board: bool, push: float, duration: float, theta0: float, twin: bool,
) -> None:  # fmt: skip
    """Write OUT/PREFIX.h and OUT/PREFIX.c: the controller's init and step functions with its
    gains and nominal model baked in (C99, math.h only, no dynamic memory).

    With --verify the code is compiled and run in the loop: the C controller's closed loop
    must equal the Python one's (double precision: within 1e-9 rad over the run; the float
    version's deviation is reported).

    With --pil it is cross-compiled for the board's processor and run in the loop on an
    emulated Cortex-M3 (processor in the loop): the report says how far it is from the host's
    build and what each step costs on the board; nothing is written unless it succeeds.
    """
    import math
    import os

    from mwip import outdir
    from mwip.export.c_code import ExportError, generate_c
    from mwip.export.transpile import check_constant
    from mwip.io import write_text_atomic
    from mwip.laws.registry import get

    try:
        spec = get(name)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--controller") from None
    given: dict[str, Any] = {}
    if settings_file is not None:
        from mwip.laws.settings_file import load_settings

        try:
            file_name, given = load_settings(settings_file)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--settings") from None
        if file_name != name:
            raise click.BadParameter(
                f"{settings_file!r} holds settings of {file_name!r}, not of --controller {name!r}",
                param_hint="--settings",
            )
    given.update(split_sets(sets))
    try:  # the registry validates the settings (once)
        resolved = spec.resolve(given)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--set") from None
    precision = "float" if single else "double"
    for key in given:  # a setting that C cannot hold, named before anything is designed
        for x in _numbers(resolved[key]):
            why = check_constant(x, precision)
            if why is not None:
                raise click.BadParameter(f"{key}: {why}", param_hint="--set")
    try:
        out = outdir.check(out, force=force, command="export c")
    except ValueError as exc:
        raise click.BadParameter(str(exc).removeprefix("--out: "), param_hint="--out") from None
    if Ts is not None and not (math.isfinite(Ts) and 0 < Ts <= 1.0):
        raise click.BadParameter(f"must be in (0, 1] s, got {Ts!r}", param_hint="--Ts")
    if not (math.isfinite(duration) and 0 < duration <= 600):
        raise click.BadParameter(f"must be in (0, 600] s, got {duration!r}",
                                 param_hint="--duration")  # fmt: skip
    if not (math.isfinite(theta0) and abs(theta0) < math.pi / 2):
        raise click.BadParameter(f"must be in (-1.5708, 1.5708) rad, got {theta0!r}",
                                 param_hint="--theta0")  # fmt: skip

    rb = robot_option(robot_file)
    design, plant = rb.design, rb.body
    period = Ts if Ts is not None else spec.Ts
    prefix = prefix or f"mwip_{name}"

    def build() -> Any:
        return spec.build(design, given, period)

    try:
        code = generate_c(build(), prefix=prefix, precision=precision,
                          doc=f"{spec.title} ({spec.source})")  # fmt: skip
    except ExportError as exc:
        raise click.BadParameter(str(exc), param_hint="--controller/--set") from None
    pil_run = None
    if pil or board:
        from mwip.cli._export_pil import run_pil_cli

        pil_run = run_pil_cli(name, build, code, robot=rb, twin=twin, theta0=theta0,
                              duration=duration, push=push, board=board, pil=pil)  # fmt: skip
    outdir.claim(out, "export c")
    for fname, text in code.files().items():
        write_text_atomic(out / fname, text)
    click.echo(f"wrote {out / (prefix + '.h')}, {out / (prefix + '.c')} "
               f"({precision}, Ts = {period:g} s)")  # fmt: skip
    if pil_run is not None:
        pil_run.write(out)
    if not verify:
        return
    from mwip.export.sil import CController, NoCompiler
    from mwip.export.sil import verify as run_verify

    try:
        cctrl = CController(code, static=bool(getattr(build(), "static", False)))
    except NoCompiler as exc:
        raise click.UsageError(f"--verify: {exc}") from None
    except RuntimeError as exc:  # the compiler ($CC) failed: one line, its first words
        lines = [x.strip() for x in str(exc).splitlines() if x.strip()]
        said = f": {lines[1]}" if len(lines) > 1 else " (it printed nothing)"
        raise click.ClickException(f"--verify: the C compiler failed{said}; check $CC "
                                   f"({os.environ.get('CC') or 'unset'}) or install gcc; the "
                                   f"C files in {str(out)!r} are written") from None  # fmt: skip
    tw = rb.twin if twin else None
    rep = run_verify(build(), cctrl, plant=plant, q0=(0.0, theta0, 0.0), duration=duration,
                     twin=tw)  # fmt: skip
    tol = 1e-9 if precision == "double" else math.inf
    click.echo(
        f"software in the loop ({'twin' if twin else 'simulation'}, {duration:g} s): "
        f"max |state difference| {rep.max_state_diff:.3g} (theta {rep.max_theta_diff:.3g} rad), "
        f"max |u difference| {rep.max_u_diff:.3g} N m; status python {rep.status_python}, "
        f"C {rep.status_c}; C step {rep.seconds_per_call * 1e6:.1f} us per call via ctypes; "
        f"peak delivered torque {rep.peak_torque:.4g} N m"
    )
    if not rep.ok(tol):
        click.echo(f"mwip: error: the C controller differs from the Python one by more than "
                   f"{tol:g}", err=True)  # fmt: skip
        sys.exit(1)


def _numbers(value: Any) -> list[float]:
    """The numbers in a resolved setting (a number, a tuple or an array; others: none)."""
    import numpy as np

    if isinstance(value, bool):
        return []
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return []
    return [float(x) for x in arr.ravel()]
