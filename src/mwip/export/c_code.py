"""Plain C99 for a designed controller: a header and a source for the robot's board.

:func:`generate_c` takes a controller *object* as mwip builds it (designed on the nominal
parameters: ``mwip.laws.registry.build(name, nominal, settings, Ts)``) and writes::

    typedef struct { ... } PREFIX_state;                  /* what the law remembers    */
    void PREFIX_init(PREFIX_state *s, const mwip_real y[8]); /* first measurement       */
    void PREFIX_step(PREFIX_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2]);

``y = [psi, theta, alpha, psi', theta', alpha', x, y]`` is the measurement (rad, rad/s, m) as
the board computes it (:class:`mwip.core.Measurement`), ``t`` the time since start (s),
``u = [u_r, u_l]`` the wheel torques (N m) to hold until the next call (every ``Ts``). Gains,
observer matrices and the nominal model's coefficients are baked in as constants; no dynamic
memory, no library beyond ``math.h``. ``precision="float"`` writes single-precision code for a
microcontroller without double-precision hardware (the LM3S2965's Cortex-M3 has none).

Each law's C template lives in its folder (``mwip/laws/<family>/c_export.py``) and reads the
law's packed parameters (:meth:`PackedLaw.fields <mwip.laws.packing.PackedLaw.fields>`), not
the controller's attributes; it is written in the same order of operations as the compiled
kernel that the simulations run (``mwip/laws/<family>/kernel.py``), and the model terms
``F, G`` of (2.36) are translated from their one Python source
(:func:`mwip.models.reduced.f_g_terms`, :mod:`mwip.export.transpile`). Software in the loop
(:mod:`mwip.export.sil`) compiles the result and checks that the closed loop equals the
Python controller's.

Supported: LQR (Section 4.4.2, continuous-designed or sampled design), SMC / DO1SMC / HODOSMC
(3.49)-(3.51) with the n-th order observer (3.20)-(3.23) in its exact sampled form, ASTA and
ASMC (4.1)-(4.7), TSMC (4.30)-(4.32) with (4.43), and the Fig. 5.3 fuzzy controller (PDC
(5.10) with the position and direction Mamdani FLSs of Section 5.3.2, IT2 or type-1).
"""

from __future__ import annotations

import copy
import importlib
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from mwip.export.transpile import c_literal, to_c_function
from mwip.laws.c_support import CExportError

__all__ = ["CCode", "generate_c", "ExportError", "PRECISIONS"]

PRECISIONS = ("double", "float")


class ExportError(ValueError):
    """The controller (or one of its settings) cannot be written as C."""


@dataclass(frozen=True)
class CCode:
    """Generated code: ``header`` (``PREFIX.h``) and ``source`` (``PREFIX.c``)."""

    prefix: str
    header: str
    source: str
    precision: str
    kind: str
    Ts: float | None

    def files(self) -> dict[str, str]:
        """File name -> text."""
        return {f"{self.prefix}.h": self.header, f"{self.prefix}.c": self.source}


class _W:
    """Small writer of C constants in the chosen precision."""

    def __init__(self, precision: str) -> None:
        self.p = precision

    def num(self, x: float) -> str:
        return c_literal(float(x), self.p)

    def arr(self, name: str, values: Any) -> str:
        a = np.asarray(values, dtype=float)
        dims = "".join(f"[{d}]" for d in a.shape)
        body = _nest(a, self.num)
        return f"static const mwip_real {name}{dims} = {body};"


def _nest(a: np.ndarray, fmt: Any) -> str:
    if a.ndim == 1:
        return "{" + ", ".join(fmt(x) for x in a) + "}"
    return "{" + ", ".join(_nest(r, fmt) for r in a) + "}"


_PRELUDE = """\
#include <math.h>
#include "{prefix}.h"

#if {is_float}
#define MWIP_SIN sinf
#define MWIP_COS cosf
#define MWIP_SQRT sqrtf
#define MWIP_FABS fabsf
#else
#define MWIP_SIN sin
#define MWIP_COS cos
#define MWIP_SQRT sqrt
#define MWIP_FABS fabs
#endif
"""

#: Small helpers, emitted only where the code uses them (no unused static functions).
_HELPERS = {
    "mwip_min": "static mwip_real mwip_min(mwip_real a, mwip_real b) { return a < b ? a : b; }",
    "mwip_max": "static mwip_real mwip_max(mwip_real a, mwip_real b) { return a > b ? a : b; }",
    "mwip_sgn": "static mwip_real mwip_sgn(mwip_real x) { return (mwip_real)((x > 0) - (x < 0)); }",
    "mwip_clip1": "static mwip_real mwip_clip1(mwip_real x) "
    "{ return mwip_min(1, mwip_max(-1, x)); }",
}


