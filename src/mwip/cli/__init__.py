"""Command-line interface: ``mwip simulate | design | params | run | reproduce | ...``.

One module per command (or command group) in this package, each thin: parse the options,
build the typed request once (a :class:`~mwip.scenario.Scenario`, a campaign, a study
file, ...), call the library, print. The library validates; a command only says which
option a refused value came from. Modules whose name starts with ``_`` are helpers
(:mod:`._common`: shared options and parsing; :mod:`._errors`: one-line errors and exit
codes). Every other module here is registered on the root group automatically: the click
commands it lists in ``__all__`` (docs/extending.md, "Adding a command").

Errors in the input are reported as one line ``mwip: error: ...`` on stderr with exit code 2
and no traceback; nothing is written before all input has been validated, and every file is
written atomically. The command modules import only click at module level (``mwip --help``
loads them all); the library loads with the command that runs.
"""

from __future__ import annotations

import pkgutil
import sys
from typing import Any

import click

from mwip.cli._strict import strict_options as _strict_options

__all__ = ["main", "cli", "entry"]


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mwip")
def cli() -> None:
    """mwip: models, observers, controllers and simulation of mobile wheeled inverted pendulums."""


def _register(group: click.Group) -> None:
    """Add the commands of every command module of this package (a module not starting
    with ``_``; the click commands in its ``__all__``) to ``group``."""
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        name = f"{__name__}.{info.name}"
        __import__(name)  # (the import statement's path: ``python -X importtime`` shows it)
        module = sys.modules[name]
        for attr in module.__all__:
            command = getattr(module, attr)
            if isinstance(command, click.Command):
                group.add_command(command)


_register(cli)
_strict_options(cli)  # an option given twice, a non-finite number: refused (cli/_strict.py)


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI, turning input errors into one-line messages (exit code 2).

    Never a traceback: bad input is exit 2, Ctrl-C exit 130 (a second Ctrl-C while the first
    is being handled ends the process at once), any other failure one line and exit 1
    (``MWIP_TRACEBACK=1`` shows the traceback).
    """
    from mwip.cli._errors import run_guarded

    return run_guarded(cli, argv)


def entry() -> None:
    """Console-script entry point (exits with :func:`main`'s code).

    After Ctrl-C the process ends at once (``os._exit`` once the output is flushed): the
    clean-up that matters (the staging folder, the worker processes) is done by then, and
    the interpreter's own exit handlers (joining pools and queues) would only add delay, or
    another Ctrl-C and a traceback.
    """
    import contextlib
    import os
    import signal
    import sys

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
