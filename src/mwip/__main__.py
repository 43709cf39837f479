"""``python -m mwip`` runs the command-line interface.

Ctrl-C while the CLI is still being imported ends the process quietly (exit code 130;
:mod:`mwip.console`).
"""

from mwip.console import entry

entry()
