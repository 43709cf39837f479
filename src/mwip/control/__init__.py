"""Controllers (Chapters 3-5) behind one protocol, :class:`mwip.control.base.Controller`.

The names below are imported on first use (PEP 562), so that ``mwip.control.registry`` (the
command line's controller list) loads without SciPy or Numba.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["Controller", "LQR", "LQRDesign", "design_lqr", "lqr", "dlqr", "lqr_sampled"]

_WHERE = {"Controller": "mwip.control.base", **{n: "mwip.control.lqr" for n in __all__[1:]}}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'mwip.control' has no attribute {name!r}")
