"""Running the root group: every failure becomes one line on stderr and an exit code.

Bad input is ``mwip: error: ...`` with exit code 2; Ctrl-C exit 130 (a second Ctrl-C while
the first is being handled ends the process at once); any other failure one line and exit 1
(``MWIP_TRACEBACK=1`` shows the traceback). Never a traceback otherwise.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import click

from mwip.cli._common import cut as _cut

__all__ = ["run_guarded"]


def run_guarded(group: click.Group, argv: list[str] | None = None) -> int:
    """Run ``group`` on ``argv`` (default: the process's arguments) and return the exit code,
    turning input errors into one-line messages (exit code 2)."""
    import warnings

    fmt, warnings.formatwarning = warnings.formatwarning, _warning_line
    try:
        with _interrupts():
            try:
                return _main(group, argv)
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


def _main(group: click.Group, argv: list[str] | None) -> int:
    import os

    try:
        group.main(args=argv, prog_name="mwip", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code)
    except click.UsageError as exc:
        if type(exc).__name__ == "NoArgsIsHelpError" and exc.ctx is not None:
            # bare `mwip` or a bare group (`mwip twin`): its help on stdout, exit 0 (the
            # convention of git, pip and click before 8.2)
            click.echo(exc.ctx.get_help())
            return 0
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
    except ImportError as exc:  # an optional package missing: which extra brings it
        from mwip.cli._common import EXTRAS, extra_message

        root = (exc.name or "").partition(".")[0]
        extra = next((e for e, mods in EXTRAS.items() if root in mods and e != "pandas"), None)
        if isinstance(exc, ModuleNotFoundError) and root and (extra or root == "pandas"):
            click.echo(f"mwip: error: {extra_message([root], extra or 'pandas')}", err=True)
            return 2
        if os.environ.get("MWIP_TRACEBACK"):
            raise
        click.echo(f"mwip: internal error: {type(exc).__name__}: {_one_line(exc)} "
                   "(set MWIP_TRACEBACK=1 to see where)", err=True)  # fmt: skip
        return 1
    except (MemoryError, RecursionError) as exc:  # the input asks for too much: bad input
        click.echo(f"mwip: error: {type(exc).__name__}: the input asks for more than this "
                   "machine can give; reduce the sizes or durations", err=True)  # fmt: skip
        return 2
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback on request
        if os.environ.get("MWIP_TRACEBACK"):
            raise
        click.echo(f"mwip: internal error: {type(exc).__name__}: {_one_line(exc)} "
                   "(set MWIP_TRACEBACK=1 to see where)", err=True)  # fmt: skip
        return 1
    return 0


def _one_line(exc: BaseException) -> str:
    return _cut(str(exc)) or type(exc).__name__


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
