"""What the command modules share: options, the parsing of robot and twin names, the output
folder check, the ``--set KEY=VALUE`` syntax, the progress display.

Only click and the standard library at import time (``mwip --help`` imports every command
module); the library modules load inside the helpers that need them.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from mwip.damping import DAMPING_READINGS

if TYPE_CHECKING:
    from mwip.params import Params

__all__ = [
    "DAMPING",
    "FORCE",
    "FILE_FORCE",
    "ROBOT_OPTION",
    "gone_option",
    "NonEmptyPath",
    "in_range",
    "robot_option",
    "out_ok",
    "file_ok",
    "record_file",
    "params_value",
    "progress",
    "split_sets",
    "cut",
    "EXTRAS",
    "extra_message",
    "need_extra",
]


def params_value(value: str, what: str, base: str | None = None,
                 damping: str = "units") -> Params:  # fmt: skip
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


class NonEmptyPath(click.Path):
    """``click.Path`` that refuses an empty name (``Path("")`` would be the current folder)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail("the name is empty; give a path", param, ctx)
        return super().convert(value, param, ctx)


FORCE = click.option(
    "--force",
    is_flag=True,
    help="Write into OUT even if it is a non-empty folder that mwip did not create, or one "
    "another mwip command owns (entries of the same names are replaced).",
)


def out_ok(out: Path, force: bool, command: str | None = None) -> Path:
    """OUT if mwip may write there (:mod:`mwip.outdir`; not a folder another command than
    ``command`` owns), else exit 2 naming --out."""
    from mwip.outdir import check

    try:
        return check(out, force, command=command)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None


FILE_FORCE = click.option(
    "--force",
    is_flag=True,
    help="Replace the output file even if it exists and mwip did not write it.",
)


def file_ok(path: Path, force: bool, option: str = "--out") -> Path:
    """``path`` if mwip may write that one file (:mod:`mwip.outfile`: new, mwip's own, or
    ``force``), else exit 2 naming ``option`` and --force."""
    from mwip.outfile import check

    try:
        return check(path, force, option)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None


def record_file(path: Path) -> None:
    """Note the file just written as mwip's (a rerun may replace it without --force)."""
    from mwip.outfile import record

    record(path)


DAMPING = click.option(
    "--damping",
    type=click.Choice(DAMPING_READINGS),
    default="units",
    show_default=True,
    help="How the book's tables' Db, Dw (printed in N s/m) enter (2.32): units = D r^2 "
    "(SPEC.md section 2), literal = the printed numbers in N m s/rad. Applies to the book's "
    "sets (real, nominal); a parameter file gives rotational coefficients directly.",
)

ROBOT_OPTION = click.option(
    "--robot", "robot_file", type=NonEmptyPath(dir_okay=False, path_type=Path), default=None,
    help="The robot: a robot file (body, design model, drive, firmware, sensors, payload; "
    "`mwip robot show` prints the default, the book's robot; docs/robot.md).",
)  # fmt: skip


def robot_option(path: Path | None, damping: str = "units", hint: str = "--robot") -> Any:
    """The robot of ``--robot FILE`` (a :class:`mwip.robot.Robot`); without a file the book's
    robot under the ``--damping`` reading. Errors are one line naming ``hint`` (the option
    or argument that gave the file)."""
    from mwip.robot import default_robot, load_robot

    if path is None:
        robot = default_robot()
        if damping != "units":
            from dataclasses import replace

            from mwip.params import book_params

            robot = replace(robot, body=book_params("real", damping),
                            design=book_params("nominal", damping))  # fmt: skip
        return robot
    if damping != "units":
        raise click.UsageError(
            "--damping reads the book's tables; a robot file (--robot) gives its body's and "
            "design model's Db, Dw as the rotational coefficients of (2.32): give one of the two"
        )
    if not path.exists():
        raise click.BadParameter(f"no such file {str(path)!r}", param_hint=hint)
    try:
        return load_robot(path)
    except (ValueError, OSError) as exc:
        raise click.BadParameter(str(exc), param_hint=hint) from None


def gone_option(*names: str, hint: str, flag: bool = False) -> Callable[[Any], Any]:
    """A hidden option of a removed name: given, it is one line saying what replaced it
    (exit 2), rather than a silent other meaning or a bare "no such option"."""

    def refuse(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if value not in (None, False, ()):
            raise click.UsageError(f"{names[0]} is gone: {hint}")
        return None

    return click.option(*names, hidden=True, expose_value=False, callback=refuse,
                        is_flag=flag, default=None if not flag else False)  # fmt: skip


def in_range(name: str, value: float, lo: float, hi: float, *, lo_open: bool = True) -> float:
    """``value`` if finite and in (lo, hi] (``[lo, hi]`` unless ``lo_open``), else exit 2
    naming the option ``name`` and the range."""
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        raise click.BadParameter(
            f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}], got {value!r}", param_hint=name
        )
    return value


def split_sets(items: tuple[str, ...]) -> dict[str, str]:
    """``("K=20,15", "phi=0.1")`` -> ``{"K": "20,15", "phi": "0.1"}``: the syntax of
    ``--set``; the values are validated by whoever resolves them (the controller's
    registry entry, through the scenario or the export)."""
    given: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise click.BadParameter(f"must be KEY=VALUE, got {item!r}", param_hint="--set")
        given[key.strip()] = value.strip()
    return given


@contextmanager
def progress(n: int, label: str, long: bool = False) -> Iterator[Callable[[int], None] | None]:
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


#: pyproject.toml's optional extras and the packages (import names) each one brings.
EXTRAS: dict[str, tuple[str, ...]] = {
    "campaign": ("dask", "distributed", "pyarrow", "pandas"),
    "tune": ("optuna", "cmaes"),
    "gym": ("gymnasium",),
    "control": ("control",),
    "pandas": ("pandas",),
}


def _installed(module: str) -> bool:
    """Whether ``module`` can be imported (found without importing it)."""
    import importlib.util

    if module in sys.modules:
        return sys.modules[module] is not None
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def extra_message(missing: list[str], extra: str, what: str = "this command") -> str:
    """One line: ``what`` needs the optional ``extra`` (``missing`` packages) and how to
    install it."""
    return (f"{what} needs the optional extra '{extra}' ({', '.join(missing)} not installed): "
            f"pip install -e '.[{extra}]' in mwip's folder (or pip install 'mwip[{extra}]')")


def need_extra(extra: str, what: str, modules: tuple[str, ...] | None = None) -> None:
    """Exit 2 with one line naming ``extra`` unless its packages (``modules``: those of them
    that ``what`` uses) are installed."""
    missing = [m for m in (EXTRAS[extra] if modules is None else modules) if not _installed(m)]
    if missing:
        raise click.UsageError(extra_message(missing, extra, what))


def cut(text: str, limit: int = 400) -> str:
    """``text`` on one line, at most ``limit`` characters (a huge bad value is quoted in
    part)."""
    text = " ".join(text.split())
    return text if len(text) <= limit else f"{text[: limit - 40]} ... ({len(text)} characters)"
