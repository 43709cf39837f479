"""What every law's C template (``mwip/laws/<family>/c_export.py``) shares.

A template is a function ``generate(law, w, prefix) -> (state_fields, code, kind)`` of the
law's :class:`~mwip.laws.packing.PackedLaw` (it reads the packed parameters by name, never a
controller's attributes), a writer ``w`` of C constants in the chosen precision (``w.num(x)``,
``w.arr(name, values)``, :mod:`mwip.export.c_code`) and the C prefix. The code may call the
helpers the export emits on use: ``mwip_min``, ``mwip_max``, ``mwip_sgn``, ``mwip_clip1``, the
model terms ``mwip_f_g`` of (2.36) and the macros ``MWIP_SQRT``, ``MWIP_FABS``.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

__all__ = ["Writer", "coef_args", "CExportError"]


class CExportError(ValueError):
    """The law (or one of its settings) cannot be written as C."""


class Writer(Protocol):
    def num(self, x: float) -> str: ...

    def arr(self, name: str, values: Any) -> str: ...


def coef_args(w: Writer, c: np.ndarray) -> str:
    """The argument list of ``mwip_f_g`` with the nominal coefficients baked in."""
    return ", ".join(w.num(x) for x in c)
