"""``python -m mwip`` runs the command-line interface."""

import sys

from mwip.cli import main

sys.exit(main())
