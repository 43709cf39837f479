"""``mwip export c --pil [--board]``: processor in the loop for the export command
(:mod:`mwip.export.pil`, :mod:`mwip.export.board`).

:func:`run_pil_cli` checks the tools, builds the images and runs the loops before anything is
written (a missing or failing tool is one line, exit 2); :meth:`PilRun.write` then writes
``pil.json``, ``pil_steps.csv``, ``twin-delay.toml`` and the two images into the export's
folder, each atomically.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import click

from mwip.cli._common import progress

__all__ = ["run_pil_cli", "PilRun"]


@dataclass
class PilRun:
    """What ``--pil`` computed: the report, the images, the whole-board comparison
    (largest state and torque difference from the in-process run, QEMU's wall time) if
    ``--board``."""

    report: Any
    firmware: Any
    board: tuple[float, float, float] | None
    robot: Any = None

    def files(self) -> dict[str, bytes]:
        """File name -> contents."""
        import json

        rep, p = self.report, self.firmware.code.prefix
        data = rep.to_dict()
        if self.board is not None:
            data["whole_board"] = {"machine": "QEMU lm3s6965evb, UART0 frames",
                                   "max_state_diff_vs_pil": self.board[0],
                                   "max_u_diff_vs_pil": self.board[1],
                                   "seconds": self.board[2]}  # fmt: skip
        rows = ["step,t,instructions,cycle_bound"] + [
            f"{k},{k * rep.Ts:.6g},{n},{c}"
            for k, (n, c) in enumerate(zip(rep.instructions, rep.cycles, strict=True))
        ]
        out = {
            "pil.json": (json.dumps(data, indent=2) + "\n").encode(),
            "pil_steps.csv": ("\n".join(rows) + "\n").encode(),
            f"{p}_pil.elf": self.firmware.pil_elf,
            f"{p}_board.elf": self.firmware.board_elf,
        }
        try:  # the robot with the measured delay (a law longer than Ts has none)
            out["robot.toml"] = measured_robot_text(self.robot, rep).encode()
        except ValueError:
            pass
        return out

    def write(self, out: Path) -> None:
        """Write :meth:`files` into ``out`` (atomically, one by one) and say so."""
        from mwip.io import write_atomic

        names = []
        for name, data in self.files().items():
            write_atomic(out / name, _writer(data))
            names.append(name)
        click.echo(f"wrote {', '.join(str(out / n) for n in names)}")


def _writer(data: bytes) -> Callable[[IO[bytes]], object]:
    return lambda fh: fh.write(data)


def _fail(exc: BaseException) -> click.UsageError:
    return click.UsageError(f"--pil: {exc}")


def measured_robot_text(robot: Any, rep: Any) -> str:
    """The robot file of ``robot`` with its firmware's computation delay set from the PIL
    measurement ``rep`` (:func:`mwip.export.pil.delay_from_pil`), its source saying so."""
    from dataclasses import replace

    from mwip.export.pil import delay_from_pil
    from mwip.robot import robot_to_toml

    delay, source = delay_from_pil(rep, Ts=robot.Ts)
    delay = min(max(delay, 0.0), 1.0)
    tw = robot.twin
    measured = replace(robot, twin=replace(tw, firmware=replace(tw.firmware, delay=delay)))
    return robot_to_toml(measured.with_sources({"firmware.delay": f"measured: {source}"}))


def run_pil_cli(name: str, build: Any, code: Any, *, robot: Any, twin: bool, theta0: float,
                duration: float, push: float, board: bool, pil: bool) -> PilRun:  # fmt: skip
    """Run ``--pil`` (and ``--board``) for the export of ``name`` (``build()`` makes the
    Python controller, ``code`` its C); print the results; raise click errors (bad input and
    missing or failing tools: exit 2; the emulated processor failing: exit 1)."""
    from mwip.export.firmware import FirmwareError, NoToolchain, build_firmware, find_toolchain
    from mwip.export.pil import CostRun, PILError, load_unicorn, run_pil
    from mwip.export.sil import NoCompiler, find_compiler

    if board and not pil:
        raise click.BadParameter("needs --pil (the whole-board check compares with it)",
                                 param_hint="--board")  # fmt: skip
    if not (math.isfinite(push) and abs(push) <= 10.0):
        raise click.BadParameter(f"must be in [-10, 10] N m, got {push!r}", param_hint="--push")
    if code.Ts is None:
        raise click.BadParameter("processor in the loop needs a sampled controller (a Ts)",
                                 param_hint="--Ts")  # fmt: skip
    try:
        toolchain = find_toolchain()
        load_unicorn()
        find_compiler()
        if board:
            from mwip.export.board import qemu_available

            if not qemu_available():
                raise NoToolchain("--board needs QEMU: install Debian's qemu-system-arm "
                                  "(apt-get install qemu-system-arm)")  # fmt: skip
    except (NoToolchain, NoCompiler) as exc:
        raise _fail(exc) from None
    try:
        firmware = build_firmware(code, toolchain)
    except FirmwareError as exc:
        raise _fail(exc) from None
    run = CostRun(theta0=theta0, duration=duration, push=push, push_start=duration / 2)
    plant = robot.body
    tw = robot.twin if twin else None
    n = max(int(round(duration / code.Ts)), 1)
    try:
        with progress(n, "processor in the loop", long=True) as prog:
            rep = run_pil(name, build(), code, plant=plant, run=run, twin=tw, firmware=firmware,
                          progress=prog)  # fmt: skip
    except PILError as exc:
        raise click.ClickException(f"processor in the loop: {exc}") from None
    _say(rep, twin)
    board_result = _board(firmware, build, plant, run, tw, n) if board else None
    return PilRun(rep, firmware, board_result, robot)


def _say(rep: Any, twin: bool) -> None:
    from mwip.export.pil import CONTROL_SHARE

    where = "twin" if twin else "simulation"
    push = f", push {rep.run.push:g} N m at {rep.run.push_start:g} s" if rep.run.push else ""
    if rep.identical:
        same = "bit-identical to the host's build"
    else:
        causes = []
        if rep.libm_calls:
            causes.append("the board's newlib sin/cos differ from the host's glibc by 1 ulp at "
                          "some arguments")  # fmt: skip
        if rep.precision == "double":
            causes.append("libgcc's soft-float double addition misrounds 2^k - y for y 33 "
                          "binary orders smaller")  # fmt: skip
        why = "; ".join(causes + ["docs/export.md"])
        same = (f"max |state difference| from the host's build {rep.max_state_diff:.3g} (theta "
                f"{rep.max_theta_diff:.3g} rad), max |u difference| {rep.max_u_diff:.3g} N m "
                f"({why})")  # fmt: skip
    click.echo(f"processor in the loop (emulated Cortex-M3, {rep.precision}; {where}, "
               f"{rep.run.duration:g} s from theta0 = {rep.run.theta0:g} rad{push}): {same}; "
               f"status host {rep.status_host}, PIL {rep.status_pil}; "
               f"{rep.seconds:.1f} s of emulation")  # fmt: skip
    if rep.status_pil != "ok":
        click.echo(f"mwip: the robot did not balance ({rep.status_pil}): the cost below covers "
                   f"the {len(rep.instructions)} steps before; lower --push or --theta0",
                   err=True)  # fmt: skip
    if rep.float_state_diff is not None:
        click.echo(f"float build vs the double Python controller on this run: max |state "
                   f"difference| {rep.float_state_diff:.3g} (theta {rep.float_theta_diff:.3g} "
                   "rad)")  # fmt: skip
    phases = ", ".join(f"{k} {v:,}" for k, v in rep.phase_max().items())
    share = rep.time_s() / rep.Ts
    verdict = (
        f"fits in the {CONTROL_SHARE:.0%} of Ts left after sensor fusion and I/O"
        if rep.fits()
        else f"does NOT fit in the {CONTROL_SHARE:.0%} of Ts left after sensor fusion and I/O"
    )
    click.echo(f"cost per step: first {rep.first:,}, median {rep.median:,.0f}, max {rep.max:,} "
               f"instructions ({phases}); <= {rep.max_cycles:,} cycles (CPI <= "
               f"{rep.cpi_bound:.2f}) = {rep.time_s() * 1e3:.3f} ms at 50 MHz, {share:.1%} of "
               f"Ts: {verdict}; flash {rep.flash_bytes:,} B, RAM {rep.ram_bytes:,} B, stack "
               f"{rep.stack_bytes:,} B")  # fmt: skip


def _board(firmware: Any, build: Any, plant: Any, run: Any, tw: Any,
           n: int) -> tuple[float, float, float]:  # fmt: skip
    import time

    import numpy as np

    from mwip.export.board import BoardController, BoardError
    from mwip.export.pil import PILController, _closed_loop

    static = bool(getattr(build(), "static", False))
    t0 = time.perf_counter()
    try:
        with progress(n, "whole board (QEMU)", long=True) as prog, \
                BoardController(firmware, static=static) as dev:  # fmt: skip
            a = _closed_loop(dev, plant, run, firmware.code.Ts, tw, 1, prog)
    except BoardError as exc:
        raise click.ClickException(f"whole-board check: {exc}") from None
    seconds = time.perf_counter() - t0
    b = _closed_loop(PILController(firmware, static=static), plant, run, firmware.code.Ts, tw, 1,
                     None)  # fmt: skip
    ds = float(np.nanmax(np.abs(a.state - b.state)))
    du = float(np.nanmax(np.abs(a.u - b.u)))
    same = "equal to the emulated processor" if ds == 0 and du == 0 else (
        f"max |state difference| {ds:.3g}, max |u difference| {du:.3g} N m from the emulated "
        "processor")  # fmt: skip
    click.echo(f"whole board (QEMU lm3s6965evb, UART0 frames): {same}; {seconds:.1f} s")
    return ds, du, seconds
