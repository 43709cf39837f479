"""The control laws (Chapters 3-5), one folder per family: ``lqr``, ``smc`` (SMC, DO-based
SMC, HODOSMC), ``asta`` (ASTA, ASMC), ``tsmc``, ``fig53`` (IT2 and type-1 fuzzy). Each folder
holds its controller class, compiled kernel, packing, registry entry and C template (see
``docs/extending.md``). Shared by all: :mod:`mwip.laws.registry` (every controller by name),
:mod:`mwip.laws.packing` (parameter and state vectors), :mod:`mwip.laws.dispatch` (one sample
of any packed law), :mod:`mwip.laws.batch` (one parameter vector per robot),
:mod:`mwip.laws.switching` (sgn / sat).

The names below are imported on first use (PEP 562), so that ``mwip.laws.registry`` (the
command line's controller list) loads without SciPy or Numba.
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["Controller", "LQR", "LQRDesign", "design_lqr", "dlqr", "lqr_sampled"]

__getattr__, __dir__ = exports(
    __name__,
    {"Controller": "mwip.laws.base", **{n: "mwip.laws.lqr.controller" for n in __all__[1:]}},
)

if TYPE_CHECKING:
    from mwip.laws.base import Controller
    from mwip.laws.lqr.controller import LQR, LQRDesign, design_lqr, dlqr, lqr_sampled
