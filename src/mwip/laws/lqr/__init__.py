"""The linear-quadratic regulator about upright (Sec. 4.4.2), continuous or sampled design.

One folder holds the whole law:

- ``controller.py``: the controller class (the :class:`mwip.core.Controller` protocol);
- ``kernel.py``: the compiled law, the one implementation the class, the compiled closed loop
  (its ``step``, through :mod:`mwip.laws.dispatch`) and the tests' oracles agree with;
- ``packing.py``: its parameter and state vectors, named layouts
  (:mod:`mwip.laws.packing`), the same for Python, the compiled loop and the C export;
- ``spec.py``: its registry entries (settings, defaults and allowed ranges), found
  automatically by :mod:`mwip.laws.registry`;
- ``c_export.py``: its C template, reading the packed parameters.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["LQR", "LQRDesign", "design_lqr", "lqr", "dlqr", "lqr_sampled", "BOOK_Q", "BOOK_R",
           "zoh"]

__getattr__, __dir__ = exports(__name__, {
    "LQR": "mwip.laws.lqr.controller",
    "LQRDesign": "mwip.laws.lqr.controller",
    "design_lqr": "mwip.laws.lqr.controller",
    "lqr": "mwip.laws.lqr.controller",
    "dlqr": "mwip.laws.lqr.controller",
    "lqr_sampled": "mwip.laws.lqr.controller",
    "BOOK_Q": "mwip.laws.lqr.controller",
    "BOOK_R": "mwip.laws.lqr.controller",
    "zoh": "mwip.laws.lqr.controller",
})

if TYPE_CHECKING:
    from mwip.laws.lqr.controller import (
        BOOK_Q,
        BOOK_R,
        LQR,
        LQRDesign,
        design_lqr,
        dlqr,
        lqr,
        lqr_sampled,
        zoh,
    )