def _helpers(body: str) -> str:
    used = [k for k in _HELPERS if k + "(" in body]
    if "mwip_clip1(" in body:
        used += [k for k in ("mwip_min", "mwip_max") if k not in used]
    return "\n".join(_HELPERS[k] for k in _HELPERS if k in used)


def _header(prefix: str, precision: str, fields: list[str], doc: str, Ts: float | None) -> str:
    guard = prefix.upper() + "_H"
    real = "float" if precision == "float" else "double"
    body = "\n".join(f"    {f};" for f in fields) or "    int unused; /* a static law */"
    period = f"{Ts:g} s" if Ts is not None else "any sample period (static law)"
    return f"""\
/* {prefix}: {doc}
 * Generated by mwip (mwip export c). Call {prefix}_init once with the first measurement,
 * then {prefix}_step every {period} with the new measurement; hold u until the next call.
 * y = [psi, theta, alpha, psi', theta', alpha', x, y] (rad, rad/s, m); u = [u_r, u_l] (N m).
 */
#ifndef {guard}
#define {guard}

#ifndef MWIP_REAL_DEFINED
#define MWIP_REAL_DEFINED
typedef {real} mwip_real;
#endif

typedef struct {{
{body}
}} {prefix}_state;

void {prefix}_init({prefix}_state *s, const mwip_real y[8]);
void {prefix}_step({prefix}_state *s, mwip_real t, const mwip_real y[8], mwip_real u[2]);

#define {prefix.upper()}_TS {repr(float(Ts)) if Ts is not None else "0.0"}

#endif
"""


def _f_g_c(precision: str) -> str:
    from mwip.models.reduced import f_g_terms

    return to_c_function(f_g_terms, "mwip_f_g", precision)


def _packed(ctrl: Any) -> Any:
    """The controller's packed law (:mod:`mwip.laws.packing`): what the C templates read. A
    law packed only after ``reset`` (``packed_law()`` is ``None`` before it: TSMC, whose
    cubics (4.43) are fitted to the first measurement) is packed from a copy reset on the
    upright state; its C fits them again on the board at ``init``, so it needs a sample
    period."""
    from mwip.core import Measurement

    get = getattr(ctrl, "packed_law", None)
    if get is None:
        raise ExportError(f"no C export for {type(ctrl).__name__}")
    law = get()
    if law is None:
        twin = copy.deepcopy(ctrl)
        twin.reset(Measurement(0.0, np.zeros((1, 8))))
        law = twin.packed_law()
        if law is not None and getattr(ctrl, "Ts", None) is None:
            raise ExportError(f"{law.name or type(ctrl).__name__}: give a sample period (Ts) "
                              "to export it for a sampled loop")  # fmt: skip
    if law is None:
        raise ExportError(f"{type(ctrl).__name__}: an observer with a user-supplied f_g cannot "
                          "be exported")  # fmt: skip
    return law


def _dispatch(ctrl: Any, w: _W, prefix: str) -> tuple[list[str], str, str]:
    """The C of ``ctrl``'s law: the template of its family (``mwip/laws/<family>/c_export.py``),
    found by the law code."""
    from mwip.laws.families import family_of

    law = _packed(ctrl)
    module = importlib.import_module(f"mwip.laws.{family_of(law.code)}.c_export")
    try:
        return module.generate(law, w, prefix)
    except CExportError as exc:
        raise ExportError(str(exc)) from None


def generate_c(controller: Any, *, prefix: str = "mwip_ctrl", precision: str = "double",
               doc: str = "") -> CCode:  # fmt: skip
    """C99 header and source of ``controller`` (module docstring).

    Raises :class:`ExportError` for a controller or setting that cannot be exported, and
    ``ValueError`` for a bad ``prefix`` (a C identifier) or ``precision``.
    """
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,40}", prefix):
        raise ValueError(f"prefix must be a C identifier (letters, digits, _), got {prefix!r}")
    w = _W(precision)
    try:
        fields, code, kind = _dispatch(controller, w, prefix)
    except ExportError:
        raise
    except ValueError as exc:  # a constant C cannot hold (transpile.check_constant)
        raise ExportError(f"{type(controller).__name__}: {exc}") from None
    Ts = getattr(controller, "Ts", None)
    header = _header(prefix, precision, fields, doc or kind, Ts)
    is_float = "1" if precision == "float" else "0"
    model = _f_g_c(precision) + "\n\n" if "mwip_f_g(" in code else ""
    source = (
        f"/* {prefix}.c: generated by mwip; {doc or kind}. Plain C99, math.h only. */\n"
        + _PRELUDE.format(prefix=prefix, is_float=is_float)
        + "\n"
        + _helpers(code)
        + "\n\n"
        + model
        + code
        + "\n"
    )
    return CCode(prefix, header, source, precision, kind, Ts)
