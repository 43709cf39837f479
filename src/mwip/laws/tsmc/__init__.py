"""Terminal sliding-mode control with augmented surfaces (Sec. 4.3).

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

__all__ = ["TSMC"]

__getattr__, __dir__ = exports(__name__, {
    "TSMC": "mwip.laws.tsmc.controller",
})

if TYPE_CHECKING:
    from mwip.laws.tsmc.controller import TSMC
