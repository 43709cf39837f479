"""``python -m mwip`` runs the command-line interface.

Ctrl-C while the CLI is still being imported ends the process quietly (exit code 130).
"""

import os
import signal


def _exit_130(signum: int, frame: object) -> None:
    os._exit(130)


if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
    signal.signal(signal.SIGINT, _exit_130)

from mwip.cli import entry  # noqa: E402 - after the handler, so Ctrl-C here is quiet

entry()
