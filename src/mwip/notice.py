"""One-line notices on stderr before something slow that happens once: a first-use
compilation (the ahead-of-time module :mod:`mwip.sim.aot`, the JIT-compiled loops
:mod:`mwip.sim.loop`) or a long design (the IT2 PDC LMIs, :func:`mwip.fuzzy.pdc.design_pdc`).

Each notice is printed at most once per process, as ``mwip: <text>`` on stderr, for the CLI
and the Python API alike (the README's batch loop says it is compiling before the minutes
that takes). They are not :mod:`warnings` (a study's warnings are filtered while it runs,
and a notice is not a warning); ``MWIP_NOTICES=off`` silences them.
"""

from __future__ import annotations

import os
import sys

__all__ = ["once", "enabled"]

_SHOWN: set[str] = set()


def enabled() -> bool:
    """Whether notices are printed (``MWIP_NOTICES`` is not ``off``)."""
    return os.environ.get("MWIP_NOTICES", "on").strip().lower() != "off"


def once(key: str, text: str) -> bool:
    """Print ``mwip: text`` on stderr unless the notice ``key`` was shown in this process
    (or notices are off); returns whether it was printed."""
    if key in _SHOWN or not enabled():
        return False
    _SHOWN.add(key)
    try:
        print(f"mwip: {text}", file=sys.stderr, flush=True)
    except (OSError, ValueError):  # stderr closed: a notice is never worth a failure
        return False
    return True
