"""The fuzzy controller of Fig. 5.3 (Chapter 5): PDC balance law and Mamdani position/direction
FLSs, IT2 or type 1.

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

__all__ = ["Fig53Controller"]

__getattr__, __dir__ = exports(__name__, {
    "Fig53Controller": "mwip.laws.fig53.controller",
})

if TYPE_CHECKING:
    from mwip.laws.fig53.controller import Fig53Controller
