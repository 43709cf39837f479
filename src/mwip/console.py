"""The ``mwip`` console script and ``python -m mwip``.

Ctrl-C while the command-line interface is still being imported (the first second of a run:
click, NumPy, the commands) ends the process quietly with exit code 130: the handler is in
place before :mod:`mwip.cli` is imported, and :func:`mwip.cli.entry` takes over from there.
"""

from __future__ import annotations

import os
import signal

__all__ = ["entry"]


def _exit_130(signum: int, frame: object) -> None:
    os._exit(130)


def entry() -> None:
    """Run the CLI (:func:`mwip.cli.entry`), quiet to Ctrl-C from the first moment."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _exit_130)
    from mwip.cli import entry as run

    run()
