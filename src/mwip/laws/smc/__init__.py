"""The sliding-mode family (Sec. 3.5): SMC (3.49)-(3.51), and with a disturbance observer (DO-
based SMC, HODOSMC; Sec. 3.6).

One folder holds the whole law:

- ``controller.py``: the controller class (the :class:`mwip.core.Controller` protocol);
- ``kernel.py``: the compiled law, the one implementation the class, the compiled closed loop
  (its ``step``, through :mod:`mwip.laws.dispatch`) and the tests" oracles agree with;
- ``packing.py``: its parameter and state vectors, named layouts
  (:mod:`mwip.laws.packing`), the same for Python, the compiled loop and the C export;
- ``spec.py``: its registry entries (settings, defaults and allowed ranges), found
  automatically by :mod:`mwip.laws.registry`;
- ``c_export.py``: its C template, reading the packed parameters.

The names below are imported on first use (:mod:`mwip.lazy`).
"""

from typing import TYPE_CHECKING

from mwip.lazy import exports

__all__ = ["SlidingModeController", "SMCGains", "gains_from_bounds", "make_smc"]

__getattr__, __dir__ = exports(__name__, {
    "SlidingModeController": "mwip.laws.smc.controller",
    "SMCGains": "mwip.laws.smc.controller",
    "gains_from_bounds": "mwip.laws.smc.controller",
    "make_smc": "mwip.laws.smc.controller",
})

if TYPE_CHECKING:
    from mwip.laws.smc.controller import (
        SlidingModeController,
        SMCGains,
        gains_from_bounds,
        make_smc,
    )
